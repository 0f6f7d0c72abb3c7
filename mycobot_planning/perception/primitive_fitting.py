"""Cylinder or box? Circle and line models on the support-plane projection, with Hough voting.

The full story: docs/perception.md, section mycobot_planning.perception.primitive_fitting.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from .cloud_processing import PointFeatures
from .clustering import connected_labels
from .params import PerceptionParameters

WALL_MAX_NZ = 0.5
"""A point is on a wall when its normal is within 30 degrees of horizontal (|n_z| < sin 30°)."""
CAP_MIN_NZ = math.cos(math.radians(30.0))
"""A point is on a cap (top face) when its normal is within 30 degrees of vertical."""
FLAT_CURVATURE_MARGIN = 4.0
"""Line inliers may be as curved as FLAT_CURVATURE_MARGIN times what the flat table shows: walls
facing the camera carry more normal-direction noise than a table seen at a glancing angle."""
_RANSAC_EVAL_POINTS = 600
_RANSAC_BATCH = 128
_RANSAC_FIRST_BATCH = 32
_MAX_MODELS_PER_ROUND = 6


@dataclass
class NoiseModel:
    """Sensor noise measured on the support plane, used to keep thresholds above it.

    ``sigma``: standard deviation of plane distances of (voxel-filtered) plane points;
    ``flat_curvature``: 90th percentile of the curvature of plane points at the object voxel
    size: what "flat" looks like through this sensor. When noise dominates curvature (any real
    depth camera at the seed's thresholds) the curvature tests stop discriminating and the
    normal-direction tests decide; the thresholds are relaxed so that they do not reject
    true walls."""

    sigma: float = 0.0
    flat_curvature: float = 0.0


@dataclass
class PlaneFrame:
    """The support plane as a frame: origin on the plane, columns of ``rotation`` = (u, v, n),
    n the plane normal pointing up. World (target-frame) coordinates ↔ plane coordinates."""

    origin: np.ndarray
    rotation: np.ndarray

    @classmethod
    def from_plane(cls, normal: np.ndarray, offset: float, anchor: np.ndarray) -> PlaneFrame:
        """Plane n·x + offset = 0 (n up); origin = ``anchor`` projected onto the plane; the
        rotation is the smallest one taking z to n, so u, v follow the world x, y axes as
        closely as possible (a horizontal table gives yaw in world terms)."""
        n = np.asarray(normal, dtype=float)
        n = n / np.linalg.norm(n)
        R = rotation_from_z(n)
        anchor = np.asarray(anchor, dtype=float)
        origin = anchor - (n @ anchor + offset) * n
        return cls(origin, R)

    def to_plane(self, points: np.ndarray) -> np.ndarray:
        return (points - self.origin) @ self.rotation

    def vectors_to_plane(self, vectors: np.ndarray) -> np.ndarray:
        return vectors @ self.rotation

    def to_world(self, local: np.ndarray) -> np.ndarray:
        return local @ self.rotation.T + self.origin

    def pose(self, u: float, v: float, h: float, yaw: float = 0.0) -> np.ndarray:
        """4x4 world pose of a point (u, v, h) in the plane frame, turned by ``yaw`` about n."""
        c, s = math.cos(yaw), math.sin(yaw)
        T = np.eye(4)
        T[:3, :3] = self.rotation @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        T[:3, 3] = self.to_world(np.array([u, v, h]))
        return T


def rotation_from_z(n: np.ndarray) -> np.ndarray:
    """Smallest rotation taking (0, 0, 1) to the unit vector ``n`` (Rodrigues)."""
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, n)
    s, c = np.linalg.norm(axis), float(z @ n)
    if s < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    k = axis / s
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + s * K + (1 - c) * (K @ K)


# --------------------------------------------------------------------------------------------
# RANSAC in 2D (vectorised over batches of hypotheses, adaptive stopping)
# --------------------------------------------------------------------------------------------


def _needed_iterations(inlier_ratio: float, sample_size: int, confidence: float = 0.995) -> float:
    w = inlier_ratio**sample_size
    if w <= 0:
        return math.inf
    if w >= 1:
        return 1
    return math.log(1 - confidence) / math.log(1 - w)


def ransac_line(xy: np.ndarray, threshold: float, max_iterations: int,
                rng: np.random.Generator) -> tuple[np.ndarray, float] | None:
    """Best 2D line as (unit normal (2,), rho) with normal·p = rho, or None.

    Hypotheses are scored on at most _RANSAC_EVAL_POINTS points, in batches, stopping as soon
    as the standard RANSAC bound says an all-inlier sample has almost surely been drawn."""
    if xy.shape[0] < 2:
        return None

    def hypotheses(ev: np.ndarray, idx: np.ndarray) -> tuple[np.ndarray, Callable[[int], Any]]:
        i, j = idx
        d = xy[j] - xy[i]
        length = np.hypot(d[:, 0], d[:, 1])
        ok = length > 1e-9
        normals = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.where(ok, length, 1.0)[:, None]
        rho = np.einsum("bd,bd->b", normals, xy[i])
        counts = (np.abs(ev @ normals.T - rho) < threshold).sum(axis=0)
        return np.where(ok, counts, -1), lambda k: (normals[k], float(rho[k]))

    best = _ransac(xy, max_iterations, rng, 2, hypotheses)
    if best is None:
        return None
    normal, rho = best
    if rho < 0:
        normal, rho = -normal, -rho
    return normal, rho


def _circles_through(p1: np.ndarray, p2: np.ndarray, p3: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Circumcircles (centres (b, 2), radii (b,)) of point triples; degenerate → radius inf."""
    ax, ay = p1[:, 0], p1[:, 1]
    bx, by = p2[:, 0], p2[:, 1]
    cx, cy = p3[:, 0], p3[:, 1]
    d = 2.0 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
    ok = np.abs(d) > 1e-12
    d = np.where(ok, d, 1.0)
    a2, b2, c2 = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
    ux = (a2 * (by - cy) + b2 * (cy - ay) + c2 * (ay - by)) / d
    uy = (a2 * (cx - bx) + b2 * (ax - cx) + c2 * (bx - ax)) / d
    centres = np.stack([ux, uy], axis=1)
    radii = np.where(ok, np.hypot(ax - ux, ay - uy), np.inf)
    return centres, radii


def ransac_circle(xy: np.ndarray, threshold: float, max_iterations: int, rng: np.random.Generator,
                  r_min: float, r_max: float) -> tuple[np.ndarray, float] | None:
    """Best 2D circle (centre (2,), radius) with r_min <= radius <= r_max, or None."""
    if xy.shape[0] < 3:
        return None

    def hypotheses(ev: np.ndarray, idx: np.ndarray) -> tuple[np.ndarray, Callable[[int], Any]] | None:
        centres, radii = _circles_through(xy[idx[0]], xy[idx[1]], xy[idx[2]])
        ok = (radii >= r_min) & (radii <= r_max)
        if not np.any(ok):
            return None
        c, r = centres[ok], radii[ok]
        dist = np.sqrt((ev[:, None, 0] - c[None, :, 0]) ** 2 + (ev[:, None, 1] - c[None, :, 1]) ** 2)
        return (np.abs(dist - r) < threshold).sum(axis=0), lambda k: (c[k], float(r[k]))

    return _ransac(xy, max_iterations, rng, 3, hypotheses)


def _ransac(xy: np.ndarray, max_iterations: int, rng: np.random.Generator, sample_size: int,
            hypotheses: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, Callable[[int], Any]] | None]) -> Any:
    """Batched RANSAC with adaptive stopping; the best model, or None.

    ``hypotheses(ev, idx)`` fits one model per column of ``idx`` ((sample_size, b) indices into
    ``xy``) and returns their inlier counts on the evaluation points ``ev`` (at most
    _RANSAC_EVAL_POINTS of ``xy``) with a function giving the k-th counted model, or None when
    no model of the batch is usable."""
    n = xy.shape[0]
    ev = xy if n <= _RANSAC_EVAL_POINTS else xy[rng.choice(n, _RANSAC_EVAL_POINTS, replace=False)]
    best, best_count, done, needed = None, 0, 0, float(max_iterations)
    while done < min(max_iterations, needed):
        b = int(min(_RANSAC_BATCH if done else _RANSAC_FIRST_BATCH, max_iterations - done))
        scored = hypotheses(ev, rng.integers(0, n, size=(sample_size, b)))
        if scored is not None:
            counts, model = scored
            k = int(np.argmax(counts))
            if counts[k] > best_count:
                best_count, best = int(counts[k]), model(k)
                needed = _needed_iterations(best_count / ev.shape[0], sample_size)
        done += b
    return best


def fit_circle_geometric(xy: np.ndarray, centre: np.ndarray, radius: float,
                         iterations: int = 20) -> tuple[np.ndarray, float]:
    """Geometric least-squares circle (Gauss-Newton on the point-to-circle distances) from an
    initial guess. Unlike algebraic fits it is not biased towards small radii on partial arcs."""
    c, r = np.array(centre, dtype=float), float(radius)
    for _ in range(iterations):
        d = xy - c
        dist = np.hypot(d[:, 0], d[:, 1])
        dist = np.where(dist > 1e-12, dist, 1e-12)
        resid = dist - r
        J = np.column_stack([-d[:, 0] / dist, -d[:, 1] / dist, -np.ones_like(dist)])
        try:
            step, *_ = np.linalg.lstsq(J, -resid, rcond=None)
        except np.linalg.LinAlgError:
            break
        c += step[:2]
        r += step[2]
        if np.abs(step).max() < 1e-9:
            break
    return c, abs(r)


# --------------------------------------------------------------------------------------------
# The per-cluster model competition
# --------------------------------------------------------------------------------------------


@dataclass
class CircleModel:
    centre: np.ndarray
    radius: float
    votes: int


@dataclass
class LineModel:
    theta: float
    """Direction of the line normal in the plane, in [0, pi)."""
    rho: float
    """Signed distance of the line from the cluster's centre (the Hough origin): measured from
    there, the same wall found in two rounds gives nearly the same rho even when its direction
    differs by a degree."""
    votes: int


@dataclass
class FittedPrimitive:
    """A cylinder or box standing on the support plane, in the target frame.

    ``dimensions`` use shape_msgs order: cylinder [height, radius], box [x, y, z] with x along
    the box yaw. ``pose`` is the primitive's centre (bottom on the plane)."""

    shape: str
    dimensions: list[float]
    pose: np.ndarray
    yaw: float = 0.0
    circle_votes: int = 0
    line_votes: int = 0
    point_count: int = 0
    faces: int = 0
    """Distinct walls behind the winning line votes (a box seen from one side shows 1 or 2)."""
    circles: list[CircleModel] = field(default_factory=list)
    lines: list[LineModel] = field(default_factory=list)


@dataclass
class _ClusterData:
    local: np.ndarray  # (N, 3) u, v, h
    normals: np.ndarray  # (N, 3) in plane frame
    curvature: np.ndarray
    rsd: np.ndarray
    wall: np.ndarray  # bool
    cap: np.ndarray  # bool


def _horizontal_unit(normals: np.ndarray) -> np.ndarray:
    h = normals[:, :2]
    n = np.hypot(h[:, 0], h[:, 1])
    return h / np.where(n > 1e-12, n, 1.0)[:, None]


def _cluster_count_ok(local: np.ndarray, tolerance: float, min_size: int, max_clusters: int,
                      height_tolerance: float | None) -> tuple[bool, np.ndarray]:
    """Seed's Euclidean check on a model's inliers: the clusters with >= min_size points must be
    at most max_clusters (and, for two circle clusters, reach the same height). Returns
    (accepted, mask of points in the kept clusters)."""
    if local.shape[0] == 0:
        return False, np.zeros(0, bool)
    labels = connected_labels(local, tolerance)
    counts = np.bincount(labels)
    big = np.flatnonzero(counts >= min_size)
    if big.size == 0 or big.size > max_clusters:
        return False, np.zeros(local.shape[0], bool)
    if height_tolerance is not None and big.size == 2:
        tops = [local[labels == b, 2].max() for b in big]
        if abs(tops[0] - tops[1]) > height_tolerance:
            return False, np.zeros(local.shape[0], bool)
    return True, np.isin(labels, big)


class PrimitiveFitter:
    """Fits one cylinder or box per cluster (see docs/perception.md (mycobot_planning.perception.primitive_fitting)). Stateless apart from the
    parameters, the plane frame and the noise model of the current cloud."""

    def __init__(self, params: PerceptionParameters, frame: PlaneFrame, noise: NoiseModel) -> None:
        self.p = params
        self.frame = frame
        self.noise = noise
        # Distances: never tighter than twice the measured noise; curvature of flat faces:
        # never below what a flat table measures.
        self.distance = max(params.ransac_distance_threshold, 2.0 * noise.sigma)
        self.line_curvature = max(params.line_curvature_threshold, FLAT_CURVATURE_MARGIN * noise.flat_curvature)
        self.circle_curvature = params.circle_curvature_threshold
        self.cos_circle = math.cos(params.circle_normal_angle_threshold)
        self.cos_line = math.cos(params.line_normal_angle_threshold)

    # -- data ---------------------------------------------------------------------------------
    def _prepare(self, points: np.ndarray, feats: PointFeatures) -> _ClusterData:
        local = self.frame.to_plane(points)
        normals = self.frame.vectors_to_plane(feats.normals)
        nz = np.abs(normals[:, 2])
        wall = feats.valid & (nz < WALL_MAX_NZ)
        cap = feats.valid & (nz > CAP_MIN_NZ)
        return _ClusterData(local, normals, feats.curvature, feats.rsd_radius, wall, cap)

    # -- model filters (the seed's inlier filtering) --------------------------------------------
    def _circle_support(self, data: _ClusterData, idx: np.ndarray, centre: np.ndarray,
                        radius: float) -> np.ndarray:
        """Indices (subset of idx) of the filtered circle inliers; empty if the model fails."""
        p = self.p
        xy = data.local[idx, :2]
        radial = xy - centre
        dist = np.hypot(radial[:, 0], radial[:, 1])
        inl = np.abs(dist - radius) < self.distance
        if inl.sum() < p.inlier_threshold:
            return idx[:0]
        cand = idx[inl]
        ok, keep = _cluster_count_ok(data.local[cand], p.circle_cluster_tolerance, p.circle_min_cluster_size,
                                     p.circle_max_clusters, p.circle_height_tolerance)
        if not ok:
            return idx[:0]
        cand = cand[keep]
        radial = data.local[cand, :2] - centre
        radial /= np.maximum(np.hypot(radial[:, 0], radial[:, 1]), 1e-12)[:, None]
        cos_ang = np.abs(np.einsum("nd,nd->n", _horizontal_unit(data.normals[cand]), radial))
        good = (cos_ang >= self.cos_circle) & (data.curvature[cand] > self.circle_curvature) \
            & (np.abs(data.rsd[cand] - radius) <= p.circle_radius_tolerance)
        return cand[good]

    def _line_support(self, data: _ClusterData, idx: np.ndarray, normal: np.ndarray, rho: float) -> np.ndarray:
        p = self.p
        xy = data.local[idx, :2]
        inl = np.abs(xy @ normal - rho) < self.distance
        if inl.sum() < p.inlier_threshold:
            return idx[:0]
        cand = idx[inl]
        cos_ang = np.abs(_horizontal_unit(data.normals[cand]) @ normal)
        cand = cand[(cos_ang >= self.cos_line) & (data.curvature[cand] < self.line_curvature)]
        if cand.size < p.inlier_threshold:
            return idx[:0]
        ok, keep = _cluster_count_ok(data.local[cand], p.line_cluster_tolerance, p.line_min_cluster_size,
                                     p.line_max_clusters, None)
        return cand[keep] if ok else idx[:0]

    # -- voting ------------------------------------------------------------------------------
    def _vote(self, data: _ClusterData, rng: np.random.Generator) -> tuple[list[CircleModel], list[LineModel]]:
        p = self.p
        wall_idx = np.flatnonzero(data.wall)
        circles: list[CircleModel] = []
        lines: list[LineModel] = []
        if wall_idx.size < p.inlier_threshold:
            return circles, lines
        xy_all = data.local[wall_idx, :2]
        origin = xy_all.mean(axis=0)  # Hough origin of the line models: the cluster's centre
        extent = np.ptp(xy_all, axis=0)
        r_max = max(float(np.hypot(*extent)) / 1.2, 2 * self.distance)
        r_min = max(2.0 * self.distance, 1e-3)
        for _ in range(p.num_iterations):
            work = wall_idx.copy()
            for _model in range(_MAX_MODELS_PER_ROUND):
                if work.size < p.inlier_threshold:
                    break
                xy = data.local[work, :2]
                line = ransac_line(xy, self.distance, p.ransac_max_iterations, rng)
                circle = ransac_circle(xy, self.distance, p.ransac_max_iterations, rng, r_min, r_max)
                line_sup = self._line_support(data, work, *line) if line is not None else work[:0]
                circ_sup = self._circle_support(data, work, *circle) if circle is not None else work[:0]
                valid_line = line_sup.size >= p.inlier_threshold
                valid_circle = circ_sup.size >= p.inlier_threshold
                if not (valid_line or valid_circle):
                    break
                if valid_circle and (not valid_line or circ_sup.size >= line_sup.size):
                    centre, radius = circle  # type: ignore[misc]
                    circles.append(CircleModel(np.array(centre), float(radius), int(circ_sup.size)))
                    d = np.abs(np.hypot(*(data.local[work, :2] - centre).T) - radius)
                    work = work[d >= 3.0 * self.distance]
                else:
                    normal, rho = line  # type: ignore[misc]
                    theta = math.atan2(normal[1], normal[0]) % math.pi
                    unit = np.array([math.cos(theta), math.sin(theta)])
                    rho_here = float(unit @ (normal * rho) - unit @ origin)
                    lines.append(LineModel(theta, rho_here, int(line_sup.size)))
                    d = np.abs(data.local[work, :2] @ normal - rho)
                    work = work[d >= 3.0 * self.distance]
        return circles, lines

    def _best_circle_cluster(self, circles: list[CircleModel], data: _ClusterData) -> tuple[int, list[CircleModel]]:
        """Votes and members of the best neighbourhood (±1 bin) in the (u, v, r) Hough space."""
        if not circles:
            return 0, []
        p = self.p
        xy = data.local[data.wall, :2]
        lo = xy.min(axis=0) - 0.1
        hi = xy.max(axis=0) + 0.1
        r_hi = max(c.radius for c in circles) * 1.5 + 1e-6
        cb = (hi - lo) / p.hough_center_bins
        rb = r_hi / p.hough_radius_bins
        bins = np.array([[*np.floor((c.centre - lo) / cb), math.floor(c.radius / rb)] for c in circles])
        votes = np.array([c.votes for c in circles])
        near = np.all(np.abs(bins[:, None, :] - bins[None, :, :]) <= 1, axis=2)
        score = near @ votes
        k = int(np.argmax(score))
        return int(score[k]), [c for c, m in zip(circles, near[k]) if m]

    def _best_line_cluster(self, lines: list[LineModel]) -> tuple[int, list[LineModel]]:
        """Votes and members of the best box-yaw neighbourhood: line directions folded modulo
        90 degrees into hough_angle_bins/2 bins, neighbours within line_theta_threshold."""
        if not lines:
            return 0, []
        period = math.pi / 2
        bin_width = math.pi / self.p.hough_angle_bins
        width = max(self.p.line_theta_threshold, bin_width)
        psi = np.array([ln.theta % period for ln in lines])
        psi = np.floor(psi / bin_width) * bin_width + bin_width / 2  # quantised to the Hough bins
        diff = np.abs(psi[:, None] - psi[None, :]) % period
        diff = np.minimum(diff, period - diff)
        near = diff <= width + 1e-12
        votes = np.array([ln.votes for ln in lines])
        score = near @ votes
        k = int(np.argmax(score))
        return int(score[k]), [ln for ln, m in zip(lines, near[k]) if m]

    def _count_faces(self, lines: list[LineModel]) -> int:
        """Distinct walls among the lines of one yaw cluster. Two walls of a box are either
        perpendicular or parallel and apart by the box's size, so lines less than 45 degrees
        apart whose rho (from the cluster centre) agree within line_rho_threshold (or one rho
        bin of the Hough space) are the same wall found again in another round."""
        p = self.p
        rho_span = 2.0 * max(abs(ln.rho) for ln in lines) + 1e-9
        rho_tol = max(p.line_rho_threshold, rho_span / p.hough_rho_bins)
        faces: list[LineModel] = []
        for ln in sorted(lines, key=lambda m: -m.votes):
            for f in faces:
                dt = abs(ln.theta - f.theta) % math.pi
                if min(dt, math.pi - dt) < math.pi / 4 and abs(ln.rho - f.rho) <= rho_tol:
                    break
            else:
                faces.append(ln)
        return len(faces)

    # -- 3D primitives -----------------------------------------------------------------------
    def _top_height(self, data: _ClusterData) -> float:
        """Height of the object's top: the median height of its upper cap points when the
        camera sees the top (noise cancels), else a high percentile of all heights."""
        h = data.local[:, 2]
        h_hi = float(np.percentile(h, 99.5))
        cap = data.cap & (h > h_hi - 0.02)
        if cap.sum() >= 10:
            return float(np.median(h[cap]))
        return h_hi

    def _cylinder(self, data: _ClusterData, members: list[CircleModel], votes: tuple[int, int]) -> FittedPrimitive:
        w = np.array([c.votes for c in members], dtype=float)
        centre = np.average(np.array([c.centre for c in members]), axis=0, weights=w)
        radius = float(np.average([c.radius for c in members], weights=w))
        wall = np.flatnonzero(data.wall)
        for band in (4.0, 2.5):
            xy = data.local[wall, :2]
            radial = xy - centre
            dist = np.hypot(radial[:, 0], radial[:, 1])
            cos_ang = np.abs(np.einsum("nd,nd->n", _horizontal_unit(data.normals[wall]),
                                       radial / np.maximum(dist, 1e-12)[:, None]))
            sel = (np.abs(dist - radius) < band * self.distance) & (cos_ang >= self.cos_circle)
            if sel.sum() >= 3:
                centre, radius = fit_circle_geometric(xy[sel], centre, radius)
        height = max(self._top_height(data), 1e-3)
        pose = self.frame.pose(centre[0], centre[1], height / 2.0)
        return FittedPrimitive("cylinder", [height, radius], pose, 0.0, votes[0], votes[1],
                               int(data.local.shape[0]))

    def _box(self, data: _ClusterData, members: list[LineModel], votes: tuple[int, int]) -> FittedPrimitive:
        period = math.pi / 2
        w = np.array([ln.votes for ln in members], dtype=float)
        ang = np.array([ln.theta for ln in members]) * (2 * math.pi / period)  # 4*theta
        yaw = math.atan2(np.sum(w * np.sin(ang)), np.sum(w * np.cos(ang))) * period / (2 * math.pi)
        yaw = self._refine_yaw(data, yaw)
        c, s = math.cos(yaw), math.sin(yaw)
        # Footprint from the points clear of the plane (stray noise points at the foot of an
        # object are the usual outliers), robust to the odd point with 1/99 percentiles.
        h = data.local[:, 2]
        body = h > 0.1 * max(float(h.max()), 1e-9)
        xy = data.local[body if body.sum() >= 20 else slice(None), :2]
        along = xy @ np.array([c, s])
        across = xy @ np.array([-s, c])
        lo_a, hi_a = np.percentile(along, [1.0, 99.0])
        lo_c, hi_c = np.percentile(across, [1.0, 99.0])
        height = self._top_height(data)
        centre_ac = np.array([(lo_a + hi_a) / 2, (lo_c + hi_c) / 2])
        centre = np.array([c * centre_ac[0] - s * centre_ac[1], s * centre_ac[0] + c * centre_ac[1]])
        # A box seen exactly face-on without its top shows no depth: give it a minimal one rather
        # than a zero dimension (which no collision checker accepts).
        thinnest = max(2.0 * self.distance, 2.0 * self.p.voxel_leaf_size, 1e-3)
        dims = [max(float(hi_a - lo_a), thinnest), max(float(hi_c - lo_c), thinnest), max(height, thinnest)]
        # yaw is in (-45°, 45°]: a box turned by 90° is the same box with x and y swapped.
        pose = self.frame.pose(centre[0], centre[1], dims[2] / 2.0, yaw)
        return FittedPrimitive("box", dims, pose, yaw, votes[0], votes[1], int(data.local.shape[0]))

    def _refine_yaw(self, data: _ClusterData, yaw: float) -> float:
        """Least-squares wall direction: every wall point's horizontal normal, folded modulo 90
        degrees, near the voted yaw, averaged (each visible face contributes its normals)."""
        wall = data.wall
        if wall.sum() < 3:
            return _wrap_quarter(yaw)
        hn = _horizontal_unit(data.normals[wall])
        ang = np.arctan2(hn[:, 1], hn[:, 0])
        d = _wrap_quarter(ang - yaw)
        close = np.abs(d) < math.radians(10.0)
        if close.sum() >= 3:
            yaw = yaw + float(np.mean(d[close]))
        return _wrap_quarter(yaw)

    def fit(self, points: np.ndarray, feats: PointFeatures, rng: np.random.Generator) -> FittedPrimitive | None:
        """One primitive for one cluster, or None when neither model gathers enough votes."""
        data = self._prepare(points, feats)
        circles, lines = self._vote(data, rng)
        circle_votes, circle_members = self._best_circle_cluster(circles, data)
        line_votes, line_members = self._best_line_cluster(lines)
        if circle_votes == 0 and line_votes == 0:
            return None
        if circle_votes >= line_votes:
            prim = self._cylinder(data, circle_members, (circle_votes, line_votes))
        else:
            prim = self._box(data, line_members, (circle_votes, line_votes))
            prim.faces = self._count_faces(line_members)
        prim.circles, prim.lines = circles, lines
        return prim


def _wrap_quarter(angle):  # type: ignore[no-untyped-def]
    """Angle (scalar or array) folded into (-45°, 45°]: box yaws are defined modulo 90°."""
    q = math.pi / 2
    return q / 2 - np.mod(q / 2 - angle, q) if isinstance(angle, np.ndarray) else q / 2 - ((q / 2 - angle) % q)
