"""Signed distance to a planning scene's world objects, with its gradient (MoveIt's distance_field
as CHOMP reads it through collision_distance_field).

CHOMP's obstacle cost is a function of how far each robot sphere is from the world; its
gradient pushes the path away. Boxes, spheres, cylinders and cones get their exact signed
distance in closed form; a mesh gets a voxel grid around it (its surface rasterised, the inside
filled, SciPy's Euclidean distance transform on both sides), read by trilinear interpolation.
The field of a scene is the minimum over its objects; gradients are central differences of
that function (unit length away from the nearest object). Objects every sphere-bearing body is
allowed to touch (the allowed collision matrix) are left out; pairs allowed for some bodies
only are kept (a stronger push than needed; the exact check has the last word).
"""
from __future__ import annotations

import math
import threading
from typing import Callable, Iterable, Sequence

import coal
import numpy as np
from scipy import ndimage

from ..collision_detection.world import SceneObject, Shape
from ..planning_scene.planning_scene import PlanningScene

__all__ = ["WorldDistanceField", "shape_distance"]

#: step of the central differences giving the gradient (m)
GRADIENT_STEP = 1e-4
#: voxel edge of a mesh's grid: its largest extent over this many, within the bounds below (m)
MESH_VOXELS_ACROSS = 48
MESH_MIN_RESOLUTION = 0.004
MESH_MAX_RESOLUTION = 0.02

SignedDistance = Callable[[np.ndarray], np.ndarray]


def _box(half: np.ndarray) -> SignedDistance:
    def distance(p: np.ndarray) -> np.ndarray:
        q = np.abs(p) - half
        outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
        return outside + np.minimum(q.max(axis=1), 0.0)
    return distance


def _sphere(radius: float) -> SignedDistance:
    def distance(p: np.ndarray) -> np.ndarray:
        return np.linalg.norm(p, axis=1) - radius
    return distance


def _cylinder(radius: float, half: float) -> SignedDistance:
    def distance(p: np.ndarray) -> np.ndarray:
        q = np.column_stack([np.hypot(p[:, 0], p[:, 1]) - radius, np.abs(p[:, 2]) - half])
        return np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)
    return distance


def _capsule(radius: float, half: float) -> SignedDistance:
    def distance(p: np.ndarray) -> np.ndarray:
        z = np.clip(p[:, 2], -half, half)
        return np.linalg.norm(p - np.column_stack([np.zeros_like(z), np.zeros_like(z), z]), axis=1) - radius
    return distance


def _cone(radius: float, half: float) -> SignedDistance:
    """Coal's cone: base disc of ``radius`` at z = -half, apex at z = +half. In the (r, z) half
    plane the solid is the triangle (0, -half), (radius, -half), (0, half): the distance to its
    boundary, negative inside."""
    a = np.array([0.0, -half])
    b = np.array([radius, -half])
    c = np.array([0.0, half])

    def segment(p2: np.ndarray, s: np.ndarray, e: np.ndarray) -> np.ndarray:
        d = e - s
        t = np.clip(((p2 - s) @ d) / float(d @ d), 0.0, 1.0)
        return np.linalg.norm(p2 - (s + t[:, None] * d), axis=1)

    def distance(p: np.ndarray) -> np.ndarray:
        p2 = np.column_stack([np.hypot(p[:, 0], p[:, 1]), p[:, 2]])
        unsigned = np.minimum(segment(p2, a, b), segment(p2, b, c))
        inside = (p2[:, 1] >= -half) & (p2[:, 0] <= radius * (half - p2[:, 1]) / (2.0 * half))
        return np.where(inside, -unsigned, unsigned)
    return distance


def _triangle_points(vertices: np.ndarray, triangles: np.ndarray, step: float) -> np.ndarray:
    """Points on every triangle, no two neighbours further apart than ``step``."""
    corners = vertices[triangles]  # (T, 3, 3)
    edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).max(axis=1)
    counts = np.maximum(1, np.ceil(edges / step).astype(int))
    out = [vertices]
    for n in np.unique(counts):
        chosen = corners[counts == n]
        i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
        keep = i + j <= n
        u, v = i[keep] / n, j[keep] / n
        w = 1.0 - u - v
        points = (w[None, :, None] * chosen[:, None, 0] + u[None, :, None] * chosen[:, None, 1]
                  + v[None, :, None] * chosen[:, None, 2])
        out.append(points.reshape(-1, 3))
    return np.vstack(out)


def _mesh(geometry: coal.BVHModelBase, padding: float) -> SignedDistance | None:
    """A voxel signed-distance grid of a mesh (closed meshes are filled; an open one is a shell)."""
    vertices = np.asarray(geometry.vertices(), dtype=float)
    if len(vertices) == 0:
        return None
    triangles = np.array([[t[0], t[1], t[2]] for t in map(geometry.tri_indices, range(geometry.num_tris))],
                         dtype=int).reshape(-1, 3)
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    resolution = float(np.clip(np.max(high - low) / MESH_VOXELS_ACROSS, MESH_MIN_RESOLUTION, MESH_MAX_RESOLUTION))
    origin = low - padding - 2.0 * resolution
    shape = np.ceil((high + padding + 2.0 * resolution - origin) / resolution).astype(int) + 1
    surface = _triangle_points(vertices, triangles, 0.5 * resolution) if len(triangles) else vertices
    cells = np.clip(np.round((surface - origin) / resolution).astype(int), 0, shape - 1)
    occupied = np.zeros(tuple(shape), dtype=bool)
    occupied[cells[:, 0], cells[:, 1], cells[:, 2]] = True
    occupied = ndimage.binary_fill_holes(occupied)
    outside = ndimage.distance_transform_edt(~occupied, sampling=resolution)
    inside = ndimage.distance_transform_edt(occupied, sampling=resolution)
    grid = np.where(occupied, -inside + 0.5 * resolution, outside - 0.5 * resolution)
    upper = origin + (shape - 1) * resolution

    def distance(p: np.ndarray) -> np.ndarray:
        clamped = np.clip(p, origin, upper)
        beyond = np.linalg.norm(p - clamped, axis=1)
        coordinates = ((clamped - origin) / resolution).T
        return ndimage.map_coordinates(grid, coordinates, order=1, mode="nearest") + beyond
    return distance


def shape_distance(shape: Shape, padding: float) -> SignedDistance | None:
    """Signed distance to one shape in its own frame (None: a shape kind this does not know)."""
    g = shape.geometry
    if isinstance(g, coal.Box):
        return _box(np.asarray(g.halfSide, dtype=float))
    if isinstance(g, coal.Sphere):
        return _sphere(float(g.radius))
    if isinstance(g, coal.Cylinder):
        return _cylinder(float(g.radius), float(g.halfLength))
    if isinstance(g, coal.Capsule):
        return _capsule(float(g.radius), float(g.halfLength))
    if isinstance(g, coal.Cone):
        return _cone(float(g.radius), float(g.halfLength))
    if isinstance(g, coal.BVHModelBase):
        return _cached_mesh(g, padding)
    return None


_MESH_FIELDS: dict[tuple[int, float], tuple[coal.CollisionGeometry, SignedDistance | None]] = {}
_MESH_FIELDS_LOCK = threading.Lock()
_MESH_FIELDS_SIZE = 16


def _cached_mesh(geometry: coal.BVHModelBase, padding: float) -> SignedDistance | None:
    """A mesh's grid, built once per mesh and padding (scene objects share their loaded meshes,
    and a scene's objects outlive many plans): the entry holds the mesh, so its id stays its own."""
    key = (id(geometry), float(padding))
    with _MESH_FIELDS_LOCK:
        entry = _MESH_FIELDS.get(key)
    if entry is not None and entry[0] is geometry:
        return entry[1]
    distance = _mesh(geometry, padding)
    with _MESH_FIELDS_LOCK:
        if len(_MESH_FIELDS) >= _MESH_FIELDS_SIZE:
            _MESH_FIELDS.pop(next(iter(_MESH_FIELDS)))
        _MESH_FIELDS[key] = (geometry, distance)
    return distance


class WorldDistanceField:
    """Signed distance (m, negative inside) from points to the nearest of a scene's world objects."""

    def __init__(self, objects: Iterable[SceneObject], padding: float) -> None:
        self._parts: list[tuple[np.ndarray, np.ndarray, SignedDistance]] = []
        self.names: list[str] = []
        for obj in objects:
            for shape in obj.shapes:
                distance = shape_distance(shape, padding)
                if distance is None:
                    continue
                pose = np.asarray(obj.pose, dtype=float) @ np.asarray(shape.pose, dtype=float)
                self._parts.append((pose[:3, :3].copy(), pose[:3, 3].copy(), distance))
                self.names.append(obj.id)

    @classmethod
    def of_scene(cls, scene: PlanningScene, bodies: Sequence[str], padding: float) -> "WorldDistanceField":
        """The field of the world objects of ``scene`` that at least one of ``bodies`` (the links
        and attached objects with spheres) may not touch."""
        acm = scene.allowed_collision_matrix
        names = sorted(set(bodies))
        kept = [obj for obj in scene.world_geometry() if any(not acm.is_allowed(obj.id, b) for b in names)]
        return cls(kept, padding)

    def __len__(self) -> int:
        return len(self._parts)

    def distance(self, points: np.ndarray) -> np.ndarray:
        """(M,) signed distances of (M, 3) world points (inf when the world is empty)."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        out = np.full(len(points), math.inf)
        for rotation, translation, distance in self._parts:
            np.minimum(out, distance((points - translation) @ rotation), out=out)
        return out

    def distance_and_gradient(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(M,) signed distances and (M, 3) gradients (central differences, GRADIENT_STEP)."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        count = len(points)
        if not self._parts:
            return np.full(count, math.inf), np.zeros((count, 3))
        offsets = np.vstack([np.zeros(3), np.eye(3) * GRADIENT_STEP, -np.eye(3) * GRADIENT_STEP])  # (7, 3)
        values = self.distance((points[None] + offsets[:, None]).reshape(-1, 3)).reshape(7, count)
        gradient = ((values[1:4] - values[4:7]) / (2.0 * GRADIENT_STEP)).T
        return values[0], gradient
