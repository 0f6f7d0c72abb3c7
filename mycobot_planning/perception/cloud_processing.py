"""Point cloud basics, vectorised: validation, transforms, cropping, voxel grids, and per-point
normals, curvature and RSD radius from k-nearest-neighbour PCA (SciPy cKDTree).

Speed comes from two habits: throw points away early (crop, then voxel grids sized to the
question being asked) and never loop over points in Python — neighbourhoods are gathered into
(N, k, 3) arrays and all 3x3 eigenproblems are solved in one batched call.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .errors import CloudFormatError

PLANE_RSD_RADIUS = 0.2
"""RSD radius reported for flat neighbourhoods (PCL's RSD caps at a 'plane radius' too)."""


def as_point_array(points: object, colors: object = None, *, transform: np.ndarray | None = None,
                   crop: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None
                   ) -> tuple[np.ndarray, np.ndarray | None]:
    """Validate a cloud, drop points with a NaN or infinite coordinate, optionally transform it
    (4x4) and crop it to an axis-aligned box (lower, upper) in the transformed frame.

    Accepts (N, 3) or organised (H, W, 3) real arrays; colours, if given, must have the same
    leading shape and 3 channels. Returns float64 (M, 3) points and uint8 (M, 3) colours (M may
    be 0 after cropping). Raises :class:`CloudFormatError` for anything else, including a cloud
    with no finite point at all. Masks are computed in the input dtype and only the surviving
    points are converted, because most of a camera frame is usually cropped away."""
    try:
        pts = np.asarray(points)
    except Exception as err:  # ragged lists and the like
        raise CloudFormatError(f"point cloud is not an array: {err}") from None
    if pts.dtype == object or not np.issubdtype(pts.dtype, np.number) or np.issubdtype(pts.dtype, np.complexfloating):
        raise CloudFormatError(f"point cloud must hold real numbers, got dtype {pts.dtype}")
    if pts.ndim not in (2, 3) or pts.shape[-1] != 3:
        raise CloudFormatError(f"point cloud must have shape (N, 3) or (H, W, 3), got {pts.shape}")
    pts = pts.reshape(-1, 3)
    if pts.shape[0] == 0:
        raise CloudFormatError("point cloud is empty")
    cols = None
    if colors is not None:
        cols = np.asarray(colors)
        if cols.shape[-1:] != (3,) or cols.size != pts.size:
            raise CloudFormatError(f"colors must have one (r, g, b) per point, got shape {cols.shape} "
                                   f"for {pts.shape[0]} points")
        if not np.issubdtype(cols.dtype, np.number):
            raise CloudFormatError(f"colors must be numeric, got dtype {cols.dtype}")
        cols = cols.reshape(-1, 3)
    if np.issubdtype(pts.dtype, np.floating):
        finite = np.isfinite(pts[:, 0]) & np.isfinite(pts[:, 1]) & np.isfinite(pts[:, 2])
        n_finite = int(finite.sum())
        if n_finite == 0:
            raise CloudFormatError(f"point cloud has no finite point (all {pts.shape[0]} are NaN or infinite)")
    else:
        finite, n_finite = None, pts.shape[0]
    if transform is not None:
        sel = pts if finite is None or n_finite == pts.shape[0] else pts[finite]
        cols = cols if cols is None or finite is None or n_finite == pts.shape[0] else cols[finite]
        pts, finite = transform_points(sel.astype(np.float64), transform), None
    keep = finite
    if crop is not None:
        lo, hi = crop
        inside = ((pts[:, 0] >= lo[0]) & (pts[:, 0] <= hi[0]) & (pts[:, 1] >= lo[1]) & (pts[:, 1] <= hi[1])
                  & (pts[:, 2] >= lo[2]) & (pts[:, 2] <= hi[2]))
        keep = inside if keep is None else keep & inside
    if keep is not None:
        pts = pts[keep]
        cols = None if cols is None else cols[keep]
    pts = pts.astype(np.float64, copy=False)
    if cols is not None and cols.dtype != np.uint8:
        cols = np.clip(np.nan_to_num(cols.astype(np.float64)), 0, 255).astype(np.uint8)
    return pts, cols


def transform_points(points: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Apply a 4x4 rigid transform to (N, 3) points."""
    T = np.asarray(T, dtype=float)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise CloudFormatError("cloud transform must be a finite 4x4 matrix")
    return points @ T[:3, :3].T + T[:3, 3]


def crop_mask(points: np.ndarray, lower: tuple[float, float, float], upper: tuple[float, float, float]) -> np.ndarray:
    """Points inside the axis-aligned box [lower, upper] (bounds may be infinite)."""
    lo, hi = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    return np.all((points >= lo) & (points <= hi), axis=1)


@dataclass
class VoxelGrid:
    """Result of :func:`voxel_downsample`: one centroid per occupied voxel, the voxel of every
    input point (``inverse``) and the number of points per voxel."""

    points: np.ndarray
    colors: np.ndarray | None
    inverse: np.ndarray
    counts: np.ndarray


def voxel_downsample(points: np.ndarray, leaf: float, colors: np.ndarray | None = None) -> VoxelGrid:
    """Replace the points of each occupied ``leaf``-sized voxel by their centroid (PCL VoxelGrid).

    Averaging also lowers the depth noise by about sqrt(points per voxel). ``leaf`` <= 0 keeps
    every point."""
    n = points.shape[0]
    if leaf <= 0 or n == 0:
        return VoxelGrid(points, colors, np.arange(n), np.ones(n, dtype=np.int64))
    span = (points.max(axis=0) - points.min(axis=0)) / leaf
    if not np.all(span < 2.0**52):
        raise CloudFormatError(f"point cloud spans {np.ptp(points, axis=0).max():.3g} m: too large for a voxel "
                               f"grid with leaf {leaf} m (crop it first)")
    cells = np.floor((points - points.min(axis=0)) / leaf).astype(np.int64)
    dims = cells.max(axis=0) + 1
    if float(dims[0]) * float(dims[1]) * float(dims[2]) < 2.0**62:
        keys = cells[:, 0] + dims[0] * (cells[:, 1] + dims[1] * cells[:, 2])
    else:  # an enormous (but finite) extent: rank the cells instead of packing them into one int64
        _, keys = np.unique(cells, axis=0, return_inverse=True)
        keys = keys.reshape(-1)
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    starts = np.flatnonzero(np.r_[True, sorted_keys[1:] != sorted_keys[:-1]])
    counts = np.diff(np.r_[starts, n])
    inverse = np.empty(n, dtype=np.int64)
    inverse[order] = np.repeat(np.arange(starts.size), counts)
    sums = np.add.reduceat(points[order], starts, axis=0)
    centroids = sums / counts[:, None]
    mean_colors = None
    if colors is not None:
        csum = np.add.reduceat(colors[order].astype(np.float64), starts, axis=0)
        mean_colors = np.round(csum / counts[:, None]).astype(np.uint8)
    return VoxelGrid(centroids, mean_colors, inverse, counts)


@dataclass
class PointFeatures:
    """Per-point local geometry. ``normals`` unit (sign arbitrary: consumers use |cos|),
    ``curvature`` = lambda0 / (lambda0 + lambda1 + lambda2), ``rsd_radius`` the radius of the
    circle best explaining how normals turn with distance (capped at PLANE_RSD_RADIUS),
    ``valid`` false where the neighbourhood was too small (isolated or boundary noise)."""

    normals: np.ndarray
    curvature: np.ndarray
    rsd_radius: np.ndarray
    valid: np.ndarray
    neighbors: np.ndarray
    """(N, k) neighbour indices; N (one past the end) marks a missing neighbour."""


def _smallest_eigen(cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending) and the smallest eigenvector of many symmetric 3x3 matrices.

    Closed form (the trigonometric solution of the characteristic cubic, then the eigenvector
    as the largest cross product of two rows of A - lambda_min I): several times faster than a
    batched LAPACK eigh, and only the normal is needed."""
    a00, a11, a22 = cov[:, 0, 0], cov[:, 1, 1], cov[:, 2, 2]
    a01, a02, a12 = cov[:, 0, 1], cov[:, 0, 2], cov[:, 1, 2]
    q = (a00 + a11 + a22) / 3.0
    p1 = a01 * a01 + a02 * a02 + a12 * a12
    p2 = (a00 - q) ** 2 + (a11 - q) ** 2 + (a22 - q) ** 2 + 2.0 * p1
    p = np.sqrt(p2 / 6.0)
    safe_p = np.where(p > 0, p, 1.0)
    b00, b11, b22 = (a00 - q) / safe_p, (a11 - q) / safe_p, (a22 - q) / safe_p
    b01, b02, b12 = a01 / safe_p, a02 / safe_p, a12 / safe_p
    det_b = b00 * (b11 * b22 - b12 * b12) - b01 * (b01 * b22 - b12 * b02) + b02 * (b01 * b12 - b11 * b02)
    phi = np.arccos(np.clip(det_b / 2.0, -1.0, 1.0)) / 3.0
    l_max = q + 2.0 * p * np.cos(phi)
    l_min = q + 2.0 * p * np.cos(phi + 2.0 * np.pi / 3.0)
    l_mid = 3.0 * q - l_max - l_min
    evals = np.stack([l_min, l_mid, l_max], axis=1)
    shifted = cov - l_min[:, None, None] * np.eye(3)
    r0, r1, r2 = shifted[:, 0], shifted[:, 1], shifted[:, 2]
    crosses = np.stack([np.cross(r0, r1), np.cross(r0, r2), np.cross(r1, r2)], axis=1)
    norms = np.linalg.norm(crosses, axis=2)
    best = norms.argmax(axis=1)
    rows = np.arange(cov.shape[0])
    normal = crosses[rows, best]
    nn = norms[rows, best]
    degenerate = nn <= 1e-300
    normal = np.where(degenerate[:, None], np.array([0.0, 0.0, 1.0]), normal / np.where(degenerate, 1.0, nn)[:, None])
    return evals, normal


def _weighted_pca(nbr_pts: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weighted mean, covariance eigenvalues and normal of each (k, 3) neighbourhood.

    The six covariance entries are formed as plain weighted sums over the neighbour axis
    (much faster in NumPy than a batch of tiny matrix products)."""
    wsum = np.maximum(weights.sum(axis=1), 1e-12)
    x, y, z = nbr_pts[:, :, 0], nbr_pts[:, :, 1], nbr_pts[:, :, 2]
    mx, my, mz = ((weights * c).sum(axis=1) / wsum for c in (x, y, z))
    dx, dy, dz = x - mx[:, None], y - my[:, None], z - mz[:, None]
    wx, wy = weights * dx, weights * dy
    cxx, cxy, cxz = (wx * dx).sum(1), (wx * dy).sum(1), (wx * dz).sum(1)
    cyy, cyz = (wy * dy).sum(1), (wy * dz).sum(1)
    czz = (weights * dz * dz).sum(1)
    cov = np.empty((nbr_pts.shape[0], 3, 3))
    cov[:, 0, 0], cov[:, 1, 1], cov[:, 2, 2] = cxx, cyy, czz
    cov[:, 0, 1] = cov[:, 1, 0] = cxy
    cov[:, 0, 2] = cov[:, 2, 0] = cxz
    cov[:, 1, 2] = cov[:, 2, 1] = cyz
    cov /= wsum[:, None, None]
    evals, normal = _smallest_eigen(cov)
    return np.stack([mx, my, mz], axis=1), evals, normal


def estimate_features(points: np.ndarray, k: int, radius: float, min_neighbors: int = 3,
                      max_plane_error: float = 0.01, tree: cKDTree | None = None,
                      with_rsd: bool = True) -> PointFeatures:
    """Normals, curvature and RSD radius of every point from its ``k`` nearest neighbours
    within ``radius`` (the seed's k_neighbors, rsd_radius, min_boundary_neighbors).

    After a plain PCA, neighbours are re-weighted by their distance to the local plane
    (Cauchy weights with scale ``max_plane_error``) and the PCA is repeated, so a point on one
    face of a box near an edge is not tilted by the other face."""
    n = points.shape[0]
    if n == 0:
        empty = np.zeros((0, 3))
        return PointFeatures(empty, np.zeros(0), np.zeros(0), np.zeros(0, bool), np.zeros((0, k), np.int64))
    k_eff = int(min(k, n))
    tree = tree if tree is not None else cKDTree(points)
    dist, idx = tree.query(points, k=k_eff, distance_upper_bound=radius, workers=-1)
    if k_eff == 1:
        dist, idx = dist[:, None], idx[:, None]
    present = np.isfinite(dist)
    n_nbrs = present.sum(axis=1)
    valid = n_nbrs >= max(3, min(min_neighbors, k_eff))
    padded = np.vstack([points, np.zeros((1, 3))])
    nbr_pts = padded[idx]
    weights = present.astype(np.float64)
    mean, evals, normals = _weighted_pca(nbr_pts, weights)
    if max_plane_error > 0:
        resid = ((nbr_pts[:, :, 0] - mean[:, 0:1]) * normals[:, 0:1] + (nbr_pts[:, :, 1] - mean[:, 1:2]) * normals[:, 1:2]
                 + (nbr_pts[:, :, 2] - mean[:, 2:3]) * normals[:, 2:3])
        weights = weights / (1.0 + np.square(resid / max_plane_error))
        mean, evals, normals = _weighted_pca(nbr_pts, weights)
    evals = np.maximum(evals, 0.0)
    total = evals.sum(axis=1)
    curvature = np.where(total > 0, evals[:, 0] / np.where(total > 0, total, 1.0), 0.0)
    if with_rsd:
        rsd = _rsd_radius(points, normals, idx, dist, present)
    else:
        rsd = np.full(n, PLANE_RSD_RADIUS)
    return PointFeatures(normals, curvature, rsd, valid, idx)


def _rsd_radius(points: np.ndarray, normals: np.ndarray, idx: np.ndarray, dist: np.ndarray,
                present: np.ndarray) -> np.ndarray:
    """Minimum surface radius in the spirit of the Radius-based Surface Descriptor.

    Along a curved surface the angle between two normals grows with their distance as
    alpha = d / r; RSD's r_min is the radius along the direction that turns fastest (the
    cylinder's cross-section, not its axis). For every neighbour r_j = d_j / alpha_j; the lower
    quartile over the outer half of the neighbourhood (where alpha is large against normal
    noise) estimates r_min. Flat neighbourhoods give large values, capped at PLANE_RSD_RADIUS."""
    padded_n = np.vstack([normals, np.zeros((1, 3))])
    nb = padded_n[idx]
    cosang = np.abs(nb[:, :, 0] * normals[:, 0:1] + nb[:, :, 1] * normals[:, 1:2] + nb[:, :, 2] * normals[:, 2:3])
    alpha = np.arccos(np.clip(cosang, 0.0, 1.0))
    d = np.where(present, dist, 0.0)
    far = present & (d >= 0.5 * d.max(axis=1, keepdims=True)) & (d > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(far & (alpha > 1e-9), d / alpha, np.inf)
    ratio = np.where(far, ratio, np.inf)
    ratio.sort(axis=1)
    count = far.sum(axis=1)
    pick = np.minimum((count * 0.25).astype(np.int64), idx.shape[1] - 1)
    r = ratio[np.arange(ratio.shape[0]), pick]
    r = np.where((count > 0) & np.isfinite(r), r, PLANE_RSD_RADIUS)
    return np.minimum(r, PLANE_RSD_RADIUS)
