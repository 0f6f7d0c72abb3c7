"""perception_server: point cloud → support surface + cylinders and boxes as collision objects.

The full story: docs/nodes.md, section mycobot_planning.ros.perception.perception_server.
"""
from __future__ import annotations

import json
import math
import threading
import time
import traceback
from typing import Any

from rcl_interfaces.msg import SetParametersResult
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2
from std_srvs.srv import Trigger

from interfaces_py.clients import PlanningSceneInterface, RpcError
from interfaces_py.json_rpc import BAD_REQUEST, JsonRpcServer
from mycobot_planning.ros.node_runtime import Parameters, ParameterSpec
from mycobot_planning.ros.perception.perception_object_source import apply_detected_objects
from mycobot_planning.ros.perception.perception_setup import cloud_to_target_transform, detection_lines
from mycobot_planning.perception import (
    CloudFormatError,
    DetectionResult,
    ParameterError,
    PerceptionError,
    PerceptionParameters,
    SceneDetector,
    unpack_message,
)
from mycobot_planning.perception.scene_detection import TARGET_SHAPES

NODE_NAME = "perception_server"
_NODE_NAMES = ("target_shape", "target_dimensions", "apply_to_planning_server", "planning_server",
               "cloud_frame_id", "cloud_frame_pose", "max_cloud_age", "sensor_qos")
_REQUEST_KEYS = ("target_shape", "target_dimensions", "apply")


class _PipelineSpec(ParameterSpec):
    """A pipeline parameter: infinite crop bounds are legitimate values (the seed's
    ``crop_min_z: -.inf``), NaN is not; everything else as ParameterSpec."""

    def check(self, value: Any) -> str | None:
        if isinstance(value, float) and math.isinf(value):
            return self.validator(value) if self.validator is not None else None
        return super().check(value)


def _pipeline_specs() -> list[ParameterSpec]:
    specs: list[ParameterSpec] = []
    for name, d in PerceptionParameters.descriptors().items():
        low, high = d["min"], d["max"]
        bounded = low is not None and high is not None and d["type"] in ("int", "float")
        specs.append(_PipelineSpec(
            name, d["default"], d["description"],
            range=(low, high) if bounded else None,
            non_empty=d["type"] == "str",
            read_only=name == "point_cloud_topic",
        ))
    return specs


def _target_shape_check(value: Any) -> str | None:
    if not isinstance(value, str) or value.strip().lower() not in TARGET_SHAPES:
        return f"target_shape must be one of {sorted(TARGET_SHAPES)}, got {value!r}"
    return None


def _target_dimensions_check(value: Any) -> str | None:
    if not isinstance(value, (list, tuple)) or len(value) not in (2, 3):
        return "target_dimensions must be [height, radius] (cylinder) or [x, y, z] (box)"
    if any(isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0 for v in value):
        return f"target_dimensions must be positive numbers, got {list(value)}"
    return None


def _pose_check(value: Any) -> str | None:
    if not isinstance(value, (list, tuple)) or len(value) != 6:
        return "cloud_frame_pose must be [x, y, z, roll, pitch, yaw]"
    return None


def _server_check(value: Any) -> str | None:
    if not isinstance(value, str) or not value.strip() or any(c.isspace() for c in value):
        return f"planning_server must be a node name without spaces, got {value!r}"
    return None


class PerceptionServer(Node):
    """See docs/nodes.md (mycobot_planning.ros.perception.perception_server)."""

    def __init__(self) -> None:
        super().__init__(NODE_NAME)
        self.params = Parameters(self, [
            *_pipeline_specs(),
            ParameterSpec("target_shape", "cylinder", "shape of the target when a request names none: cylinder or box",
                          validator=_target_shape_check),
            ParameterSpec("target_dimensions", [0.35, 0.0125], "dimensions of the target when a request gives none: "
                          "[height, radius] for a cylinder, [x, y, z] for a box (m)",
                          validator=_target_dimensions_check),
            ParameterSpec("apply_to_planning_server", False, "add the detected support surface and objects to the "
                          "planning_server's scene after each successful detection"),
            ParameterSpec("planning_server", "/planning_server", "the planning_server node (apply_to_planning_server)",
                          read_only=True, validator=_server_check),
            ParameterSpec("cloud_frame_id", "", "a frame other than target_frame that clouds may come in (e.g. the "
                          "camera's optical frame); empty: clouds must be in target_frame"),
            ParameterSpec("cloud_frame_pose", [0.0] * 6, "pose [x, y, z, roll, pitch, yaw] of cloud_frame_id in "
                          "target_frame (m, rad)", array_size=6, validator=_pose_check),
            ParameterSpec("max_cloud_age", 0.0, "refuse a latest cloud received longer ago than this (s); 0: any age",
                          range=(0.0, 3600.0)),
            ParameterSpec("sensor_qos", False, "subscribe best-effort (camera drivers publish sensor-data QoS); "
                          "false: reliable (the camera_simulator)", read_only=True),
        ])
        try:
            self._pipeline = PerceptionParameters.from_dict(
                {n: self.params.get(n) for n in PerceptionParameters.names()})
        except ParameterError as exc:
            raise ValueError(str(exc)) from None
        self._detector = SceneDetector(self._pipeline)
        self.add_on_set_parameters_callback(self._check_set)
        self.params.on_change(self._on_change)
        problem = self._target_problem(self.params.get("target_shape"), self.params.get("target_dimensions"))
        if problem:
            self.get_logger().warning(f"the default target does not make sense: {problem}")

        self._cloud_lock = threading.Lock()
        self._detect_lock = threading.Lock()
        self._cloud: PointCloud2 | None = None
        self._cloud_received = 0.0
        self._clouds = 0
        self._applied: list[str] = []
        self._topic = str(self.params.get("point_cloud_topic"))
        qos = QoSProfile(depth=1, durability=DurabilityPolicy.VOLATILE,
                         reliability=ReliabilityPolicy.BEST_EFFORT if self.params.get("sensor_qos")
                         else ReliabilityPolicy.RELIABLE)
        self.create_subscription(PointCloud2, self._topic, self._on_cloud, qos,
                                 callback_group=MutuallyExclusiveCallbackGroup())
        self._group = ReentrantCallbackGroup()
        self.create_service(Trigger, "~/get_planning_scene", self._srv_get_planning_scene, callback_group=self._group)
        self._rpc = JsonRpcServer(self)
        self._rpc.register("get_planning_scene", self._rpc_get_planning_scene)
        self._scene_interface: PlanningSceneInterface | None = None
        self._scene_lock = threading.Lock()
        self.get_logger().info(f"perception_server ready: clouds from {self._topic}, objects in "
                               f"'{self._pipeline.target_frame}'")

    # ------------------------------------------------------------------ parameters
    def _check_set(self, params: list[Parameter]) -> SetParametersResult:
        """All pipeline changes of one set together through PerceptionParameters.replace, so
        cross-parameter rules (crop_min < crop_max, min_cluster_size <= max_cluster_size) hold."""
        names = set(PerceptionParameters.names())
        changes = {p.name: (p.value.tolist() if hasattr(p.value, "tolist") else p.value)
                   for p in params if p.name in names}
        if not changes:
            return SetParametersResult(successful=True)
        try:
            self._pipeline.replace(**changes)
        except ParameterError as exc:
            self.get_logger().warning(f"refused {sorted(changes)}: {exc}")
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _on_change(self, changed: dict[str, Any]) -> None:
        pipeline = {k: v for k, v in changed.items() if k in PerceptionParameters.names()}
        if pipeline:
            with self._detect_lock:
                self._pipeline = self._pipeline.replace(**pipeline)
                self._detector = SceneDetector(self._pipeline)
            self.get_logger().info(f"perception parameters now {pipeline}")

    @staticmethod
    def _target_problem(shape: Any, dims: Any) -> str | None:
        names = TARGET_SHAPES.get(str(shape).strip().lower())
        if names is not None and len(dims or ()) != len(names):
            return f"target_dimensions of a {shape} are [{', '.join(names)}], got {list(dims or ())}"
        return None

    # ------------------------------------------------------------------ clouds
    def _on_cloud(self, msg: PointCloud2) -> None:
        with self._cloud_lock:
            self._cloud, self._cloud_received = msg, time.monotonic()
            self._clouds += 1
            first = self._clouds == 1
        if first:
            self.get_logger().info(f"first point cloud received on {self._topic}: {msg.width}x{msg.height} in frame "
                                   f"'{msg.header.frame_id}'")

    # ------------------------------------------------------------------ requests
    def get_planning_scene(self, target_shape: Any = None, target_dimensions: Any = None,
                           apply: bool | None = None) -> dict[str, Any]:
        """Detect in the latest cloud; the JSON-able answer (see docs/nodes.md (mycobot_planning.ros.perception.perception_server))."""
        shape = self.params.get("target_shape") if target_shape is None else target_shape
        dims = self.params.get("target_dimensions") if target_dimensions is None else target_dimensions
        apply = bool(self.params.get("apply_to_planning_server")) if apply is None else bool(apply)
        with self._cloud_lock:
            msg, received = self._cloud, self._cloud_received
        with self._detect_lock:
            frame = self._pipeline.target_frame
            detector = self._detector
            if msg is None:
                return self._failure(f"no point cloud received on {self._topic}", frame)
            age = time.monotonic() - received
            cloud = {"frame_id": msg.header.frame_id, "width": int(msg.width), "height": int(msg.height),
                     "age": round(age, 3)}
            max_age = float(self.params.get("max_cloud_age"))
            if max_age > 0 and age > max_age:
                return self._failure(f"the latest cloud on {self._topic} is {age:.1f} s old "
                                     f"(max_cloud_age {max_age:g} s)", frame, cloud)
            try:
                transform = cloud_to_target_transform(msg.header.frame_id, frame, self.params.get("cloud_frame_id"),
                                                      self.params.get("cloud_frame_pose"))
                points, colors = unpack_message(msg, keep_organized=True)
            except PerceptionError as exc:
                return self._failure(f"unusable point cloud on {self._topic}: {exc}", frame, cloud)
            try:
                # detect(require_target=True) is get_planning_scene() with the cloud's own
                # problems (only NaNs, ...) told apart from detection failures.
                result = detector.detect(points, colors, cloud_to_target=transform, target_shape=shape,
                                         target_dimensions=dims, require_target=True)
            except CloudFormatError as exc:
                return self._failure(f"unusable point cloud on {self._topic}: {exc}", frame, cloud)
            except PerceptionError as exc:  # a request that makes no sense (unknown shape, ...)
                result = DetectionResult(False, str(exc), frame_id=frame)
            except Exception as exc:  # a bug must not take the node down: answer and log the traceback
                self.get_logger().error(f"detection failed: {type(exc).__name__}: {exc}\n{traceback.format_exc()}")
                return self._failure(f"internal error in the perception pipeline: {type(exc).__name__}: {exc}",
                                     frame, cloud)
        response = result.to_response()
        response.update(frame_id=frame, cloud=cloud)
        if result.success:
            self.get_logger().info("get_planning_scene: " + "\n".join(detection_lines(response)))
        else:
            self.get_logger().warning(f"get_planning_scene: {result.message}")
        if result.success and apply:
            self._apply(result, response)
        return response

    @property
    def scene_interface(self) -> PlanningSceneInterface:
        """The planning_server client, created at the first apply: until then the node does not
        listen to the planning_server's answers to everybody else."""
        with self._scene_lock:
            if self._scene_interface is None:
                self._scene_interface = PlanningSceneInterface(node=self, server=self.params.get("planning_server"),
                                                               timeout=10.0)
            return self._scene_interface

    def _apply(self, result: DetectionResult, response: dict[str, Any]) -> None:
        objects = result.scene_world().collision_objects
        try:
            added, removed, skipped = apply_detected_objects(self.scene_interface, objects, self._applied)
        except RpcError as exc:
            response["success"] = False
            response["message"] = (f"{result.message}; adding the objects to {self.params.get('planning_server')} "
                                   f"failed: {exc.message}")
            response["applied_to_planning_server"] = []
            self.get_logger().error(response["message"])
            return
        self._applied = [i for i in dict.fromkeys([*self._applied, *added]) if i not in removed]
        response["applied_to_planning_server"] = added
        response["removed_from_planning_server"] = removed
        self.get_logger().info(f"applied to {self.params.get('planning_server')}: {', '.join(added) or 'nothing'}"
                               + (f"; removed {', '.join(removed)}" if removed else "")
                               + (f"; left alone (attached to the robot): {', '.join(skipped)}" if skipped else ""))

    def _failure(self, message: str, frame: str, cloud: dict[str, Any] | None = None) -> dict[str, Any]:
        self.get_logger().warning(f"get_planning_scene: {message}")
        response = DetectionResult(False, message, frame_id=frame).to_response()
        response.update(frame_id=frame, cloud=cloud)
        return response

    def _rpc_get_planning_scene(self, params: dict[str, Any]) -> dict[str, Any]:
        unknown = sorted(set(params) - set(_REQUEST_KEYS))
        if unknown:
            raise RpcError(BAD_REQUEST,
                           f"get_planning_scene: unknown parameters {unknown}; known: {list(_REQUEST_KEYS)}")
        apply = params.get("apply")
        if apply is not None and not isinstance(apply, bool):
            raise RpcError(BAD_REQUEST, f"get_planning_scene: 'apply' must be true or false, got {apply!r}")
        return self.get_planning_scene(params.get("target_shape"), params.get("target_dimensions"), apply)

    def _srv_get_planning_scene(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        answer = self.get_planning_scene()
        response.success = bool(answer["success"])
        response.message = json.dumps(answer)
        return response
