"""ROS-free perception: point cloud → support surface + cylinders and boxes as collision objects.

The perception_server node wraps :class:`SceneDetector`; the camera_simulator node wraps
:class:`DepthCamera` over a :class:`GroundTruthScene`. Both exchange sensor_msgs/PointCloud2
through :mod:`.pointcloud_layout`. Nothing here imports rclpy.

    >>> from mycobot_planning.perception import SceneDetector, PerceptionParameters
    >>> result = SceneDetector(PerceptionParameters()).get_planning_scene(
    ...     points, colors, target_shape="cylinder", target_dimensions=[0.35, 0.0125])
    >>> result.success, result.target_object_id, result.support_surface_id
"""
from .depth_camera import CameraIntrinsics, DepthCamera, DepthCameraConfig, SimulatedCloud, load_camera_scene, look_at
from .errors import CloudFormatError, ParameterError, PerceptionError, RequestError
from .params import UNUSED_SEED_PARAMETERS, PerceptionParameters
from .pointcloud_layout import PackedCloud, PointFieldSpec, pack_xyzrgb, unpack_cloud, unpack_message
from .scene_detection import DetectedObject, DetectionResult, SceneDetector, identify_target, validate_target
from .scene_model import GroundTruthScene, SceneBox, SceneCylinder

__all__ = [
    "CameraIntrinsics", "CloudFormatError", "DepthCamera", "DepthCameraConfig", "DetectedObject",
    "DetectionResult", "GroundTruthScene", "PackedCloud", "ParameterError", "PerceptionError",
    "PerceptionParameters", "PointFieldSpec", "RequestError", "SceneBox", "SceneCylinder", "SceneDetector",
    "SimulatedCloud", "UNUSED_SEED_PARAMETERS", "identify_target", "load_camera_scene", "look_at",
    "pack_xyzrgb", "unpack_cloud", "unpack_message", "validate_target",
]
