"""The one pose converter: every form a user, a parameter or a message gives a pose in, to a 4x4.

Services take Pose messages or their dicts, ROS parameters give 6 or 7 numbers, rclpy code
passes geometry_msgs objects and library code 4x4 matrices. Each caller used to parse its
own subset with its own error; now they all call :func:`pose_matrix` and turn the one
:class:`PoseError` into their own answer (a MoveIt error code, a SceneError, ...).
"""
from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from .msgs import MessageError, Pose

__all__ = ["PoseError", "pose_matrix", "pose_message"]

_LOG = logging.getLogger("mycobot_planning.pose_conversion")
#: a quaternion whose norm is further than this from 1 is normalized with a warning
QUATERNION_NORM_TOLERANCE = 1e-3

_FORMS = ("a Pose (message, dict or geometry_msgs/Pose), 7 numbers [x, y, z, qx, qy, qz, qw], "
          "six finite numbers [x, y, z, roll, pitch, yaw] or a 4x4 matrix")


class PoseError(ValueError):
    """A value that is not a pose; the message names the value (``what``) and the problem."""


def pose_matrix(value: Any, what: str = "pose") -> np.ndarray:
    """A rigid 4x4 transform from any accepted pose form (see module docstring).

    Quaternions are normalised (a zero one is refused); 6 numbers are fixed-axis roll, pitch,
    yaw as in URDF; matrices must be finite rigid transforms. Raises PoseError naming ``what``.
    """
    try:
        return _matrix(value, what)
    except MessageError as exc:
        raise PoseError(f"{what}: {exc}") from None


def pose_message(value: Any, what: str = "pose") -> Pose:
    """The same conversion, as a Pose message."""
    if isinstance(value, Pose):
        return value
    return Pose.from_matrix(pose_matrix(value, what))


def _matrix(value: Any, what: str) -> np.ndarray:
    if isinstance(value, Pose):  # fields may have been changed since construction: check again
        return _checked(list(value.position) + list(value.orientation), what)
    if isinstance(value, Mapping):
        return Pose.from_dict(value).to_matrix()
    position = getattr(value, "position", None)
    if position is not None and hasattr(position, "x"):  # geometry_msgs/Pose or alike
        q = value.orientation
        return _checked([position.x, position.y, position.z, q.x, q.y, q.z, q.w], what)
    if isinstance(value, (str, bytes)) or value is None:
        raise PoseError(f"{what}: expected {_FORMS}, got {type(value).__name__}")
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise PoseError(f"{what}: expected {_FORMS}, got {type(value).__name__}") from None
    if not np.all(np.isfinite(arr)):
        raise PoseError(f"{what}: contains NaN or infinite values")
    if arr.shape == (7,):
        return _checked(arr.tolist(), what)
    if arr.shape == (6,):
        return Pose.from_xyz_rpy(arr[:3].tolist(), arr[3:].tolist()).to_matrix()
    if arr.shape == (4, 4):
        try:
            Pose.from_matrix(arr)  # refuses what is not a rigid transform, naming why
        except MessageError as exc:
            raise PoseError(f"{what}: not a rigid transform: {exc.args[-1] if exc.args else exc}") from None
        return arr.copy()
    raise PoseError(f"{what}: expected {_FORMS}, got shape {arr.shape}")


def _checked(values: list[float], what: str) -> np.ndarray:
    """x, y, z, qx, qy, qz, qw: finite, the quaternion normalised by Pose (a zero one refused)."""
    if len(values) != 7:
        raise PoseError(f"{what}: a pose needs 3 position and 4 orientation values")
    if not all(np.isfinite(values)):
        raise PoseError(f"{what}: contains NaN or infinite values")
    norm = math.sqrt(sum(v * v for v in values[3:]))
    if abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE and norm > 0.0:
        # e.g. a ROS 1 habit in ROS 2: setting x = 1 on a fresh quaternion, whose w is already 1
        _LOG.warning("%s: the orientation (x, y, z, w) = (%g, %g, %g, %g) is not a unit quaternion (norm %.4g); "
                     "it is normalized", what, *values[3:], norm)
    return Pose(position=values[:3], orientation=values[3:]).to_matrix()
