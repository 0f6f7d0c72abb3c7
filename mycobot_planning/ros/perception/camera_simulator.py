"""camera_simulator: a simulated RGB-D camera publishing sensor_msgs/PointCloud2 (XYZ + RGB).

The full story: docs/nodes.md, section mycobot_planning.ros.perception.camera_simulator.
"""
from __future__ import annotations

import json
import math
import threading
from typing import Any

import numpy as np
from rcl_interfaces.msg import SetParametersResult
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import String

from interfaces_py.msgs import PlanningSceneWorld
from mycobot_planning.ros.node_runtime import Parameters, ParameterSpec
from mycobot_planning.ros.perception.perception_setup import (
    CAMERA_PARAMETER_NAMES,
    SCENE_PARAMETER_NAMES,
    camera_config_from_parameters,
    camera_parameter_defaults,
    camera_parameter_loss,
    pose_vector,
    scene_from_parameters,
    scene_parameters_given,
)
from mycobot_planning.paths import config_file
from mycobot_planning.perception import (
    DepthCamera,
    DepthCameraConfig,
    GroundTruthScene,
    PackedCloud,
    PerceptionError,
    load_camera_scene,
    pack_xyzrgb,
)

NODE_NAME = "camera_simulator"
DEFAULT_TOPIC = "/camera_head/depth/color/points"
CLOUD_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
LATCHED_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
_OUTPUT_FRAMES = ("world", "camera")


def point_cloud2(packed: PackedCloud, frame_id: str, stamp: Any) -> PointCloud2:
    """A packed cloud (perception.pointcloud_layout) as a sensor_msgs/PointCloud2."""
    msg = PointCloud2()
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.height, msg.width = packed.height, packed.width
    msg.fields = [PointField(name=f.name, offset=f.offset, datatype=f.datatype, count=f.count) for f in packed.fields]
    msg.is_bigendian = packed.is_bigendian
    msg.point_step, msg.row_step = packed.point_step, packed.row_step
    msg.data = packed.data
    msg.is_dense = packed.is_dense
    return msg


def _default_scene_file() -> str:
    try:
        return str(config_file("camera_scene.yaml"))
    except FileNotFoundError:
        return ""


def _numbers(name: str, group: int | None = None, size: int | None = None):
    """A validator: a list of finite numbers, empty or of ``size`` values / a multiple of ``group``."""
    def check(value: Any) -> str | None:
        if value is None:  # `[]` in a params file has no type: rcl leaves the parameter unset
            return None
        if not isinstance(value, (list, tuple)):
            return f"{name} must be a list of numbers, got {value!r}"
        if any(isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) for v in value):
            return f"{name} must contain finite numbers only, got {list(value)!r}"
        if size is not None and len(value) not in (0, size):
            return f"{name} must be empty or have exactly {size} values, got {len(value)}"
        if group is not None and len(value) % group:
            return f"{name} must hold groups of {group} numbers, got {len(value)} values"
        return None
    return check


def _one_of(name: str, options: tuple[str, ...]):
    def check(value: Any) -> str | None:
        return None if value in options else f"{name} must be one of {list(options)}, got {value!r}"
    return check


class CameraSimulator(Node):
    """See docs/nodes.md (mycobot_planning.ros.perception.camera_simulator)."""

    def __init__(self) -> None:
        super().__init__(NODE_NAME)
        # scene_file first: the camera and scene parameters take their defaults from it.
        self._file_params = Parameters(self, [
            ParameterSpec("scene_file", _default_scene_file(), "camera-scene YAML (camera: and scene: sections, see "
                          "config/camera_scene.yaml); empty: camera from the parameters, scene from table_size, "
                          "cylinders, boxes", read_only=True),
        ])
        scene_file = str(self._file_params.get("scene_file"))
        file_camera, file_scene = DepthCameraConfig(), None
        if scene_file:
            try:
                file_camera, file_scene = load_camera_scene(scene_file)
            except PerceptionError as exc:
                raise ValueError(f"scene_file: {exc}") from None
        cam = camera_parameter_defaults(file_camera)
        scene_frame = file_scene.frame_id if file_scene is not None else "base_link"
        self.params = Parameters(self, [
            ParameterSpec("topic", DEFAULT_TOPIC, "topic of the published sensor_msgs/PointCloud2", non_empty=True,
                          read_only=True),
            ParameterSpec("rate", 1.0, "frames per second (a 640x480 frame is 4.9 MB)", range=(0.01, 30.0)),
            ParameterSpec("output_frame", "world", "'world': points in the scene's frame (frame_id = "
                          "scene_frame_id); 'camera': points in the optical frame (frame_id = camera_frame_id)",
                          validator=_one_of("output_frame", _OUTPUT_FRAMES)),
            ParameterSpec("seed", 0, "seed of the depth noise and dropouts (-1: different every run)",
                          range=(-1, 2**31 - 1)),
            # camera
            ParameterSpec("width", cam["width"], "image width (pixels)", range=(1, 4096)),
            ParameterSpec("height", cam["height"], "image height (pixels)", range=(1, 4096)),
            ParameterSpec("horizontal_fov", cam["horizontal_fov"], "horizontal field of view (rad; square pixels, "
                          "principal point at the image centre)", range=(0.01, 3.1)),
            ParameterSpec("camera_position", cam["camera_position"], "camera (optical centre) position [x, y, z] in "
                          "the scene frame (m)", array_size=3),
            ParameterSpec("camera_look_at", cam["camera_look_at"], "point [x, y, z] the optical axis goes through "
                          "(m); image up is towards +z", array_size=3),
            ParameterSpec("near", cam["near"], "nearest depth returned (m)", range=(0.001, 100.0)),
            ParameterSpec("far", cam["far"], "farthest depth returned (m)", range=(0.001, 100.0)),
            ParameterSpec("depth_noise_stddev", cam["depth_noise_stddev"], "depth noise sigma at zero depth (m)",
                          range=(0.0, 1.0)),
            ParameterSpec("depth_noise_quadratic", cam["depth_noise_quadratic"], "growth of the depth noise: sigma = "
                          "depth_noise_stddev + depth_noise_quadratic * z^2 (1/m)", range=(0.0, 1.0)),
            ParameterSpec("dropout_probability", cam["dropout_probability"], "probability that a pixel returns "
                          "nothing (NaN)", range=(0.0, 0.99)),
            ParameterSpec("max_incidence_angle_deg", cam["max_incidence_angle_deg"], "returns at a more grazing "
                          "incidence are dropped (degrees)", range=(1.0, 90.0)),
            ParameterSpec("camera_frame_id", cam["camera_frame_id"], "frame_id of the optical frame "
                          "(output_frame 'camera')", non_empty=True),
            # scene
            ParameterSpec("table_size", [], "table box [x, y, z] (m); with cylinders / boxes: non-empty replaces "
                          "the scene_file's scene", validator=_numbers("table_size", size=3), dynamic_typing=True),
            ParameterSpec("table_pose", [], "table centre [x, y, z, roll, pitch, yaw] (m, rad)",
                          validator=_numbers("table_pose", size=6), dynamic_typing=True),
            ParameterSpec("cylinders", [], "cylinders standing on the table: [x, y, height, radius] per cylinder, "
                          "flattened", validator=_numbers("cylinders", group=4), dynamic_typing=True),
            ParameterSpec("boxes", [], "boxes standing on the table: [x, y, yaw, sx, sy, sz] per box, flattened",
                          validator=_numbers("boxes", group=6), dynamic_typing=True),
            ParameterSpec("ground_plane_z", -0.75, "height of the floor of a parameter scene (m; below -far: no "
                          "floor in view)", range=(-100.0, 100.0)),
            ParameterSpec("scene_frame_id", scene_frame, "frame of the scene (frame_id of output_frame 'world')",
                          non_empty=True),
        ])
        self._file_camera, self._file_scene = file_camera, file_scene
        self._lock = threading.Lock()
        self._camera, self._scene = self._build(self.params.values())  # ValueError: bad configuration
        if scene_file:
            loss = camera_parameter_loss(file_camera, self._camera.config)
            if loss and not any(self.params.get(n) != cam[n] for n in CAMERA_PARAMETER_NAMES):
                self.get_logger().warning(f"{scene_file}: the camera parameters approximate the file's camera: {loss}")
        seed = int(self.params.get("seed"))
        self._rng = np.random.default_rng(None if seed < 0 else seed)
        self._frames = 0
        self.add_on_set_parameters_callback(self._check_set)
        self.params.on_change(self._on_change)

        self._group = MutuallyExclusiveCallbackGroup()
        self._pub = self.create_publisher(PointCloud2, self.params.get("topic"), CLOUD_QOS)
        self._truth_pub = self.create_publisher(String, "~/ground_truth", LATCHED_QOS)
        self._timer = self.create_timer(1.0 / float(self.params.get("rate")), self._tick, callback_group=self._group)
        self._publish_ground_truth()
        self._log_configuration()
        self.get_logger().info(f"camera_simulator ready: publishing on {self.params.get('topic')} at "
                               f"{float(self.params.get('rate')):g} Hz")

    # ------------------------------------------------------------------ configuration
    def _build(self, values: dict[str, Any]) -> tuple[DepthCamera, GroundTruthScene]:
        """Camera and scene of parameter values; ValueError naming the problem."""
        try:
            config = camera_config_from_parameters(values)
            scene = scene_from_parameters(values, self._file_scene)
        except PerceptionError as exc:
            raise ValueError(str(exc)) from None
        return DepthCamera(config), scene

    def _check_set(self, params: list[Parameter]) -> SetParametersResult:
        """Refuse a change that makes the camera or scene invalid as a whole (near >= far, a
        camera looking straight up, a table pose of the wrong size...)."""
        values = self.params.values()
        relevant = False
        for p in params:
            if p.name in CAMERA_PARAMETER_NAMES or p.name in SCENE_PARAMETER_NAMES:
                values[p.name] = p.value.tolist() if hasattr(p.value, "tolist") else p.value
                relevant = True
        if not relevant:
            return SetParametersResult(successful=True)
        try:
            self._build(values)
        except ValueError as exc:
            self.get_logger().warning(f"refused {[p.name for p in params]}: {exc}")
            return SetParametersResult(successful=False, reason=str(exc))
        except (TypeError, OverflowError) as exc:
            return SetParametersResult(successful=False, reason=f"{type(exc).__name__}: {exc}")
        return SetParametersResult(successful=True)

    def _on_change(self, changed: dict[str, Any]) -> None:
        if any(n in CAMERA_PARAMETER_NAMES or n in SCENE_PARAMETER_NAMES for n in changed):
            camera, scene = self._build(self.params.values())
            with self._lock:
                self._camera, self._scene = camera, scene
            self._publish_ground_truth()
            self._log_configuration()
        if "rate" in changed:
            self._timer.cancel()
            self.destroy_timer(self._timer)
            self._timer = self.create_timer(1.0 / float(changed["rate"]), self._tick, callback_group=self._group)
            self.get_logger().info(f"publishing at {float(changed['rate']):g} Hz")
        if "seed" in changed:
            seed = int(changed["seed"])
            with self._lock:
                self._rng = np.random.default_rng(None if seed < 0 else seed)
        if "output_frame" in changed:
            self._log_configuration()

    def _log_configuration(self) -> None:
        with self._lock:
            config, scene = self._camera.config, self._scene
        intr = config.intrinsics
        source = "parameters" if scene_parameters_given(self.params.values()) or self._file_scene is None \
            else self._file_params.get("scene_file")
        shapes = ", ".join(s.id for s in scene.shapes()) or "nothing"
        fov = math.degrees(2 * math.atan(intr.width / (2 * intr.fx)))
        self.get_logger().info(
            f"camera {intr.width}x{intr.height} fov {fov:.1f}deg at "
            f"{[round(float(v), 3) for v in config.pose[:3, 3]]}; scene from {source} in '{scene.frame_id}': {shapes}")
        if self.params.get("output_frame") == "camera":
            pose = ", ".join(f"{v:.6f}" for v in pose_vector(config.pose))
            self.get_logger().info(
                f"clouds in the optical frame '{config.frame_id}': give the perception_server "
                f"-p cloud_frame_id:={config.frame_id} -p \"cloud_frame_pose:=[{pose}]\" (pose in '{scene.frame_id}')")

    def _publish_ground_truth(self) -> None:
        with self._lock:
            scene = self._scene
        world = PlanningSceneWorld(collision_objects=scene.collision_objects())
        self._truth_pub.publish(String(data=json.dumps(world.to_dict())))

    # ------------------------------------------------------------------ frames
    def capture(self) -> PointCloud2:
        """Render one frame into a PointCloud2 message (stamped now)."""
        with self._lock:
            camera, scene, rng = self._camera, self._scene, self._rng
        frame = "camera" if self.params.get("output_frame") == "camera" else "world"
        cloud = camera.capture(scene, rng, frame=frame)
        return point_cloud2(pack_xyzrgb(cloud.points, cloud.colors), cloud.frame_id, self.get_clock().now().to_msg())

    def _tick(self) -> None:
        try:
            msg = self.capture()
        except Exception as exc:  # a frame that cannot be rendered is logged, the node keeps running
            self.get_logger().error(f"rendering a frame failed: {type(exc).__name__}: {exc}",
                                    throttle_duration_sec=10.0)
            return
        self._pub.publish(msg)
        self._frames += 1
        if self._frames == 1:
            self.get_logger().info(f"published the first cloud ({msg.width}x{msg.height}, frame "
                                   f"'{msg.header.frame_id}', {len(msg.data) / 1e6:.1f} MB)")
