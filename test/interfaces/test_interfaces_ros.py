"""Tests for interfaces_py.ros_conversions: ROS message round trips and marker geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest
from builtin_interfaces.msg import Duration, Time
from geometry_msgs.msg import Pose as PoseMsg
from sensor_msgs.msg import JointState
from shape_msgs.msg import SolidPrimitive as SolidPrimitiveMsg
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory as JointTrajectoryMsg
from trajectory_msgs.msg import JointTrajectoryPoint as JointTrajectoryPointMsg
from visualization_msgs.msg import Marker

from interfaces_py.msgs import (
    CollisionObject,
    JointTrajectory,
    JointTrajectoryPoint,
    Mesh,
    MessageError,
    PlanningScene,
    Pose,
    RobotState,
    RobotTrajectory,
    SolidPrimitive,
)
from interfaces_py.ros_conversions import (
    collision_object_to_markers,
    duration_to_seconds,
    joint_state_to_robot_state,
    joint_trajectory_from_msg,
    joint_trajectory_to_msg,
    marker_to_collision_object,
    message_from_string,
    pose_from_msg,
    pose_to_msg,
    primitive_from_marker,
    primitive_from_msg,
    primitive_to_msg,
    robot_state_to_joint_state,
    seconds_to_duration,
    string_msg,
)


def _marker_matrix(marker: Marker) -> np.ndarray:
    return pose_from_msg(marker.pose).to_matrix()


# ---- poses and primitives ------------------------------------------------------------


def test_pose_round_trips_exactly():
    pose = Pose(position=[0.1, -0.0, 1e-300], orientation=[0.1, 0.2, 0.3, 0.4])
    msg = pose_to_msg(pose)
    assert isinstance(msg, PoseMsg)
    assert (msg.position.x, msg.position.y, msg.position.z) == tuple(pose.position)
    assert (msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w) == tuple(pose.orientation)
    assert pose_from_msg(msg) == pose
    assert pose_to_msg(pose_from_msg(msg)) == msg


def test_pose_from_default_msg_is_identity_and_zero_quaternion_rejected():
    assert pose_from_msg(PoseMsg()) == Pose.identity()
    msg = PoseMsg()
    msg.orientation.w = 0.0
    with pytest.raises(MessageError, match=r"Pose\.orientation: quaternion norm"):
        pose_from_msg(msg)


def test_primitive_constants_match_shape_msgs():
    for name in ("BOX", "SPHERE", "CYLINDER", "CONE", "BOX_X", "BOX_Y", "BOX_Z", "SPHERE_RADIUS",
                 "CYLINDER_HEIGHT", "CYLINDER_RADIUS", "CONE_HEIGHT", "CONE_RADIUS"):
        assert getattr(SolidPrimitive, name) == getattr(SolidPrimitiveMsg, name), name


@pytest.mark.parametrize(
    "prim",
    [SolidPrimitive.box(0.1, 0.2, 1e-300), SolidPrimitive.sphere(1 / 3), SolidPrimitive.cylinder(0.4, 0.05),
     SolidPrimitive.cone(0.3, 0.1)],
    ids=lambda p: p.type_name,
)
def test_primitive_round_trips(prim):
    msg = primitive_to_msg(prim)
    assert msg.type == prim.type and list(msg.dimensions) == prim.dimensions
    assert primitive_from_msg(msg) == prim
    assert primitive_to_msg(primitive_from_msg(msg)) == msg


def test_primitive_from_msg_rejects_prism_and_bad_dimensions():
    with pytest.raises(MessageError, match=r"SolidPrimitive\.type: unknown primitive type 5"):
        primitive_from_msg(SolidPrimitiveMsg(type=SolidPrimitiveMsg.PRISM, dimensions=[1.0, 1.0]))
    with pytest.raises(MessageError, match=r"SolidPrimitive\.dimensions: expected 3"):
        primitive_from_msg(SolidPrimitiveMsg(type=SolidPrimitiveMsg.BOX, dimensions=[1.0]))


# ---- joint states --------------------------------------------------------------------


def test_joint_state_round_trip_with_stamp():
    state = RobotState(joint_names=["j1", "j2"], positions=[0.1, -0.0], velocities=[1 / 3, 1e-300])
    stamp = Time(sec=12, nanosec=345)
    msg = robot_state_to_joint_state(state, stamp=stamp, frame_id="base")
    assert isinstance(msg, JointState)
    assert msg.header.stamp == stamp and msg.header.frame_id == "base"
    assert list(msg.name) == ["j1", "j2"] and list(msg.position) == [0.1, -0.0] and list(msg.effort) == []
    back = joint_state_to_robot_state(msg)
    assert back == state and math.copysign(1.0, back.positions[1]) == -1.0
    assert robot_state_to_joint_state(back, stamp=stamp, frame_id="base") == msg


def test_joint_state_without_stamp_or_velocities():
    msg = robot_state_to_joint_state(RobotState.from_joint_positions({"a": 1.0}))
    assert msg.header.stamp == Time() and list(msg.velocity) == []
    assert joint_state_to_robot_state(msg).joint_positions() == {"a": 1.0}


def test_joint_state_with_mismatched_lengths_is_rejected():
    msg = JointState(name=["a", "b"], position=[0.0])
    with pytest.raises(MessageError, match=r"RobotState\.positions: expected 2"):
        joint_state_to_robot_state(msg)


# ---- trajectories ----------------------------------------------------------------------


@pytest.mark.parametrize(
    "seconds, sec, nanosec",
    [(0.0, 0, 0), (0.1, 0, 100_000_000), (1.5, 1, 500_000_000), (2.000000001, 2, 1),
     (123456.789012345, 123456, 789012345), (0.9999999999, 1, 0), (1e-300, 0, 0)],
)
def test_seconds_to_duration(seconds, sec, nanosec):
    d = seconds_to_duration(seconds)
    assert (d.sec, d.nanosec) == (sec, nanosec)


def test_seconds_to_duration_rounds_as_exact_arithmetic_does():
    """The float fast path gives the nanosecond the exact rational rounding gives: random times,
    halfway cases (0.5 ns) and times beyond the fast path's 2**50 ns."""
    from fractions import Fraction

    rng = np.random.default_rng(11)
    times = [*rng.uniform(0.0, 1e5, 20000).tolist(), *rng.uniform(0.0, 2e-6, 2000).tolist(),
             0.5e-9, 1.5e-9, 2.5e-9, 1e7 + 0.5e-9, 2.0 ** 51 / 1e9, 3e6 + 1.5e-9]
    for seconds in times:
        d = seconds_to_duration(seconds)
        assert d.sec * 10**9 + d.nanosec == round(Fraction(seconds) * 10**9), seconds


def test_duration_round_trips_to_the_nanosecond():
    rng = np.random.default_rng(3)
    for total in [0, 1, 999_999_999, 1_000_000_000, *rng.integers(0, 10**15, size=2000).tolist()]:
        d = Duration(sec=total // 10**9, nanosec=total % 10**9)
        assert seconds_to_duration(duration_to_seconds(d)) == d
    assert duration_to_seconds(Duration(sec=1, nanosec=100_000_000)) == 1.1


def test_joint_trajectory_round_trip():
    traj = JointTrajectory(
        joint_names=["j1", "j2"],
        points=[
            JointTrajectoryPoint([0.0, -0.0]),
            JointTrajectoryPoint([0.1, 1e-300], [1 / 3, 0.0], [0.0, -2.5], time_from_start=0.1),
            JointTrajectoryPoint([0.2, 0.3], time_from_start=1.1),
            JointTrajectoryPoint([0.3, 0.4], time_from_start=123456.789012345),
        ],
        frame_id="world",
    )
    stamp = Time(sec=5, nanosec=6)
    msg = joint_trajectory_to_msg(traj, stamp=stamp)
    assert isinstance(msg, JointTrajectoryMsg)
    assert msg.header.frame_id == "world" and msg.header.stamp == stamp and list(msg.joint_names) == ["j1", "j2"]
    assert [(p.time_from_start.sec, p.time_from_start.nanosec) for p in msg.points] == [
        (0, 0), (0, 100_000_000), (1, 100_000_000), (123456, 789012345)]
    assert list(msg.points[1].velocities) == [1 / 3, 0.0] and list(msg.points[0].velocities) == []
    assert list(msg.points[1].accelerations) == [0.0, -2.5]
    back = joint_trajectory_from_msg(msg)
    assert back == traj  # these times are whole nanoseconds, so even the floats come back exactly
    assert joint_trajectory_to_msg(back, stamp=stamp) == msg
    assert joint_trajectory_to_msg(RobotTrajectory(traj, "arm_group"), stamp=stamp) == msg


def test_joint_trajectory_from_msg_exact_nanoseconds_and_validation():
    msg = JointTrajectoryMsg(joint_names=["a"])
    msg.points = [
        JointTrajectoryPointMsg(positions=[0.0], time_from_start=Duration(sec=0, nanosec=1)),
        JointTrajectoryPointMsg(positions=[1.0], effort=[3.0], time_from_start=Duration(sec=7, nanosec=999_999_999)),
    ]
    traj = joint_trajectory_from_msg(msg)
    assert traj.points[0].time_from_start == 1e-9 and traj.points[1].time_from_start == 7.999999999
    assert joint_trajectory_to_msg(traj).points[1].time_from_start == Duration(sec=7, nanosec=999_999_999)
    assert list(joint_trajectory_to_msg(traj).points[1].effort) == []  # efforts are not carried
    msg.points.reverse()
    with pytest.raises(MessageError, match=r"JointTrajectory\.points\[1\]\.time_from_start"):
        joint_trajectory_from_msg(msg)


# ---- markers ---------------------------------------------------------------------------


def test_box_marker_geometry_with_object_and_shape_poses():
    # Object at (1, 0, 0) turned 90° about z; box offset 0.5 along the object's x axis,
    # so it must land at (1, 0.5, 0), still turned 90°.
    obj_pose = Pose.from_xyz_rpy([1, 0, 0], [0, 0, math.pi / 2])
    obj = CollisionObject(id="box", frame_id="base", pose=obj_pose, primitives=[SolidPrimitive.box(0.1, 0.2, 0.3)],
                          primitive_poses=[Pose(position=[0.5, 0, 0])])
    stamp = Time(sec=1, nanosec=2)
    (m,) = collision_object_to_markers(obj, ns="scene", id_start=7, color=(1, 0, 0, 0.5), stamp=stamp)
    assert (m.type, m.action, m.ns, m.id) == (Marker.CUBE, Marker.ADD, "scene", 7)
    assert m.header.frame_id == "base" and m.header.stamp == stamp
    assert (m.scale.x, m.scale.y, m.scale.z) == (0.1, 0.2, 0.3)
    assert (m.color.r, m.color.g, m.color.b, m.color.a) == (1.0, 0.0, 0.0, 0.5)
    T = _marker_matrix(m)
    np.testing.assert_allclose(T[:3, 3], [1.0, 0.5, 0.0], atol=1e-15)
    np.testing.assert_allclose(T[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)
    # A box corner, transformed by the marker pose, is where object ∘ shape puts it.
    corner = np.array([0.05, 0.1, 0.15, 1.0])
    np.testing.assert_allclose(T @ corner, [1.0 - 0.1, 0.5 + 0.05, 0.15, 1.0], atol=1e-15)


def test_cylinder_marker_geometry_with_general_poses():
    obj_pose = Pose.from_xyz_rpy([0.3, -0.2, 0.7], [0.3, -0.4, 1.2])
    shape_pose = Pose.from_xyz_rpy([0.05, 0.1, -0.2], [0.5, 0.0, -0.7])
    obj = CollisionObject(id="can", pose=obj_pose, primitives=[SolidPrimitive.cylinder(height=0.4, radius=0.05)],
                          primitive_poses=[shape_pose])
    (m,) = collision_object_to_markers(obj)
    assert m.type == Marker.CYLINDER and m.ns == "planning_scene" and m.id == 0 and m.header.frame_id == "world"
    assert (m.scale.x, m.scale.y, m.scale.z) == (0.1, 0.1, 0.4)
    np.testing.assert_allclose(_marker_matrix(m), obj_pose.to_matrix() @ shape_pose.to_matrix(), atol=1e-14)


def test_markers_for_every_shape_kind():
    verts = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    obj = CollisionObject(
        id="all",
        pose=Pose(position=[0, 0, 1]),
        primitives=[SolidPrimitive.sphere(0.25), SolidPrimitive.cone(0.4, 0.1), SolidPrimitive.box(1, 1, 1)],
        primitive_poses=[Pose(), Pose(), Pose()],
        meshes=[Mesh.from_file("/opt/meshes/part.stl", [0.001, 0.001, 0.001]),
                Mesh.from_file("package://pkg/part.dae"),
                Mesh.from_triangles(verts, [[0, 1, 2], [0, 2, 3]], [2, 2, 2])],
        mesh_poses=[Pose(), Pose(), Pose(position=[1, 0, 0])],
    )
    markers = collision_object_to_markers(obj, id_start=10)
    assert [m.id for m in markers] == list(range(10, 16))
    sphere, cone, box, abs_mesh, pkg_mesh, tri = markers
    assert sphere.type == Marker.SPHERE and (sphere.scale.x, sphere.scale.y, sphere.scale.z) == (0.5, 0.5, 0.5)
    assert cone.type == Marker.TRIANGLE_LIST and len(cone.points) % 3 == 0 and len(cone.points) > 0
    pts = np.array([[p.x, p.y, p.z] for p in cone.points])
    assert pts[:, 2].max() == pytest.approx(0.2) and pts[:, 2].min() == pytest.approx(-0.2)
    assert np.hypot(pts[:, 0], pts[:, 1]).max() == pytest.approx(0.1)
    assert np.hypot(pts[pts[:, 2] > 0.19, 0], pts[pts[:, 2] > 0.19, 1]).max() == 0.0  # tip on the axis at +h/2
    assert box.type == Marker.CUBE
    assert abs_mesh.type == Marker.MESH_RESOURCE and abs_mesh.mesh_resource == "file:///opt/meshes/part.stl"
    assert (abs_mesh.scale.x, abs_mesh.scale.y, abs_mesh.scale.z) == (0.001, 0.001, 0.001)
    assert pkg_mesh.mesh_resource == "package://pkg/part.dae"
    assert tri.type == Marker.TRIANGLE_LIST and (tri.scale.x, tri.scale.y, tri.scale.z) == (2.0, 2.0, 2.0)
    assert [(p.x, p.y, p.z) for p in tri.points] == [tuple(map(float, verts[k])) for k in (0, 1, 2, 0, 2, 3)]
    assert (tri.pose.position.x, tri.pose.position.z) == (1.0, 1.0)


def test_remove_object_has_no_markers_and_bad_color_rejected():
    assert collision_object_to_markers(CollisionObject(id="x", operation=CollisionObject.REMOVE)) == []
    with pytest.raises(MessageError, match="color"):
        collision_object_to_markers(CollisionObject.sphere("s", 1.0), color=(1, 0, 0))
    with pytest.raises(MessageError, match="color"):
        collision_object_to_markers(CollisionObject.sphere("s", 1.0), color=(1, 0, 0, 2))


@pytest.mark.parametrize(
    "prim",
    [SolidPrimitive.box(0.1, 0.2, 0.3), SolidPrimitive.sphere(0.25), SolidPrimitive.cylinder(0.4, 0.05)],
    ids=lambda p: p.type_name,
)
def test_primitive_from_marker_inverts_markers(prim):
    pose = Pose.from_xyz_rpy([0.1, 0.2, 0.3], [0.4, 0.5, 0.6])
    obj = CollisionObject(id="o", frame_id="base", pose=pose, primitives=[prim], primitive_poses=[Pose()])
    (m,) = collision_object_to_markers(obj, ns="ns", id_start=4)
    back_prim, back_pose = primitive_from_marker(m)
    assert back_prim == prim and back_pose == pose
    assert marker_to_collision_object(m, id="o") == obj
    assert marker_to_collision_object(m).id == "ns_4"


def test_primitive_from_marker_rejects_non_primitives():
    m = Marker(type=Marker.SPHERE)
    m.scale.x, m.scale.y, m.scale.z = 1.0, 2.0, 1.0
    with pytest.raises(MessageError, match="ellipsoid"):
        primitive_from_marker(m)
    m.type = Marker.CYLINDER
    with pytest.raises(MessageError, match="elliptic"):
        primitive_from_marker(m)
    m.type = Marker.TEXT_VIEW_FACING
    with pytest.raises(MessageError, match=r"Marker\.type: marker type 9"):
        primitive_from_marker(m)
    m.type = Marker.CUBE
    m.scale.x = 0.0
    with pytest.raises(MessageError, match=r"BOX x must be > 0"):
        primitive_from_marker(m)


# ---- JSON over String ------------------------------------------------------------------


def test_string_msg_round_trip():
    scene = PlanningScene(world={"collision_objects": [CollisionObject.box("b", [0.1, 0.2, 0.3]).to_dict()]})
    msg = string_msg(scene)
    assert isinstance(msg, String) and msg.data == scene.to_json()
    assert message_from_string(PlanningScene, msg) == scene
    with pytest.raises(MessageError, match="malformed JSON"):
        message_from_string(PlanningScene, String(data="{not json"))


def test_fast_built_trajectory_messages_equal_the_constructed_ones(monkeypatch):
    """joint_trajectory_to_msg fills the generated messages' slots directly (skipping their
    constructors): the messages must equal, serialize and deserialize as those built the ordinary
    way, up to Duration's largest time."""
    from rclpy.serialization import deserialize_message, serialize_message

    from interfaces_py import ros_conversions

    assert ros_conversions._FAST_POINTS and ros_conversions._FAST_DURATIONS  # rosidl's slots are there
    rng = np.random.default_rng(5)
    times = np.cumsum(rng.uniform(0.0, 0.02, 200))
    traj = JointTrajectory.from_arrays([f"j{k}" for k in range(6)], times, rng.normal(size=(200, 6)),
                                       rng.normal(size=(200, 6)), rng.normal(size=(200, 6)))
    traj.points[-1].time_from_start = 2.0 ** 31 - 0.5  # Duration's largest seconds (exact rounding there)
    fast = joint_trajectory_to_msg(traj, stamp=Time(sec=1, nanosec=2))
    monkeypatch.setattr(ros_conversions, "_FAST_POINTS", False)
    monkeypatch.setattr(ros_conversions, "_FAST_DURATIONS", False)
    plain = joint_trajectory_to_msg(traj, stamp=Time(sec=1, nanosec=2))
    assert fast == plain
    data, plain_data = serialize_message(fast), serialize_message(plain)
    assert len(data) == len(plain_data)  # (CDR's alignment padding is not zeroed: bytes may differ there)
    again = deserialize_message(data, JointTrajectoryMsg)
    assert again == fast == deserialize_message(plain_data, JointTrajectoryMsg)
    assert joint_trajectory_from_msg(again) == joint_trajectory_from_msg(plain)
    point = fast.points[3]  # a fast-built message behaves as any: its setters still work
    point.positions = [1.0] * 6
    point.time_from_start.sec = 4
    assert list(point.positions) == [1.0] * 6 and point.time_from_start == Duration(sec=4, nanosec=point.time_from_start.nanosec)
    assert "positions=[1.0, 1.0" in repr(point)
