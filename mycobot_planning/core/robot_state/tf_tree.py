"""The transform tree a robot_state_publisher broadcasts: one parent -> child transform per URDF
joint at a robot state (fixed joints once, on /tf_static; moving joints on /tf at every joint
state). Computed with one Pinocchio forward-kinematics pass per state."""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ..robot_model.robot_model import RobotModel
from .robot_state import RobotState

#: (parent link, child link, translation xyz, quaternion xyzw)
Transform = tuple[str, str, list[float], list[float]]


def joint_transforms(model: RobotModel, state: RobotState, fixed: bool) -> list[Transform]:
    """Transforms of the fixed joints (``fixed``) or of the moving ones, at ``state``."""
    joints = [model.joint(name) for name in model.joint_names]
    chosen = [j for j in joints if (j.type == "fixed") == fixed]
    links = {link for j in chosen for link in (j.parent_link, j.child_link)}
    poses = state.frame_poses(sorted(links))
    out: list[Transform] = []
    for j in chosen:
        relative = np.linalg.inv(poses[j.parent_link]) @ poses[j.child_link]
        out.append((j.parent_link, j.child_link, relative[:3, 3].tolist(),
                    Rotation.from_matrix(relative[:3, :3]).as_quat().tolist()))
    return out
