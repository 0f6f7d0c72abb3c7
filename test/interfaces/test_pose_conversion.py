"""The one pose converter: every accepted form gives the same 4x4, every bad one one PoseError."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from interfaces_py.msgs import Pose
from interfaces_py.pose_conversion import PoseError, pose_matrix, pose_message

QUARTER_TURN_Z = [0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)]


def expected() -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    T[:3, 3] = [0.1, 0.2, 0.3]
    return T


def ros_pose():
    """A geometry_msgs/Pose look-alike (attributes, not lists)."""
    q = QUARTER_TURN_Z
    return SimpleNamespace(position=SimpleNamespace(x=0.1, y=0.2, z=0.3),
                           orientation=SimpleNamespace(x=q[0], y=q[1], z=q[2], w=q[3]))


@pytest.mark.parametrize("form", [
    Pose(position=[0.1, 0.2, 0.3], orientation=QUARTER_TURN_Z),
    {"position": [0.1, 0.2, 0.3], "orientation": QUARTER_TURN_Z},
    [0.1, 0.2, 0.3, *QUARTER_TURN_Z],
    [0.1, 0.2, 0.3, *[2 * q for q in QUARTER_TURN_Z]],  # not normalised: normalised
    [0.1, 0.2, 0.3, 0.0, 0.0, math.pi / 2],  # x y z roll pitch yaw
    expected(),
    expected().tolist(),
    ros_pose(),
], ids=["msg", "dict", "7", "7-unnormalised", "6-rpy", "matrix", "nested-list", "geometry_msgs"])
def test_every_form_gives_the_same_matrix(form):
    assert pose_matrix(form) == pytest.approx(expected(), abs=1e-12)
    assert pose_message(form).to_matrix() == pytest.approx(expected(), abs=1e-12)


@pytest.mark.parametrize("bad, text", [
    ([0.1, 0.2, 0.3], "got shape (3,)"),
    ([0, 0, 0, 0, 0, 0, 0], "quaternion"),
    ([math.nan, 0, 0, 0, 0, 0, 1], "NaN"),
    (np.ones((4, 4)), "not a rigid transform"),
    ("pose", "got str"),
    (None, "got NoneType"),
    ({"position": [0, 0]}, "position"),
    ([1e6, 0, 0, 0, 0, 0, 1], "workspace"),
])
def test_bad_poses_raise_one_error_type_naming_the_value(bad, text):
    with pytest.raises(PoseError) as info:
        pose_matrix(bad, "goal pose")
    assert str(info.value).startswith("goal pose") and text in str(info.value)


def test_a_message_changed_after_construction_is_checked_again():
    msg = Pose()
    msg.position[0] = math.nan
    with pytest.raises(PoseError, match="NaN"):
        pose_matrix(msg, "object pose")


def test_a_non_unit_quaternion_is_normalized_with_a_warning(caplog):
    """ROS 2's quaternion starts with w = 1: setting x = 1 on it (ROS 1's flip) gives (1, 0, 0, 1)."""
    with caplog.at_level("WARNING", logger="mycobot_planning.pose_conversion"):
        matrix = pose_matrix([0, 0, 0, 1, 0, 0, 1], "ik_frame")
    assert np.allclose(matrix[:3, :3], [[1, 0, 0], [0, 0, -1], [0, 1, 0]])  # 90 degrees about x
    assert "ik_frame" in caplog.text and "not a unit quaternion" in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING", logger="mycobot_planning.pose_conversion"):
        pose_matrix([0, 0, 0, 0, 0, 0.7071068, 0.7071068])
    assert caplog.text == ""
