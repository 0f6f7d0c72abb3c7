"""MoveIt-style messages as plain, validated dataclasses with an exact JSON wire form.

The full story: docs/interfaces.md, section interfaces_py.msgs.
"""

from __future__ import annotations

import functools
import json
import math
import typing
from collections.abc import Mapping, Sequence
from dataclasses import MISSING, dataclass, field, fields
from typing import Any, ClassVar, TypeVar

import numpy as np

__all__ = [
    "MessageError",
    "Pose",
    "SolidPrimitive",
    "Mesh",
    "CollisionObject",
    "AttachedCollisionObject",
    "AllowedCollisionMatrix",
    "RobotState",
    "PlanningSceneWorld",
    "PlanningScene",
    "JointTrajectoryPoint",
    "JointTrajectory",
    "RobotTrajectory",
    "MoveItErrorCode",
]
# The task-constructor messages (defined at the end of this module) are listed separately until
# interfaces_py/__init__.py and the generic message tests include them; import them by name.
TASK_MESSAGES = (
    "TrajectoryExecutionInfo",
    "SolutionInfo",
    "SubTrajectory",
    "TaskSolution",
    "StageDescription",
    "TaskDescription",
    "StageStatistics",
    "TaskStatistics",
)

M = TypeVar("M", bound="_Message")

# Bounds on values that cannot be right: a message beyond them is refused with the bound, so an
# absurd number never reaches collision checking or planning arithmetic (1e300 m boxes overflow
# Coal's bounding volumes; 1e308 positions overflow IK).
#: m: the largest coordinate of any pose or mesh vertex. The myCobot reaches 0.28 m and large
#: industrial arms a few metres; a scene beyond a kilometre is a unit mistake or an attack.
WORKSPACE_BOUND = 1000.0
#: m: the largest primitive dimension (box side, radius, height): a 100 m wall is already a floor.
MAX_OBJECT_EXTENT = 100.0
#: Vertices and triangles of one explicit mesh at most (the perception pipeline's are thousands).
MAX_MESH_VERTICES = 1_000_000
MAX_MESH_TRIANGLES = 2_000_000
#: Characters of an identifier (object id, link, joint, frame or ACM entry name) at most.
MAX_NAME_LENGTH = 256


def printable(text: str, limit: int = 200, keep: str = "") -> str:
    """``text`` safe to show in a log line or an error message: control characters (but those in
    ``keep``) and lone surrogates (which UTF-8, and so rclpy's logging, cannot encode) escaped,
    cut at ``limit`` characters with a note of how many more there were."""
    text = str(text)
    if len(text) > limit:
        text = text[:limit] + f"... ({len(text) - limit} more characters)"
    if text.isprintable():
        return text
    # isprintable() is False for control characters and for lone surrogates (category Cs).
    return "".join(ch if ch in keep or ch.isprintable() else ascii(ch)[1:-1] for ch in text)


def _text_problem(value: str) -> str | None:
    """Why a string cannot travel in a message (UTF-8 cannot encode it, or it holds NUL)."""
    if "\x00" in value:
        return f"must not contain NUL characters: '{printable(value, 80)}'"
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        return f"is not valid Unicode (it holds a lone surrogate): '{printable(value, 80)}'"
    return None


def _require_name(path: str, value: str, required: bool = True) -> None:
    """An identifier: non-empty (when required), no control characters, at most MAX_NAME_LENGTH."""
    if not value:
        if required:
            raise MessageError(path, "must be a non-empty string")
        return
    if len(value) > MAX_NAME_LENGTH:
        raise MessageError(path, f"is {len(value)} characters long; names have at most {MAX_NAME_LENGTH}")
    if not value.isprintable():
        raise MessageError(path, f"must not contain control characters: '{printable(value, 80)}'")


class MessageError(ValueError):
    """A message field is missing, mistyped or out of range, or the JSON is malformed.

    ``field`` is the dotted path of the offending field (``"Pose.orientation"``,
    ``"PlanningScene.world.collision_objects[2].id"``) so callers and users can find the
    problem in a large message; ``problem`` says what is wrong with it.
    """

    def __init__(self, field: str, problem: str) -> None:
        super().__init__(f"{field}: {problem}")
        self.field = field
        self.problem = problem


# --------------------------------------------------------------------------------------
# Generic dataclass <-> dict machinery (shared by every message class)
# --------------------------------------------------------------------------------------


def _describe(value: Any) -> str:
    text = printable(repr(value), 10_000)
    return f"{type(value).__name__} {text if len(text) <= 40 else text[:37] + '...'}"


def _convert(tp: Any, value: Any, path: str) -> Any:
    """Check ``value`` against the field annotation ``tp`` and return its canonical form.

    Canonical means plain Python types (list, float, int, bool, str, message instances), so
    equality, copying and ``json.dumps`` behave predictably whatever the caller passed in
    (tuples, numpy arrays, numpy scalars, or dicts for nested messages).
    """
    if typing.get_origin(tp) is list:
        (item_tp,) = typing.get_args(tp)
        # Any sequence (list, tuple, array.array from ROS messages, numpy array) but not text.
        if isinstance(value, (str, bytes, bytearray)) or not (
            isinstance(value, Sequence) or (isinstance(value, np.ndarray) and value.ndim > 0)
        ):
            raise MessageError(path, f"expected a list, got {_describe(value)}")
        return [_convert(item_tp, v, f"{path}[{i}]") for i, v in enumerate(value)]
    if tp is float:
        if isinstance(value, (bool, np.bool_)) or not isinstance(
            value, (int, float, np.integer, np.floating)
        ):
            raise MessageError(path, f"expected a number, got {_describe(value)}")
        number = float(value)
        if not math.isfinite(number):
            raise MessageError(path, f"must be finite, got {number}")
        return number
    if tp is int:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
            raise MessageError(path, f"expected an integer, got {_describe(value)}")
        return int(value)
    if tp is bool:
        if not isinstance(value, (bool, np.bool_)):
            raise MessageError(path, f"expected true/false, got {_describe(value)}")
        return bool(value)
    if tp is str:
        if not isinstance(value, str):
            raise MessageError(path, f"expected a string, got {_describe(value)}")
        problem = _text_problem(value)
        if problem is not None:
            raise MessageError(path, problem)
        return value
    if isinstance(tp, type) and issubclass(tp, _Message):
        if isinstance(value, tp):
            return value
        if isinstance(value, Mapping):
            try:
                return tp.from_dict(value)
            except MessageError as err:
                # Re-root the nested error's path ("Pose.position" -> "X.pose.position").
                prefix = tp.__name__
                if err.field == prefix or err.field.startswith(prefix + "."):
                    raise MessageError(path + err.field[len(prefix):], err.problem) from None
                raise MessageError(path, str(err)) from None
        raise MessageError(path, f"expected {tp.__name__} or a dict, got {_describe(value)}")
    raise TypeError(f"unsupported message field type {tp!r} at {path}")  # programming error


def _encode(value: Any) -> Any:
    if isinstance(value, _Message):
        return value.to_dict()
    if isinstance(value, list):
        return [_encode(v) for v in value]
    return value


@functools.cache
def _schema(cls: type) -> tuple[tuple[str, Any, bool], ...]:
    """(name, resolved type, has_default) per dataclass field; resolved once per class."""
    hints = typing.get_type_hints(cls)
    return tuple(
        (f.name, hints[f.name], f.default is not MISSING or f.default_factory is not MISSING)
        for f in fields(cls)
    )


class _Message:
    """Base of all message dataclasses: validation, dict and JSON conversion.

    Subclasses are ``@dataclass`` classes with typed fields and override ``_validate`` for
    the rules types cannot express (lengths, ranges, enum values, cross-field consistency).
    """

    def __post_init__(self) -> None:
        name = type(self).__name__
        for fname, tp, _ in _schema(type(self)):
            setattr(self, fname, _convert(tp, getattr(self, fname), f"{name}.{fname}"))
        self._validate()

    def _validate(self) -> None:
        """Class-specific checks after type conversion; raise MessageError."""

    def to_dict(self) -> dict[str, Any]:
        """Plain dict of JSON-compatible values (nested messages become dicts)."""
        return {fname: _encode(getattr(self, fname)) for fname, _, _ in _schema(type(self))}

    @classmethod
    def from_dict(cls: type[M], d: Mapping[str, Any]) -> M:
        """Build from a dict; omitted fields take their defaults, unknown keys are errors."""
        name = cls.__name__
        if not isinstance(d, Mapping):
            raise MessageError(name, f"expected a JSON object, got {_describe(d)}")
        schema = _schema(cls)
        known = {fname for fname, _, _ in schema}
        unknown = sorted(str(k) for k in d if k not in known)
        if unknown:
            raise MessageError(
                f"{name}.{unknown[0]}", f"unknown field; {name} has {', '.join(sorted(known))}"
            )
        for fname, _, has_default in schema:
            if not has_default and fname not in d:
                raise MessageError(f"{name}.{fname}", "missing required field")
        return cls(**d)

    def to_json(self) -> str:
        """Compact JSON text; floats are written with ``repr`` so they parse back exactly."""
        return json.dumps(self.to_dict(), allow_nan=False, separators=(",", ":"))

    @classmethod
    def from_json(cls: type[M], s: str | bytes) -> M:
        """Parse JSON text produced by ``to_json`` (or written by hand / another language)."""
        if not isinstance(s, (str, bytes, bytearray)):
            raise MessageError(cls.__name__, f"expected JSON text, got {_describe(s)}")
        try:
            data = json.loads(s)
        except ValueError as err:  # JSONDecodeError and UnicodeDecodeError
            raise MessageError(cls.__name__, f"malformed JSON: {err}") from None
        return cls.from_dict(data)


def _require_len(path: str, values: Sequence[Any], n: int, what: str = "values") -> None:
    if len(values) != n:
        raise MessageError(path, f"expected {n} {what}, got {len(values)}")


def _require_unique_names(path: str, names: Sequence[str]) -> None:
    seen: set[str] = set()
    for i, n in enumerate(names):
        _require_name(f"{path}[{i}]", n)
        if n in seen:
            raise MessageError(path, f"duplicate name '{n}'")
        seen.add(n)


# --------------------------------------------------------------------------------------
# Geometry
# --------------------------------------------------------------------------------------


def _quat_mul(a: Sequence[float], b: Sequence[float]) -> list[float]:
    """Hamilton product a*b of (x, y, z, w) quaternions."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return [
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ]


@dataclass
class Pose(_Message):
    """geometry_msgs/Pose: position (x, y, z) and unit quaternion orientation (x, y, z, w).

    The quaternion is normalised on construction because downstream code (collision checking,
    IK targets) assumes a rotation; a near-zero quaternion is rejected rather than guessed.
    Normalisation is skipped when the norm is already within 1e-12 of 1, which makes it
    idempotent and therefore keeps the JSON round trip bit-exact.
    """

    position: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    orientation: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0, 1.0])

    def _validate(self) -> None:
        _require_len("Pose.position", self.position, 3, "coordinates (x, y, z)")
        _require_len("Pose.orientation", self.orientation, 4, "quaternion components (x, y, z, w)")
        far = max(abs(c) for c in self.position)
        if far > WORKSPACE_BOUND:
            raise MessageError("Pose.position", f"{self.position} is beyond the workspace bound of "
                                                f"{WORKSPACE_BOUND:g} m")
        norm = math.hypot(*self.orientation)
        if norm <= 1e-9:
            raise MessageError("Pose.orientation", f"quaternion norm {norm:g} is too small to normalise")
        if abs(norm - 1.0) > 1e-12:
            self.orientation = [q / norm for q in self.orientation]

    @classmethod
    def identity(cls) -> Pose:
        return cls()

    @classmethod
    def from_xyz_rpy(
        cls, xyz: Sequence[float] = (0.0, 0.0, 0.0), rpy: Sequence[float] = (0.0, 0.0, 0.0)
    ) -> Pose:
        """Pose from position and fixed-axis roll, pitch, yaw (URDF ``<origin rpy>``: R = Rz Ry Rx)."""
        rpy = _convert(list[float], rpy, "Pose.from_xyz_rpy(rpy)")
        _require_len("Pose.from_xyz_rpy(rpy)", rpy, 3, "angles (roll, pitch, yaw)")
        cr, sr = math.cos(rpy[0] / 2), math.sin(rpy[0] / 2)
        cp, sp = math.cos(rpy[1] / 2), math.sin(rpy[1] / 2)
        cy, sy = math.cos(rpy[2] / 2), math.sin(rpy[2] / 2)
        quat = [
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy,
        ]
        return cls(position=xyz, orientation=quat)

    def to_matrix(self) -> np.ndarray:
        """4x4 homogeneous transform, the representation ``mycobot_planning.core`` works in."""
        x, y, z, w = self.orientation
        T = np.eye(4)
        T[:3, :3] = [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
        T[:3, 3] = self.position
        return T

    @classmethod
    def from_matrix(cls, T: Any) -> Pose:
        """Pose from a 4x4 homogeneous transform; rejects matrices that are not rigid motions."""
        path = "Pose.from_matrix(T)"
        try:
            T = np.asarray(T, dtype=float)
        except (TypeError, ValueError):
            raise MessageError(path, f"expected a 4x4 numeric matrix, got {_describe(T)}") from None
        if T.shape != (4, 4):
            raise MessageError(path, f"expected shape (4, 4), got {T.shape}")
        if not np.all(np.isfinite(T)):
            raise MessageError(path, "must be finite")
        R = T[:3, :3]
        if not np.allclose(T[3], [0, 0, 0, 1], atol=1e-9):
            raise MessageError(path, f"bottom row must be [0, 0, 0, 1], got {T[3].tolist()}")
        if not np.allclose(R.T @ R, np.eye(3), atol=1e-6) or np.linalg.det(R) <= 0:
            raise MessageError(path, "rotation block is not a proper rotation matrix")
        # Shepperd's method: pick the largest diagonal term for numerical stability.
        tr = R[0, 0] + R[1, 1] + R[2, 2]
        if tr > 0:
            s = math.sqrt(tr + 1.0) * 2
            q = [(R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s, s / 4]
        elif R[0, 0] > R[1, 1] and R[0, 0] > R[2, 2]:
            s = math.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2]) * 2
            q = [s / 4, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s, (R[2, 1] - R[1, 2]) / s]
        elif R[1, 1] > R[2, 2]:
            s = math.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2]) * 2
            q = [(R[0, 1] + R[1, 0]) / s, s / 4, (R[1, 2] + R[2, 1]) / s, (R[0, 2] - R[2, 0]) / s]
        else:
            s = math.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1]) * 2
            q = [(R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, s / 4, (R[1, 0] - R[0, 1]) / s]
        return cls(position=T[:3, 3], orientation=q)

    def compose(self, other: Pose) -> Pose:
        """``self ∘ other``: ``other`` expressed in the frame that ``self`` places (shape pose in object)."""
        rotated = self.to_matrix()[:3, :3] @ np.asarray(other.position)
        position = [p + r for p, r in zip(self.position, rotated.tolist())]
        return Pose(position=position, orientation=_quat_mul(self.orientation, other.orientation))


def _as_pose(pose: Pose | np.ndarray | None, path: str) -> Pose:
    """Accept a Pose, a 4x4 matrix (core's representation) or None (identity)."""
    if pose is None:
        return Pose()
    if isinstance(pose, Pose):
        return pose
    try:
        return Pose.from_matrix(pose)
    except MessageError as err:
        raise MessageError(path, err.problem) from None


@dataclass
class SolidPrimitive(_Message):
    """shape_msgs/SolidPrimitive (box, sphere, cylinder, cone), centred on its pose.

    Dimension layout follows shape_msgs exactly (box [x, y, z], sphere [r], cylinder [h, r],
    cone [h, r]) so values can be copied from MoveIt code and ROS messages unchanged.
    Cylinder and cone axes are the local z axis; a cone's base is at z = -h/2, its tip at +h/2.
    """

    type: int
    dimensions: list[float]

    BOX: ClassVar[int] = 1
    SPHERE: ClassVar[int] = 2
    CYLINDER: ClassVar[int] = 3
    CONE: ClassVar[int] = 4
    BOX_X: ClassVar[int] = 0
    BOX_Y: ClassVar[int] = 1
    BOX_Z: ClassVar[int] = 2
    SPHERE_RADIUS: ClassVar[int] = 0
    CYLINDER_HEIGHT: ClassVar[int] = 0
    CYLINDER_RADIUS: ClassVar[int] = 1
    CONE_HEIGHT: ClassVar[int] = 0
    CONE_RADIUS: ClassVar[int] = 1
    # type -> (name, dimension names)
    _LAYOUT: ClassVar[dict[int, tuple[str, tuple[str, ...]]]] = {
        1: ("BOX", ("x", "y", "z")),
        2: ("SPHERE", ("radius",)),
        3: ("CYLINDER", ("height", "radius")),
        4: ("CONE", ("height", "radius")),
    }

    def _validate(self) -> None:
        if self.type not in self._LAYOUT:
            raise MessageError(
                "SolidPrimitive.type",
                f"unknown primitive type {self.type}; expected BOX(1), SPHERE(2), CYLINDER(3) or CONE(4)",
            )
        tname, dnames = self._LAYOUT[self.type]
        _require_len("SolidPrimitive.dimensions", self.dimensions, len(dnames),
                     f"dimensions for {tname} [{', '.join(dnames)}]")
        for i, (d, dname) in enumerate(zip(self.dimensions, dnames)):
            if d <= 0:
                raise MessageError(f"SolidPrimitive.dimensions[{i}]", f"{tname} {dname} must be > 0, got {d}")
            if d > MAX_OBJECT_EXTENT:
                raise MessageError(f"SolidPrimitive.dimensions[{i}]",
                                   f"{tname} {dname} {d:g} m is larger than the bound of {MAX_OBJECT_EXTENT:g} m")

    @property
    def type_name(self) -> str:
        """"BOX", "SPHERE", "CYLINDER" or "CONE" (for messages and logs)."""
        return self._LAYOUT[self.type][0]

    @classmethod
    def box(cls, x: float, y: float, z: float) -> SolidPrimitive:
        return cls(cls.BOX, [x, y, z])

    @classmethod
    def sphere(cls, radius: float) -> SolidPrimitive:
        return cls(cls.SPHERE, [radius])

    @classmethod
    def cylinder(cls, height: float, radius: float) -> SolidPrimitive:
        return cls(cls.CYLINDER, [height, radius])

    @classmethod
    def cone(cls, height: float, radius: float) -> SolidPrimitive:
        return cls(cls.CONE, [height, radius])


@dataclass
class Mesh(_Message):
    """A mesh shape: either a file ``resource`` (path or package:// / file:// URI) or explicit
    ``vertices`` + ``triangles`` (shape_msgs/Mesh), never both, so there is one source of truth.

    ``scale`` multiplies vertex coordinates in both cases (as rviz's Marker.scale and MoveIt's
    mesh loading do). Triangle indices must refer to existing vertices.
    """

    resource: str = ""
    scale: list[float] = field(default_factory=lambda: [1.0, 1.0, 1.0])
    vertices: list[list[float]] = field(default_factory=list)
    triangles: list[list[int]] = field(default_factory=list)

    def _validate(self) -> None:
        _require_len("Mesh.scale", self.scale, 3, "scale factors (x, y, z)")
        for i, s in enumerate(self.scale):
            if s <= 0:
                raise MessageError(f"Mesh.scale[{i}]", f"must be > 0, got {s}")
        if self.resource:
            if not self.resource.strip():
                raise MessageError("Mesh.resource", "must not be blank")
            if self.vertices or self.triangles:
                raise MessageError("Mesh", "give either a resource or vertices/triangles, not both")
            return
        if not self.triangles:
            raise MessageError("Mesh.triangles", "empty: a mesh needs a resource or at least one triangle")
        if len(self.vertices) > MAX_MESH_VERTICES or len(self.triangles) > MAX_MESH_TRIANGLES:
            raise MessageError("Mesh", f"{len(self.vertices)} vertices and {len(self.triangles)} triangles: at most "
                                       f"{MAX_MESH_VERTICES} and {MAX_MESH_TRIANGLES}")
        for i, v in enumerate(self.vertices):
            _require_len(f"Mesh.vertices[{i}]", v, 3, "coordinates (x, y, z)")
            if max(abs(c * f) for c, f in zip(v, self.scale)) > WORKSPACE_BOUND:
                raise MessageError(f"Mesh.vertices[{i}]", f"{v} (scaled) is beyond the workspace bound of "
                                                          f"{WORKSPACE_BOUND:g} m")
        n = len(self.vertices)
        for i, tri in enumerate(self.triangles):
            _require_len(f"Mesh.triangles[{i}]", tri, 3, "vertex indices")
            for k in tri:
                if not 0 <= k < n:
                    raise MessageError(f"Mesh.triangles[{i}]", f"vertex index {k} out of range for {n} vertices")

    @classmethod
    def from_file(cls, resource: str, scale: Sequence[float] = (1.0, 1.0, 1.0)) -> Mesh:
        return cls(resource=resource, scale=scale)

    @classmethod
    def from_triangles(
        cls, vertices: Any, triangles: Any, scale: Sequence[float] = (1.0, 1.0, 1.0)
    ) -> Mesh:
        return cls(vertices=vertices, triangles=triangles, scale=scale)


# --------------------------------------------------------------------------------------
# Scene
# --------------------------------------------------------------------------------------


@dataclass
class CollisionObject(_Message):
    """moveit_msgs/CollisionObject: shapes placed at ``pose`` in ``frame_id``.

    Each shape's pose is relative to the object ``pose`` (MoveIt >= Noetic semantics), so
    moving the object means changing one pose. ``operation`` uses MoveIt's values: ADD
    replaces any object with the same id, APPEND adds shapes to it, REMOVE and MOVE ignore the
    shapes (MOVE takes the new ``pose``). ADD and APPEND must carry at least one shape.
    Planes and subframes of the MoveIt message are not supported.
    """

    id: str
    frame_id: str = "world"
    pose: Pose = field(default_factory=Pose)
    primitives: list[SolidPrimitive] = field(default_factory=list)
    primitive_poses: list[Pose] = field(default_factory=list)
    meshes: list[Mesh] = field(default_factory=list)
    mesh_poses: list[Pose] = field(default_factory=list)
    operation: int = 0

    ADD: ClassVar[int] = 0
    REMOVE: ClassVar[int] = 1
    APPEND: ClassVar[int] = 2
    MOVE: ClassVar[int] = 3
    _OPERATIONS: ClassVar[dict[int, str]] = {0: "ADD", 1: "REMOVE", 2: "APPEND", 3: "MOVE"}

    def _validate(self) -> None:
        _require_name("CollisionObject.id", self.id)
        _require_name("CollisionObject.frame_id", self.frame_id)
        if self.operation not in self._OPERATIONS:
            raise MessageError(
                "CollisionObject.operation",
                f"unknown operation {self.operation}; expected ADD(0), REMOVE(1), APPEND(2) or MOVE(3)",
            )
        if len(self.primitive_poses) != len(self.primitives):
            raise MessageError("CollisionObject.primitive_poses",
                               f"{len(self.primitive_poses)} poses for {len(self.primitives)} primitives")
        if len(self.mesh_poses) != len(self.meshes):
            raise MessageError("CollisionObject.mesh_poses",
                               f"{len(self.mesh_poses)} poses for {len(self.meshes)} meshes")
        if self.operation in (self.ADD, self.APPEND) and not self.primitives and not self.meshes:
            raise MessageError("CollisionObject.primitives",
                               f"{self.operation_name} needs at least one primitive or mesh")

    @property
    def operation_name(self) -> str:
        return self._OPERATIONS[self.operation]

    @classmethod
    def box(cls, id: str, size: Sequence[float], pose: Pose | np.ndarray | None = None,
            frame_id: str = "world") -> CollisionObject:
        """Box of ``size`` (x, y, z) centred at ``pose`` (Pose, 4x4 matrix or None = origin)."""
        _require_len("CollisionObject.box(size)", size, 3, "box sizes (x, y, z)")
        return cls(id=id, frame_id=frame_id, pose=_as_pose(pose, "CollisionObject.pose"),
                   primitives=[SolidPrimitive.box(*size)], primitive_poses=[Pose()])

    @classmethod
    def cylinder(cls, id: str, height: float, radius: float, pose: Pose | np.ndarray | None = None,
                 frame_id: str = "world") -> CollisionObject:
        """Cylinder along the local z axis, centred at ``pose``."""
        return cls(id=id, frame_id=frame_id, pose=_as_pose(pose, "CollisionObject.pose"),
                   primitives=[SolidPrimitive.cylinder(height, radius)], primitive_poses=[Pose()])

    @classmethod
    def sphere(cls, id: str, radius: float, pose: Pose | np.ndarray | None = None,
               frame_id: str = "world") -> CollisionObject:
        return cls(id=id, frame_id=frame_id, pose=_as_pose(pose, "CollisionObject.pose"),
                   primitives=[SolidPrimitive.sphere(radius)], primitive_poses=[Pose()])

    @classmethod
    def mesh(cls, id: str, resource: str, pose: Pose | np.ndarray | None = None,
             frame_id: str = "world", scale: Sequence[float] = (1.0, 1.0, 1.0)) -> CollisionObject:
        return cls(id=id, frame_id=frame_id, pose=_as_pose(pose, "CollisionObject.pose"),
                   meshes=[Mesh.from_file(resource, scale)], mesh_poses=[Pose()])


@dataclass
class AttachedCollisionObject(_Message):
    """moveit_msgs/AttachedCollisionObject: ``object`` rigidly attached to robot link ``link_name``.

    ``touch_links`` may collide with the object (the gripper fingers holding it); ``weight`` is
    kept for MoveIt compatibility (kg) and must be >= 0.
    """

    link_name: str
    object: CollisionObject
    touch_links: list[str] = field(default_factory=list)
    weight: float = 0.0

    def _validate(self) -> None:
        _require_name("AttachedCollisionObject.link_name", self.link_name)
        for i, link in enumerate(self.touch_links):
            _require_name(f"AttachedCollisionObject.touch_links[{i}]", link)
        if self.weight < 0:
            raise MessageError("AttachedCollisionObject.weight", f"must be >= 0, got {self.weight}")


@dataclass
class AllowedCollisionMatrix(_Message):
    """moveit_msgs/AllowedCollisionMatrix: which pairs of bodies may touch.

    ``entry_values[i][j]`` is True when ``entry_names[i]`` and ``entry_names[j]`` may collide;
    the matrix must be square and symmetric because collision is symmetric and an asymmetric
    matrix has no meaning. ``default_entry_*`` give a per-name fallback used when a pair has no
    explicit entry (True: that body may collide with anything), exactly as in MoveIt.
    """

    entry_names: list[str] = field(default_factory=list)
    entry_values: list[list[bool]] = field(default_factory=list)
    default_entry_names: list[str] = field(default_factory=list)
    default_entry_values: list[bool] = field(default_factory=list)

    def _validate(self) -> None:
        path = "AllowedCollisionMatrix"
        _require_unique_names(f"{path}.entry_names", self.entry_names)
        n = len(self.entry_names)
        _require_len(f"{path}.entry_values", self.entry_values, n, "rows (one per entry name)")
        for i, row in enumerate(self.entry_values):
            _require_len(f"{path}.entry_values[{i}]", row, n, "columns (one per entry name)")
        for i in range(n):
            for j in range(i + 1, n):
                if self.entry_values[i][j] != self.entry_values[j][i]:
                    raise MessageError(f"{path}.entry_values", "not symmetric for "
                                       f"('{self.entry_names[i]}', '{self.entry_names[j]}')")
        _require_unique_names(f"{path}.default_entry_names", self.default_entry_names)
        _require_len(f"{path}.default_entry_values", self.default_entry_values,
                     len(self.default_entry_names), "values (one per default entry name)")

    def is_allowed(self, a: str, b: str) -> bool:
        """MoveIt's lookup: the explicit entry if there is one, else either body's default."""
        names = self.entry_names
        if a in names and b in names:
            return self.entry_values[names.index(a)][names.index(b)]
        defaults = dict(zip(self.default_entry_names, self.default_entry_values))
        return defaults.get(a, False) or defaults.get(b, False)

    def set_allowed(self, a: str, b: str, allowed: bool = True) -> None:
        """Set the (a, b) entry symmetrically, adding names as needed (matrix stays valid)."""
        for name in (a, b):
            if not isinstance(name, str) or not name:
                raise MessageError("AllowedCollisionMatrix.entry_names", f"invalid name {name!r}")
            if name not in self.entry_names:
                self.entry_names.append(name)
                for row in self.entry_values:
                    row.append(False)
                self.entry_values.append([False] * len(self.entry_names))
        i, j = self.entry_names.index(a), self.entry_names.index(b)
        self.entry_values[i][j] = self.entry_values[j][i] = bool(allowed)


@dataclass
class RobotState(_Message):
    """moveit_msgs/RobotState: joint positions (and optional velocities) plus attached objects.

    The wire form of a robot state; ``mycobot_planning.core.RobotState`` is the computational
    one. ``velocities`` is empty or one per joint. ``is_diff`` marks a partial state to be
    merged into the current one, as in MoveIt.
    """

    joint_names: list[str] = field(default_factory=list)
    positions: list[float] = field(default_factory=list)
    velocities: list[float] = field(default_factory=list)
    attached_collision_objects: list[AttachedCollisionObject] = field(default_factory=list)
    is_diff: bool = False

    def _validate(self) -> None:
        _require_unique_names("RobotState.joint_names", self.joint_names)
        n = len(self.joint_names)
        _require_len("RobotState.positions", self.positions, n, "positions (one per joint name)")
        if self.velocities:
            _require_len("RobotState.velocities", self.velocities, n, "velocities (one per joint name, or none)")
        ids = [a.object.id for a in self.attached_collision_objects]
        if len(set(ids)) != len(ids):
            raise MessageError("RobotState.attached_collision_objects", "duplicate object id")

    def joint_positions(self) -> dict[str, float]:
        return dict(zip(self.joint_names, self.positions))

    @classmethod
    def from_joint_positions(cls, positions: Mapping[str, float], is_diff: bool = False) -> RobotState:
        return cls(joint_names=list(positions), positions=list(positions.values()), is_diff=is_diff)


@dataclass
class PlanningSceneWorld(_Message):
    """moveit_msgs/PlanningSceneWorld: the world (non-robot) collision objects."""

    collision_objects: list[CollisionObject] = field(default_factory=list)


@dataclass
class PlanningScene(_Message):
    """moveit_msgs/PlanningScene: robot state, world objects and ACM; a diff when ``is_diff``.

    Published as JSON on ``/monitored_planning_scene``; ``fixed_frame`` is the frame world
    objects are expressed in after the scene resolves them.
    """

    name: str = ""
    robot_model_name: str = ""
    fixed_frame: str = "world"
    robot_state: RobotState = field(default_factory=RobotState)
    world: PlanningSceneWorld = field(default_factory=PlanningSceneWorld)
    allowed_collision_matrix: AllowedCollisionMatrix = field(default_factory=AllowedCollisionMatrix)
    is_diff: bool = False


# --------------------------------------------------------------------------------------
# Trajectories and results
# --------------------------------------------------------------------------------------


@dataclass
class JointTrajectoryPoint(_Message):
    """trajectory_msgs/JointTrajectoryPoint with ``time_from_start`` as float seconds (>= 0).

    Float seconds keep JSON readable; ros_conversions maps to sec/nanosec exactly to the ns.
    ``velocities``/``accelerations`` are empty or one per position.
    """

    positions: list[float]
    velocities: list[float] = field(default_factory=list)
    accelerations: list[float] = field(default_factory=list)
    time_from_start: float = 0.0

    def _validate(self) -> None:
        n = len(self.positions)
        for fname in ("velocities", "accelerations"):
            values = getattr(self, fname)
            if values and len(values) != n:
                raise MessageError(f"JointTrajectoryPoint.{fname}",
                                   f"expected {n} values (one per position, or none), got {len(values)}")
        if self.time_from_start < 0:
            raise MessageError("JointTrajectoryPoint.time_from_start", f"must be >= 0, got {self.time_from_start}")


@dataclass
class JointTrajectory(_Message):
    """trajectory_msgs/JointTrajectory: waypoints over ``joint_names`` with non-decreasing times.

    Every point must give one position per joint name, which is what controllers require; the
    header stamp is not part of the JSON (it is set when publishing).
    """

    joint_names: list[str]
    points: list[JointTrajectoryPoint]
    frame_id: str = ""

    def _validate(self) -> None:
        _require_unique_names("JointTrajectory.joint_names", self.joint_names)
        n = len(self.joint_names)
        previous = 0.0
        for i, p in enumerate(self.points):
            if len(p.positions) != n:
                raise MessageError(f"JointTrajectory.points[{i}].positions",
                                   f"expected {n} positions (one per joint name), got {len(p.positions)}")
            if p.time_from_start < previous:
                raise MessageError(f"JointTrajectory.points[{i}].time_from_start",
                                   f"{p.time_from_start} is earlier than the previous point's {previous}")
            previous = p.time_from_start

    @property
    def duration(self) -> float:
        """Time of the last point (0.0 for an empty trajectory)."""
        return self.points[-1].time_from_start if self.points else 0.0


@dataclass
class RobotTrajectory(_Message):
    """moveit_msgs/RobotTrajectory (joint part only), tagged with the planning group it moves."""

    joint_trajectory: JointTrajectory
    group_name: str = ""


@dataclass
class MoveItErrorCode(_Message):
    """moveit_msgs/MoveItErrorCode: the outcome of planning/execution, with MoveIt's values.

    Truthy iff SUCCESS, so ``if not result.error_code:`` reads naturally. ``message`` and
    ``source`` (the component that failed) are the Jazzy additions to the message.
    """

    val: int = 1
    message: str = ""
    source: str = ""

    SUCCESS: ClassVar[int] = 1
    UNDEFINED: ClassVar[int] = 0
    FAILURE: ClassVar[int] = 99999
    PLANNING_FAILED: ClassVar[int] = -1
    INVALID_MOTION_PLAN: ClassVar[int] = -2
    MOTION_PLAN_INVALIDATED_BY_ENVIRONMENT_CHANGE: ClassVar[int] = -3
    CONTROL_FAILED: ClassVar[int] = -4
    UNABLE_TO_AQUIRE_SENSOR_DATA: ClassVar[int] = -5  # sic: MoveIt's spelling
    TIMED_OUT: ClassVar[int] = -6
    PREEMPTED: ClassVar[int] = -7
    START_STATE_IN_COLLISION: ClassVar[int] = -10
    START_STATE_VIOLATES_PATH_CONSTRAINTS: ClassVar[int] = -11
    GOAL_IN_COLLISION: ClassVar[int] = -12
    GOAL_VIOLATES_PATH_CONSTRAINTS: ClassVar[int] = -13
    GOAL_CONSTRAINTS_VIOLATED: ClassVar[int] = -14
    INVALID_GROUP_NAME: ClassVar[int] = -15
    INVALID_GOAL_CONSTRAINTS: ClassVar[int] = -16
    INVALID_ROBOT_STATE: ClassVar[int] = -17
    INVALID_LINK_NAME: ClassVar[int] = -18
    INVALID_OBJECT_NAME: ClassVar[int] = -19
    FRAME_TRANSFORM_FAILURE: ClassVar[int] = -21
    COLLISION_CHECKING_UNAVAILABLE: ClassVar[int] = -22
    ROBOT_STATE_STALE: ClassVar[int] = -23
    SENSOR_INFO_STALE: ClassVar[int] = -24
    COMMUNICATION_FAILURE: ClassVar[int] = -25
    START_STATE_INVALID: ClassVar[int] = -26
    GOAL_STATE_INVALID: ClassVar[int] = -27
    UNRECOGNIZED_GOAL_TYPE: ClassVar[int] = -28
    CRASH: ClassVar[int] = -29
    ABORT: ClassVar[int] = -30
    NO_IK_SOLUTION: ClassVar[int] = -31
    _NAMES: ClassVar[dict[int, str]] = {}  # filled below from the constants above

    def _validate(self) -> None:
        if self.val not in self._NAMES:
            raise MessageError("MoveItErrorCode.val", f"unknown MoveIt error code {self.val}")

    @property
    def name(self) -> str:
        """Symbolic name of ``val``, e.g. "NO_IK_SOLUTION"."""
        return self._NAMES[self.val]

    @classmethod
    def from_name(cls, name: str, message: str = "", source: str = "") -> MoveItErrorCode:
        val = getattr(cls, name, None) if isinstance(name, str) and name.isupper() else None
        if not isinstance(val, int) or val not in cls._NAMES:
            raise MessageError("MoveItErrorCode.val", f"unknown MoveIt error code name {name!r}")
        return cls(val, message, source)

    def __bool__(self) -> bool:
        return self.val == self.SUCCESS

    def __str__(self) -> str:
        return f"{self.name}: {self.message}" if self.message else self.name


MoveItErrorCode._NAMES.update(
    {v: k for k, v in vars(MoveItErrorCode).items() if k.isupper() and not k.startswith("_") and type(v) is int}
)


# --------------------------------------------------------------------------------------
# Task constructor (moveit_task_constructor_msgs equivalents)
# --------------------------------------------------------------------------------------


@dataclass
class TrajectoryExecutionInfo(_Message):
    """moveit_task_constructor_msgs/TrajectoryExecutionInfo: the controllers that execute a
    sub-trajectory. Empty means "whichever controllers drive the trajectory's joints"."""

    controller_names: list[str] = field(default_factory=list)

    def _validate(self) -> None:
        _require_unique_names("TrajectoryExecutionInfo.controller_names", self.controller_names)


@dataclass
class SolutionInfo(_Message):
    """moveit_task_constructor_msgs/SolutionInfo: which stage made a (sub-)solution, its cost
    and comment. ``stage_name`` and ``planner_id`` are additions for readable logs."""

    id: int = 0
    cost: float = 0.0
    comment: str = ""
    stage_id: int = 0
    stage_name: str = ""
    planner_id: str = ""

    def _validate(self) -> None:
        if self.id < 0:
            raise MessageError("SolutionInfo.id", f"must be >= 0, got {self.id}")
        if self.stage_id < 0:
            raise MessageError("SolutionInfo.stage_id", f"must be >= 0, got {self.stage_id}")


def _empty_robot_trajectory() -> RobotTrajectory:
    return RobotTrajectory(joint_trajectory=JointTrajectory(joint_names=[], points=[]))


def _empty_scene_diff() -> PlanningScene:
    return PlanningScene(is_diff=True)


@dataclass
class SubTrajectory(_Message):
    """moveit_task_constructor_msgs/SubTrajectory: one step of a task solution.

    Execution semantics (MTC's ExecuteTaskSolution): execute ``trajectory`` (may be empty, e.g.
    for "attach object") with ``execution_info.controller_names``, then apply ``scene_diff``
    (attached/detached objects, allowed collisions, world changes) to the monitored scene.
    The diff never carries joint values (``robot_state.joint_names`` is empty): joints move only
    through trajectories.
    """

    info: SolutionInfo = field(default_factory=SolutionInfo)
    execution_info: TrajectoryExecutionInfo = field(default_factory=TrajectoryExecutionInfo)
    trajectory: RobotTrajectory = field(default_factory=_empty_robot_trajectory)
    scene_diff: PlanningScene = field(default_factory=_empty_scene_diff)

    def _validate(self) -> None:
        if not self.scene_diff.is_diff:
            raise MessageError("SubTrajectory.scene_diff.is_diff", "must be true: a sub-trajectory carries a scene diff")
        if self.scene_diff.robot_state.joint_names:
            raise MessageError("SubTrajectory.scene_diff.robot_state.joint_names",
                               "must be empty: joints move only through the trajectory")

    @property
    def duration(self) -> float:
        return self.trajectory.joint_trajectory.duration

    @property
    def has_trajectory(self) -> bool:
        return bool(self.trajectory.joint_trajectory.points)


@dataclass
class TaskSolution(_Message):
    """moveit_task_constructor_msgs/Solution: a complete task solution, ready to execute.

    ``start_scene`` is the full scene the solution starts from (execution should refuse to start
    if the robot is elsewhere); ``sub_trajectory`` lists the steps in execution order. ``cost``
    and ``comment`` (additions) repeat the top-level solution's values.
    """

    task_id: str = ""
    start_scene: PlanningScene = field(default_factory=PlanningScene)
    sub_trajectory: list[SubTrajectory] = field(default_factory=list)
    cost: float = 0.0
    comment: str = ""

    def _validate(self) -> None:
        if self.start_scene.is_diff:
            raise MessageError("TaskSolution.start_scene.is_diff", "must be false: the start scene is a full scene")
        ids = [s.info.id for s in self.sub_trajectory]
        if len(set(ids)) != len(ids):
            raise MessageError("TaskSolution.sub_trajectory", "duplicate sub-trajectory info.id")

    @property
    def duration(self) -> float:
        """Total execution time of the trajectories (s)."""
        return sum(s.duration for s in self.sub_trajectory)

    def controller_names(self) -> list[str]:
        """Every controller named by a sub-trajectory, in first-use order."""
        names: list[str] = []
        for sub in self.sub_trajectory:
            for name in sub.execution_info.controller_names:
                if name not in names:
                    names.append(name)
        return names


@dataclass
class StageDescription(_Message):
    """moveit_task_constructor_msgs/StageDescription: one stage of the task tree.

    ``flags`` are MTC's interface flags (READS_START 1, READS_END 2, WRITES_NEXT_START 4,
    WRITES_PREV_END 8); ``parent_id`` is 0 for the root container; ``type`` is the stage class.
    """

    id: int
    parent_id: int = 0
    name: str = ""
    flags: int = 0
    type: str = ""

    def _validate(self) -> None:
        if self.id <= 0:
            raise MessageError("StageDescription.id", f"must be > 0, got {self.id}")
        if self.parent_id < 0 or self.parent_id == self.id:
            raise MessageError("StageDescription.parent_id", f"invalid parent id {self.parent_id} for stage {self.id}")
        if not 0 <= self.flags <= 15:
            raise MessageError("StageDescription.flags", f"must be in [0, 15], got {self.flags}")


@dataclass
class TaskDescription(_Message):
    """moveit_task_constructor_msgs/TaskDescription: the stage tree, parents before children."""

    task_id: str = ""
    stages: list[StageDescription] = field(default_factory=list)

    def _validate(self) -> None:
        seen: set[int] = set()
        for i, stage in enumerate(self.stages):
            if stage.id in seen:
                raise MessageError(f"TaskDescription.stages[{i}].id", f"duplicate stage id {stage.id}")
            if stage.parent_id != 0 and stage.parent_id not in seen:
                raise MessageError(f"TaskDescription.stages[{i}].parent_id",
                                   f"parent {stage.parent_id} must be listed before stage {stage.id}")
            seen.add(stage.id)


@dataclass
class StageStatistics(_Message):
    """moveit_task_constructor_msgs/StageStatistics: solution ids (and costs) and failures of a
    stage, and the time it spent computing (s, children included for containers)."""

    id: int
    solved: list[int] = field(default_factory=list)
    failed: list[int] = field(default_factory=list)
    cost: list[float] = field(default_factory=list)
    num_failed: int = 0
    total_compute_time: float = 0.0

    def _validate(self) -> None:
        _require_len("StageStatistics.cost", self.cost, len(self.solved), "costs (one per solved id)")
        if self.num_failed < len(self.failed):
            raise MessageError("StageStatistics.num_failed",
                               f"{self.num_failed} is less than the {len(self.failed)} failures listed")
        if self.total_compute_time < 0:
            raise MessageError("StageStatistics.total_compute_time", f"must be >= 0, got {self.total_compute_time}")


@dataclass
class TaskStatistics(_Message):
    """moveit_task_constructor_msgs/TaskStatistics: statistics of every stage."""

    task_id: str = ""
    stages: list[StageStatistics] = field(default_factory=list)

    def _validate(self) -> None:
        ids = [s.id for s in self.stages]
        if len(set(ids)) != len(ids):
            raise MessageError("TaskStatistics.stages", "duplicate stage id")
