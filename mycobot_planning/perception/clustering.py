"""Euclidean cluster extraction (PCL's EuclideanClusterExtraction) with SciPy and NumPy.

Two points are connected when they are closer than ``tolerance``; clusters are the connected
components. The pairs come from one cKDTree.query_pairs call and the components from a
vectorised union-find (label propagation with pointer jumping), so nothing loops over points
in Python — and, unlike scipy.sparse.csgraph, there is no per-call set-up cost, which matters
because the object fitting checks many small inlier sets. Dense clouds are first reduced to a
voxel grid of tolerance / 2 (points sharing a voxel are always within tolerance of each
other), which bounds the number of pairs.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .cloud_processing import voxel_downsample

_DIRECT_LIMIT = 64


def _components(n: int, edges: np.ndarray) -> np.ndarray:
    """Smallest member index of each node's connected component (edges: (E, 2) int array)."""
    labels = np.arange(n)
    if edges.size == 0:
        return labels
    i, j = edges[:, 0], edges[:, 1]
    while True:
        li, lj = labels[i], labels[j]
        low = np.minimum(li, lj)
        hooked = labels.copy()
        np.minimum.at(hooked, li, low)  # hook each root under the smallest label it touches
        np.minimum.at(hooked, lj, low)
        while True:  # pointer jumping: every node straight to its root
            jumped = hooked[hooked]
            if np.array_equal(jumped, hooked):
                break
            hooked = jumped
        if np.array_equal(hooked, labels):
            return labels
        labels = hooked


def connected_labels(points: np.ndarray, tolerance: float) -> np.ndarray:
    """Component label of every point (labels are 0..C-1 in order of first appearance)."""
    n = points.shape[0]
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    if n > _DIRECT_LIMIT:
        grid = voxel_downsample(points, tolerance / 2.0)
        if grid.points.shape[0] < 0.7 * n:
            return connected_labels(grid.points, tolerance)[grid.inverse]
    pairs = cKDTree(points).query_pairs(tolerance, output_type="ndarray")
    roots = _components(n, pairs)
    _, labels = np.unique(roots, return_inverse=True)
    return labels.reshape(-1)


def euclidean_clusters(points: np.ndarray, tolerance: float, min_size: int = 1,
                       max_size: int | None = None) -> list[np.ndarray]:
    """Index arrays of the clusters with min_size..max_size points, largest first."""
    labels = connected_labels(points, tolerance)
    if labels.size == 0:
        return []
    counts = np.bincount(labels)
    order = np.argsort(labels, kind="stable")
    splits = np.split(order, np.cumsum(counts)[:-1])
    keep = [s for s in splits if s.size >= min_size and (max_size is None or s.size <= max_size)]
    keep.sort(key=lambda s: -s.size)
    return keep
