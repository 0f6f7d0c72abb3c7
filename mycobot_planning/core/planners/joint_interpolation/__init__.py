"""MTC's joint interpolation planner (pipeline_id "joint_interpolation")."""
from .joint_interpolation import interpolate_joint_path, plan_joint_interpolation

__all__ = ["interpolate_joint_path", "plan_joint_interpolation"]
