"""The myCobot arm as the tests drive it: its joints, its tip link, the 'ready' values the ROS
tests start from, and where the tip is for given arm values by our own forward kinematics (the
reference a reached pose is checked against)."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mycobot_planning.core import RobotModel, RobotState

ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6",
       "link6_to_link6_flange"]
TIP = "link6_flange"
READY = [0.0, -0.3, 0.6, 0.2, 0.0, 0.0]


def tip_pose(model: RobotModel, arm: Sequence[float] | np.ndarray) -> np.ndarray:
    """The 4x4 pose of TIP with the ARM joints at ``arm`` (the others at their defaults)."""
    state = RobotState(model)
    state.set_joint_positions(dict(zip(ARM, arm)))
    return state.frame_pose(TIP)
