"""Conversions between :mod:`interfaces_py.msgs` and standard ROS 2 messages.

Why a separate module: ``interfaces_py.msgs`` must import without ROS (core code and offline
tools use it), while nodes need the standard messages of the design card's "ROS interface
conventions": ``geometry_msgs/Pose``, ``shape_msgs/SolidPrimitive``, ``sensor_msgs/JointState``,
``trajectory_msgs/JointTrajectory``, ``visualization_msgs/Marker`` and ``std_msgs/String`` for
everything that has no standard message (JSON from ``to_json``).

All functions are pure (no node, no rclpy). Floats are copied unchanged except where the ROS
type is narrower (Marker colours are float32; times are integer nanoseconds).
"""

from __future__ import annotations

from array import array

import math
from fractions import Fraction
from typing import Any, Sequence, TypeVar

from builtin_interfaces.msg import Duration as DurationMsg
from builtin_interfaces.msg import Time as TimeMsg
from geometry_msgs.msg import Point as PointMsg
from geometry_msgs.msg import Pose as PoseMsg
from geometry_msgs.msg import Vector3 as Vector3Msg
from sensor_msgs.msg import JointState as JointStateMsg
from shape_msgs.msg import SolidPrimitive as SolidPrimitiveMsg
from std_msgs.msg import ColorRGBA as ColorRGBAMsg
from std_msgs.msg import String as StringMsg
from trajectory_msgs.msg import JointTrajectory as JointTrajectoryMsg
from trajectory_msgs.msg import JointTrajectoryPoint as JointTrajectoryPointMsg
from visualization_msgs.msg import Marker

from interfaces_py.msgs import (
    CollisionObject,
    JointTrajectory,
    JointTrajectoryPoint,
    MessageError,
    Pose,
    RobotState,
    RobotTrajectory,
    SolidPrimitive,
)

__all__ = [
    "pose_to_msg",
    "pose_from_msg",
    "primitive_to_msg",
    "primitive_from_msg",
    "robot_state_to_joint_state",
    "joint_state_to_robot_state",
    "seconds_to_duration",
    "duration_to_seconds",
    "joint_trajectory_to_msg",
    "joint_trajectory_from_msg",
    "collision_object_to_markers",
    "primitive_from_marker",
    "marker_to_collision_object",
    "string_msg",
    "message_from_string",
]

M = TypeVar("M")
_NS_PER_S = 1_000_000_000
_CONE_SEGMENTS = 32  # rviz has no cone marker; cones are drawn as a triangle list


# ---- geometry ------------------------------------------------------------------------


def pose_to_msg(pose: Pose) -> PoseMsg:
    msg = PoseMsg()
    msg.position.x, msg.position.y, msg.position.z = pose.position
    msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w = pose.orientation
    return msg


def pose_from_msg(msg: PoseMsg) -> Pose:
    """Pose from geometry_msgs/Pose; a non-unit quaternion is normalised, a zero one rejected."""
    p, q = msg.position, msg.orientation
    return Pose(position=[p.x, p.y, p.z], orientation=[q.x, q.y, q.z, q.w])


def primitive_to_msg(primitive: SolidPrimitive) -> SolidPrimitiveMsg:
    # Our type values and dimension layout are shape_msgs' own, so this is a plain copy.
    return SolidPrimitiveMsg(type=primitive.type, dimensions=list(primitive.dimensions))


def primitive_from_msg(msg: SolidPrimitiveMsg) -> SolidPrimitive:
    """SolidPrimitive from shape_msgs; PRISM (5) is not supported and raises MessageError."""
    return SolidPrimitive(type=int(msg.type), dimensions=[float(d) for d in msg.dimensions])


# ---- joint states and trajectories -----------------------------------------------------


def robot_state_to_joint_state(
    state: RobotState, stamp: TimeMsg | None = None, frame_id: str = ""
) -> JointStateMsg:
    """sensor_msgs/JointState for ``/joint_states``; attached objects have no place in it."""
    msg = JointStateMsg()
    if stamp is not None:
        msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.name = list(state.joint_names)
    msg.position = list(state.positions)
    msg.velocity = list(state.velocities)
    return msg


def joint_state_to_robot_state(msg: JointStateMsg) -> RobotState:
    """RobotState from a JointState (efforts are dropped: RobotState has none)."""
    return RobotState(
        joint_names=list(msg.name),
        positions=[float(v) for v in msg.position],
        velocities=[float(v) for v in msg.velocity],
    )


#: ns below which seconds_to_duration's float product is exact enough (see there)
_FAST_NS_LIMIT = float(2 ** 50)
#: what the generated messages' constructors set ``_check_fields`` to (ROS_PYTHON_CHECK_FIELDS)
_CHECK_FIELDS = bool(getattr(JointTrajectoryPointMsg(), "_check_fields", False))
#: Duration.sec is an int32
_INT32 = 2 ** 31


def seconds_to_duration(seconds: float) -> DurationMsg:
    """builtin_interfaces/Duration nearest to ``seconds``, rounded to the nanosecond.

    Uses exact rational arithmetic so that any time that is a whole number of nanoseconds
    (which is every time that came from a Duration) maps back to the same sec/nanosec.
    """
    if not math.isfinite(seconds):
        raise MessageError("Duration", f"must be finite, got {seconds}")
    scaled = seconds * 1e9
    total = round(scaled)
    # Below 2**50 ns the float product is within 0.125 of the exact one, so a product within 0.25
    # of an integer has that integer as the exact nearest; otherwise (halfway cases, huge times)
    # round the exact rational. The fast path keeps planned trajectories' hundreds of points cheap.
    if not (abs(scaled) < _FAST_NS_LIMIT and abs(scaled - total) < 0.25):
        total = round(Fraction(seconds) * _NS_PER_S)
    sec, nanosec = divmod(total, _NS_PER_S)
    if _FAST_DURATIONS and -_INT32 <= sec < _INT32:  # else the constructor says what is out of range
        duration = _new_duration(DurationMsg)
        duration._check_fields = _CHECK_FIELDS
        duration._sec = sec
        duration._nanosec = nanosec
        return duration
    return DurationMsg(sec=sec, nanosec=nanosec)


def _has_slots(cls: type, fields: Sequence[str]) -> bool:
    """Whether ``cls`` stores ``fields`` in the slots rosidl's Python generator gives messages."""
    slots = getattr(cls, "__slots__", ())
    return "_check_fields" in slots and all("_" + name in slots for name in fields)


#: trajectory points and durations built with their slots filled directly, skipping the generated
#: constructor and setters, which re-create and re-check every field (~7 us per trajectory point,
#: several times the rest). Only for values already of the field's stored type (array('d'), int,
#: a message) and only for classes with rosidl's slots; test_ros_conversions proves the result
#: serializes to the same bytes as the ordinary construction.
_FAST_POINTS = _has_slots(JointTrajectoryPointMsg, ("positions", "velocities", "accelerations", "effort",
                                                    "time_from_start"))
_FAST_DURATIONS = _has_slots(DurationMsg, ("sec", "nanosec"))
_new_point = JointTrajectoryPointMsg.__new__
_new_duration = DurationMsg.__new__


def duration_to_seconds(msg: DurationMsg) -> float:
    # One correctly rounded division: the nearest float to the exact nanosecond count.
    return (msg.sec * _NS_PER_S + msg.nanosec) / _NS_PER_S


def joint_trajectory_to_msg(
    trajectory: JointTrajectory | RobotTrajectory, stamp: TimeMsg | None = None
) -> JointTrajectoryMsg:
    """trajectory_msgs/JointTrajectory (controller command / ``ros2 topic echo`` form).

    A RobotTrajectory is accepted for convenience; its group name has no place in the message.
    """
    if isinstance(trajectory, RobotTrajectory):
        trajectory = trajectory.joint_trajectory
    msg = JointTrajectoryMsg()
    if stamp is not None:
        msg.header.stamp = stamp
    msg.header.frame_id = trajectory.frame_id
    msg.joint_names = list(trajectory.joint_names)
    msg.points = [_point_msg(p) for p in trajectory.points]
    return msg


def _point_msg(p: JointTrajectoryPoint) -> JointTrajectoryPointMsg:
    """One trajectory point: the hot part of every planned trajectory's message (hundreds of
    points), so its slots are filled directly (see _FAST_POINTS) when the generated class allows it."""
    time_from_start = seconds_to_duration(p.time_from_start)
    if _FAST_POINTS:
        point = _new_point(JointTrajectoryPointMsg)
        point._check_fields = _CHECK_FIELDS
        point._positions = array("d", p.positions)
        point._velocities = array("d", p.velocities)
        point._accelerations = array("d", p.accelerations)
        point._effort = array("d")
        point._time_from_start = time_from_start
        return point
    point = JointTrajectoryPointMsg()
    # array('d'): the generated setters and the C conversion take it without a per-value check
    point.positions = array("d", p.positions)
    point.velocities = array("d", p.velocities)
    point.accelerations = array("d", p.accelerations)
    point.time_from_start = time_from_start
    return point


def joint_trajectory_from_msg(msg: JointTrajectoryMsg) -> JointTrajectory:
    """JointTrajectory from the ROS message (header stamp and per-point efforts are dropped)."""
    return JointTrajectory(
        joint_names=list(msg.joint_names),
        points=[
            JointTrajectoryPoint(
                positions=[float(v) for v in p.positions],
                velocities=[float(v) for v in p.velocities],
                accelerations=[float(v) for v in p.accelerations],
                time_from_start=duration_to_seconds(p.time_from_start),
            )
            for p in msg.points
        ],
        frame_id=msg.header.frame_id,
    )


# ---- markers ---------------------------------------------------------------------------


def _color_msg(color: Sequence[float]) -> ColorRGBAMsg:
    try:
        r, g, b, a = (float(c) for c in color)
    except (TypeError, ValueError):
        raise MessageError("color", f"expected (r, g, b, a) numbers, got {color!r}") from None
    if not all(0.0 <= c <= 1.0 for c in (r, g, b, a)):
        raise MessageError("color", f"each of (r, g, b, a) must be in [0, 1], got {color!r}")
    return ColorRGBAMsg(r=r, g=g, b=b, a=a)


def _cone_triangles(height: float, radius: float) -> list[tuple[float, float, float]]:
    """Cone as triangle-list corners: base disc at z = -h/2, tip at +h/2 (FCL/coal convention)."""
    tip, centre = (0.0, 0.0, height / 2), (0.0, 0.0, -height / 2)
    rim = [
        (radius * math.cos(2 * math.pi * k / _CONE_SEGMENTS),
         radius * math.sin(2 * math.pi * k / _CONE_SEGMENTS), -height / 2)
        for k in range(_CONE_SEGMENTS)
    ]
    corners: list[tuple[float, float, float]] = []
    for k in range(_CONE_SEGMENTS):
        a, b = rim[k], rim[(k + 1) % _CONE_SEGMENTS]
        corners += [a, b, tip, b, a, centre]
    return corners


def _mesh_uri(resource: str) -> str:
    """rviz needs a URI: turn an absolute file path into file://, keep anything else."""
    return "file://" + resource if resource.startswith("/") else resource


def collision_object_to_markers(
    obj: CollisionObject,
    ns: str = "planning_scene",
    id_start: int = 0,
    color: Sequence[float] = (0.5, 0.7, 1.0, 1.0),
    stamp: TimeMsg | None = None,
) -> list[Marker]:
    """One ADD marker per shape of ``obj``, ids ``id_start, id_start + 1, ...`` in ``ns``.

    Marker poses are ``obj.pose ∘ shape pose`` in ``obj.frame_id``. Primitives become CUBE /
    SPHERE / CYLINDER (scale = full extents: box sizes, sphere 2r, cylinder 2r, 2r, h); cones a
    TRIANGLE_LIST; meshes MESH_RESOURCE or TRIANGLE_LIST with ``scale`` = mesh scale. A REMOVE
    object yields no markers: deleting is the caller's job, as only it knows the marker ids.
    """
    if obj.operation == CollisionObject.REMOVE:
        return []
    color_msg = _color_msg(color)
    markers: list[Marker] = []

    def new_marker(marker_type: int, shape_pose: Pose, scale: Sequence[float]) -> Marker:
        m = Marker()
        m.header.frame_id = obj.frame_id
        if stamp is not None:
            m.header.stamp = stamp
        m.ns = ns
        m.id = id_start + len(markers)
        m.type = marker_type
        m.action = Marker.ADD
        m.pose = pose_to_msg(obj.pose.compose(shape_pose))
        m.scale = Vector3Msg(x=float(scale[0]), y=float(scale[1]), z=float(scale[2]))
        m.color = color_msg
        markers.append(m)
        return m

    for prim, prim_pose in zip(obj.primitives, obj.primitive_poses):
        d = prim.dimensions
        if prim.type == SolidPrimitive.BOX:
            new_marker(Marker.CUBE, prim_pose, d)
        elif prim.type == SolidPrimitive.SPHERE:
            new_marker(Marker.SPHERE, prim_pose, [2 * d[0]] * 3)
        elif prim.type == SolidPrimitive.CYLINDER:
            r, h = d[SolidPrimitive.CYLINDER_RADIUS], d[SolidPrimitive.CYLINDER_HEIGHT]
            new_marker(Marker.CYLINDER, prim_pose, [2 * r, 2 * r, h])
        else:  # CONE
            m = new_marker(Marker.TRIANGLE_LIST, prim_pose, [1.0, 1.0, 1.0])
            m.points = [PointMsg(x=x, y=y, z=z) for x, y, z in
                        _cone_triangles(d[SolidPrimitive.CONE_HEIGHT], d[SolidPrimitive.CONE_RADIUS])]
    for mesh, mesh_pose in zip(obj.meshes, obj.mesh_poses):
        if mesh.resource:
            m = new_marker(Marker.MESH_RESOURCE, mesh_pose, mesh.scale)
            m.mesh_resource = _mesh_uri(mesh.resource)
        else:
            m = new_marker(Marker.TRIANGLE_LIST, mesh_pose, mesh.scale)
            m.points = [PointMsg(x=v[0], y=v[1], z=v[2])
                        for tri in mesh.triangles for v in (mesh.vertices[k] for k in tri)]
    return markers


def primitive_from_marker(marker: Marker) -> tuple[SolidPrimitive, Pose]:
    """Inverse of the primitive markers: (primitive, marker pose in marker.header.frame_id).

    Only CUBE, round SPHERE and round CYLINDER markers describe a SolidPrimitive; anything else
    (ellipsoids, elliptic cylinders, lines, text...) raises MessageError.
    """
    s = marker.scale
    if marker.type == Marker.CUBE:
        prim = SolidPrimitive.box(s.x, s.y, s.z)
    elif marker.type == Marker.SPHERE:
        if not s.x == s.y == s.z:
            raise MessageError("Marker.scale", f"SPHERE marker is an ellipsoid ({s.x}, {s.y}, {s.z})")
        prim = SolidPrimitive.sphere(s.x / 2)
    elif marker.type == Marker.CYLINDER:
        if s.x != s.y:
            raise MessageError("Marker.scale", f"CYLINDER marker is elliptic (x={s.x}, y={s.y})")
        prim = SolidPrimitive.cylinder(s.z, s.x / 2)
    else:
        raise MessageError("Marker.type", f"marker type {marker.type} has no SolidPrimitive equivalent "
                           "(expected CUBE(1), SPHERE(2) or CYLINDER(3))")
    return prim, pose_from_msg(marker.pose)


def marker_to_collision_object(marker: Marker, id: str | None = None) -> CollisionObject:
    """CollisionObject (ADD) from a primitive marker; id defaults to "<ns>_<id>"."""
    prim, pose = primitive_from_marker(marker)
    return CollisionObject(
        id=id if id is not None else f"{marker.ns}_{marker.id}",
        frame_id=marker.header.frame_id or "world",
        pose=pose,
        primitives=[prim],
        primitive_poses=[Pose()],
    )


# ---- JSON over std_msgs/String ---------------------------------------------------------


def string_msg(obj: Any) -> StringMsg:
    """std_msgs/String carrying ``obj.to_json()`` (how non-standard messages travel)."""
    return StringMsg(data=obj.to_json())


def message_from_string(cls: type[M], msg: StringMsg) -> M:
    """Parse a std_msgs/String produced by :func:`string_msg` as message class ``cls``."""
    return cls.from_json(msg.data)  # type: ignore[attr-defined]
