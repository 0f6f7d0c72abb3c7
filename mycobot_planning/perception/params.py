"""Parameters of the perception pipeline, named as in the seed's ``get_planning_scene_server.yaml``.

One dataclass, :class:`PerceptionParameters`, holds every setting. Names and defaults are the
seed's wherever the seed's parameter has an effect in this implementation; a few settings the
seed does not have (voxel leaf sizes, the object clustering distance, the random seed) are ours
and say so in their description. Each field carries a description and, where it has one, a
range, so the perception_server node can declare ROS parameters with descriptors from the same
table instead of repeating it.

The seed's YAML also carries parameters that have no effect here (its region-growing settings,
legacy shape-fitting settings, debug PCD output, ...). :data:`UNUSED_SEED_PARAMETERS` lists them
so that a seed YAML file loads unchanged; :meth:`PerceptionParameters.from_dict` reports any
other unknown name as an error, because a misspelt parameter silently ignored is a bug that
costs an afternoon.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from ..paths import read_yaml_file
from .errors import ParameterError

NODE_NAME = "perception_server"
"""Name of the node whose ``ros__parameters`` section :meth:`PerceptionParameters.from_yaml` reads
first (the seed's node was ``get_planning_scene_server``; both are accepted)."""

SEED_NODE_NAME = "get_planning_scene_server"

UNUSED_SEED_PARAMETERS: dict[str, str] = {
    "use_sim_time": "a ROS clock setting, handled by rclpy, not by the pipeline",
    "rgb_image_topic": "colours travel inside the PointCloud2 (rgb field); no image is needed",
    "max_iterations": "unused by the seed as well (the plane RANSAC uses max_plane_segmentation_iterations)",
    "distance_threshold": "unused by the seed as well (the plane RANSAC uses plane_segmentation_distance_threshold)",
    "max_iterations_normals": "normals use one robust re-weighting pass (max_plane_error) instead of MLESAC",
    "nearest_neighbors": "region growing is replaced by Euclidean clustering (object_cluster_tolerance): "
    "region growing with a smoothness test splits a box into its faces",
    "smoothness_threshold": "region growing is replaced by Euclidean clustering",
    "curvature_threshold": "region growing is replaced by Euclidean clustering",
    "shape_fitting_max_iterations": "legacy in the seed",
    "shape_fitting_distance_threshold": "legacy in the seed",
    "shape_fitting_min_radius": "legacy in the seed",
    "shape_fitting_max_radius": "legacy in the seed",
    "shape_fitting_normal_distance_weight": "legacy in the seed",
    "shape_fitting_normal_search_radius": "legacy in the seed",
    "output_directory": "debug PCD output is not written",
    "debug_pcd_filename": "debug PCD output is not written",
}


def _p(default: Any, description: str, low: float | None = None, high: float | None = None,
       *, ours: bool = False, group: str = "") -> Any:
    """A dataclass field with its ROS-parameter descriptor data in ``metadata``."""
    meta = {"description": description + (" (not in the seed)" if ours else ""),
            "min": low, "max": high, "ours": ours, "group": group}
    return field(default=default, metadata=meta)


@dataclass
class PerceptionParameters:
    """Every setting of the point cloud → planning scene pipeline (see the module docstring).

    Distances are metres, angles radians unless the name says otherwise. ``angle_tolerance``
    is a cosine, as in the seed (cos 2.5° = 0.9990482216).
    """

    # Topic and frame -------------------------------------------------------------------------
    point_cloud_topic: str = _p("/camera_head/depth/color/points",
                                "Topic of the incoming sensor_msgs/PointCloud2", group="io")
    target_frame: str = _p("base_link", "Frame the planning scene objects are expressed in", group="io")

    # Cropping ---------------------------------------------------------------------------------
    enable_cropping: bool = _p(True, "Crop the cloud (in target_frame) to the box below", group="crop")
    crop_min_x: float = _p(0.10, "Minimum x of the crop box", group="crop")
    crop_max_x: float = _p(1.1, "Maximum x of the crop box", group="crop")
    crop_min_y: float = _p(0.00, "Minimum y of the crop box", group="crop")
    crop_max_y: float = _p(0.90, "Maximum y of the crop box", group="crop")
    crop_min_z: float = _p(-math.inf, "Minimum z of the crop box", group="crop")
    crop_max_z: float = _p(math.inf, "Maximum z of the crop box", group="crop")

    # Support plane ----------------------------------------------------------------------------
    z_tolerance: float = _p(0.03, "A support plane's centre must be within this distance of z = 0",
                            0.0, 10.0, group="plane")
    angle_tolerance: float = _p(0.9990482216, "Cosine of the largest tilt of a support plane (and of a "
                                "point normal that counts as horizontal)", 0.0, 1.0, group="plane")
    plane_segmentation_threshold: float = _p(
        0.001, "Points within this distance of the support plane belong to it; points further above "
        "it are object points (raised automatically to 5 sigma of the measured plane noise)",
        0.0, 1.0, group="plane")
    min_cluster_size: int = _p(100, "Minimum points in a support-surface candidate or an object cluster",
                               1, 100_000_000, group="plane")
    max_cluster_size: int = _p(1_000_000, "Maximum points in a support-surface candidate or an object cluster",
                               1, 1_000_000_000, group="plane")
    cluster_tolerance: float = _p(0.02, "Euclidean clustering distance for support-surface candidates",
                                  1e-4, 1.0, group="plane")
    normal_estimation_k: int = _p(30, "Neighbours used for normals in the support-plane search", 3, 500,
                                  group="plane")
    w_inliers: float = _p(1.0, "Weight of the inlier count in the support-plane score", 0.0, 1000.0, group="plane")
    w_size: float = _p(1.0, "Weight of the plane area in the support-plane score", 0.0, 1000.0, group="plane")
    w_distance: float = _p(1.0, "Weight of the closeness to z = 0 in the support-plane score", 0.0, 1000.0,
                           group="plane")
    w_orientation: float = _p(1.0, "Weight of the horizontality in the support-plane score", 0.0, 1000.0,
                              group="plane")
    max_plane_segmentation_iterations: int = _p(1000, "Maximum RANSAC iterations per support-plane candidate",
                                                1, 1_000_000, group="plane")
    plane_segmentation_distance_threshold: float = _p(0.01, "RANSAC inlier distance for support-plane candidates",
                                                      1e-5, 1.0, group="plane")
    plane_voxel_leaf_size: float = _p(0.015, "Voxel leaf size of the cloud searched for the support plane",
                                      0.0, 1.0, ours=True, group="plane")

    # Support surface object ---------------------------------------------------------------------
    support_surface_name: str = _p("support_surface", "Id of the support surface collision object",
                                   group="surface")
    min_surface_thickness: float = _p(0.0001, "Thickness of the support surface box (its top face lies on "
                                      "the plane)", 1e-6, 1.0, group="surface")

    # Normals, curvature, RSD ------------------------------------------------------------------
    k_neighbors: int = _p(30, "Neighbours used for object normals, curvature and RSD", 3, 500, group="features")
    max_plane_error: float = _p(0.01, "Scale of the robust re-weighting of a point's local plane fit",
                                1e-6, 1.0, group="features")
    min_boundary_neighbors: int = _p(10, "Points with fewer neighbours within rsd_radius get no features "
                                     "(isolated or boundary noise)", 3, 500, group="features")
    rsd_radius: float = _p(0.02, "Neighbourhood radius of the features and of the RSD radius estimate",
                           1e-4, 1.0, group="features")
    voxel_leaf_size: float = _p(0.003, "Voxel leaf size of the object points before feature estimation",
                                0.0, 1.0, ours=True, group="features")
    object_cluster_tolerance: float = _p(0.01, "Euclidean clustering distance between object points",
                                         1e-4, 1.0, ours=True, group="features")

    # Object segmentation -------------------------------------------------------------------------
    num_iterations: int = _p(5, "Rounds of RANSAC model extraction per cluster (each round votes)",
                             1, 1000, group="objects")
    inlier_threshold: int = _p(85, "Minimum filtered inliers for a circle or line model to vote",
                               1, 100_000_000, group="objects")
    hough_angle_bins: int = _p(180, "Angle bins of the line Hough space (over 180 degrees)", 4, 100_000,
                               group="objects")
    hough_rho_bins: int = _p(1000, "Distance bins of the line Hough space", 2, 1_000_000, group="objects")
    hough_radius_bins: int = _p(25, "Radius bins of the circle Hough space", 2, 100_000, group="objects")
    hough_center_bins: int = _p(50, "Centre bins (per axis) of the circle Hough space", 2, 100_000,
                                group="objects")
    ransac_distance_threshold: float = _p(0.001, "RANSAC inlier distance of the 2D line and circle models "
                                          "(raised automatically to 2 sigma of the measured noise)",
                                          1e-6, 1.0, group="objects")
    ransac_max_iterations: int = _p(1000, "Maximum RANSAC iterations per model", 1, 1_000_000, group="objects")
    line_rho_threshold: float = _p(0.01, "Lines of similar direction whose rho (measured from the cluster "
                                   "centre) differ by less than this are the same wall (for the wall count)",
                                   0.0, 10.0, ours=True, group="objects")
    line_theta_threshold: float = _p(0.0524, "Lines whose directions differ by less than this (modulo 90 "
                                     "degrees) vote for the same box yaw", 0.0, math.pi / 4, ours=True,
                                     group="objects")

    # Circle inlier filtering -----------------------------------------------------------------
    circle_min_cluster_size: int = _p(20, "Minimum points in a cluster of circle inliers", 1, 100_000_000,
                                      group="circle")
    circle_max_clusters: int = _p(2, "Maximum clusters of circle inliers (two arcs of one cylinder)", 1, 1000,
                                  group="circle")
    circle_height_tolerance: float = _p(0.025, "Largest top-height difference between two circle clusters",
                                        0.0, 10.0, group="circle")
    circle_curvature_threshold: float = _p(0.0015, "Circle inliers must have a curvature above this",
                                           0.0, 1.0 / 3.0, group="circle")
    circle_radius_tolerance: float = _p(0.020, "Largest difference between a point's RSD radius and the "
                                        "circle radius", 0.0, 10.0, group="circle")
    circle_normal_angle_threshold: float = _p(0.2, "Largest angle between a point's horizontal normal and "
                                              "the circle's radial direction", 0.0, math.pi, group="circle")
    circle_cluster_tolerance: float = _p(0.025, "Euclidean clustering distance of circle inliers",
                                         1e-5, 10.0, group="circle")

    # Line inlier filtering -------------------------------------------------------------------
    line_min_cluster_size: int = _p(20, "Minimum points in a cluster of line inliers", 1, 100_000_000,
                                    group="line")
    line_max_clusters: int = _p(1, "Maximum clusters of line inliers", 1, 1000, group="line")
    line_curvature_threshold: float = _p(0.0011, "Line inliers must have a curvature below this "
                                         "(raised automatically above the measured noise floor)",
                                         0.0, 1.0 / 3.0, group="line")
    line_normal_angle_threshold: float = _p(0.2, "Largest angle between a point's horizontal normal and the "
                                            "line's normal", 0.0, math.pi, group="line")
    line_cluster_tolerance: float = _p(0.025, "Euclidean clustering distance of line inliers", 1e-5, 10.0,
                                       group="line")

    # Reproducibility ---------------------------------------------------------------------------
    random_seed: int = _p(0, "Seed of the RANSAC random generator (results are reproducible per cloud)",
                          0, 2**31 - 1, ours=True, group="objects")

    def __post_init__(self) -> None:
        self.validate()

    # ------------------------------------------------------------------------------------------
    def validate(self) -> None:
        """Check types and ranges of every field; raise :class:`ParameterError` naming the first
        bad one. Called on construction and by :meth:`replace`, so an instance is always valid."""
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            setattr(self, f.name, _coerce(f.name, f.type, value))
            value = getattr(self, f.name)
            low, high = f.metadata.get("min"), f.metadata.get("max")
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                if isinstance(value, float) and math.isnan(value):
                    raise ParameterError(f"parameter '{f.name}' is NaN")
                if low is not None and value < low:
                    raise ParameterError(f"parameter '{f.name}' = {value} is below its minimum {low}")
                if high is not None and value > high:
                    raise ParameterError(f"parameter '{f.name}' = {value} is above its maximum {high}")
        for axis in "xyz":
            lo, hi = getattr(self, f"crop_min_{axis}"), getattr(self, f"crop_max_{axis}")
            if lo >= hi:
                raise ParameterError(f"crop box is empty along {axis}: crop_min_{axis} = {lo} >= crop_max_{axis} = {hi}")
        if self.min_cluster_size > self.max_cluster_size:
            raise ParameterError(f"min_cluster_size = {self.min_cluster_size} exceeds "
                                 f"max_cluster_size = {self.max_cluster_size}")
        if self.w_inliers + self.w_size + self.w_distance + self.w_orientation <= 0:
            raise ParameterError("the support-plane score weights w_inliers, w_size, w_distance, "
                                 "w_orientation are all zero")
        if not self.target_frame:
            raise ParameterError("parameter 'target_frame' must not be empty")
        if not self.support_surface_name:
            raise ParameterError("parameter 'support_surface_name' must not be empty")

    def replace(self, **changes: Any) -> PerceptionParameters:
        """A validated copy with some fields changed (unknown names raise ParameterError)."""
        unknown = sorted(set(changes) - set(self.names()))
        if unknown:
            raise ParameterError(f"unknown perception parameter(s) {unknown}")
        return dataclasses.replace(self, **changes)

    @classmethod
    def names(cls) -> list[str]:
        return [f.name for f in dataclasses.fields(cls)]

    @classmethod
    def descriptors(cls) -> dict[str, dict[str, Any]]:
        """name -> {default, type ('bool'|'int'|'float'|'str'), description, min, max, ours}: what a
        node needs to declare each ROS parameter with a descriptor and a range."""
        out: dict[str, dict[str, Any]] = {}
        for f in dataclasses.fields(cls):
            out[f.name] = {
                "default": f.default,
                "type": _type_name(f.type),
                "description": f.metadata["description"],
                "min": f.metadata["min"],
                "max": f.metadata["max"],
                "ours": f.metadata["ours"],
            }
        return out

    def to_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls, values: Mapping[str, Any], *, strict: bool = True) -> PerceptionParameters:
        """Parameters from a flat mapping of seed-style names (missing names keep their defaults).

        Names in :data:`UNUSED_SEED_PARAMETERS` are accepted and ignored. Any other unknown name
        raises :class:`ParameterError` when ``strict`` (the default)."""
        if not isinstance(values, Mapping):
            raise ParameterError(f"perception parameters must be a mapping, got {type(values).__name__}")
        known = set(cls.names())
        unknown = sorted(k for k in values if k not in known and k not in UNUSED_SEED_PARAMETERS)
        if unknown and strict:
            raise ParameterError(f"unknown perception parameter(s) {unknown}; known: {sorted(known)}")
        return cls(**{k: v for k, v in values.items() if k in known})

    @classmethod
    def from_yaml(cls, path: str | Path, *, strict: bool = True) -> PerceptionParameters:
        """Parameters from a ROS 2 parameter file (``<node>: ros__parameters: {...}``, with node
        ``perception_server``, ``get_planning_scene_server`` or ``/**``) or from a flat mapping."""
        path = Path(path)
        data = read_yaml_file(path, ParameterError, f"perception parameters from {path}")
        return cls.from_dict(_ros_parameters_section(data, str(path)), strict=strict)

    @classmethod
    def unused_parameters(cls, values: Mapping[str, Any]) -> list[str]:
        """The names in ``values`` that are seed parameters without effect here (for a warning)."""
        return sorted(k for k in values if k in UNUSED_SEED_PARAMETERS)

    # Derived values used by the pipeline -------------------------------------------------------
    @property
    def crop_min(self) -> tuple[float, float, float]:
        return (self.crop_min_x, self.crop_min_y, self.crop_min_z)

    @property
    def crop_max(self) -> tuple[float, float, float]:
        return (self.crop_max_x, self.crop_max_y, self.crop_max_z)


def _ros_parameters_section(data: Any, where: str) -> Mapping[str, Any]:
    if data is None:
        return {}
    if not isinstance(data, Mapping):
        raise ParameterError(f"{where}: expected a mapping at the top level")
    for node in (NODE_NAME, SEED_NODE_NAME, "/**"):
        section = data.get(node)
        if isinstance(section, Mapping) and isinstance(section.get("ros__parameters"), Mapping):
            return section["ros__parameters"]
    if "ros__parameters" in data and isinstance(data["ros__parameters"], Mapping):
        return data["ros__parameters"]
    nested = [k for k, v in data.items() if isinstance(v, Mapping) and "ros__parameters" in v]
    if nested:
        raise ParameterError(f"{where}: no ros__parameters for node '{NODE_NAME}' "
                             f"(found nodes {nested})")
    return data


def _type_name(tp: Any) -> str:
    tp = tp if isinstance(tp, str) else getattr(tp, "__name__", str(tp))
    return {"bool": "bool", "int": "int", "float": "float", "str": "str"}[tp]


def _coerce(name: str, tp: Any, value: Any) -> Any:
    """Accept what YAML and ROS hand us (ints for floats, 'inf' strings) and nothing else."""
    kind = _type_name(tp)
    if kind == "bool":
        if isinstance(value, bool):
            return value
        raise ParameterError(f"parameter '{name}' must be a bool, got {value!r}")
    if kind == "str":
        if isinstance(value, str):
            return value
        raise ParameterError(f"parameter '{name}' must be a string, got {value!r}")
    if isinstance(value, bool):
        raise ParameterError(f"parameter '{name}' must be a number, got {value!r}")
    if kind == "int":
        if isinstance(value, int):
            return value
        if isinstance(value, float) and value.is_integer():
            return int(value)
        raise ParameterError(f"parameter '{name}' must be an integer, got {value!r}")
    if isinstance(value, (int, float)):
        return float(value)
    if isinstance(value, str) and value.strip().lower() in ("inf", "+inf", ".inf", "-inf", "-.inf"):
        return -math.inf if value.strip().startswith("-") else math.inf
    raise ParameterError(f"parameter '{name}' must be a number, got {value!r}")
