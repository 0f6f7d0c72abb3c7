"""Triangle meshes of what we draw: robot link collision shapes and planning-scene objects.

Why one module: the browser viewer (viser) and the PNG snapshots (matplotlib) must show the
same robot and the same objects as the collision checker sees them. So both draw the shapes the
core checks — the URDF's collision geometry as Coal shapes (``RobotModel.link_collision_geometry``)
and the scene's CollisionObjects, resolved by the core ``PlanningScene`` — turned into
``TriMesh`` (vertices, faces) here, never re-parsed from the URDF.

Curved primitives are tessellated with ``segments`` facets around the axis: coarse enough to send
at 100 Hz to a browser, fine enough to look round.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Iterable

import numpy as np

from interfaces_py.msgs import CollisionObject, SolidPrimitive

__all__ = [
    "TriMesh",
    "LinkShape",
    "ObjectShape",
    "box_mesh",
    "cylinder_mesh",
    "sphere_mesh",
    "cone_mesh",
    "capsule_mesh",
    "coal_shape_mesh",
    "primitive_mesh",
    "robot_link_shapes",
    "object_shapes",
    "transform_points",
]

DEFAULT_SEGMENTS = 24


@dataclass(frozen=True)
class TriMesh:
    """Vertices (N x 3, float) and triangular faces (M x 3, int, counter-clockwise seen from
    outside) in the shape's own frame."""

    vertices: np.ndarray
    faces: np.ndarray

    def __post_init__(self) -> None:
        v = np.asarray(self.vertices, dtype=float).reshape(-1, 3)
        f = np.asarray(self.faces, dtype=np.int32).reshape(-1, 3)
        if len(f) and (f.min() < 0 or f.max() >= len(v)):
            raise ValueError(f"face index out of range for {len(v)} vertices")
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "faces", f)

    def transformed(self, pose: np.ndarray) -> "TriMesh":
        return TriMesh(transform_points(pose, self.vertices), self.faces)

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.vertices.min(axis=0), self.vertices.max(axis=0)


@dataclass(frozen=True)
class LinkShape:
    """One collision shape of a robot link: its mesh and its pose in the link frame."""

    link: str
    index: int
    kind: str
    mesh: TriMesh
    pose: np.ndarray


@dataclass(frozen=True)
class ObjectShape:
    """One shape of a collision object: its mesh and its pose in the object frame."""

    object_id: str
    index: int
    kind: str
    mesh: TriMesh
    pose: np.ndarray = field(default_factory=lambda: np.eye(4))


def transform_points(pose: np.ndarray, points: np.ndarray) -> np.ndarray:
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    return points @ np.asarray(pose)[:3, :3].T + np.asarray(pose)[:3, 3]


# ------------------------------------------------------------------------------- primitives
def box_mesh(size: Iterable[float]) -> TriMesh:
    """Axis-aligned box of full side lengths ``size`` centred at the origin (12 triangles)."""
    sx, sy, sz = (0.5 * float(s) for s in size)
    v = np.array([[x, y, z] for x in (-sx, sx) for y in (-sy, sy) for z in (-sz, sz)])
    # vertex index = 4*ix + 2*iy + iz
    f = np.array([
        [0, 1, 3], [0, 3, 2],  # -x
        [4, 6, 7], [4, 7, 5],  # +x
        [0, 4, 5], [0, 5, 1],  # -y
        [2, 3, 7], [2, 7, 6],  # +y
        [0, 2, 6], [0, 6, 4],  # -z
        [1, 5, 7], [1, 7, 3],  # +z
    ])
    return TriMesh(v, f)


def _ring(radius: float, z: float, segments: int) -> np.ndarray:
    a = np.linspace(0.0, 2.0 * math.pi, segments, endpoint=False)
    return np.column_stack([radius * np.cos(a), radius * np.sin(a), np.full(segments, z)])


def cylinder_mesh(height: float, radius: float, segments: int = DEFAULT_SEGMENTS) -> TriMesh:
    """Cylinder along z, centred at the origin (the URDF, Coal and shape_msgs convention)."""
    h = 0.5 * float(height)
    n = segments
    v = np.vstack([_ring(radius, -h, n), _ring(radius, h, n), [[0, 0, -h], [0, 0, h]]])
    faces = []
    for i in range(n):
        j = (i + 1) % n
        faces += [[i, j, n + j], [i, n + j, n + i], [2 * n, j, i], [2 * n + 1, n + i, n + j]]
    return TriMesh(v, faces)


def cone_mesh(height: float, radius: float, segments: int = DEFAULT_SEGMENTS) -> TriMesh:
    """Cone along z centred at the origin: base at z = -h/2, tip at +h/2 (shape_msgs)."""
    h = 0.5 * float(height)
    n = segments
    v = np.vstack([_ring(radius, -h, n), [[0, 0, -h], [0, 0, h]]])
    faces = []
    for i in range(n):
        j = (i + 1) % n
        faces += [[n, j, i], [i, j, n + 1]]
    return TriMesh(v, faces)


def sphere_mesh(radius: float, segments: int = DEFAULT_SEGMENTS) -> TriMesh:
    """UV sphere of ``radius`` (``segments`` around, ``segments // 2`` from pole to pole)."""
    return _capsule(float(radius), 0.0, segments)


def capsule_mesh(height: float, radius: float, segments: int = DEFAULT_SEGMENTS) -> TriMesh:
    """Capsule along z: a cylinder of ``height`` capped by two half spheres of ``radius``."""
    return _capsule(float(radius), 0.5 * float(height), segments)


def _capsule(radius: float, half_length: float, segments: int) -> TriMesh:
    n = max(8, segments)
    rings = max(4, n // 2)
    if rings % 2:
        rings += 1
    vertices = [[0.0, 0.0, -radius - half_length]]
    for k in range(1, rings):
        polar = math.pi * k / rings  # 0 at the south pole
        z = -radius * math.cos(polar)
        z += half_length if k >= rings // 2 else -half_length
        ring = _ring(radius * math.sin(polar), z, n)
        vertices.extend(ring.tolist())
        if half_length > 0 and k == rings // 2:  # equator: split into both cylinder ends
            vertices.extend(_ring(radius, -half_length, n).tolist())
    vertices.append([0.0, 0.0, radius + half_length])
    v = np.asarray(vertices)
    ring_count = (len(v) - 2) // n
    faces = []
    for i in range(n):  # south cap
        faces.append([0, 1 + (i + 1) % n, 1 + i])
    # order rings by z so that the equator split (cylinder) is stitched correctly
    starts = sorted(range(ring_count), key=lambda r: v[1 + r * n, 2])
    for a, b in zip(starts, starts[1:]):
        for i in range(n):
            j = (i + 1) % n
            p, q = 1 + a * n, 1 + b * n
            faces += [[p + i, p + j, q + j], [p + i, q + j, q + i]]
    top = len(v) - 1
    last = 1 + starts[-1] * n
    for i in range(n):  # north cap
        faces.append([top, last + i, last + (i + 1) % n])
    return TriMesh(v, faces)


def primitive_mesh(primitive: SolidPrimitive, segments: int = DEFAULT_SEGMENTS) -> TriMesh:
    """Mesh of a shape_msgs SolidPrimitive (box [x, y, z], sphere [r], cylinder/cone [h, r])."""
    d = primitive.dimensions
    if primitive.type == SolidPrimitive.BOX:
        return box_mesh(d)
    if primitive.type == SolidPrimitive.SPHERE:
        return sphere_mesh(d[0], segments)
    if primitive.type == SolidPrimitive.CYLINDER:
        return cylinder_mesh(d[0], d[1], segments)
    if primitive.type == SolidPrimitive.CONE:
        return cone_mesh(d[0], d[1], segments)
    raise ValueError(f"cannot draw primitive type {primitive.type}")  # pragma: no cover - validated by msgs


def coal_shape_mesh(shape: Any, segments: int = DEFAULT_SEGMENTS) -> tuple[str, TriMesh]:
    """(kind, mesh) of a Coal collision geometry: Box, Sphere, Cylinder, Cone, Capsule,
    Ellipsoid, Convex or a BVH triangle model. Raises ValueError for shapes that have no
    finite surface to draw (planes, half-spaces, octrees)."""
    import coal

    if isinstance(shape, coal.Box):
        return "box", box_mesh(2.0 * np.asarray(shape.halfSide))
    if isinstance(shape, coal.Sphere):
        return "sphere", sphere_mesh(shape.radius, segments)
    if isinstance(shape, coal.Cylinder):
        return "cylinder", cylinder_mesh(2.0 * shape.halfLength, shape.radius, segments)
    if isinstance(shape, coal.Cone):
        return "cone", cone_mesh(2.0 * shape.halfLength, shape.radius, segments)
    if isinstance(shape, coal.Capsule):
        return "capsule", capsule_mesh(2.0 * shape.halfLength, shape.radius, segments)
    if isinstance(shape, coal.Ellipsoid):
        unit = sphere_mesh(1.0, segments)
        return "ellipsoid", TriMesh(unit.vertices * np.asarray(shape.radii), unit.faces)
    if isinstance(shape, coal.BVHModelBase):
        vertices = np.asarray(shape.vertices(), dtype=float).reshape(-1, 3)
        faces = np.array([[t[0], t[1], t[2]] for t in (shape.tri_indices(i) for i in range(shape.num_tris))],
                         dtype=np.int32).reshape(-1, 3)
        return "mesh", TriMesh(vertices, faces)
    if isinstance(shape, coal.ConvexBase):
        points = np.array([np.asarray(shape.points(i)) for i in range(shape.num_points)], dtype=float)
        return "convex", _convex_hull_mesh(points)
    raise ValueError(f"cannot draw a {type(shape).__name__} collision shape")


def _convex_hull_mesh(points: np.ndarray) -> TriMesh:
    from scipy.spatial import ConvexHull

    hull = ConvexHull(points)
    faces = hull.simplices.copy()
    centre = points.mean(axis=0)
    for k, (a, b, c) in enumerate(faces):  # orient outward
        normal = np.cross(points[b] - points[a], points[c] - points[a])
        if np.dot(normal, points[a] - centre) < 0:
            faces[k] = [a, c, b]
    return TriMesh(points, faces)


# ------------------------------------------------------------------------------- robot and objects
def robot_link_shapes(model: Any, segments: int = DEFAULT_SEGMENTS) -> list[LinkShape]:
    """Every collision shape of every link of ``model`` (a core RobotModel), posed in its link
    frame, in link order. Shapes Coal cannot give a surface for are skipped."""
    shapes: list[LinkShape] = []
    for link in model.links_with_collision_geometry():
        for index, (geometry, pose) in enumerate(model.link_collision_geometry(link)):
            try:
                kind, mesh = coal_shape_mesh(geometry, segments)
            except ValueError:
                continue
            shapes.append(LinkShape(link, index, kind, mesh, np.asarray(pose, dtype=float)))
    return shapes


def object_shapes(obj: CollisionObject, package_dirs: Iterable[Any] = (), segments: int = DEFAULT_SEGMENTS,
                  ) -> list[ObjectShape]:
    """The shapes of a collision object, posed in the object frame (its ``pose``).

    Mesh resources are loaded the way the collision checker loads them
    (``core.collision_detection.world.mesh_geometry``); a mesh that cannot be loaded raises the checker's
    SceneError, so the viewer and the checker never disagree silently.
    """
    out: list[ObjectShape] = []
    for k, (primitive, pose) in enumerate(zip(obj.primitives, obj.primitive_poses)):
        out.append(ObjectShape(obj.id, k, primitive.type_name.lower(), primitive_mesh(primitive, segments),
                               pose.to_matrix()))
    if obj.meshes:
        from ..core.collision_detection.world import mesh_geometry

        for k, (mesh, pose) in enumerate(zip(obj.meshes, obj.mesh_poses)):
            geometry = mesh_geometry(mesh, f"collision object '{obj.id}' mesh {k}", package_dirs)
            _kind, trimesh = coal_shape_mesh(geometry, segments)
            out.append(ObjectShape(obj.id, len(obj.primitives) + k, "mesh", trimesh, pose.to_matrix()))
    return out
