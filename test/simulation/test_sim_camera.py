"""The simulated depth camera: rendered headless (EGL, Mesa's software rasteriser when there is
no GPU) at the seeds' camera_head pose and intrinsics, turned into the point cloud perception
expects; our perception pipeline finds the cylinder where the physics has it, and sees it
fallen once it is knocked over."""
from __future__ import annotations

import numpy as np
import pytest

from mycobot_planning.simulation import MujocoSimulator, tilt_deg
from mycobot_planning.paths import config_file
from mycobot_planning.perception import PerceptionParameters, SceneDetector, load_camera_scene

#: Perception parameters for the twin's world: the seed's tiny table (10 x 20 cm, top at z = 0)
#: stands on a floor 3 cm lower. The default z_tolerance (3 cm) would take the floor for the
#: support surface, and the table top is too small for the default plane search (100 clusters
#: of 15 mm voxels); docs/simulation.md, section "Depth camera".
TWIN_PERCEPTION = PerceptionParameters(z_tolerance=0.01, min_cluster_size=30, plane_voxel_leaf_size=0.008)


def detect(frame):
    colors = np.full(frame.points.shape, 128, dtype=np.uint8)
    return SceneDetector(TWIN_PERCEPTION).get_planning_scene(frame.points, colors, target_shape="cylinder",
                                                             target_dimensions=[0.35, 0.0125])


@pytest.fixture
def camera_sim(mycobot):
    with MujocoSimulator(mycobot) as simulator:
        yield simulator


def test_the_camera_is_the_seeds_camera_head(camera_sim):
    config, _ = load_camera_scene(config_file("camera_scene.yaml"))
    frame = camera_sim.capture()
    assert frame.frame_id == "world"
    assert frame.points.shape == (config.intrinsics.height, config.intrinsics.width, 3)
    np.testing.assert_allclose(frame.camera_pose, config.pose)
    # the table top (z = 0) seen at the right depth everywhere: pose and intrinsics agree
    cloud = frame.cloud()
    top = cloud[(np.abs(cloud[:, 0] - 0.22) < 0.04) & (np.abs(cloud[:, 1] - 0.05) < 0.025) & (cloud[:, 2] > -0.01)]
    assert top.shape[0] > 500
    assert abs(float(np.median(top[:, 2]))) < 0.0005


def test_the_cloud_in_the_optical_frame_is_the_same_cloud(mycobot):
    with MujocoSimulator(mycobot, camera_frame="camera", camera_noise=False) as optical, \
            MujocoSimulator(mycobot, camera_noise=False) as world:
        a, b = optical.capture(), world.capture()
    assert a.frame_id == "camera_head_depth_optical_frame"
    pose = a.camera_pose
    moved = a.points.reshape(-1, 3) @ pose[:3, :3].T + pose[:3, 3]
    valid = ~np.isnan(moved[:, 0])
    np.testing.assert_allclose(moved[valid], b.points.reshape(-1, 3)[valid], atol=1e-5)


def test_perception_finds_the_cylinder_where_the_physics_has_it(camera_sim):
    camera_sim.advance(0.5)  # the cylinder settles on the table
    truth = camera_sim.object_pose("object")[:3, 3]
    result = detect(camera_sim.capture())
    assert result.success, result.message
    cylinder = next(d for d in result.detections if d.id == result.target_object_id)
    assert cylinder.shape == "cylinder"
    assert np.linalg.norm(cylinder.center - truth) < 0.005
    assert cylinder.dimensions[0] == pytest.approx(0.35, abs=0.005)


def test_a_knocked_over_cylinder_is_seen_fallen(camera_sim):
    camera_sim.set_object_state("object", angular_velocity=[3.0, 0.0, 0.0])
    camera_sim.advance(2.0)
    pose = camera_sim.object_pose("object")
    assert tilt_deg(pose) > 60.0
    cloud = camera_sim.capture().cloud()
    axis, centre = pose[:3, 2], pose[:3, 3]
    along = (cloud - centre) @ axis
    radial = np.linalg.norm(cloud - centre - np.outer(along, axis), axis=1)
    on_cylinder = (np.abs(along) <= 0.175) & (radial <= 0.0125 + 0.003)
    assert on_cylinder.sum() > 500  # the camera sees it where it lies
    where_it_stood = np.linalg.norm(cloud[:, :2] - [0.22, 0.12], axis=1) < 0.03
    assert not np.any(where_it_stood & (cloud[:, 2] > 0.05))  # nothing stands there any more
    result = detect(camera_sim.capture())
    assert not any(d.shape == "cylinder" and d.dimensions[0] > 0.3 for d in result.detections)


def test_frames_come_at_the_camera_rate_while_stepping(camera_sim):
    stamps = []
    camera_sim.on_frame(lambda frame: stamps.append(frame.stamp))
    camera_sim.set_camera_rate(10.0)
    camera_sim.advance(1.0)
    camera_sim.wait_for_frame()
    assert stamps == pytest.approx([0.1 * k for k in range(10)], abs=1e-6)
    assert camera_sim.status().camera_frames == 10
    assert camera_sim.latest_frame.stamp == pytest.approx(0.9)
