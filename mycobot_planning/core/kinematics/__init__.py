"""Inverse kinematics per planning group (MoveIt's kinematics plugins): ik_solver."""
from .ik_solver import IKOptions, IKSolver, solve_ik

__all__ = ["IKOptions", "IKSolver", "solve_ik"]
