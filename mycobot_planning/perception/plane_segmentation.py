"""Support-plane segmentation, scored as in the seed.

Only points within reach of a valid plane (|z| at most z_tolerance plus the tilt the angle
tolerance allows across the cloud) are considered. Candidates are the Euclidean clusters of points whose normals are nearly vertical (tables,
shelves, box tops); each gets a RANSAC plane. A candidate is valid when its centre lies inside
the crop box (if cropping), within ``z_tolerance`` of z = 0, and its normal within the
``angle_tolerance`` cone around +z. Valid candidates are ranked by

    w_inliers * inliers / most_inliers + w_size * area / largest_area
    + w_distance * (1 - |z_centre| / z_tolerance) + w_orientation * n_z

where the area is the bounding rectangle of the inliers projected on the plane. The inlier and
size terms are normalised by the best candidate so that all four terms live in [0, 1] and the
weights mean what they say.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .cloud_processing import estimate_features, voxel_downsample
from .clustering import euclidean_clusters
from .params import PerceptionParameters
from .primitive_fitting import PlaneFrame


@dataclass
class PlaneCandidate:
    """One horizontal cluster and its plane n·x + offset = 0 (n pointing up)."""

    normal: np.ndarray
    offset: float
    center: np.ndarray
    inliers: int
    points: int
    area: float
    valid: bool
    reason: str = ""
    score: float = -math.inf
    scores: dict[str, float] = field(default_factory=dict)
    extent_min: np.ndarray = field(default_factory=lambda: np.zeros(2))
    extent_max: np.ndarray = field(default_factory=lambda: np.zeros(2))
    frame: PlaneFrame | None = None


def fit_plane_ransac(points: np.ndarray, threshold: float, max_iterations: int,
                     rng: np.random.Generator, confidence: float = 0.995) -> tuple[np.ndarray, float, np.ndarray] | None:
    """RANSAC plane (batched hypotheses, adaptive stopping) refined by least squares on its
    inliers. Returns (unit normal with n_z >= 0, offset, inlier mask) or None."""
    n = points.shape[0]
    if n < 3:
        return None
    ev = points if n <= 1000 else points[rng.choice(n, 1000, replace=False)]
    best, best_count, done, needed = None, 0, 0, float(max_iterations)
    while done < min(max_iterations, needed):
        b = int(min(32 if done == 0 else 128, max_iterations - done))  # a clean plane stops after one small batch
        i, j, k = rng.integers(0, n, size=(3, b))
        nrm = np.cross(points[j] - points[i], points[k] - points[i])
        length = np.linalg.norm(nrm, axis=1)
        ok = length > 1e-12
        nrm = nrm / np.where(ok, length, 1.0)[:, None]
        off = -np.einsum("bd,bd->b", nrm, points[i])
        counts = (np.abs(ev @ nrm.T + off) < threshold).sum(axis=0)
        counts = np.where(ok, counts, -1)
        m = int(np.argmax(counts))
        if counts[m] > best_count:
            best_count, best = int(counts[m]), (nrm[m], float(off[m]))
            w = (best_count / ev.shape[0]) ** 3
            needed = math.inf if w <= 0 else (1 if w >= 1 else math.log(1 - confidence) / math.log(1 - w))
        done += b
    if best is None:
        return None
    normal, offset = best
    inliers = np.abs(points @ normal + offset) < threshold
    for _ in range(2):  # least-squares refinement on the inliers
        if inliers.sum() < 3:
            break
        sel = points[inliers]
        centroid = sel.mean(axis=0)
        _, _, vt = np.linalg.svd(sel - centroid, full_matrices=False)
        normal = vt[2]
        offset = -float(normal @ centroid)
        inliers = np.abs(points @ normal + offset) < threshold
    if normal[2] < 0:
        normal, offset = -normal, -offset
    return normal, offset, inliers


def find_support_plane(points: np.ndarray, params: PerceptionParameters,
                       rng: np.random.Generator) -> tuple[PlaneCandidate | None, list[PlaneCandidate]]:
    """The best support plane among the horizontal clusters of ``points`` (target frame), and
    every candidate considered (with the reason a rejected one was rejected)."""
    p = params
    # Only points that could belong to a *valid* plane take part: its centre is within
    # z_tolerance of 0 and it tilts at most acos(angle_tolerance) across the cloud's extent.
    # (On a table this drops the floor and the walls before the costly normal estimation.)
    if points.shape[0]:
        span = float(np.hypot(*np.ptp(points[:, :2], axis=0)))
        tilt = math.tan(math.acos(min(1.0, p.angle_tolerance)))
        reach = p.z_tolerance + p.plane_segmentation_distance_threshold + tilt * span
        points = points[np.abs(points[:, 2]) <= reach]
    grid = voxel_downsample(points, p.plane_voxel_leaf_size)
    coarse = grid.points
    if coarse.shape[0] < 3:
        return None, []
    feats = estimate_features(coarse, p.normal_estimation_k, math.inf, 3, 0.0, with_rsd=False)
    horizontal = np.flatnonzero(feats.valid & (np.abs(feats.normals[:, 2]) > p.angle_tolerance))
    clusters = euclidean_clusters(coarse[horizontal], p.cluster_tolerance, p.min_cluster_size, p.max_cluster_size)
    candidates: list[PlaneCandidate] = []
    for members in clusters:
        cpts = coarse[horizontal[members]]
        fit = fit_plane_ransac(cpts, p.plane_segmentation_distance_threshold,
                               p.max_plane_segmentation_iterations, rng)
        if fit is None:
            continue
        normal, offset, inl = fit
        sel = cpts[inl]
        center = sel.mean(axis=0)
        frame = PlaneFrame.from_plane(normal, offset, center)
        uv = frame.to_plane(sel)[:, :2]
        lo, hi = uv.min(axis=0), uv.max(axis=0)
        cand = PlaneCandidate(normal, offset, center, int(inl.sum()), int(cpts.shape[0]),
                              float(np.prod(hi - lo)), True, extent_min=lo, extent_max=hi, frame=frame)
        if p.enable_cropping and not (p.crop_min_x <= center[0] <= p.crop_max_x
                                      and p.crop_min_y <= center[1] <= p.crop_max_y):
            cand.valid, cand.reason = False, "centre outside the crop box"
        elif abs(center[2]) >= p.z_tolerance:
            cand.valid, cand.reason = False, f"centre at z = {center[2]:.3f}, not within z_tolerance of 0"
        elif normal[2] <= p.angle_tolerance:
            tilt = math.degrees(math.acos(min(1.0, normal[2])))
            cand.valid, cand.reason = False, f"tilted by {tilt:.1f} degrees"
        candidates.append(cand)
    valid = [c for c in candidates if c.valid]
    if not valid:
        return None, candidates
    most_inliers = max(c.inliers for c in valid)
    largest = max(c.area for c in valid) or 1.0
    for c in valid:
        c.scores = {
            "inliers": c.inliers / most_inliers,
            "size": c.area / largest,
            "distance": 1.0 - abs(c.center[2]) / p.z_tolerance,
            "orientation": float(c.normal[2]),
        }
        c.score = (p.w_inliers * c.scores["inliers"] + p.w_size * c.scores["size"]
                   + p.w_distance * c.scores["distance"] + p.w_orientation * c.scores["orientation"])
    best = max(valid, key=lambda c: c.score)
    return best, candidates
