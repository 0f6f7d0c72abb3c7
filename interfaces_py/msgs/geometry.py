"""geometry_msgs/Pose and shape_msgs' SolidPrimitive and Mesh."""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from .base import (
    MAX_MESH_TRIANGLES,
    MAX_MESH_VERTICES,
    MAX_OBJECT_EXTENT,
    WORKSPACE_BOUND,
    MessageError,
    _convert,
    _describe,
    _Message,
    _require_len,
)

# Pose.from_matrix's tolerances (np.allclose's, entry by entry)
_BOTTOM_ROW = np.array([0.0, 0.0, 0.0, 1.0])
_BOTTOM_ROW_TOLERANCE = 1e-9 + 1e-5 * _BOTTOM_ROW
_EYE3 = np.eye(3)
_ORTHONORMAL_TOLERANCE = 1e-6 + 1e-5 * _EYE3


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
        # np.allclose's tests (atol 1e-9 and 1e-6, rtol 1e-5) entry by entry: without its
        # wrappers (~20 us each; a plan converts many poses)
        if not np.all(np.abs(T[3] - _BOTTOM_ROW) <= _BOTTOM_ROW_TOLERANCE):
            raise MessageError(path, f"bottom row must be [0, 0, 0, 1], got {T[3].tolist()}")
        if not np.all(np.abs(R.T @ R - _EYE3) <= _ORTHONORMAL_TOLERANCE) or np.linalg.det(R) <= 0:
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
