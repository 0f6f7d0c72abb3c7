"""MTC's joint interpolation planner (pipeline_id "joint_interpolation")."""
from .joint_interpolation import (
    JOINT_INTERPOLATION_PIPELINE_ID,
    JointInterpolationPlanner,
    interpolate_joint_path,
    plan_joint_interpolation,
)

__all__ = ["JOINT_INTERPOLATION_PIPELINE_ID", "JointInterpolationPlanner", "interpolate_joint_path",
           "plan_joint_interpolation"]
