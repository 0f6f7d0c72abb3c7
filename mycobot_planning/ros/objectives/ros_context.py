"""The behaviors' context over ROS: what the objective server's node offers them.

Everything is a client of public ROS interfaces (move_group's actions and services, the
controllers' actions, /joint_states, /tf and /tf_static, the perception_server); nothing here
reaches into another node. Clients are made once per name and shared by every tree.
"""
from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import numpy as np
from action_msgs.msg import GoalInfo
from action_msgs.srv import CancelGoal
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import Marker, MarkerArray

from interfaces_py.action_client import ActionClient
from interfaces_py.perception_client import PerceptionClient
from interfaces_py.names import TRAJECTORY_EXECUTION_EVENT
from mycobot_planning.behavior_tree.behaviors import BehaviorContext, JointStateValue, OperatorPrompts, WaypointStore
from mycobot_planning.behavior_tree.ports import PoseStamped
from mycobot_planning.core.transforms import make_pose, matrix_to_quat

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: the topic VisualizePose publishes on (MoveIt Pro's UI topic name is not public; RViz reads any)
MARKER_TOPIC = "/visual_markers"


class _TfBuffer:
    """The latest transform of every frame from /tf and /tf_static (tf2_ros has no pip wheel)."""

    def __init__(self, node: Node, group: Any) -> None:
        self._lock = threading.Lock()
        self._parent: dict[str, tuple[str, np.ndarray]] = {}
        node.create_subscription(TFMessage, "/tf", self._on_tf, 100, callback_group=group)
        node.create_subscription(TFMessage, "/tf_static", self._on_tf, LATCHED, callback_group=group)

    def _on_tf(self, msg: TFMessage) -> None:
        with self._lock:
            for t in msg.transforms:
                tr, q = t.transform.translation, t.transform.rotation
                self._parent[t.child_frame_id.lstrip("/")] = (
                    t.header.frame_id.lstrip("/"), make_pose((tr.x, tr.y, tr.z), quat_xyzw=(q.x, q.y, q.z, q.w)))

    def _to_root(self, frame: str) -> tuple[str, np.ndarray]:
        pose, seen = np.eye(4), set()
        while frame in self._parent and frame not in seen:
            seen.add(frame)
            parent, transform = self._parent[frame]
            pose, frame = transform @ pose, parent
        return frame, pose

    def lookup(self, target: str, source: str) -> np.ndarray:
        target, source = target.lstrip("/"), source.lstrip("/")
        with self._lock:
            root_t, t_pose = self._to_root(target)
            root_s, s_pose = self._to_root(source)
        if root_t != root_s:
            raise LookupError(f"no transform from '{source}' to '{target}' on /tf (roots '{root_s}' and '{root_t}')")
        return np.linalg.inv(t_pose) @ s_pose


class RosBehaviorContext(BehaviorContext):
    """BehaviorContext answered by ROS through ``node`` (spun by the caller's executor)."""

    def __init__(self, node: Node, waypoints: WaypointStore, operator: OperatorPrompts, *,
                 planning_group: str = "arm", ik_frame: str = "link6_flange",
                 arm_controller_action: str = "/arm_controller/follow_joint_trajectory",
                 gripper_action: str = "/grip_action_controller/gripper_cmd") -> None:
        super().__init__(waypoints, operator)
        self.node = node
        self.planning_group = planning_group
        self.ik_frame = ik_frame
        self.arm_controller_action = arm_controller_action
        self.gripper_action = gripper_action
        self.group = ReentrantCallbackGroup()
        self._lock = threading.Lock()
        self._actions: dict[str, Any] = {}
        self._services: dict[str, Any] = {}
        self._topics: dict[str, tuple[Any, list[Callable[[Any], None]]]] = {}
        self._joint_state: JointState | None = None
        #: /joint_states messages received so far (tells a fresh reading from the same one again)
        self._joint_state_count = 0
        self._perception: Any = None
        self.detected_object_ids: list[str] = []
        node.create_subscription(JointState, "/joint_states", self._on_joint_state, 10, callback_group=self.group)
        self._tf = _TfBuffer(node, self.group)
        self._markers = node.create_publisher(MarkerArray, MARKER_TOPIC, 10)
        self._stop_event = node.create_publisher(String, TRAJECTORY_EXECUTION_EVENT, 10)

    # -- BehaviorContext --------------------------------------------------------------------
    def log(self, level: str, text: str) -> None:
        # one call site per severity: rclpy refuses a call site whose severity changes
        logger = self.node.get_logger()
        if level == "debug":
            logger.debug(text)
        elif level in ("warn", "warning"):
            logger.warning(text)
        elif level == "error":
            logger.error(text)
        else:
            logger.info(text)

    def lookup_transform(self, target_frame: str, source_frame: str) -> np.ndarray:
        if target_frame.lstrip("/") == source_frame.lstrip("/"):
            return np.eye(4)
        return self._tf.lookup(target_frame, source_frame)

    def _on_joint_state(self, msg: JointState) -> None:
        with self._lock:
            self._joint_state = msg
            self._joint_state_count += 1

    def joint_state_count(self) -> int:
        """How many /joint_states messages have arrived (a reading is fresh when this grew)."""
        with self._lock:
            return self._joint_state_count

    def current_joint_state(self) -> JointStateValue:
        with self._lock:
            msg = self._joint_state
        if msg is None:
            raise LookupError("no /joint_states received yet")
        return JointStateValue(list(msg.name), [float(p) for p in msg.position])

    def joint_velocities(self) -> list[float]:
        with self._lock:
            msg = self._joint_state
        return [float(v) for v in msg.velocity] if msg is not None else []

    def visualize_pose(self, marker_name: str, pose: PoseStamped, size: float, lifetime: float, text: str) -> None:
        markers = MarkerArray()
        rotation = make_pose(pose.pose.position, quat_xyzw=pose.pose.orientation)
        for index, axis in enumerate("xyz"):
            m = Marker()
            m.header.frame_id = pose.frame_id or "world"
            m.ns, m.id, m.type, m.action = marker_name, index, Marker.ARROW, Marker.ADD
            m.scale.x, m.scale.y, m.scale.z = float(size), float(size) * 0.1, float(size) * 0.1
            m.color.a = 1.0
            setattr(m.color, "rgb"[index], 1.0)
            m.pose.position.x, m.pose.position.y, m.pose.position.z = (float(v) for v in pose.pose.position)
            # the arrow points along the marker's x axis: turn x onto the pose's axis
            turn = {"x": np.eye(3), "y": np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]]),
                    "z": np.array([[0, 0, -1], [0, 1, 0], [1, 0, 0.0]])}[axis]
            q = matrix_to_quat(rotation[:3, :3] @ turn)
            m.pose.orientation.x, m.pose.orientation.y, m.pose.orientation.z, m.pose.orientation.w = (float(v) for v in q)
            m.lifetime.sec = int(lifetime)
            m.lifetime.nanosec = int((lifetime - int(lifetime)) * 1e9)
            markers.markers.append(m)
        if text:
            label = Marker()
            label.header.frame_id = pose.frame_id or "world"
            label.ns, label.id, label.type, label.action, label.text = marker_name, 3, Marker.TEXT_VIEW_FACING, Marker.ADD, text
            label.scale.z = float(size) * 0.3
            label.color.a = label.color.r = label.color.g = label.color.b = 1.0
            label.pose.position.x, label.pose.position.y, label.pose.position.z = (float(v) for v in pose.pose.position)
            markers.markers.append(label)
        self._markers.publish(markers)
        self.log("info", f"VisualizePose '{marker_name}': {pose.to_dict()}")

    # -- clients ----------------------------------------------------------------------------
    def action_client(self, action_type: Any, name: str) -> Any:
        with self._lock:
            client = self._actions.get(name)
            if client is None:
                client = self._actions[name] = ActionClient(self.node, action_type, name, callback_group=self.group)
            return client

    def service_client(self, srv_type: Any, name: str) -> Any:
        with self._lock:
            client = self._services.get(name)
            if client is None:
                client = self._services[name] = self.node.create_client(srv_type, name, callback_group=self.group)
            return client

    def next_message(self, msg_type: Any, topic: str, deliver: Callable[[Any], None]) -> Callable[[], None]:
        """``deliver(msg)`` with the next message on ``topic``; returns the cancel. Subscriptions
        are made once per topic and kept: destroying one while the executor waits on it races
        (rclpy's InvalidHandle)."""
        with self._lock:
            entry = self._topics.get(topic)
            if entry is None:
                waiting: list[Callable[[Any], None]] = []

                def on_message(msg: Any) -> None:
                    with self._lock:
                        ready, waiting[:] = list(waiting), []
                    for callback in ready:
                        callback(msg)

                subscription = self.node.create_subscription(msg_type, topic, on_message, 1,
                                                             callback_group=self.group)
                entry = self._topics[topic] = (subscription, waiting)
            entry[1].append(deliver)

        def cancel() -> None:
            with self._lock:
                if deliver in entry[1]:
                    entry[1].remove(deliver)

        return cancel

    def perception(self) -> PerceptionClient:
        with self._lock:
            if self._perception is None:
                self._perception = PerceptionClient(node=self.node)
            return self._perception

    def stop_arm(self) -> list[str]:
        """Stop every motion: move_group's stop event, and every goal of the arm's and the
        gripper's controllers canceled (a cancel request with no goal id cancels all of them;
        the controllers hold position). Returns the controllers asked."""
        self._stop_event.publish(String(data="stop"))
        asked = []
        for name in (self.arm_controller_action, self.gripper_action):
            client = self.service_client(CancelGoal, f"{name}/_action/cancel_goal")
            if client.service_is_ready():
                client.call_async(CancelGoal.Request(goal_info=GoalInfo()))
                asked.append(name)
        return asked
