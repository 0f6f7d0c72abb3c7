"""ROS-free helpers of the perception nodes: parameters ⇄ camera and scene, and cloud frames.

The full story: docs/nodes.md, section mycobot_planning.ros.perception.perception_setup.
"""
from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

import numpy as np

from mycobot_planning.core.transforms import matrix_to_rpy
from mycobot_planning.perception import (
    CloudFormatError,
    DepthCameraConfig,
    GroundTruthScene,
    PerceptionError,
)
from mycobot_planning.perception.scene_model import pose_from_vector

CAMERA_PARAMETER_NAMES = (
    "width", "height", "horizontal_fov", "camera_position", "camera_look_at", "near", "far",
    "depth_noise_stddev", "depth_noise_quadratic", "dropout_probability", "max_incidence_angle_deg",
    "camera_frame_id",
)
SCENE_PARAMETER_NAMES = ("table_size", "table_pose", "cylinders", "boxes", "ground_plane_z", "scene_frame_id")


# ---------------------------------------------------------------------------- poses
def pose_vector(T: np.ndarray) -> list[float]:
    """[x, y, z, roll, pitch, yaw] (fixed-axis rpy, the seeds' pose vectors) of a 4x4 pose."""
    T = np.asarray(T, dtype=float)
    return [float(v) for v in (*T[:3, 3], *matrix_to_rpy(T[:3, :3]))]


# ---------------------------------------------------------------------------- camera
def camera_parameter_defaults(config: DepthCameraConfig) -> dict[str, Any]:
    """The camera parameters that reproduce ``config`` (a camera-scene file's camera).

    The pose becomes position + a look-at point on the optical axis (where it meets z = 0 when
    it looks down, else 1 m ahead). What the parameters cannot express is approximated and
    :func:`camera_parameter_loss` says so: a roll of the camera about its optical axis, and a
    principal point or fy that differ from the centred, square-pixel pinhole of horizontal_fov."""
    intr, pose = config.intrinsics, config.pose
    eye, forward = pose[:3, 3], pose[:3, 2]
    distance = -eye[2] / forward[2] if forward[2] < -1e-6 and eye[2] > 0 else 1.0
    target = eye + distance * forward
    return {
        "width": int(intr.width),
        "height": int(intr.height),
        "horizontal_fov": float(2.0 * math.atan(intr.width / (2.0 * intr.fx))),
        "camera_position": [float(v) for v in eye],
        "camera_look_at": [float(v) for v in target],
        "near": float(config.near),
        "far": float(config.far),
        "depth_noise_stddev": float(config.depth_noise_stddev),
        "depth_noise_quadratic": float(config.depth_noise_quadratic),
        "dropout_probability": float(config.dropout_probability),
        "max_incidence_angle_deg": float(math.degrees(config.max_incidence_angle)),
        "camera_frame_id": str(config.frame_id),
    }


def camera_config_from_parameters(values: Mapping[str, Any]) -> DepthCameraConfig:
    """The simulated camera of the parameter values (names in :data:`CAMERA_PARAMETER_NAMES`).
    :class:`PerceptionError` names the first problem (near >= far, a degenerate look-at, ...)."""
    missing = [n for n in CAMERA_PARAMETER_NAMES if n not in values]
    if missing:
        raise PerceptionError(f"camera: missing parameters {missing}")
    position, target = list(values["camera_position"]), list(values["camera_look_at"])
    for name, vec in (("camera_position", position), ("camera_look_at", target)):
        if len(vec) != 3 or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in vec):
            raise PerceptionError(f"camera: {name} must be three finite numbers [x, y, z], got {vec}")
    if not str(values["camera_frame_id"]).strip():
        raise PerceptionError("camera: camera_frame_id must not be empty")
    return DepthCameraConfig.from_dict({
        "width": int(values["width"]),
        "height": int(values["height"]),
        "horizontal_fov": float(values["horizontal_fov"]),
        "position": position,
        "look_at": target,
        "near": float(values["near"]),
        "far": float(values["far"]),
        "depth_noise_stddev": float(values["depth_noise_stddev"]),
        "depth_noise_quadratic": float(values["depth_noise_quadratic"]),
        "dropout_probability": float(values["dropout_probability"]),
        "max_incidence_angle_deg": float(values["max_incidence_angle_deg"]),
        "frame_id": str(values["camera_frame_id"]),
    })


def camera_parameter_loss(original: DepthCameraConfig, rebuilt: DepthCameraConfig) -> str | None:
    """Why the parameter camera differs from the file's (None when it is the same camera)."""
    problems = []
    if not np.allclose(original.pose, rebuilt.pose, atol=1e-6):
        problems.append("the camera pose (a roll about the optical axis is not expressible as position + look_at)")
    a, b = original.intrinsics, rebuilt.intrinsics
    if not np.allclose([a.fx, a.fy, a.cx, a.cy], [b.fx, b.fy, b.cx, b.cy], atol=1e-6):
        problems.append("the intrinsics (only a centred, square-pixel pinhole of horizontal_fov is expressible)")
    return "; ".join(problems) or None


# ---------------------------------------------------------------------------- scene
def scene_parameters_given(values: Mapping[str, Any]) -> bool:
    """True when the flat scene parameters describe a scene (one of them is non-empty)."""
    return any(len(values.get(name) or ()) > 0 for name in ("table_size", "cylinders", "boxes"))


def scene_from_parameters(values: Mapping[str, Any], file_scene: GroundTruthScene | None) -> GroundTruthScene:
    """The ground-truth scene: ``file_scene`` unless the flat parameters describe one (see the
    docs/nodes.md (mycobot_planning.ros.perception.perception_setup)); ``scene_frame_id`` names its frame either way."""
    frame = str(values.get("scene_frame_id") or "").strip()
    if not frame:
        raise PerceptionError("scene: scene_frame_id must not be empty")
    if file_scene is not None and not scene_parameters_given(values):
        scene = GroundTruthScene(file_scene.support_surface, list(file_scene.cylinders), list(file_scene.boxes),
                                 file_scene.ground_plane_z, file_scene.ground_color, frame)
        return scene
    table_size = [float(v) for v in (values.get("table_size") or ())]
    table_pose = [float(v) for v in (values.get("table_pose") or ())]
    if table_size and len(table_size) != 3:
        raise PerceptionError(f"scene: table_size must be [x, y, z] (or empty for no table), got {table_size}")
    ground = values.get("ground_plane_z")
    return GroundTruthScene.from_flat_parameters(
        table_size, table_pose if table_size else [0.0] * 6, values.get("cylinders") or (), values.get("boxes") or (),
        None if ground is None else float(ground), frame_id=frame)


# ---------------------------------------------------------------------------- cloud frames
def cloud_to_target_transform(cloud_frame: str, target_frame: str, cloud_frame_id: str,
                              cloud_frame_pose: Sequence[float]) -> np.ndarray | None:
    """The transform from a cloud's frame into ``target_frame`` (None: already there).

    Without tf2 the perception_server knows one other frame: ``cloud_frame_id``, posed at
    ``cloud_frame_pose`` [x, y, z, roll, pitch, yaw] in ``target_frame`` (what a static
    transform publisher would say about a fixed camera). A cloud in any other frame raises
    :class:`CloudFormatError` saying which parameters to set."""
    if cloud_frame == target_frame:
        return None
    if cloud_frame_id and cloud_frame == cloud_frame_id:
        return pose_from_vector(cloud_frame_pose, "cloud_frame_pose")
    known = f"'{target_frame}'" + (f" and '{cloud_frame_id}' (cloud_frame_id)" if cloud_frame_id else "")
    raise CloudFormatError(
        f"the point cloud is in frame '{cloud_frame}', but the known frames are {known}: set "
        f"cloud_frame_id:={cloud_frame or '<frame>'} and cloud_frame_pose:=[x, y, z, roll, pitch, yaw] "
        f"(that frame's pose in '{target_frame}')")


# ---------------------------------------------------------------------------- logs
def detection_lines(response: Mapping[str, Any]) -> list[str]:
    """Human lines for a get_planning_scene response: the outcome, then one per object."""
    lines = [str(response.get("message", ""))]
    names = {"cylinder": ("height", "radius"), "box": ("x", "y", "z")}
    for obj in response.get("objects") or ():
        dims = ", ".join(f"{n}={v:.4f}" for n, v in zip(names.get(obj.get("shape"), ()), obj.get("dimensions", ())))
        pos = ", ".join(f"{v:.4f}" for v in obj.get("position", ()))
        yaw = f" yaw={math.degrees(obj['yaw']):.1f}deg" if obj.get("shape") == "box" and "yaw" in obj else ""
        target = "  <- target" if obj.get("id") == response.get("target_object_id") else ""
        lines.append(f"  {obj.get('id')}: {obj.get('shape')} at ({pos}) {dims}{yaw}, "
                     f"{obj.get('points')} points{target}")
    return lines
