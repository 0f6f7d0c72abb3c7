"""Cartesian motion: move_group's compute_cartesian_path (cartesian_path), MoveIt's precision
refinement of it (cartesian_precision) and MTC's MoveRelative motion (relative_motion)."""
from .cartesian_path import CartesianPathResult, compute_cartesian_path
from .cartesian_precision import CartesianPrecision
from .relative_motion import plan_relative_motion

__all__ = ["CartesianPathResult", "CartesianPrecision", "compute_cartesian_path", "plan_relative_motion"]
