"""PerceptionParameters: the seed's names and defaults, YAML loading, validation errors."""
from __future__ import annotations

import math

import pytest

from mycobot_planning.paths import config_file
from mycobot_planning.perception.errors import ParameterError, PerceptionError
from mycobot_planning.perception.params import UNUSED_SEED_PARAMETERS, PerceptionParameters

# The seed's get_planning_scene_server.yaml values for the parameters that have an effect here.
SEED_VALUES = {
    "point_cloud_topic": "/camera_head/depth/color/points", "target_frame": "base_link",
    "enable_cropping": True, "crop_min_x": 0.10, "crop_max_x": 1.1, "crop_min_y": 0.0, "crop_max_y": 0.90,
    "crop_min_z": -math.inf, "crop_max_z": math.inf, "z_tolerance": 0.03, "angle_tolerance": 0.9990482216,
    "plane_segmentation_threshold": 0.001, "min_cluster_size": 100, "max_cluster_size": 1000000,
    "cluster_tolerance": 0.02, "normal_estimation_k": 30, "w_inliers": 1.0, "w_size": 1.0, "w_distance": 1.0,
    "w_orientation": 1.0, "max_plane_segmentation_iterations": 1000, "plane_segmentation_distance_threshold": 0.01,
    "support_surface_name": "support_surface", "min_surface_thickness": 0.0001, "k_neighbors": 30,
    "max_plane_error": 0.01, "min_boundary_neighbors": 10, "rsd_radius": 0.02, "num_iterations": 5,
    "inlier_threshold": 85, "hough_angle_bins": 180, "hough_rho_bins": 1000, "hough_radius_bins": 25,
    "hough_center_bins": 50, "ransac_distance_threshold": 0.001, "ransac_max_iterations": 1000,
    "circle_min_cluster_size": 20, "circle_max_clusters": 2, "circle_height_tolerance": 0.025,
    "circle_curvature_threshold": 0.0015, "circle_radius_tolerance": 0.020, "circle_normal_angle_threshold": 0.2,
    "circle_cluster_tolerance": 0.025, "line_min_cluster_size": 20, "line_max_clusters": 1,
    "line_curvature_threshold": 0.0011, "line_normal_angle_threshold": 0.2, "line_cluster_tolerance": 0.025,
}

# The seed's file verbatim in content (names and values), including parameters without effect.
SEED_YAML = """
get_planning_scene_server:
  ros__parameters:
    use_sim_time: true
    point_cloud_topic: "/camera_head/depth/color/points"
    rgb_image_topic: "/camera_head/color/image_raw"
    target_frame: "base_link"
    enable_cropping: true
    crop_min_x: 0.10
    crop_max_x: 1.1
    crop_min_y: 0.00
    crop_max_y: 0.90
    crop_min_z: -inf
    crop_max_z: inf
    max_iterations: 100
    distance_threshold: 0.01
    z_tolerance: 0.03
    angle_tolerance: 0.9990482216
    plane_segmentation_threshold: 0.001
    min_cluster_size: 100
    max_cluster_size: 1000000
    cluster_tolerance: 0.02
    normal_estimation_k: 30
    w_inliers: 1.0
    w_size: 1.0
    w_distance: 1.0
    w_orientation: 1.0
    max_plane_segmentation_iterations: 1000
    plane_segmentation_distance_threshold: 0.01
    support_surface_name: "support_surface"
    min_surface_thickness: 0.0001
    k_neighbors: 30
    max_plane_error: 0.01
    max_iterations_normals: 100
    min_boundary_neighbors: 10
    rsd_radius: 0.02
    nearest_neighbors: 30
    smoothness_threshold: 20.0
    curvature_threshold: 0.2
    num_iterations: 5
    inlier_threshold: 85
    hough_angle_bins: 180
    hough_rho_bins: 1000
    hough_radius_bins: 25
    hough_center_bins: 50
    ransac_distance_threshold: 0.001
    ransac_max_iterations: 1000
    circle_min_cluster_size: 20
    circle_max_clusters: 2
    circle_height_tolerance: 0.025
    circle_curvature_threshold: 0.0015
    circle_radius_tolerance: 0.020
    circle_normal_angle_threshold: 0.2
    circle_cluster_tolerance: 0.025
    line_min_cluster_size: 20
    line_max_clusters: 1
    line_curvature_threshold: 0.0011
    line_normal_angle_threshold: 0.2
    line_cluster_tolerance: 0.025
    shape_fitting_max_iterations: 1000
    shape_fitting_distance_threshold: 0.01
    shape_fitting_min_radius: 0.01
    shape_fitting_max_radius: 0.1
    shape_fitting_normal_distance_weight: 0.1
    shape_fitting_normal_search_radius: 0.05
    output_directory: "/home/ubuntu/Downloads/"
    debug_pcd_filename: "debug_cloud.pcd"
"""


def test_defaults_are_the_seed_values():
    params = PerceptionParameters()
    for name, value in SEED_VALUES.items():
        assert getattr(params, name) == value, name


def test_every_parameter_has_a_descriptor_with_description_and_type():
    descriptors = PerceptionParameters.descriptors()
    assert set(descriptors) == set(PerceptionParameters.names())
    for name, d in descriptors.items():
        assert d["description"], name
        assert d["type"] in ("bool", "int", "float", "str"), name
        assert d["default"] == getattr(PerceptionParameters(), name)
    # Parameters the seed does not have say so.
    assert descriptors["voxel_leaf_size"]["ours"] and "not in the seed" in descriptors["voxel_leaf_size"]["description"]
    assert not descriptors["inlier_threshold"]["ours"]
    assert descriptors["angle_tolerance"]["min"] == 0.0 and descriptors["angle_tolerance"]["max"] == 1.0


def test_shipped_yaml_equals_the_defaults():
    assert PerceptionParameters.from_yaml(config_file("perception_server.yaml")) == PerceptionParameters()


def test_the_seed_yaml_loads_unchanged(tmp_path):
    path = tmp_path / "get_planning_scene_server.yaml"
    path.write_text(SEED_YAML)
    params = PerceptionParameters.from_yaml(path)
    assert params.crop_min_z == -math.inf and params.crop_max_z == math.inf  # 'inf' strings
    for name, value in SEED_VALUES.items():
        assert getattr(params, name) == value, name
    import yaml

    raw = yaml.safe_load(SEED_YAML)["get_planning_scene_server"]["ros__parameters"]
    unused = PerceptionParameters.unused_parameters(raw)
    assert "smoothness_threshold" in unused and "shape_fitting_max_radius" in unused
    assert set(unused) <= set(UNUSED_SEED_PARAMETERS)


def test_unknown_parameter_is_named():
    with pytest.raises(ParameterError, match=r"unknown perception parameter\(s\) \['inlier_treshold'\]"):
        PerceptionParameters.from_dict({"inlier_treshold": 10})
    assert PerceptionParameters.from_dict({"inlier_treshold": 10}, strict=False) == PerceptionParameters()
    with pytest.raises(ParameterError, match="unknown"):
        PerceptionParameters().replace(no_such_thing=1)


@pytest.mark.parametrize("changes, message", [
    ({"inlier_threshold": 0}, "'inlier_threshold' = 0 is below its minimum 1"),
    ({"angle_tolerance": 1.5}, "'angle_tolerance' = 1.5 is above its maximum 1.0"),
    ({"rsd_radius": float("nan")}, "'rsd_radius' is NaN"),
    ({"k_neighbors": 2.5}, "'k_neighbors' must be an integer"),
    ({"enable_cropping": "yes"}, "'enable_cropping' must be a bool"),
    ({"z_tolerance": "far"}, "'z_tolerance' must be a number"),
    ({"target_frame": ""}, "'target_frame' must not be empty"),
    ({"crop_min_x": 1.0, "crop_max_x": 0.5}, "crop box is empty along x"),
    ({"min_cluster_size": 10, "max_cluster_size": 5}, "min_cluster_size = 10 exceeds max_cluster_size = 5"),
    ({"w_inliers": 0.0, "w_size": 0.0, "w_distance": 0.0, "w_orientation": 0.0}, "weights"),
])
def test_bad_values_raise_naming_the_parameter(changes, message):
    with pytest.raises(ParameterError, match=message.replace("(", r"\(").replace(")", r"\)")):
        PerceptionParameters().replace(**changes)


def test_yaml_types_are_coerced_and_errors_are_perception_errors(tmp_path):
    params = PerceptionParameters.from_dict({"z_tolerance": 1, "k_neighbors": 20.0, "crop_max_z": ".inf"})
    assert isinstance(params.z_tolerance, float) and params.z_tolerance == 1.0
    assert params.k_neighbors == 20 and isinstance(params.k_neighbors, int)
    bad = tmp_path / "bad.yaml"
    bad.write_text("perception_server: [1, 2")
    with pytest.raises(PerceptionError, match="cannot read perception parameters"):
        PerceptionParameters.from_yaml(bad)
    other = tmp_path / "other.yaml"
    other.write_text("some_other_node:\n  ros__parameters: {a: 1}\n")
    with pytest.raises(ParameterError, match="no ros__parameters for node 'perception_server'"):
        PerceptionParameters.from_yaml(other)
