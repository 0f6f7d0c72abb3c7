"""Where trajectory execution used to live: the names stay importable from here.

New code imports from core.trajectory_execution (and the trajectory message conversion from
core.robot_trajectory).
"""
from .robot_trajectory import joint_trajectory_to_timed, timed_to_joint_trajectory
from .trajectory_execution import *  # noqa: F401,F403 - the old module's public names
from .trajectory_execution import __all__ as _moved

__all__ = [*_moved, "joint_trajectory_to_timed", "timed_to_joint_trajectory"]
