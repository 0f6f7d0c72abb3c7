"""The get-planning-scene pipeline: point cloud in, collision objects out.

    cloud ─ validate ─ transform to target_frame ─ crop ─ voxel grid
          ─ support plane (seed scoring) ─ sensor noise from the plane
          ─ points above the plane ─ normals, curvature, RSD ─ Euclidean clusters
          ─ per cluster: circle vs line Hough voting ─ cylinder or box on the plane
          ─ collision objects cylinder_0.., box_0.. + the support surface ─ target choice

:class:`SceneDetector` is what the perception_server node wraps. :meth:`SceneDetector.detect`
raises :class:`~.errors.PerceptionError` for input that cannot be read (wrong shape, no finite
point, a target request that makes no sense); :meth:`SceneDetector.get_planning_scene` is the
service form that never raises for bad input and answers ``success: false`` with the reason,
like the seed's service (whose response carries target_object_id, support_surface_id, success).

Ids follow the seed: ``cylinder_0, cylinder_1, ...`` and ``box_0, ...`` numbered per shape,
largest cluster first; the support surface is ``support_surface_name``. The target is the
object of the requested shape whose dimensions are most similar to the requested ones
(similarity = 0.7 for the shape + 0.3 * (1 - mean relative dimension error), as the seed
scores it; a box's x and y may be given in either order).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from interfaces_py.msgs import CollisionObject, PlanningSceneWorld, Pose, SolidPrimitive

from .cloud_processing import PointFeatures, as_point_array, estimate_features, voxel_downsample
from .clustering import euclidean_clusters
from .errors import PerceptionError, RequestError
from .params import PerceptionParameters
from .plane_segmentation import PlaneCandidate, find_support_plane
from .primitive_fitting import FittedPrimitive, NoiseModel, PrimitiveFitter

NOISE_SIGMAS = 5.0
"""Object points must be this many (raw) noise sigmas above the support plane."""
_PLANE_SAMPLE = 40_000
"""About this many points (an even subsample of the cropped cloud) go into the plane search."""

TARGET_SHAPES = {"cylinder": ("height", "radius"), "box": ("x", "y", "z")}


@dataclass
class DetectedObject:
    """A fitted primitive with its id and evidence (for logs and tests)."""

    id: str
    shape: str
    dimensions: list[float]
    pose: np.ndarray
    yaw: float
    point_count: int
    circle_votes: int
    line_votes: int
    color: tuple[int, int, int] | None = None
    faces: int = 0
    """Box walls seen (1 or 2 from one side); 0 for cylinders."""

    @property
    def center(self) -> np.ndarray:
        return self.pose[:3, 3].copy()

    def describe(self) -> str:
        names = TARGET_SHAPES[self.shape]
        dims = ", ".join(f"{n}={v:.4f}" for n, v in zip(names, self.dimensions))
        c = self.center
        return (f"{self.id}: {self.shape} at ({c[0]:.4f}, {c[1]:.4f}, {c[2]:.4f}) {dims}"
                + (f" yaw={math.degrees(self.yaw):.1f}deg walls={self.faces}" if self.shape == "box" else "")
                + f" votes circle/line {self.circle_votes}/{self.line_votes}")


@dataclass
class DetectionResult:
    """Everything the get-planning-scene service answers, plus diagnostics.

    ``objects`` are the detected cylinders and boxes (CollisionObject ADD in ``frame_id``),
    ``support_surface`` the support surface object (None if no plane was found)."""

    success: bool
    message: str
    objects: list[CollisionObject] = field(default_factory=list)
    support_surface: CollisionObject | None = None
    target_object_id: str = ""
    support_surface_id: str = ""
    detections: list[DetectedObject] = field(default_factory=list)
    frame_id: str = "base_link"
    plane_normal: np.ndarray | None = None
    plane_offset: float | None = None
    noise: NoiseModel = field(default_factory=NoiseModel)
    timings_ms: dict[str, float] = field(default_factory=dict)
    stats: dict[str, int] = field(default_factory=dict)
    plane_candidates: list[PlaneCandidate] = field(default_factory=list)

    def scene_world(self) -> PlanningSceneWorld:
        """The seed's scene_world: support surface first, then the objects."""
        objs = ([self.support_surface] if self.support_surface is not None else []) + list(self.objects)
        return PlanningSceneWorld(collision_objects=objs)

    def detection(self, object_id: str) -> DetectedObject:
        for d in self.detections:
            if d.id == object_id:
                return d
        raise KeyError(f"no detected object '{object_id}'; detected: {[d.id for d in self.detections]}")

    def to_response(self) -> dict[str, Any]:
        """JSON-ready service response: success, message, target_object_id, support_surface_id,
        scene_world (interfaces_py PlanningSceneWorld dict), and a per-object summary."""
        return {
            "success": self.success,
            "message": self.message,
            "target_object_id": self.target_object_id,
            "support_surface_id": self.support_surface_id,
            "scene_world": self.scene_world().to_dict(),
            "objects": [
                {"id": d.id, "shape": d.shape, "dimensions": [round(v, 6) for v in d.dimensions],
                 "position": [round(float(v), 6) for v in d.center],
                 "yaw": round(d.yaw, 6), "points": d.point_count}
                for d in self.detections
            ],
            "timings_ms": {k: round(v, 3) for k, v in self.timings_ms.items()},
        }


def validate_target(target_shape: str | None, target_dimensions: Sequence[float] | None) -> tuple[str, list[float]]:
    """Normalise a target request; :class:`RequestError` names what is wrong with it."""
    if not isinstance(target_shape, str) or not target_shape.strip():
        raise RequestError(f"target_shape must be one of {sorted(TARGET_SHAPES)}, got {target_shape!r}")
    shape = target_shape.strip().lower()
    if shape not in TARGET_SHAPES:
        raise RequestError(f"unknown target_shape '{target_shape}'; expected one of {sorted(TARGET_SHAPES)}")
    names = TARGET_SHAPES[shape]
    try:
        dims = [float(v) for v in (target_dimensions if target_dimensions is not None else [])]
    except (TypeError, ValueError):
        raise RequestError(f"target_dimensions must be numbers, got {target_dimensions!r}") from None
    if len(dims) != len(names):
        raise RequestError(f"target_dimensions for a {shape} are [{', '.join(names)}] "
                           f"({len(names)} values), got {len(dims)}: {dims}")
    for name, value in zip(names, dims):
        if not math.isfinite(value) or value <= 0:
            raise RequestError(f"target_dimensions: {shape} {name} must be a positive number, got {value}")
    return shape, dims


def similarity(detection: DetectedObject, shape: str, dims: Sequence[float]) -> float:
    """The seed's target score: 0.7 for the right shape + 0.3 * dimension similarity (0 for a
    different shape). A box's x and y are compared in the better of the two orders."""
    if detection.shape != shape:
        return 0.0
    got = list(detection.dimensions)
    orders = [got] if shape == "cylinder" else [got, [got[1], got[0], got[2]]]
    best = 0.0
    for o in orders:
        rel = sum(abs(a - b) / b for a, b in zip(o, dims)) / len(dims)
        best = max(best, max(0.0, 1.0 - rel))
    return 0.7 + 0.3 * best


def identify_target(detections: Sequence[DetectedObject], shape: str, dims: Sequence[float]) -> tuple[str, float]:
    """(id, score) of the best match, or ("", 0.0) when no object has the shape."""
    best_id, best_score = "", 0.0
    for d in detections:
        score = similarity(d, shape, dims)
        if score > best_score:
            best_id, best_score = d.id, score
    return best_id, best_score


class SceneDetector:
    """Point cloud → planning scene objects (see module docstring).

    >>> detector = SceneDetector(PerceptionParameters())
    >>> result = detector.detect(points, colors, target_shape="cylinder", target_dimensions=[0.35, 0.0125])
    >>> result.success, result.target_object_id, [o.id for o in result.objects]
    """

    def __init__(self, params: PerceptionParameters | None = None) -> None:
        self.params = params if params is not None else PerceptionParameters()

    def get_planning_scene(self, points: Any, colors: Any = None, *, target_shape: str | None,
                           target_dimensions: Sequence[float] | None,
                           cloud_to_target: np.ndarray | None = None) -> DetectionResult:
        """The service call: like :meth:`detect` with a required target, but every problem with
        the input becomes ``success: false`` and a message instead of an exception."""
        try:
            return self.detect(points, colors, cloud_to_target=cloud_to_target, target_shape=target_shape,
                               target_dimensions=target_dimensions, require_target=True)
        except PerceptionError as err:
            return DetectionResult(False, str(err), frame_id=self.params.target_frame)

    def detect(self, points: Any, colors: Any = None, *, cloud_to_target: np.ndarray | None = None,
               target_shape: str | None = None, target_dimensions: Sequence[float] | None = None,
               require_target: bool = False) -> DetectionResult:
        """Run the pipeline on one cloud ((N, 3) or organised (H, W, 3), NaNs allowed).

        ``cloud_to_target`` maps cloud coordinates into ``params.target_frame`` (None: the cloud
        is already there). With a target request, success also requires a matching object."""
        p = self.params
        timings: dict[str, float] = {}
        t_start = t0 = time.perf_counter()

        def lap(name: str) -> None:
            nonlocal t0
            now = time.perf_counter()
            timings[name] = (now - t0) * 1e3
            t0 = now

        shape = dims = None
        if require_target or target_shape is not None or target_dimensions is not None:
            shape, dims = validate_target(target_shape, target_dimensions)
        crop = (p.crop_min, p.crop_max) if p.enable_cropping else None
        pts, cols = as_point_array(points, colors, transform=cloud_to_target, crop=crop)
        stats = {"points_cropped": int(pts.shape[0])}
        lap("prepare")
        result = DetectionResult(False, "", frame_id=p.target_frame, timings_ms=timings, stats=stats)
        if pts.shape[0] == 0:
            result.message = "no points inside the crop box"
            return self._finish(result, t_start)
        rng = np.random.default_rng(p.random_seed)
        # The support plane is searched on an even subsample: a table seen by a VGA camera has
        # far more points than a plane fit needs.
        stride = max(1, pts.shape[0] // _PLANE_SAMPLE)
        sample = pts[::stride]
        plane, candidates = find_support_plane(sample, p, rng)
        result.plane_candidates = candidates
        lap("support_plane")
        if plane is None:
            reasons = "; ".join(sorted({c.reason for c in candidates if c.reason})) or "no horizontal surface near z = 0"
            result.message = f"no support surface found ({len(candidates)} candidate(s): {reasons})"
            return self._finish(result, t_start)
        result.plane_normal, result.plane_offset = plane.normal, plane.offset
        result.support_surface = self._support_surface(plane)
        result.support_surface_id = result.support_surface.id

        signed = pts @ plane.normal + plane.offset
        near = np.abs(signed) < p.plane_segmentation_distance_threshold
        s_sample = signed[::stride][near[::stride]]
        raw_sigma = float(1.4826 * np.median(np.abs(s_sample - np.median(s_sample)))) if s_sample.size else 0.0
        # Five sigma: with ~10^5 table points a three-sigma cut lets hundreds of noise points
        # through, and those touching an object would widen it.
        above = signed > max(p.plane_segmentation_threshold, NOISE_SIGMAS * raw_sigma)
        grid = voxel_downsample(pts[above], p.voxel_leaf_size, None if cols is None else cols[above])
        obj_pts, obj_cols = grid.points, grid.colors
        stats["object_points"] = int(obj_pts.shape[0])
        lap("objects_cloud")
        if obj_pts.shape[0] == 0:
            result.message = "no objects above the support surface"
            return self._finish(result, t_start, shape)
        noise = self._measure_noise(plane, pts[near], obj_pts, raw_sigma)
        result.noise = noise
        lap("noise")
        feats = estimate_features(obj_pts, p.k_neighbors, p.rsd_radius, p.min_boundary_neighbors, p.max_plane_error)
        lap("features")
        clusters = euclidean_clusters(obj_pts, p.object_cluster_tolerance, p.min_cluster_size, p.max_cluster_size)
        stats["clusters"] = len(clusters)
        lap("clustering")
        fitter = PrimitiveFitter(p, plane.frame, noise)  # type: ignore[arg-type]
        fitted: list[tuple[FittedPrimitive, tuple[int, int, int] | None]] = []
        for members in clusters:
            sub = _subset_features(feats, members)
            prim = fitter.fit(obj_pts[members], sub, rng)
            if prim is None:
                continue
            color = None
            if obj_cols is not None:
                color = tuple(int(v) for v in np.median(obj_cols[members], axis=0))
            fitted.append((prim, color))  # type: ignore[arg-type]
        lap("fitting")
        counters = {"cylinder": 0, "box": 0}
        for prim, color in fitted:
            oid = f"{prim.shape}_{counters[prim.shape]}"
            counters[prim.shape] += 1
            det = DetectedObject(oid, prim.shape, [float(v) for v in prim.dimensions], prim.pose, prim.yaw,
                                 prim.point_count, prim.circle_votes, prim.line_votes, color, prim.faces)
            result.detections.append(det)
            result.objects.append(_collision_object(det, p.target_frame))
        if not result.objects:
            result.message = (f"no cylinder or box found above the support surface "
                              f"({len(clusters)} cluster(s) of at least {p.min_cluster_size} points)")
            return self._finish(result, t_start, shape)
        return self._finish(result, t_start, shape, dims)

    # ---------------------------------------------------------------------------------------
    def _finish(self, result: DetectionResult, t_start: float, shape: str | None = None,
                dims: list[float] | None = None) -> DetectionResult:
        if result.objects:
            if shape is not None and dims is not None:
                target, score = identify_target(result.detections, shape, dims)
                result.target_object_id = target
                if target:
                    result.success = True
                    result.message = (f"found {len(result.objects)} object(s) on '{result.support_surface_id}'; "
                                      f"target '{target}' (similarity {score:.2f})")
                else:
                    result.message = (f"found {len(result.objects)} object(s) "
                                      f"({', '.join(d.id for d in result.detections)}) but no {shape}")
            else:
                result.success = True
                result.message = f"found {len(result.objects)} object(s) on '{result.support_surface_id}'"
        result.timings_ms["total"] = (time.perf_counter() - t_start) * 1e3
        return result

    def _measure_noise(self, plane: PlaneCandidate, plane_pts: np.ndarray, obj_pts: np.ndarray,
                       raw_sigma: float) -> NoiseModel:
        """Depth noise as the object points show it: the support plane next to the objects,
        voxelised like the object points, gives the sigma of plane distances (robust, from the
        median absolute deviation) and the curvature a flat patch shows (90th percentile)."""
        p = self.params
        if plane_pts.shape[0] < 10:
            return NoiseModel(raw_sigma, 0.0)
        # A window of the plane around the objects' footprint centre (noise grows with depth,
        # so the plane where the objects stand is the relevant sample).
        centre = np.median(obj_pts, axis=0)
        half = max(2.5 * p.rsd_radius, 15.0 * max(p.voxel_leaf_size, 1e-3))
        offset = plane_pts - centre
        in_window = (np.abs(offset[:, 0]) <= half) & (np.abs(offset[:, 1]) <= half)
        if in_window.sum() < 50:
            return NoiseModel(raw_sigma, 0.0)
        grid = voxel_downsample(plane_pts[in_window], p.voxel_leaf_size)
        if grid.points.shape[0] < max(50, p.k_neighbors):
            return NoiseModel(raw_sigma, 0.0)
        # Plane distances of the voxel centroids: the noise left after voxel averaging.
        s = grid.points @ plane.normal + plane.offset
        sigma = float(1.4826 * np.median(np.abs(s - np.median(s))))
        feats = estimate_features(grid.points, p.k_neighbors, p.rsd_radius, p.min_boundary_neighbors,
                                  p.max_plane_error, with_rsd=False)
        flat = float(np.percentile(feats.curvature[feats.valid], 90)) if feats.valid.sum() >= 10 else 0.0
        return NoiseModel(sigma, flat)

    def _support_surface(self, plane: PlaneCandidate) -> CollisionObject:
        """A thin box whose top face is the detected plane, spanning the plane's inliers."""
        p = self.params
        lo, hi = plane.extent_min, plane.extent_max
        thickness = p.min_surface_thickness
        centre_uv = (lo + hi) / 2.0
        pose = plane.frame.pose(float(centre_uv[0]), float(centre_uv[1]), -thickness / 2.0)  # type: ignore[union-attr]
        size = [max(float(hi[0] - lo[0]), thickness), max(float(hi[1] - lo[1]), thickness), thickness]
        return CollisionObject.box(p.support_surface_name, size, pose, frame_id=p.target_frame)


def _subset_features(feats: PointFeatures, members: np.ndarray) -> PointFeatures:
    return PointFeatures(feats.normals[members], feats.curvature[members], feats.rsd_radius[members],
                         feats.valid[members], feats.neighbors[members])


def _collision_object(det: DetectedObject, frame_id: str) -> CollisionObject:
    prim = (SolidPrimitive.cylinder(*det.dimensions) if det.shape == "cylinder"
            else SolidPrimitive.box(*det.dimensions))
    return CollisionObject(id=det.id, frame_id=frame_id, pose=Pose.from_matrix(det.pose),
                           primitives=[prim], primitive_poses=[Pose()])
