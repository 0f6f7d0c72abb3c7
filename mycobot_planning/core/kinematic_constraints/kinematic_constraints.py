"""Path constraints, as MoveIt's kinematic_constraints decide them: joint, position and
orientation constraints that every state of a path must satisfy.

MoveIt evaluates an orientation constraint on the rotation between the desired orientation and
the link's, as XYZ Euler angles (parameterization 0, about the desired frame's axes) or a rotation
vector (1, about the axes of the constraint's header frame: MoveIt 2 Jazzy's
OrientationConstraint::decide), each compared with its axis tolerance; a position constraint on
the link's point (link pose times target_point_offset) lying inside one of the region's
primitives. A constraint's link may also be a collision object attached to the robot (MoveIt's
resolveConstraintFrames: the object's pose is the attach link's pose times the object's pose in
that link, fixed while attached; orientation constraints on objects need the rotation vector
parameterization, as in MoveIt). Frames are resolved
once, at the request's start state (for world-fixed frames, such as the world or the robot's
base, that is exact). Planners use ``PathConstraints.satisfied`` inside their state validity
check (a state off the constraint manifold is invalid), and every planned path is checked again
densely (:func:`dense_violation`).

Sampling planners cannot find the thin set of states that satisfy a tight orientation constraint
by rejection alone; constraint_manifold.ConstraintManifold states the constraints as ``f(q) = 0`` over a
group's joints (each constrained quantity's excess over its bounds, MoveIt's
ompl_interface/detail/ompl_constraints.cpp), which OMPL's projected state space uses to project
samples and interpolate along the constraints (core/planners/ompl/solve.py).

Constraints arrive in three forms: the JSON form of the planning interface
(:func:`path_constraints_from_json`), a moveit_msgs/Constraints message read by its fields only
(:func:`constraints_json_from_msg`: no ROS import here), or this module's resolved
:class:`PathConstraints`.
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field, replace
from typing import Any, Mapping, Sequence

import numpy as np
import pinocchio as pin
from scipy.spatial.transform import Rotation

from ..robot_state.robot_state import RobotState

XYZ_EULER_ANGLES = 0
ROTATION_VECTOR = 1

#: rad (max-norm): spacing of the states checked between a path's waypoints by dense_violation
CONSTRAINT_CHECK_STEP = 0.005

#: rad: an orientation tolerance this close to the largest error (pi) is not projected onto
NEARLY_FREE = 0.05
#: rad: how far planning keeps from an error of pi on such an axis (PathConstraints.for_planning)
PLANNING_WALL = 0.1
# shape_msgs/SolidPrimitive types a constraint region may use
_REGION_TYPES = {1: "box", 2: "sphere", 3: "cylinder"}


class ConstraintError(ValueError):
    """A constraint that cannot be evaluated (unknown link, bad region, bad tolerance)."""


@dataclass(frozen=True)
class JointPathConstraint:
    joint: str
    position: float
    tolerance_above: float
    tolerance_below: float

    def violation(self, state: RobotState) -> str | None:
        value = state.joint_position(self.joint)
        if self.position - self.tolerance_below - 1e-9 <= value <= self.position + self.tolerance_above + 1e-9:
            return None
        return (f"joint {self.joint} = {value:.4f} is outside [{self.position - self.tolerance_below:.4f}, "
                f"{self.position + self.tolerance_above:.4f}]")


@dataclass(frozen=True)
class OrientationPathConstraint:
    """The orientation of ``link`` (or of the frame ``offset`` in it: an attached object) within
    ``tolerances`` of ``orientation``; ``name`` is what the constraint named (a link or an
    attached object's id). ``in_frame`` is the desired orientation in the constraint's header
    frame (the message's quaternion; default: ``orientation``, i.e. the world frame): rotation
    vector errors are measured about that frame's axes."""

    link: str
    orientation: np.ndarray  # 3x3, world frame
    tolerances: np.ndarray  # rad per axis
    parameterization: int = XYZ_EULER_ANGLES
    offset: np.ndarray | None = None  # 4x4: the constrained frame in the link's frame (None: the link itself)
    name: str = ""
    in_frame: np.ndarray | None = None  # 3x3: the desired orientation in the header frame

    @property
    def label(self) -> str:
        return self.name or self.link

    def rotation(self, link_pose: np.ndarray) -> np.ndarray:
        """World rotation of the constrained frame, from the link's world pose."""
        rotation = link_pose[:3, :3]
        return rotation if self.offset is None else rotation @ self.offset[:3, :3]

    def signed_error(self, rotation: np.ndarray) -> np.ndarray:
        """The rotation from the desired orientation to ``rotation`` in the constraint's
        parameterization: XYZ Euler angles about the desired frame's axes, or the rotation vector
        about the header frame's axes (MoveIt 2 Jazzy; for the world frame, log(R R_d^T))."""
        difference = self.orientation.T @ rotation
        if self.parameterization == ROTATION_VECTOR:
            return self.axes @ pin.log3(difference)
        return Rotation.from_matrix(difference).as_euler("XYZ")

    @property
    def axes(self) -> np.ndarray:
        """The rotation taking the desired frame's axes to the header frame's."""
        return self.orientation if self.in_frame is None else self.in_frame

    def error(self, link_pose: np.ndarray) -> np.ndarray:
        return np.abs(self.signed_error(self.rotation(link_pose)))

    def violation(self, poses: Mapping[str, np.ndarray]) -> str | None:
        error = self.error(poses[self.link])
        if np.all(error <= self.tolerances + 1e-9):
            return None
        axis = int(np.argmax(error - self.tolerances))
        return (f"orientation of {self.label} is {error[axis]:.4f} rad off about {'xyz'[axis]} "
                f"(tolerance {self.tolerances[axis]:g})")


@dataclass(frozen=True)
class Region:
    kind: str  # box, sphere, cylinder
    dimensions: tuple[float, ...]
    pose_inverse: np.ndarray  # world -> region frame

    def local(self, point: np.ndarray) -> np.ndarray:
        return self.pose_inverse[:3, :3] @ point + self.pose_inverse[:3, 3]

    def contains(self, point: np.ndarray) -> bool:
        local = self.local(point)
        if self.kind == "box":
            return bool(np.all(np.abs(local) <= np.asarray(self.dimensions) / 2 + 1e-9))
        if self.kind == "sphere":
            return float(np.linalg.norm(local)) <= self.dimensions[0] + 1e-9
        height, radius = self.dimensions
        return abs(local[2]) <= height / 2 + 1e-9 and float(np.hypot(local[0], local[1])) <= radius + 1e-9


@dataclass(frozen=True)
class PositionPathConstraint:
    """The point ``offset`` of ``link`` (in the link's frame; for an attached object, its
    target point carried into the link's frame) inside one of ``regions``."""

    link: str
    offset: np.ndarray  # the constrained point in the link frame
    regions: tuple[Region, ...]
    name: str = ""

    @property
    def label(self) -> str:
        return self.name or self.link

    def point(self, link_pose: np.ndarray) -> np.ndarray:
        return link_pose[:3, :3] @ self.offset + link_pose[:3, 3]

    def violation(self, poses: Mapping[str, np.ndarray]) -> str | None:
        point = self.point(poses[self.link])
        if any(region.contains(point) for region in self.regions):
            return None
        return f"the point of {self.label} at {np.round(point, 4).tolist()} left its constraint region"


@dataclass(frozen=True)
class PathConstraints:
    joints: tuple[JointPathConstraint, ...] = ()
    orientations: tuple[OrientationPathConstraint, ...] = ()
    positions: tuple[PositionPathConstraint, ...] = ()
    links: tuple[str, ...] = field(default=())  # the robot links whose poses the constraints read
    name: str = ""

    def __bool__(self) -> bool:
        return bool(self.joints or self.orientations or self.positions)

    def violation(self, state: RobotState) -> str | None:
        """Why ``state`` breaks a constraint, or None when it satisfies them all."""
        for joint in self.joints:
            problem = joint.violation(state)
            if problem:
                return problem
        if not self.orientations and not self.positions:
            return None
        poses = state.frame_poses(self.links)
        for constraint in (*self.orientations, *self.positions):
            problem = constraint.violation(poses)
            if problem:
                return problem
        return None

    def satisfied(self, state: RobotState) -> bool:
        return self.violation(state) is None

    def for_planning(self, references: Sequence[RobotState] = ()) -> "PathConstraints":
        """These constraints as a planner's validity check should hold them: an orientation
        tolerance within NEARLY_FREE of the largest error (pi, as in the common 3.14) is a thin
        forbidden band where the error wraps around at +-pi, which discrete checks step over;
        planning keeps out of a band PLANNING_WALL wide there instead (never closer than the
        ``references``, e.g. start and goals, already are), so paths cannot cross it."""
        changed = []
        for c in self.orientations:
            wraps = [0, 2] if c.parameterization == XYZ_EULER_ANGLES else [0, 1, 2]
            tolerances = c.tolerances.copy()
            for axis in wraps:
                if math.pi - NEARLY_FREE <= tolerances[axis] < math.pi:
                    reached = max((float(c.error(state.frame_pose(c.link))[axis]) for state in references), default=0.0)
                    tolerances[axis] = min(tolerances[axis], max(math.pi - PLANNING_WALL, reached))
            changed.append(c if np.array_equal(tolerances, c.tolerances) else replace(c, tolerances=tolerances))
        return replace(self, orientations=tuple(changed))

    def describe(self) -> str:
        """One line naming the constraints (for messages)."""
        parts = [f"joint {c.joint}" for c in self.joints]
        parts += [f"orientation of {c.label}" for c in self.orientations]
        parts += [f"position of {c.label}" for c in self.positions]
        return (f"'{self.name}': " if self.name else "") + ", ".join(parts)


# ----------------------------------------------------------------------------- from the JSON form
def _matrix(pose: Any) -> np.ndarray:
    position = np.asarray(pose.get("position", [0, 0, 0]), dtype=float)
    quat = np.asarray(pose.get("orientation", [0, 0, 0, 1]), dtype=float)
    if position.shape != (3,) or quat.shape != (4,) or not np.all(np.isfinite(position)) \
            or not np.all(np.isfinite(quat)) or np.linalg.norm(quat) < 1e-9:
        raise ConstraintError(f"invalid pose {pose!r}")
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_quat(quat / np.linalg.norm(quat)).as_matrix()
    matrix[:3, 3] = position
    return matrix


def attached_frames(scene: Any, state: RobotState | None = None) -> dict[str, tuple[str, np.ndarray]]:
    """The collision objects attached in ``scene`` (a PlanningScene, read through its public
    methods) as constraint frames: {object id: (attach link, object pose in that link)}, at
    ``state`` (default: the scene's current state)."""
    state = scene.current_state if state is None else state
    frames = {}
    for object_id in scene.attached_object_ids():
        link = scene.get_attached_object(object_id).link_name
        link_pose = state.frame_pose(link)
        frames[object_id] = (link, np.linalg.solve(link_pose, scene.frame_pose(object_id, state)))
    return frames


def path_constraints_from_json(data: Mapping[str, Any] | None, start: RobotState,
                               frame_pose: Any, attached: Mapping[str, tuple[str, np.ndarray]] | None = None,
                               name: str = "") -> PathConstraints:
    """Constraints from their JSON form (see interfaces_py.moveit_conversions.path_constraints_from_msg);
    ``frame_pose(frame)`` gives a frame's world pose at the start state (raises for an unknown one).
    ``attached`` ({object id: (link, object pose in the link)}, see :func:`attached_frames`)
    lets a constraint's link be an attached collision object."""
    if not data:
        return PathConstraints(name=name)
    model = start.model
    joints, orientations, positions, links = [], [], [], []

    def link_of(entry: Mapping[str, Any], what: str) -> tuple[str, np.ndarray | None, str]:
        link = entry.get("link")
        if isinstance(link, str) and model.has_link(link):
            links.append(link)
            return link, None, link
        if isinstance(link, str) and attached and link in attached:
            parent, offset = attached[link]
            links.append(parent)
            return parent, np.asarray(offset, dtype=float), link
        objects = f" nor an attached collision object ({', '.join(sorted(attached))})" if attached else \
            " nor an attached collision object"
        raise ConstraintError(f"{what}: unknown link {link!r}: neither a link of robot '{model.name}'{objects}")

    for entry in data.get("joints", []):
        joint = entry.get("joint")
        if joint not in model.variable_names:
            raise ConstraintError(f"joint constraint: unknown joint {joint!r}")
        above, below = float(entry.get("above", 0.0)), float(entry.get("below", 0.0))
        if not (np.isfinite(above) and np.isfinite(below)) or above < 0 or below < 0:
            raise ConstraintError(f"joint constraint on {joint}: tolerances must be finite and >= 0")
        position = entry.get("position")
        if isinstance(position, bool) or not isinstance(position, numbers.Real) or not math.isfinite(position):
            raise ConstraintError(f"joint constraint on {joint}: 'position' must be a finite number, got {position!r}")
        joints.append(JointPathConstraint(joint, float(position), above, below))
    for entry in data.get("orientation", []):
        link, offset, label = link_of(entry, "orientation constraint")
        tolerances = np.asarray(entry.get("tolerance", []), dtype=float)
        if tolerances.shape != (3,) or not np.all(np.isfinite(tolerances)) or np.any(tolerances < 0):
            raise ConstraintError(f"orientation constraint on {label}: needs 3 tolerances >= 0 (x, y, z axis)")
        parameterization = int(entry.get("parameterization", XYZ_EULER_ANGLES))
        if parameterization not in (XYZ_EULER_ANGLES, ROTATION_VECTOR):
            raise ConstraintError(f"orientation constraint on {label}: parameterization must be 0 (XYZ Euler "
                                  f"angles) or 1 (rotation vector), got {parameterization}")
        if offset is not None and parameterization != ROTATION_VECTOR:
            raise ConstraintError(f"orientation constraint on {label}: XYZ Euler angles are not supported on an "
                                  "attached object (as in MoveIt); use the rotation vector parameterization (1)")
        base = frame_pose(entry.get("frame") or "world")
        in_frame = _matrix({"orientation": entry.get("orientation", [0, 0, 0, 1])})[:3, :3]
        desired = base[:3, :3] @ in_frame
        orientations.append(OrientationPathConstraint(link, desired, tolerances, parameterization, offset, label,
                                                      in_frame))
    for entry in data.get("position", []):
        link, offset, label = link_of(entry, "position constraint")
        base = frame_pose(entry.get("frame") or "world")
        regions = []
        for region in entry.get("regions", []):
            kind, dims = region.get("type"), tuple(float(d) for d in region.get("dimensions", []))
            expected = {"box": 3, "sphere": 1, "cylinder": 2}.get(kind)
            if expected is None or len(dims) != expected or not all(np.isfinite(dims)) or min(dims) <= 0:
                raise ConstraintError(f"position constraint on {label}: region {region!r} must be a box (3 sizes), "
                                      "sphere (radius) or cylinder (height, radius) with positive sizes")
            regions.append(Region(kind, dims, np.linalg.inv(base @ _matrix(region.get("pose", {})))))
        if not regions:
            raise ConstraintError(f"position constraint on {label}: the constraint region is empty")
        point = np.asarray(entry.get("offset", [0, 0, 0]), dtype=float)
        if point.shape != (3,) or not np.all(np.isfinite(point)):
            raise ConstraintError(f"position constraint on {label}: the offset must be 3 finite numbers")
        if offset is not None:
            point = offset[:3, :3] @ point + offset[:3, 3]
        positions.append(PositionPathConstraint(link, point, tuple(regions), label))
    return PathConstraints(tuple(joints), tuple(orientations), tuple(positions), tuple(dict.fromkeys(links)), name)


# ----------------------------------------------------------------------------- from a message
_MISSING = object()


def _field(msg: Any, name: str, default: Any = _MISSING) -> Any:
    """A message field, read from a message object or its dict form."""
    if isinstance(msg, Mapping):
        value = msg.get(name, default)
    else:
        value = getattr(msg, name, default)
    if value is _MISSING:
        raise ConstraintError(f"{type(msg).__name__} has no field '{name}'")
    return value


def _number(msg: Any, name: str, default: float | None = None) -> float:
    value = _field(msg, name, _MISSING if default is None else default)
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ConstraintError(f"field '{name}' must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ConstraintError(f"field '{name}' must be finite, got {number}")
    return number


def _int_field(msg: Any, name: str, default: int = 0) -> int:
    value = _field(msg, name, default)
    if isinstance(value, (bytes, bytearray)):  # a ROS byte field
        return value[0] if value else default
    return int(value)


def _xyz(msg: Any, name: str) -> list[float]:
    vector = _field(msg, name, None)
    if vector is None:
        return [0.0, 0.0, 0.0]
    return [_number(vector, axis, 0.0) for axis in "xyz"]


def _quaternion(msg: Any) -> list[float]:
    q = _field(msg, "orientation", None)
    if q is None:
        return [0.0, 0.0, 0.0, 1.0]
    values = [_number(q, axis, 0.0) for axis in "xyzw"]
    # MoveIt takes an unset (all-zero) quaternion as the identity
    return [0.0, 0.0, 0.0, 1.0] if max(abs(v) for v in values) < 1e-12 else values


def _frame(msg: Any) -> str:
    header = _field(msg, "header", None)
    frame = _field(header, "frame_id", "") if header is not None else ""
    return str(frame or "world")


def constraints_json_from_msg(msg: Any) -> dict[str, Any] | None:
    """A moveit_msgs/Constraints message (or its dict form: the message's field names) in the
    JSON form of :func:`path_constraints_from_json`; None when it constrains nothing. Read by
    field names only (no ROS import). Visibility constraints and mesh regions are refused."""
    if len(_field(msg, "visibility_constraints", ())):
        raise ConstraintError("visibility constraints are not supported")
    data: dict[str, Any] = {"joints": [], "orientation": [], "position": []}
    for jc in _field(msg, "joint_constraints", ()):
        data["joints"].append({"joint": str(_field(jc, "joint_name")), "position": _number(jc, "position"),
                               "above": _number(jc, "tolerance_above", 0.0),
                               "below": _number(jc, "tolerance_below", 0.0)})
    for oc in _field(msg, "orientation_constraints", ()):
        data["orientation"].append({
            "link": str(_field(oc, "link_name")), "frame": _frame(oc), "orientation": _quaternion(oc),
            "tolerance": [_number(oc, f"absolute_{axis}_axis_tolerance", 0.0) for axis in "xyz"],
            "parameterization": _int_field(oc, "parameterization", XYZ_EULER_ANGLES)})
    for pc in _field(msg, "position_constraints", ()):
        link = str(_field(pc, "link_name"))
        region = _field(pc, "constraint_region", None)
        if region is None:
            raise ConstraintError(f"position constraint on {link}: no constraint_region")
        if len(_field(region, "meshes", ())):
            raise ConstraintError(f"position constraint on {link}: mesh regions are not supported")
        primitives, poses = list(_field(region, "primitives", ())), list(_field(region, "primitive_poses", ()))
        if len(poses) != len(primitives):
            raise ConstraintError(f"position constraint on {link}: {len(primitives)} primitives but "
                                  f"{len(poses)} primitive_poses")
        regions = []
        for primitive, pose in zip(primitives, poses):
            kind = _REGION_TYPES.get(_int_field(primitive, "type", 0))
            if kind is None:
                raise ConstraintError(f"position constraint on {link}: region type {_field(primitive, 'type')} is "
                                      "not supported (box, sphere, cylinder)")
            regions.append({"type": kind, "dimensions": [float(d) for d in _field(primitive, "dimensions", ())],
                            "pose": {"position": _xyz(pose, "position"), "orientation": _quaternion(pose)}})
        data["position"].append({"link": link, "frame": _frame(pc), "offset": _xyz(pc, "target_point_offset"),
                                 "regions": regions})
    return data if any(data.values()) else None


# ----------------------------------------------------------------------------- checking paths
def first_violation(constraints: PathConstraints, start: RobotState, joint_names: Sequence[str],
                    positions: np.ndarray) -> tuple[int, str] | None:
    """(index, reason) of the first row of ``positions`` (states of ``joint_names``) that breaks
    the constraints, or None."""
    state = start.copy()
    index = [state.model.variable_index(n) for n in joint_names]
    q = state.positions.copy()
    for k, row in enumerate(np.asarray(positions, dtype=float)):
        q[index] = row
        state.set_positions(q)
        problem = constraints.violation(state)
        if problem:
            return k, problem
    return None


def dense_violation(constraints: PathConstraints, start: RobotState, joint_names: Sequence[str],
                    path: np.ndarray, step: float = CONSTRAINT_CHECK_STEP) -> tuple[int, float, str] | None:
    """Where the straight joint-space segments of ``path`` (rows: states of ``joint_names``)
    first leave the constraints, checked every ``step`` (max-norm): (k, s, reason), the state
    ``path[k] + s * (path[k + 1] - path[k])`` (s = 0: the waypoint itself), or None."""
    path = np.asarray(path, dtype=float)
    if len(path) == 0:
        return None
    found = first_violation(constraints, start, joint_names, path[:1])
    if found is not None:
        return 0, 0.0, found[1]
    rows, owners = [], []
    for k, (a, b) in enumerate(zip(path[:-1], path[1:])):
        steps = max(1, int(np.ceil(np.max(np.abs(b - a)) / step)))
        fractions = np.arange(1, steps + 1) / steps
        rows.append(a + (b - a) * fractions[:, None])
        owners.extend((k, float(s)) for s in fractions)
    if not rows:
        return None
    found = first_violation(constraints, start, joint_names, np.vstack(rows))
    if found is None:
        return None
    k, s = owners[found[0]]
    return (k + 1, 0.0, found[1]) if s >= 1.0 else (k, s, found[1])
