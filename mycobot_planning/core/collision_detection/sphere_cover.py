"""Spheres that contain a collision shape (the cover both sphere users share).

Each shape's points are cut into slabs along their principal axis and each slab is covered by
one sphere around its centre on the axis (a tighter cover than MoveIt's spheres along a
bounding cylinder's axis). ``shape_spheres`` covers a set of points (what CHOMP's body
decomposition pushes away from obstacles); ``enclosing_spheres`` covers a whole shape, proved
to contain it (what the batch collision check may call free by): docs/core.md, section
mycobot_planning.core.collision_detection.batch_check.
"""
from __future__ import annotations

import math

import coal
import numpy as np

__all__ = ["MAX_SPHERES_PER_SHAPE", "enclosing_spheres", "shape_spheres"]

#: most spheres one shape is covered with (a long thin link gets this many along its axis)
MAX_SPHERES_PER_SHAPE = 12
#: a slab along the axis is at most this many times as long as the shape is thick
SLAB_PER_RADIUS = 1.0
#: smallest radius considered when spacing the spheres (m): a flat plate is still covered
MIN_SPACING_RADIUS = 0.01


def _slabs(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The slabs of a point set along its principal axis: (centre, axis, slab edges along the
    axis from the centre, each point's position along the axis)."""
    centre = points.mean(axis=0)
    spread = points - centre
    if len(points) > 1 and np.ptp(points, axis=0).max() > 0.0:
        _, _, vt = np.linalg.svd(spread, full_matrices=False)
        axis = vt[0]
    else:
        axis = np.array([0.0, 0.0, 1.0])
    along = spread @ axis
    perpendicular = np.linalg.norm(spread - np.outer(along, axis), axis=1)
    low, high = float(along.min()), float(along.max())
    thickness = max(float(perpendicular.max()), MIN_SPACING_RADIUS)
    count = int(min(MAX_SPHERES_PER_SHAPE, max(1, math.ceil((high - low) / (SLAB_PER_RADIUS * thickness)))))
    return centre, axis, np.linspace(low, high, count + 1), along


def _cover(points: np.ndarray, groups: np.ndarray, slab_points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Spheres of the slab cover of ``slab_points``: ``groups`` (g, m) indexes the ``points`` of
    each piece (a point, or a triangle's corners); each piece goes to the slab holding its
    centroid, and a slab's sphere reaches the farthest point of its pieces. Slabs without a
    piece get no sphere."""
    centre, axis, edges, _ = _slabs(slab_points)
    count = len(edges) - 1
    along = (points[groups].mean(axis=1) - centre) @ axis
    slab = np.clip(np.searchsorted(edges, along, side="right") - 1, 0, count - 1)
    centres = centre + (0.5 * (edges[:-1] + edges[1:]))[:, None] * axis
    radii = np.zeros(count)
    keep = np.zeros(count, dtype=bool)
    for k in range(count):
        mine = points[groups[slab == k].ravel()]
        if len(mine):
            keep[k] = True
            radii[k] = float(np.max(np.linalg.norm(mine - centres[k], axis=1)))
    return centres[keep], radii[keep]


def shape_spheres(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(centres (k, 3), radii (k,)) covering ``points``: slabs along the principal axis, one
    sphere per slab at the slab's centre on the axis, its radius the farthest point of the slab."""
    centres, radii = _cover(points, np.arange(len(points))[:, None], points)
    if not radii.any():  # every point at the centre: one small sphere
        return points.mean(axis=0)[None], np.array([1e-3])
    return centres[radii > 0.0], radii[radii > 0.0]


#: at most this many triangles after cutting (a very fine mesh keeps its own)
_MAX_TRIANGLES = 20_000


def _mesh_triangles(geometry: coal.BVHModelBase) -> tuple[np.ndarray, np.ndarray]:
    vertices = np.asarray(geometry.vertices(), dtype=float)
    triangles = np.array([[t[0], t[1], t[2]] for t in (geometry.tri_indices(i) for i in range(geometry.num_tris))],
                         dtype=int).reshape(-1, 3)
    return vertices, triangles


def _split_triangles(vertices: np.ndarray, triangles: np.ndarray, longest: float) -> tuple[np.ndarray, np.ndarray]:
    """The same surface as triangles whose edges are at most ``longest`` (each long triangle
    cut into four at its edge midpoints: points of the triangle, so the pieces are the triangle)."""
    for _ in range(8):
        corners = vertices[triangles]  # (t, 3, 3)
        edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).max(axis=1)
        long = edges > longest
        if not long.any() or len(triangles) + 3 * int(long.sum()) > _MAX_TRIANGLES:
            break
        cut = triangles[long]
        base = len(vertices)
        mids = 0.5 * (vertices[cut] + vertices[np.roll(cut, -1, axis=1)])  # (c, 3, 3): ab, bc, ca
        vertices = np.vstack([vertices, mids.reshape(-1, 3)])
        ab, bc, ca = (base + 3 * np.arange(len(cut)) + k for k in range(3))
        a, b, c = cut[:, 0], cut[:, 1], cut[:, 2]
        triangles = np.vstack([triangles[~long], np.column_stack([a, ab, ca]), np.column_stack([ab, b, bc]),
                               np.column_stack([ca, bc, c]), np.column_stack([ab, bc, ca])])
    return vertices, triangles


def _along_cover(half_length: float, radius: float, thickness: float) -> tuple[np.ndarray, np.ndarray]:
    """Spheres containing a solid of cross-section within ``radius`` of the z axis, |z| <=
    half_length: slabs along z, each sphere reaching its slab's corners (sqrt(r^2 + slab^2))."""
    count = int(min(MAX_SPHERES_PER_SHAPE,
                    max(1, math.ceil(2.0 * half_length / (SLAB_PER_RADIUS * max(thickness, MIN_SPACING_RADIUS))))))
    half_slab = half_length / count
    z = -half_length + (2.0 * np.arange(count) + 1.0) * half_slab
    centres = np.column_stack([np.zeros(count), np.zeros(count), z])
    return centres, np.full(count, math.hypot(radius, half_slab))


def enclosing_spheres(geometry: coal.CollisionGeometry) -> tuple[np.ndarray, np.ndarray] | None:
    """Spheres (centres (k, 3) in the shape's frame, radii (k,)) whose union contains the shape:
    proved for primitives (a box slab's corners, a cylinder slab's rim are on its sphere), for a
    convex by one sphere around its vertices, and for a mesh every triangle (cut until short)
    lies in the sphere of its cluster (the sphere holds its corners, and a sphere is convex). None
    for a shape this cannot cover (octree, plane, height field...). The batch collision check
    (collision_detection/batch_check.py) calls a state free when these clear everything."""
    if isinstance(geometry, coal.Sphere):
        return np.zeros((1, 3)), np.array([float(geometry.radius)])
    if isinstance(geometry, coal.Box):
        half = np.asarray(geometry.halfSide, dtype=float)
        order = np.argsort(half)[::-1]  # the longest side becomes z of the cover
        centres, radii = _along_cover(float(half[order[0]]), float(np.hypot(half[order[1]], half[order[2]])),
                                      float(half[order[1]]))
        out = np.zeros_like(centres)
        out[:, order[0]] = centres[:, 2]
        return out, radii
    if isinstance(geometry, (coal.Cylinder, coal.Cone)):
        r, h = float(geometry.radius), float(geometry.halfLength)
        return _along_cover(h, r, r)
    if isinstance(geometry, coal.Capsule):
        r, h = float(geometry.radius), float(geometry.halfLength)
        centres, radii = _along_cover(h, r, r)
        caps = np.array([[0.0, 0.0, h], [0.0, 0.0, -h]])
        return np.vstack([centres, caps]), np.concatenate([radii, [r, r]])
    if isinstance(geometry, coal.Ellipsoid):
        return np.zeros((1, 3)), np.array([float(np.max(geometry.radii))])
    if isinstance(geometry, coal.ConvexBase):
        points = np.asarray(geometry.points(), dtype=float)
        if not len(points):
            return None
        centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
        return centre[None], np.array([float(np.max(np.linalg.norm(points - centre, axis=1)))])
    if isinstance(geometry, coal.BVHModelBase):
        if geometry.num_tris == 0:
            return None
        vertices, triangles = _mesh_triangles(geometry)
        size = float(np.linalg.norm(np.ptp(vertices, axis=0)))
        if size > 0.0:  # the cut adds points of the surface: pieces small against the clusters
            vertices, triangles = _split_triangles(vertices, triangles, _TRIANGLE_PER_CLUSTER * size)
        return _cluster_cover(vertices, triangles)
    return None


#: a mesh is covered by at most this many spheres, one per cluster of its triangles
MESH_SPHERES = 16
#: a mesh triangle longer than this fraction of the mesh's size is cut in four (repeatedly)
#: before clustering, so one long triangle does not swell the sphere of its cluster
_TRIANGLE_PER_CLUSTER = 0.1


def _cluster_cover(vertices: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Spheres holding every triangle: the triangles' centroids in MESH_SPHERES clusters
    (k-means from farthest-point seeds, deterministic), each cluster's sphere centred on the
    box around its triangles' corners and reaching the farthest corner."""
    centroids = vertices[triangles].mean(axis=1)
    k = min(MESH_SPHERES, len(centroids))
    seeds = [0]
    gap = np.linalg.norm(centroids - centroids[0], axis=1)
    for _ in range(1, k):
        seeds.append(int(np.argmax(gap)))
        gap = np.minimum(gap, np.linalg.norm(centroids - centroids[seeds[-1]], axis=1))
    means = centroids[seeds]
    label = np.zeros(len(centroids), dtype=int)
    for _ in range(10):
        label = np.argmin(np.linalg.norm(centroids[:, None] - means[None], axis=2), axis=1)
        for c in range(k):
            mine = centroids[label == c]
            if len(mine):
                means[c] = mine.mean(axis=0)
    centres, radii = [], []
    for c in range(k):
        corners = vertices[triangles[label == c].ravel()]
        if not len(corners):
            continue
        middle = 0.5 * (corners.min(axis=0) + corners.max(axis=0))
        centres.append(middle)
        radii.append(float(np.max(np.linalg.norm(corners - middle, axis=1))))
    return np.array(centres), np.array(radii)
