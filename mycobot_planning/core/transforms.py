"""4x4 homogeneous pose helpers.

The core passes poses as plain 4x4 NumPy arrays: no conversion cost at the Pinocchio boundary
(``SE3.homogeneous``) and no private pose class for users to learn. Rotations go through SciPy so
the conventions (fixed-axis rpy as in URDF, quaternions as x, y, z, w as in ROS) are a
library's, not ours.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

_EYE3 = np.eye(3)
_ORTHONORMAL_TOLERANCE = 1e-6 + 1e-5 * _EYE3
_BOTTOM_ROW = np.array([0.0, 0.0, 0.0, 1.0])
_BOTTOM_ROW_TOLERANCE = 1e-8 + 1e-5 * _BOTTOM_ROW

ArrayLike = Sequence[float] | np.ndarray


def rpy_to_matrix(rpy: ArrayLike) -> np.ndarray:
    """Fixed-axis roll-pitch-yaw (URDF convention: R = Rz(yaw) Ry(pitch) Rx(roll))."""
    return Rotation.from_euler("xyz", np.asarray(rpy, dtype=float)).as_matrix()


def quat_to_matrix(quat_xyzw: ArrayLike) -> np.ndarray:
    """Quaternion (x, y, z, w), normalised first, to a rotation matrix."""
    q = np.asarray(quat_xyzw, dtype=float)
    norm = float(np.linalg.norm(q))
    if not np.isfinite(norm) or norm < 1e-12:
        raise ValueError(f"quaternion {[float(v) for v in q]} is not a rotation (norm {float(norm):g})")
    return Rotation.from_quat(q / norm).as_matrix()


def matrix_to_quat(rotation: np.ndarray) -> np.ndarray:
    """Rotation matrix to quaternion (x, y, z, w) with w >= 0."""
    q = Rotation.from_matrix(np.asarray(rotation, dtype=float)[:3, :3]).as_quat()
    return -q if q[3] < 0 else q


def matrix_to_rpy(rotation: np.ndarray) -> np.ndarray:
    """Rotation matrix to fixed-axis roll-pitch-yaw."""
    return Rotation.from_matrix(np.asarray(rotation, dtype=float)[:3, :3]).as_euler("xyz")


def make_pose(
    xyz: ArrayLike = (0.0, 0.0, 0.0),
    rpy: ArrayLike | None = None,
    quat_xyzw: ArrayLike | None = None,
) -> np.ndarray:
    """A 4x4 pose from a position and either rpy or a quaternion (identity rotation if neither)."""
    if rpy is not None and quat_xyzw is not None:
        raise ValueError("give either rpy or quat_xyzw, not both")
    pose = np.eye(4)
    pose[:3, 3] = np.asarray(xyz, dtype=float)
    if rpy is not None:
        pose[:3, :3] = rpy_to_matrix(rpy)
    elif quat_xyzw is not None:
        pose[:3, :3] = quat_to_matrix(quat_xyzw)
    return pose


def pose_to_xyz_quat(pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split a 4x4 pose into position and quaternion (x, y, z, w)."""
    pose = np.asarray(pose, dtype=float)
    return pose[:3, 3].copy(), matrix_to_quat(pose[:3, :3])


def is_pose(pose: object) -> bool:
    """True for a finite 4x4 matrix whose rotation block is orthonormal and bottom row 0 0 0 1."""
    try:
        arr = np.asarray(pose, dtype=float)
    except (TypeError, ValueError):
        return False
    if arr.shape != (4, 4) or not np.all(np.isfinite(arr)):
        return False
    rot = arr[:3, :3]
    # np.allclose's tests (atol 1e-6 and its default 1e-8, rtol 1e-5) entry by entry, without its
    # wrappers (~20 us each: every pose goal, IK target and Cartesian waypoint passes here)
    return bool(
        np.all(np.abs(rot @ rot.T - _EYE3) <= _ORTHONORMAL_TOLERANCE)
        and np.linalg.det(rot) > 0
        and np.all(np.abs(arr[3] - _BOTTOM_ROW) <= _BOTTOM_ROW_TOLERANCE)
    )


def check_pose(pose: object, what: str = "pose") -> np.ndarray:
    """Return the pose as a float 4x4 array, or raise ValueError saying what is wrong with it."""
    try:
        arr = np.asarray(pose, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{what} is not a 4x4 matrix: {exc}") from None
    if arr.shape != (4, 4):
        raise ValueError(f"{what} must be a 4x4 matrix, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} contains NaN or infinite values")
    if not is_pose(arr):
        raise ValueError(f"{what} is not a rigid transform (rotation not orthonormal)")
    return arr


def inverse(pose: np.ndarray) -> np.ndarray:
    """Inverse of a rigid transform without a general matrix inverse."""
    out = np.eye(4)
    rot_t = pose[:3, :3].T
    out[:3, :3] = rot_t
    out[:3, 3] = -rot_t @ pose[:3, 3]
    return out
