"""The simulated depth camera: geometry of the returns, visibility, noise model, dropouts."""
from __future__ import annotations

import numpy as np
import pytest

from mycobot_planning.paths import config_file
from mycobot_planning.perception.depth_camera import (
    CameraIntrinsics, DepthCamera, DepthCameraConfig, load_camera_scene, look_at, optical_pose_from_link,
)
from mycobot_planning.perception.errors import PerceptionError
from mycobot_planning.perception.scene_model import GroundTruthScene, pose_from_vector

EYE = (0.35, -0.2, 0.45)
TARGET = (0.35, 0.3, 0.0)


def scene() -> GroundTruthScene:
    return GroundTruthScene.tabletop(cylinders=[(0.30, 0.25, 0.15, 0.03)],
                                     boxes=[(0.42, 0.35, 0.3, (0.05, 0.07, 0.09))])


@pytest.fixture(scope="module")
def exact():
    cam = DepthCamera(DepthCameraConfig(pose=look_at(EYE, TARGET)).noiseless())
    return cam, cam.capture(scene(), rng=0)


def test_organised_output_shapes_and_nan_for_no_return(exact):
    cam, cloud = exact
    assert cloud.points.shape == (480, 640, 3) and cloud.points.dtype == np.float32
    assert cloud.colors.shape == (480, 640, 3) and cloud.colors.dtype == np.uint8
    no_return = cloud.labels == -1
    assert no_return.any() and cloud.valid.any()
    assert np.isnan(cloud.points[no_return]).all()
    assert np.isfinite(cloud.points[cloud.valid]).all()
    pts, cols = cloud.unorganized()
    assert pts.shape == (int(cloud.valid.sum()), 3) and cols.shape == pts.shape


def test_noiseless_returns_lie_on_the_surfaces(exact):
    _, cloud = exact
    sc = scene()
    table, cyl, box = sc.shapes()
    top = cloud.points[cloud.labels == 0].astype(float)
    # the table is seen from above: every table return is on its top face or its sides
    assert np.all(top[:, 2] <= 1e-5) and np.all(top[:, 2] >= -0.03 - 1e-5)
    pc = cloud.points[cloud.labels == 1].astype(float) - cyl.pose[:3, 3]
    radial = np.hypot(pc[:, 0], pc[:, 1])
    on_side = np.abs(radial - cyl.radius) < 1e-4
    on_cap = np.abs(pc[:, 2] - cyl.height / 2) < 1e-5
    assert np.all(on_side | on_cap) and on_cap.any() and on_side.any()
    local = (cloud.points[cloud.labels == 2].astype(float) - box.pose[:3, 3]) @ box.pose[:3, :3]
    on_face = np.isclose(np.abs(local), box.size / 2, atol=1e-4).any(axis=1)
    assert on_face.all() and np.all(np.abs(local) <= box.size / 2 + 1e-4)


def test_only_surfaces_facing_the_camera_return(exact):
    _, cloud = exact
    cyl = scene().cylinders[0]
    pc = cloud.points[cloud.labels == 1].astype(float)
    side = (np.abs(np.hypot(*(pc[:, :2] - cyl.pose[:2, 3]).T) - cyl.radius) < 1e-4) \
        & (pc[:, 2] < cyl.pose[2, 3] + cyl.height / 2 - 1e-5)  # the lid's rim is seen all round
    outward = pc[side, :2] - cyl.pose[:2, 3]
    to_eye = np.array(EYE[:2]) - pc[side, :2]
    assert np.all(np.einsum("ij,ij->i", outward, to_eye) > 0)  # the far half is never seen
    box = scene().boxes[0]
    local = (cloud.points[cloud.labels == 2].astype(float) - box.pose[:3, 3]) @ box.pose[:3, :3]
    eye_local = (np.array(EYE) - box.pose[:3, 3]) @ box.pose[:3, :3]
    # a face is visible only if the eye is on its outer side
    for axis in range(3):
        for sign in (-1, 1):
            others = [a for a in range(3) if a != axis]
            on = np.isclose(local[:, axis], sign * box.size[axis] / 2, atol=1e-4) \
                & np.all(np.abs(local[:, others]) < box.size[others] / 2 - 1e-4, axis=1)  # not on an edge
            if on.any():
                assert sign * eye_local[axis] > box.size[axis] / 2


def test_occlusion_hides_the_object_behind():
    eye = (0.3, -0.3, 0.12)
    front = GroundTruthScene.tabletop(boxes=[(0.3, 0.1, 0.0, (0.2, 0.04, 0.3))])
    both = GroundTruthScene.tabletop(cylinders=[(0.3, 0.3, 0.08, 0.02)], boxes=[(0.3, 0.1, 0.0, (0.2, 0.04, 0.3))])
    alone = GroundTruthScene.tabletop(cylinders=[(0.3, 0.3, 0.08, 0.02)])
    cam = DepthCamera(DepthCameraConfig(pose=look_at(eye, (0.3, 0.3, 0.04))).noiseless())
    assert (cam.capture(alone).labels == 1).sum() > 500
    labels = cam.capture(both).labels
    assert (labels == 1).sum() == 0  # the wall in front hides the cylinder completely
    assert (labels == 2).sum() > (cam.capture(front).labels == 1).sum() * 0.99


def test_depth_noise_grows_with_depth_and_dropouts_happen():
    plane = GroundTruthScene(ground_plane_z=0.0)
    cfg = DepthCameraConfig(pose=look_at((0.0, 0.0, 1.0), (0.0, 0.0, 0.0), up=(0, 1, 0)), depth_noise_stddev=0.0,
                            depth_noise_quadratic=0.002, dropout_probability=0.1, far=5.0)
    near_cloud = DepthCamera(cfg).capture(plane, rng=1)
    cfg_far = DepthCameraConfig(pose=look_at((0.0, 0.0, 2.0), (0.0, 0.0, 0.0), up=(0, 1, 0)), depth_noise_stddev=0.0,
                                depth_noise_quadratic=0.002, dropout_probability=0.1, far=5.0)
    far_cloud = DepthCamera(cfg_far).capture(plane, rng=1)
    sd_near = np.nanstd(near_cloud.points[..., 2])
    sd_far = np.nanstd(far_cloud.points[..., 2])
    # sigma = 0.002 z^2 along the ray: about 2 mm at 1 m and 8 mm at 2 m (frontal plane)
    assert sd_near == pytest.approx(0.002, rel=0.15)
    assert sd_far == pytest.approx(0.008, rel=0.15)
    dropped = 1.0 - near_cloud.valid.mean()
    assert dropped == pytest.approx(0.1, abs=0.01)
    again = DepthCamera(cfg).capture(plane, rng=1)
    np.testing.assert_array_equal(again.points, near_cloud.points)  # seeded: reproducible


def test_grazing_returns_are_dropped():
    plane = GroundTruthScene(ground_plane_z=0.0)
    cfg = DepthCameraConfig(pose=look_at((0.0, 0.0, 0.3), (3.0, 0.0, 0.0)), far=20.0,
                            max_incidence_angle=np.deg2rad(80.0)).noiseless()
    cfg.max_incidence_angle = np.deg2rad(80.0)
    cloud = DepthCamera(cfg).capture(plane)
    pts = cloud.points[cloud.valid].astype(float)
    rays = pts - np.array([0.0, 0.0, 0.3])
    cos_inc = np.abs(rays[:, 2]) / np.linalg.norm(rays, axis=1)
    assert cos_inc.min() >= np.cos(np.deg2rad(80.0)) - 1e-6


def test_camera_frame_output_is_the_world_output_seen_from_the_camera(exact):
    cam, world = exact
    in_cam = cam.capture(scene(), rng=0, frame="camera")
    assert in_cam.frame_id == "camera_head_depth_optical_frame" and world.frame_id == "base_link"
    T = cam.config.pose
    back = in_cam.points[in_cam.valid].astype(float) @ T[:3, :3].T + T[:3, 3]
    np.testing.assert_allclose(back, world.points[world.valid], atol=1e-5)
    assert np.all(in_cam.points[in_cam.valid][:, 2] > 0)  # z forward


def test_colours_follow_the_shapes(exact):
    _, cloud = exact
    red = cloud.colors[cloud.labels == 1].astype(int)
    assert np.all(red[:, 0] > red[:, 2])  # cylinders are red, boxes blue
    blue = cloud.colors[cloud.labels == 2].astype(int)
    assert np.all(blue[:, 2] > blue[:, 0])


def test_look_at_and_link_pose_conventions():
    T = look_at((0, 0, 1), (1, 0, 1))
    np.testing.assert_allclose(T[:3, 2], [1, 0, 0], atol=1e-12)   # optical z forward
    np.testing.assert_allclose(T[:3, 1], [0, 0, -1], atol=1e-12)  # optical y down
    link = pose_from_vector([0, 0, 1, 0, 0, 0])  # a camera link looking along +x
    np.testing.assert_allclose(optical_pose_from_link(link)[:3, :3], T[:3, :3], atol=1e-12)
    intr = CameraIntrinsics.from_fov(640, 480, np.pi / 2)
    assert intr.fx == pytest.approx(320.0) and intr.cx == pytest.approx(319.5)


def test_default_camera_scene_yaml_sees_every_object_whole():
    cfg, sc = load_camera_scene(config_file("camera_scene.yaml"))
    assert (cfg.intrinsics.width, cfg.intrinsics.height) == (640, 480)
    cloud = DepthCamera(cfg.noiseless()).capture(sc)
    for index, shape in enumerate(sc.shapes()[1:], start=1):
        rows, cols = np.nonzero(cloud.labels == index)
        assert rows.size > 500, shape.id
        assert rows.min() > 0 and cols.min() > 0 and cols.max() < 639 and rows.max() < 479, shape.id
    tops = {s.id: s.pose[2, 3] + (s.height / 2 if hasattr(s, "height") else s.size[2] / 2) for s in sc.shapes()[1:]}
    for index, shape in enumerate(sc.shapes()[1:], start=1):
        assert cloud.points[cloud.labels == index][:, 2].max() == pytest.approx(tops[shape.id], abs=1e-4)


@pytest.mark.parametrize("data, message", [
    ({"camera": {"width": 640}, "scene": {}}, "give either link_pose or position \\+ look_at"),
    ({"camera": {"position": [0, 0, 1], "look_at": [0, 0, 1]}, "scene": {}}, "eye and target coincide"),
    ({"camera": {"position": [0, 0, 1], "look_at": [1, 0, 0], "fov": 1}, "scene": {}}, "unknown keys \\['fov'\\]"),
    ({"camera": {"position": [0, 0, 1], "look_at": [1, 0, 0]}, "scene": {"boxes": [{"id": "b", "size": [1, 1],
      "pose": [0, 0, 0, 0, 0, 0]}]}}, "box 'b': size must be three positive numbers"),
    ({"camera": {"position": [0, 0, 1], "look_at": [1, 0, 0]}, "scene": {"cylinders": [{"id": "c", "height": 1,
      "radius": 0.1, "pose": [0, 0, 0]}]}}, "cylinder 'c' pose: expected .*six finite numbers"),
    ({"camera": {"position": [0, 0, 1], "look_at": [1, 0, 0]}}, "no 'scene' section"),
    ({"camera": {"position": [0, 0, 1], "look_at": [1, 0, 0], "near": 2, "far": 1}, "scene": {}}, "near < far"),
])
def test_bad_camera_scene_files_are_reported(tmp_path, data, message):
    import yaml

    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(PerceptionError, match=message):
        load_camera_scene(path)


def test_duplicate_ids_are_rejected():
    with pytest.raises(PerceptionError, match="duplicate object ids \\['x'\\]"):
        GroundTruthScene.from_dict({"cylinders": [{"id": "x", "height": 1, "radius": 1, "pose": [0] * 6}],
                                    "boxes": [{"id": "x", "size": [1, 1, 1], "pose": [0] * 6}]})


def test_scene_from_flat_parameters_stands_objects_on_the_table():
    sc = GroundTruthScene.from_flat_parameters([0.5, 0.5, 0.04], [0.4, 0.3, 0.1, 0, 0, 0],
                                               cylinders=[0.3, 0.2, 0.1, 0.02], boxes=[0.5, 0.4, 0.3, 0.04, 0.05, 0.06])
    assert sc.support_top_z == pytest.approx(0.12)
    assert sc.cylinders[0].pose[2, 3] == pytest.approx(0.12 + 0.05)
    assert sc.boxes[0].pose[2, 3] == pytest.approx(0.12 + 0.03)
    assert [o.id for o in sc.collision_objects()] == ["table", "cylinder_gt_0", "box_gt_0"]
    with pytest.raises(PerceptionError, match="groups of 4 numbers"):
        GroundTruthScene.from_flat_parameters([], [], cylinders=[0.3, 0.2, 0.1])
    with pytest.raises(PerceptionError, match="groups of 6 numbers"):
        GroundTruthScene.from_flat_parameters([], [], boxes=[0.3])
    no_table = GroundTruthScene.from_flat_parameters([], [], cylinders=[0.3, 0.2, 0.1, 0.02], ground_plane_z=0.0)
    assert no_table.support_surface is None and no_table.cylinders[0].pose[2, 3] == pytest.approx(0.05)
