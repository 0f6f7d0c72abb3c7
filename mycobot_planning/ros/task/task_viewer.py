"""task_viewer: RViz's robot display and Motion Planning Tasks panel, as a local web page.

The full story: docs/nodes.md, section mycobot_planning.ros.task.task_viewer.
"""
from __future__ import annotations

from typing import Any

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.exceptions import ParameterException
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory as JointTrajectoryMsg

from interfaces_py.background_spin import BackgroundSpin
from interfaces_py.json_rpc import BAD_REQUEST, JsonRpcServer, RpcError
from interfaces_py.msgs import MessageError
from interfaces_py.ros_conversions import joint_trajectory_from_msg
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.ros.node_runtime import Parameters, ParameterSpec
from mycobot_planning.ros.objectives.objective_view import ObjectiveView
from mycobot_planning.ros.servo.pose_target_view import PoseTargetView
from mycobot_planning.ros.servo.teleop_view import TeleopView
from mycobot_planning.ros.task.sim_world_view import SimWorldView
from mycobot_planning.ros.task.task_topics import SOLUTION_QOS, STATISTICS_QOS, TASK_SUFFIXES, parse_task_topic
from mycobot_planning.paths import package_share_dirs
from mycobot_planning.visualization.viewer import TaskViewer

NODE_NAME = "task_viewer"
LATCHED_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
JOINT_STATES_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
STRING_TYPE = "std_msgs/msg/String"


def _host_check(value: Any) -> str | None:
    if not isinstance(value, str) or not value.strip():
        return "host must be an address to bind, e.g. 127.0.0.1 (localhost only) or 0.0.0.0 (every interface)"
    return None


class TaskViewerNode(Node):
    """See docs/nodes.md (mycobot_planning.ros.task.task_viewer)."""

    def __init__(self) -> None:
        super().__init__(NODE_NAME)
        try:
            self._params = Parameters(self, [
                ParameterSpec("robot_description", "", "URDF of the robot (XML text); empty: the package's myCobot 280",
                              read_only=True),
                ParameterSpec("robot_description_semantic", "", "SRDF of the robot (XML text); empty: the package's",
                              read_only=True),
                ParameterSpec("host", "127.0.0.1", "address the web page is served on (127.0.0.1: this machine "
                              "only; 0.0.0.0: every interface, anyone on the network can see it)", read_only=True,
                              validator=_host_check),
                ParameterSpec("port", 8080, "TCP port of the web page (0: any free port; a busy port: the next "
                              "free one, see ~/url)", range=(0, 65535), read_only=True),
                ParameterSpec("max_update_rate", 100.0, "most live-robot updates per second sent to the page "
                              "(joint states arriving faster are coalesced, never queued)", range=(1.0, 1000.0)),
                ParameterSpec("playback_speed", 1.0, "speed factor of solution and planned-path animations",
                              range=(0.05, 20.0)),
                ParameterSpec("loop", True, "replay animations from the start when they end"),
                ParameterSpec("auto_play_planned_path", True, "animate each new /planned_path at once"),
                ParameterSpec("discovery_period", 1.0, "seconds between looks for new task topics in the graph",
                              range=(0.05, 60.0)),
                ParameterSpec("objective_server", "/objective_server", "the objective_server whose objectives the "
                              "page's Objectives panel lists, runs and stops (empty: no panel)", read_only=True),
                ParameterSpec("servo_node", "/servo_node", "the servo_node the page's Teleoperate panel jogs "
                              "the arm through (empty: no panel)", read_only=True),
                ParameterSpec("planning_server", "/planning_server", "the planning_server whose waypoints the "
                              "Teleoperate panel lists, saves and moves to", non_empty=True, read_only=True),
                ParameterSpec("gripper_action", "/grip_action_controller/gripper_cmd", "the gripper controller's "
                              "GripperCommand action (the Teleoperate panel's open / close)", non_empty=True,
                              read_only=True),
                ParameterSpec("sim_node", "/mujoco_sim", "the physics twin whose objects the page shows at their "
                              "true poses (<sim_node>/object_poses, shapes from its 'world' method) beside the "
                              "planning scene; empty: none", read_only=True),
                ParameterSpec("teleop_group", "", "the planning group the Teleoperate panel jogs and saves "
                              "(empty: 'arm' when the robot has it, else its group with the most joints)",
                              read_only=True),
            ])
        except ParameterException as exc:
            raise ValueError(f"invalid parameters: {exc}") from None
        log = self.get_logger()
        model = self._load_model()
        server = self._params.get("objective_server").strip()
        self._objective_view = ObjectiveView(self, server) if server else None
        servo = self._params.get("servo_node").strip()
        group = self._params.get("teleop_group").strip() or _default_teleop_group(model)
        try:
            self._teleop_view = TeleopView(self, model, servo, self._params.get("planning_server"),
                                           self._params.get("gripper_action"), group) if servo else None
        except (KeyError, ValueError) as exc:
            raise ValueError(f"teleop_group: {exc}") from None
        # the pose target goes with the Teleoperate panel: the same group, its tool frame
        self._pose_target_view = PoseTargetView(self, self._params.get("planning_server"), group,
                                                self._teleop_view.frames["tool"]) if self._teleop_view else None
        try:
            self.viewer = TaskViewer(
                model, self._params.get("host"), self._params.get("port"),
                max_update_rate=self._params.get("max_update_rate"), speed=self._params.get("playback_speed"),
                loop=self._params.get("loop"), auto_play_planned_path=self._params.get("auto_play_planned_path"),
                package_dirs=package_share_dirs(), log=lambda text: log.warning(text),
                objective_actions=self._objective_view.actions() if self._objective_view else None,
                teleop_actions=self._teleop_view.actions() if self._teleop_view else None,
                teleop_joints=self._teleop_view.joint_names if self._teleop_view else (),
                teleop_limits=self._teleop_view.joint_limits if self._teleop_view else None,
                pose_target_actions=self._pose_target_view.actions() if self._pose_target_view else None,
                pose_target_link=self._pose_target_view.link if self._pose_target_view else "")
        except OSError as exc:
            raise ValueError(f"cannot serve the page on {self._params.get('host')}:{self._params.get('port')}: {exc}") \
                from None
        self._params.on_change(self._on_params)
        if self._objective_view is not None and self.viewer.objectives is not None:
            self._objective_view.attach(self.viewer.objectives)
        if self._teleop_view is not None and self.viewer.teleop is not None:
            self._teleop_view.attach(self.viewer.teleop)
        if self._pose_target_view is not None and self.viewer.pose_target is not None:
            self._pose_target_view.attach(self.viewer.pose_target)
        sim = self._params.get("sim_node").strip()
        self._sim_world_view = SimWorldView(self, self.viewer, sim) if sim else None

        # /joint_states (100 Hz and more) on a node of its own with a single-threaded executor:
        # the multi-threaded executor's re-polling would cost a core at that rate (see
        # planning_server), and it would delay the graph polling and requests.
        self._monitor = Node(f"{NODE_NAME}_state_monitor", context=self.context)
        self._monitor.create_subscription(JointState, "/joint_states", self._on_joint_state, JOINT_STATES_QOS)
        self._monitor_executor = SingleThreadedExecutor(context=self.context)
        self._monitor_executor.add_node(self._monitor)

        inputs = MutuallyExclusiveCallbackGroup()
        self.create_subscription(String, "/planning_server/monitored_planning_scene", self._on_scene, LATCHED_QOS,
                                 callback_group=inputs)
        self.create_subscription(JointTrajectoryMsg, "/planned_path", self._on_planned_path, LATCHED_QOS,
                                 callback_group=inputs)
        self._task_subscriptions: dict[str, Any] = {}
        self._task_group = MutuallyExclusiveCallbackGroup()
        self._discovery_timer = self.create_timer(self._params.get("discovery_period"), self._discover,
                                                  callback_group=MutuallyExclusiveCallbackGroup())
        self._url_pub = self.create_publisher(String, "~/url", LATCHED_QOS)
        self._url_pub.publish(String(data=self.viewer.url))

        self._rpc = JsonRpcServer(self)
        for method, handler in {
            "get_state": lambda p: self.viewer.state(),
            "select": self._rpc_select,
            "play": lambda p: self._sync(self.viewer.play),
            "pause": lambda p: self._sync(self.viewer.pause),
            "seek": self._rpc_seek,
            "show_live": lambda p: self._sync(self.viewer.show_live),
            "get_display_lags": self._rpc_lags,
            "objectives_click": self._rpc_objectives_click,
        }.items():
            self._rpc.register(method, handler)
        self._monitor_spin = BackgroundSpin(self._monitor_executor, name="joint states")
        self._discover()
        log.info(f"task_viewer: open {self.viewer.url} in a browser (robot '{model.name}', "
                 f"{len(self.viewer.live.links)} links with collision shapes)")

    # ------------------------------------------------------------------ set-up
    def _load_model(self) -> RobotModel:
        urdf = self._params.get("robot_description")
        srdf = self._params.get("robot_description_semantic")
        if not urdf and not srdf:
            return RobotModel.mycobot()
        if not urdf:
            raise ValueError("robot_description_semantic is set but robot_description (the URDF) is empty")
        try:
            return RobotModel.from_strings(urdf, srdf or '<robot name=""/>', package_dirs=package_share_dirs())
        except Exception as exc:
            raise ValueError(f"cannot build the robot model: {exc}") from None

    def _on_params(self, changed: dict[str, Any]) -> None:
        viewer = self.viewer
        if "max_update_rate" in changed:
            viewer.max_update_rate = float(changed["max_update_rate"])
        if "playback_speed" in changed:
            viewer.speed = float(changed["playback_speed"])
        if "loop" in changed:
            viewer.loop = bool(changed["loop"])
        if "auto_play_planned_path" in changed:
            viewer.auto_play_planned_path = bool(changed["auto_play_planned_path"])
        if "discovery_period" in changed:
            self._discovery_timer.cancel()
            self.destroy_timer(self._discovery_timer)
            self._discovery_timer = self.create_timer(float(changed["discovery_period"]), self._discover,
                                                      callback_group=MutuallyExclusiveCallbackGroup())
        self.get_logger().info(f"applied {', '.join(f'{k}={v}' for k, v in changed.items())}")

    # ------------------------------------------------------------------ inputs
    def _on_joint_state(self, msg: JointState) -> None:
        stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        self.viewer.on_joint_state(msg.name, msg.position, stamp if stamp > 0 else None)

    def _on_scene(self, msg: String) -> None:
        try:
            self.viewer.on_scene(msg.data)
        except (MessageError, ValueError) as exc:
            self.get_logger().warning(f"ignored a malformed /planning_server/monitored_planning_scene: {exc}")

    def _on_planned_path(self, msg: JointTrajectoryMsg) -> None:
        try:
            trajectory = joint_trajectory_from_msg(msg)
        except (MessageError, ValueError) as exc:
            self.get_logger().warning(f"ignored a malformed /planned_path: {exc}")
            return
        if trajectory.points:
            self.viewer.on_planned_path(trajectory)

    def _discover(self) -> None:
        """Subscribe to task topics that appeared since the last look."""
        for topic, types in self.get_topic_names_and_types():
            if topic in self._task_subscriptions or STRING_TYPE not in types:
                continue
            parsed = parse_task_topic(topic)
            if parsed is None:
                continue
            source, kind = parsed
            qos = SOLUTION_QOS if kind == "solution" else STATISTICS_QOS
            self._task_subscriptions[topic] = self.create_subscription(
                String, topic, lambda msg, s=source, k=kind, t=topic: self._on_task(s, k, t, msg), qos,
                callback_group=self._task_group)
            self.get_logger().info(f"following task {kind} of {source} ({topic})")

    def _on_task(self, source: str, kind: str, topic: str, msg: String) -> None:
        cls = next(c for k, c in TASK_SUFFIXES.values() if k == kind)
        try:
            message = cls.from_json(msg.data)
        except (MessageError, ValueError) as exc:
            self.get_logger().warning(f"ignored a malformed message on {topic}: {exc}")
            return
        {"description": self.viewer.on_task_description, "statistics": self.viewer.on_task_statistics,
         "solution": self.viewer.on_task_solution}[kind](source, message)

    # ------------------------------------------------------------------ JSON-RPC
    def _sync(self, action) -> dict:
        action()
        self.viewer.wait_idle()
        return self.viewer.state()

    def _rpc_select(self, params: dict) -> dict:
        task, stage, solution = params.get("task"), params.get("stage"), params.get("solution", 0)
        if not isinstance(solution, int) or isinstance(solution, bool) or solution < 0:
            raise RpcError(BAD_REQUEST, f"'solution' must be an index >= 0, got {solution!r}")
        try:
            self.viewer.select(task, stage, solution)
        except ValueError as exc:
            raise RpcError(BAD_REQUEST, str(exc)) from None
        self.viewer.wait_idle()
        return self.viewer.state()

    def _rpc_seek(self, params: dict) -> dict:
        t = params.get("time")
        if isinstance(t, bool) or not isinstance(t, (int, float)):
            raise RpcError(BAD_REQUEST, f"'time' must be a number of seconds, got {t!r}")
        return self._sync(lambda: self.viewer.seek(float(t)))

    def _rpc_objectives_click(self, params: dict) -> dict:
        """A click on the Objectives panel, as the page makes it: {"button": "run" (with
        "objective") | "stop" | "continue" | "fail" | "waypoint" (with "waypoint")}."""
        panel = self.viewer.objectives
        if panel is None:
            raise RpcError(BAD_REQUEST, "the Objectives panel is off (objective_server parameter empty)")
        button = params.get("button")
        if button == "run":
            panel.click_run(str(params.get("objective", "")) or None)
        elif button == "stop":
            panel.click_stop()
        elif button in ("continue", "fail", "waypoint"):
            panel.click_answer(button, params.get("waypoint"))
        else:
            raise RpcError(BAD_REQUEST, f"objectives_click: unknown button {button!r}; "
                                        "run, stop, continue, fail or waypoint")
        return panel.state()

    def _rpc_lags(self, params: dict) -> dict:
        lags = self.viewer.display_lags(reset=bool(params.get("reset", False)))
        state = self.viewer.state()["joint_states"]
        return {"lags_ms": [round(v * 1000.0, 4) for v in lags], "received": state["received"],
                "applied": state["applied"]}

    def close(self) -> None:
        self._monitor_spin.stop()
        self.viewer.close()


def _default_teleop_group(model: Any) -> str:
    """'arm' when the robot has it (our configurations), else the group with the most joints
    among those that do not contain another group (a composite arm + hand group is not an arm:
    the Panda's panda_arm, not panda_arm_hand)."""
    if model.has_group("arm"):
        return "arm"
    joints = {n: set(model.group(n).joint_names) for n in model.group_names}
    simple = [n for n in joints if not any(m != n and joints[m] < joints[n] for m in joints)] or list(joints)
    if not simple:
        return "arm"  # TeleopView names the problem
    return min(simple, key=lambda n: (-len(joints[n]), n))
