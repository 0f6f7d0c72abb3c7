"""Perception benchmark: the full point cloud → planning scene pipeline on 640x480 frames.

Frames come from the camera simulator over ``config/camera_scene.yaml`` (the seeds' table,
cylinder and box, seen from the seed's camera_head position), each with fresh depth noise and
dropouts, packed into the PointCloud2 byte layout and unpacked again as the perception_server
does. ``latency_ms`` times :meth:`SceneDetector.get_planning_scene` on the organised cloud
(validation, crop, plane, features, clustering, fitting, target choice); ``unpack_ms`` times
reading the PointCloud2 bytes. Accuracy against the ground truth is reported alongside, so a
faster pipeline that got worse shows it.

Summary keys (a contract, keep them stable): ``latency_ms`` (median wall time), ``objects_found``
(the smallest number of objects found in any frame), plus p90, ``cpu_ms`` (median process CPU
time, all threads: less sensitive than wall time to other load on the machine), unpack time,
worst errors against the ground truth, the spread of per-repeat medians and the machine.

Register in scenarios.SCENARIOS as "perception".
"""
from __future__ import annotations

import math
import time

import numpy as np

from .common import emit, machine, spread, stats, timed

RUNS = 10


def _errors(result, scene) -> dict[str, float]:  # type: ignore[no-untyped-def]
    """Worst centre / size / yaw errors of the detections matched to the ground truth."""
    out = {"cylinder_center_mm": 0.0, "cylinder_radius_mm": 0.0, "cylinder_height_mm": 0.0,
           "box_center_mm": 0.0, "box_yaw_deg": 0.0, "missed": 0}
    for gt in list(scene.cylinders) + list(scene.boxes):
        shape = "cylinder" if gt in scene.cylinders else "box"
        candidates = [d for d in result.detections if d.shape == shape]
        if not candidates:
            out["missed"] += 1
            continue
        det = min(candidates, key=lambda d: float(np.linalg.norm(d.center - gt.pose[:3, 3])))
        centre = float(np.linalg.norm(det.center - gt.pose[:3, 3])) * 1e3
        if shape == "cylinder":
            out["cylinder_center_mm"] = max(out["cylinder_center_mm"], centre)
            out["cylinder_radius_mm"] = max(out["cylinder_radius_mm"], abs(det.dimensions[1] - gt.radius) * 1e3)
            out["cylinder_height_mm"] = max(out["cylinder_height_mm"], abs(det.dimensions[0] - gt.height) * 1e3)
        else:
            gt_yaw = math.atan2(gt.pose[1, 0], gt.pose[0, 0])
            d = (det.yaw - gt_yaw) % (math.pi / 2)
            out["box_center_mm"] = max(out["box_center_mm"], centre)
            out["box_yaw_deg"] = max(out["box_yaw_deg"], math.degrees(min(d, math.pi / 2 - d)))
    return out


def bench_perception(repeat: int, seed: int) -> None:
    """Full perception pipeline on simulated 640x480 PointCloud2 frames of the default scene."""
    from mycobot_planning.paths import config_file
    from mycobot_planning.perception.depth_camera import DepthCamera, load_camera_scene
    from mycobot_planning.perception.params import PerceptionParameters
    from mycobot_planning.perception.pointcloud_layout import pack_xyzrgb, unpack_cloud
    from mycobot_planning.perception.scene_detection import SceneDetector

    camera_config, scene = load_camera_scene(config_file("camera_scene.yaml"))
    camera = DepthCamera(camera_config)
    detector = SceneDetector(PerceptionParameters.from_yaml(config_file("perception_server.yaml")))
    target = scene.cylinders[0]
    request = {"target_shape": "cylinder", "target_dimensions": [target.height, target.radius]}

    def frame(k: int):  # type: ignore[no-untyped-def]
        cloud = camera.capture(scene, rng=[seed, k + 1])
        packed = pack_xyzrgb(cloud.points, cloud.colors)
        return packed

    def unpack(packed):  # type: ignore[no-untyped-def]
        return unpack_cloud(packed.height, packed.width, packed.fields, packed.point_step, packed.row_step,
                            packed.data, packed.is_bigendian, keep_organized=True)

    warm = unpack(frame(-1))
    detector.get_planning_scene(*warm, **request)  # warm-up: imports, thread pools, caches
    latencies: list[float] = []
    unpack_times: list[float] = []
    cpu_times: list[float] = []
    found: list[int] = []
    successes = 0
    worst: dict[str, float] = {}
    medians: list[float] = []
    width = height = 0
    for index in range(repeat):
        times = []
        for k in range(RUNS):
            packed = frame(index * RUNS + k)
            width, height = packed.width, packed.height
            t_unpack, (points, colors) = timed(lambda: unpack(packed))
            cpu0 = time.process_time()
            elapsed, result = timed(lambda: detector.get_planning_scene(points, colors, **request))
            cpu_times.append(time.process_time() - cpu0)
            times.append(elapsed)
            unpack_times.append(t_unpack)
            found.append(len(result.objects))
            successes += bool(result.success)
            for key, value in _errors(result, scene).items():
                worst[key] = max(worst.get(key, 0.0), value)
        record = {"scenario": "perception", "repeat": index, "runs": len(times), "objects_found": found[-1]}
        record.update(stats(times, 1e3, "ms"))
        medians.append(record["median_ms"])
        emit(record)
        latencies += times
    summary = {
        "scenario": "perception",
        "summary": True,
        "latency_ms": round(float(np.median(latencies)) * 1e3, 3),
        "p90_ms": round(float(np.percentile(latencies, 90)) * 1e3, 3),
        "objects_found": int(min(found)),
        "objects_expected": len(scene.cylinders) + len(scene.boxes),
        "success_rate": round(successes / len(latencies), 3),
        "cpu_ms": round(float(np.median(cpu_times)) * 1e3, 3),
        "unpack_ms": round(float(np.median(unpack_times)) * 1e3, 3),
        "cloud": f"{width}x{height}",
        **{f"worst_{k}": round(float(v), 3) for k, v in worst.items()},
    }
    emit({**summary, **spread(medians), **machine()})
