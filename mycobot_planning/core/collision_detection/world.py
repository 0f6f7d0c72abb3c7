"""The world's objects and their shapes (MoveIt's collision_detection::World objects and
moveit_core's AttachedBody): immutable values shared between scene copies, and the Coal shapes
built from shape_msgs primitives and meshes (mesh files cached per file and scale)."""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Iterable, Sequence
from urllib.parse import unquote, urlparse

import coal
import numpy as np

from ...paths import package_share_dirs
from ..errors import SceneError

if TYPE_CHECKING:  # pragma: no cover
    from interfaces_py.msgs import Mesh, SolidPrimitive

__all__ = ["AttachedBody", "SceneObject", "Shape", "read_only", "mesh_geometry", "primitive_geometry"]


# ---------------------------------------------------------------------------------------------
# Scene content: immutable values shared between scene copies
# ---------------------------------------------------------------------------------------------


def read_only(values: np.ndarray) -> np.ndarray:
    """A read-only float copy (a pose, or any array that is shared and never changed)."""
    out = np.array(values, dtype=float)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class Shape:
    """One Coal shape of an object, with its pose in the object frame and its message form."""

    geometry: coal.CollisionGeometry
    pose: np.ndarray  # 4x4, object frame -> shape frame (read-only)
    primitive: "SolidPrimitive | None" = None
    mesh: "Mesh | None" = None


@dataclass(frozen=True, eq=False)
class SceneObject:
    """A collision object: id, pose (in world, or in its link frame once attached), shapes."""

    id: str
    pose: np.ndarray  # 4x4 (read-only)
    shapes: tuple[Shape, ...]

    def with_pose(self, pose: np.ndarray) -> "SceneObject":
        return SceneObject(self.id, read_only(pose), self.shapes)


@dataclass(frozen=True, eq=False)
class AttachedBody:
    """An object rigidly attached to a robot link; ``object.pose`` is relative to that link."""

    object: SceneObject
    link: str
    touch_links: frozenset[str]
    weight: float = 0.0

    @property
    def id(self) -> str:
        return self.object.id


# ---------------------------------------------------------------------------------------------
# Shapes from messages
# ---------------------------------------------------------------------------------------------


def _positive_dims(dims: Sequence[float], count: int, what: str) -> list[float]:
    values = [float(d) for d in dims]
    if len(values) != count:
        raise SceneError(f"{what}: expected {count} dimensions, got {len(values)}")
    for value in values:
        if not math.isfinite(value) or value <= 0.0:
            raise SceneError(f"{what}: dimensions must be finite and > 0, got {values}")
    return values


def primitive_geometry(primitive: "SolidPrimitive", what: str) -> coal.CollisionGeometry:
    """Coal shape for a shape_msgs primitive (box [x,y,z], sphere [r], cylinder/cone [h, r], axis z)."""
    kind = primitive.type
    dims = primitive.dimensions
    if kind == 1:
        x, y, z = _positive_dims(dims, 3, f"{what} (BOX)")
        geometry = coal.Box(x, y, z)
    elif kind == 2:
        (r,) = _positive_dims(dims, 1, f"{what} (SPHERE)")
        geometry = coal.Sphere(r)
    elif kind == 3:
        h, r = _positive_dims(dims, 2, f"{what} (CYLINDER)")
        geometry = coal.Cylinder(r, h)
    elif kind == 4:
        h, r = _positive_dims(dims, 2, f"{what} (CONE)")
        geometry = coal.Cone(r, h)
    else:
        raise SceneError(f"{what}: unknown primitive type {kind}; expected BOX(1), SPHERE(2), CYLINDER(3) or CONE(4)")
    geometry.computeLocalAABB()
    return geometry


def _resource_candidates(resource: str, package_dirs: Iterable[Path]) -> list[Path]:
    if resource.startswith("package://"):
        rest = resource[len("package://"):]
        package, _, relative = rest.partition("/")
        roots: list[Path] = list(package_dirs) + package_share_dirs()
        out = []
        for root in roots:
            out.append(root / package / relative)
        return out
    if resource.startswith("file://"):
        return [Path(unquote(urlparse(resource).path))]
    return [Path(resource).expanduser()]


_MESH_CACHE: dict[tuple[str, tuple[float, float, float]], coal.CollisionGeometry] = {}
_MESH_CACHE_LOCK = threading.Lock()
_MESH_CACHE_SIZE = 64


def mesh_geometry(mesh: "Mesh", what: str, package_dirs: Iterable[Path] = ()) -> coal.CollisionGeometry:
    """Coal BVH (OBBRSS) for a mesh file (cached per file and scale) or explicit triangles."""
    scale = tuple(float(s) for s in mesh.scale)
    if len(scale) != 3 or not all(math.isfinite(s) and s > 0 for s in scale):
        raise SceneError(f"{what}: mesh scale must be three finite values > 0, got {list(mesh.scale)}")
    if mesh.resource:
        candidates = _resource_candidates(mesh.resource, package_dirs)
        path = next((p for p in candidates if p.is_file()), None)
        if path is None:
            raise SceneError(
                f"{what}: mesh file '{mesh.resource}' not found (looked at {', '.join(str(p) for p in candidates)})"
            )
        key = (str(path.resolve()), scale)
        with _MESH_CACHE_LOCK:
            cached = _MESH_CACHE.get(key)
        if cached is not None:
            return cached
        try:
            geometry = coal.MeshLoader().load(str(path), np.array(scale))
        except Exception as exc:  # coal raises RuntimeError/ValueError/assimp errors
            raise SceneError(f"{what}: cannot load mesh '{mesh.resource}': {exc}") from None
        if geometry.num_tris == 0:
            raise SceneError(f"{what}: mesh '{mesh.resource}' has no triangles")
        geometry.computeLocalAABB()
        with _MESH_CACHE_LOCK:
            if len(_MESH_CACHE) >= _MESH_CACHE_SIZE:
                _MESH_CACHE.pop(next(iter(_MESH_CACHE)))
            _MESH_CACHE[key] = geometry
        return geometry
    vertices = np.asarray(mesh.vertices, dtype=float).reshape(-1, 3) * np.asarray(scale)
    triangles = np.asarray(mesh.triangles, dtype=int).reshape(-1, 3)
    if not np.all(np.isfinite(vertices)):
        raise SceneError(f"{what}: mesh vertices contain NaN or infinite values")
    if triangles.size == 0:
        raise SceneError(f"{what}: mesh has no triangles")
    if triangles.min() < 0 or triangles.max() >= len(vertices):
        raise SceneError(f"{what}: mesh triangle index out of range for {len(vertices)} vertices")
    geometry = coal.BVHModelOBBRSS()
    geometry.beginModel(len(triangles), len(vertices))
    geometry.addVertices(vertices)
    geometry.addTriangles(triangles)
    geometry.endModel()
    geometry.computeLocalAABB()
    return geometry
