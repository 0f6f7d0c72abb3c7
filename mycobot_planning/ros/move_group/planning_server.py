"""planning_server: the move_group stand-in (thin rclpy shell around move_group's capabilities).

The full story: docs/nodes.md, section mycobot_planning.ros.move_group.planning_server.
"""
from __future__ import annotations

import math
import threading
import time
import traceback
from typing import Any, Callable, Mapping

import numpy as np
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.exceptions import ParameterException
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory as JointTrajectoryMsg
from visualization_msgs.msg import Marker, MarkerArray

from interfaces_py.background_spin import BackgroundSpin
from interfaces_py.json_rpc import BAD_REQUEST, JsonRpcServer, RpcError, decode_request, log_safe
from interfaces_py.msgs import CollisionObject, JointTrajectory, MoveItErrorCode
from interfaces_py.ros_conversions import collision_object_to_markers, joint_trajectory_to_msg
from mycobot_planning.capabilities import stop, trajectory_cache
from mycobot_planning.capabilities.json_face import (
    MoveGroupJsonFace,
    PlanningDefaults,
    RequestError,
    goal_from_parameters,
)
from mycobot_planning.behavior_tree.behaviors.waypoints import WaypointStore
from mycobot_planning.core.jit_warm_up import warm_up
from mycobot_planning.core.planning_interface.planning_workers import PlanningSetup, PlanningWorkers
from mycobot_planning.core.robot_model.robot_config import RobotConfig
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.trajectory_cache import TrajectoryCacheError
from mycobot_planning.core.trajectory_execution import ExecutionSettings, load_controllers
from mycobot_planning.ros import fast_log
from mycobot_planning.ros.dedicated_service import after_response
from mycobot_planning.ros.move_group.controller_bus import ActionControllerBus
from mycobot_planning.core.warehouse.robot_state_storage import RobotStateStorage
from mycobot_planning.ros.move_group.move_group import MoveGroupFace
from mycobot_planning.ros.move_group.planning_server_parameters import planning_server_parameter_specs
from mycobot_planning.ros.move_group.warehouse_services import WarehouseServices
from mycobot_planning.ros.move_group.waypoint_methods import WaypointMethods
from mycobot_planning.ros.node_runtime import Parameters, ParameterSpec, load_yaml_file
from mycobot_planning.ros.topic_reader import TopicReader
from mycobot_planning.paths import config_dir, config_file, package_share_dirs

NODE_NAME = "planning_server"
LATCHED_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
INPUT_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
STATE_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
COMMAND_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
JOINT_STATES_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
# s: scene changes are published at most this often (a burst of updates is one publication, so an
# update is answered without waiting for a full-scene serialisation)
PUBLISH_CHECK_PERIOD = 0.1
#: s between two readings of /joint_states while the robot stands still (every message otherwise)
JOINT_STATES_IDLE_PERIOD = 0.05
#: s after the last change of the joints during which every /joint_states message is read
JOINT_STATES_FOLLOW = 2.0
MARKER_FOLLOW_PERIOD = 0.1  # s: how often attached-object markers follow the moving robot
DISPLAY_DELAY = 0.02  # s from a plan to its /display_planned_path and /planned_path messages
DISPLAY_SUBSCRIBER_POLL = 0.25  # s between looks for a first /planned_path subscriber of a kept plan
WORLD_COLOR = (0.5, 0.7, 1.0, 1.0)
ATTACHED_COLOR = (0.6, 0.3, 0.8, 1.0)
GOAL_TARGETS = ("goal.named_target", "goal.joint_values", "goal.pose")


# ---------------------------------------------------------------------------- parameters
def _declare(node: Node, specs: list[ParameterSpec]) -> Parameters:
    """Parameters(node, specs), with rclpy's own refusal of an override (a value outside a
    declared range, a wrong type) turned into the ValueError run_node reports in one line."""
    try:
        return Parameters(node, specs)
    except ParameterException as exc:
        raise ValueError(f"invalid parameters: {exc}") from None


# ---------------------------------------------------------------------------- the node
class PlanningServer(Node):
    """See docs/nodes.md (mycobot_planning.ros.move_group.planning_server)."""

    def __init__(self) -> None:
        super().__init__(NODE_NAME)
        log = self.get_logger()
        self._config = _declare(self, [
            ParameterSpec("robot_config", "",
                          "robot configuration directory (the setup assistant's output, or a folder with one URDF "
                          "and one SRDF): the robot, joint limits, kinematics, OMPL and controllers files come from "
                          "it where the parameters below leave them empty; empty: the package's myCobot 280",
                          read_only=True),
            ParameterSpec("robot_description", "", "URDF of the robot (XML text); empty: the package's myCobot 280",
                          read_only=True),
            ParameterSpec("robot_description_semantic", "", "SRDF of the robot (XML text); empty: the package's",
                          read_only=True),
            ParameterSpec("joint_limits_file", "", "joint_limits.yaml (MoveIt format); empty: config/joint_limits.yaml",
                          read_only=True),
            ParameterSpec("kinematics_file", "", "kinematics.yaml; empty: config/kinematics.yaml", read_only=True),
            ParameterSpec("ompl_planning_file", "", "ompl_planning.yaml; empty: config/ompl_planning.yaml",
                          read_only=True),
            ParameterSpec("pilz_cartesian_limits_file", "",
                          "pilz_cartesian_limits.yaml; empty: config/pilz_cartesian_limits.yaml", read_only=True),
            ParameterSpec("controllers_file", "",
                          "controllers YAML (ros2_control or MoveIt layout); empty: config/controllers.yaml",
                          read_only=True),
            ParameterSpec("planning_processes", 0,
                          "worker processes that plan (each loads the robot and the planners once, about 1-2 s in "
                          "the background): concurrent plan requests then use several cores; 0: plans run in the "
                          "server's threads, which share one core", range=(0, 64), read_only=True),
            ParameterSpec("parallel_planning_attempts", True,
                          "with planning_processes: a request of several OMPL attempts (num_planning_attempts) "
                          "is split between the worker processes free when it comes, as MoveIt runs attempts in "
                          "parallel; the answer is the one planning them in turn gives (the shortest path, the "
                          "earlier attempt on ties)", read_only=True),
            ParameterSpec("warehouse_host", ":memory:",
                          "SQLite database file of the warehouse robot states (/save_robot_state, ...), as "
                          "warehouse_ros_sqlite reads warehouse_host; '~' expands; ':memory:' (the default) keeps "
                          "them only while the server runs", non_empty=True, read_only=True),
            ParameterSpec("trajectory_cache.db_path", ":memory:",
                          "SQLite database file of the trajectory cache (MoveIt's trajectory_cache; a file of its "
                          "own, created if missing, refused if it holds anything else); '~' expands; ':memory:' "
                          "(the default) keeps entries only while the server runs", non_empty=True, read_only=True),
            ParameterSpec("waypoints_file", "",
                          "YAML file of saved waypoints (MoveIt Pro's format) the waypoint methods of "
                          "/planning_server/rpc read and write; empty: the package's myCobot waypoints for the "
                          "package's robot, none (kept in memory) for another", read_only=True),
        ])
        self._robot_config = RobotConfig.load(self._config.get("robot_config")) if self._config.get("robot_config") \
            else None
        model = self._load_model()
        for warning in model.load_warnings:
            log.warning(warning)
        setup = self._planning_setup()
        pipeline = setup.planning_pipeline()
        controllers = load_controllers(self._config_path("controllers_file", "moveit_controllers"))
        processes = int(self._config.get("planning_processes"))
        self._workers = PlanningWorkers(pipeline, setup, processes, log=self._log,
                                        parallel_attempts=bool(self._config.get("parallel_planning_attempts"))) \
            if processes else None
        self._params = _declare(self, planning_server_parameter_specs(model, pipeline, self._goal_group))

        # The high-rate streams (/joint_states and the controllers' states, 100 Hz each) are
        # served by a second node on a single-threaded executor of its own: rclpy's
        # multi-threaded executor re-polls entities whose callbacks are queued, which costs a
        # whole CPU core at these rates, and it would also delay requests behind joint states.
        self._monitor = Node(f"{NODE_NAME}_state_monitor", context=self.context)
        self._monitor_executor = SingleThreadedExecutor(context=self.context)
        self._monitor_executor.add_node(self._monitor)
        self._bus = ActionControllerBus(self, self._monitor, controllers, self._on_feedback)
        self.core = MoveGroupJsonFace(model, pipeline, controllers, self._bus, self._execution_settings(),
                                       self._planning_defaults(), log=self._log, workers=self._workers)
        try:  # opened even while disabled: a bad database file is reported at start, not on enabling
            trajectory_cache.configure(self.core, self._trajectory_cache_settings())
        except TrajectoryCacheError as exc:
            raise ValueError(f"trajectory_cache.db_path: {exc}") from None
        self._goal_last_set: str | None = None
        self._params.on_change(self._on_params)

        self._publish_lock = threading.Lock()
        self._scene_pub = self.create_publisher(String, "/planning_server/monitored_planning_scene", LATCHED_QOS)
        self._marker_pub = self.create_publisher(MarkerArray, "/planning_scene_markers", LATCHED_QOS)
        self._display_pub = self.create_publisher(JointTrajectoryMsg, "/planned_path", LATCHED_QOS)
        self._marker_positions: np.ndarray | None = None
        self._marker_time = 0.0
        self._world_markers: list[Marker] = []
        self._scene_dirty = threading.Event()
        self.core.scene_listeners.append(self._scene_dirty.set)
        # Planned paths are published by a thread of their own, DISPLAY_DELAY after the plan: the
        # planning client's answer goes out first (the two display messages would otherwise
        # compete with it for the interpreter); the newest plan wins if several queue up.
        self._display_next: JointTrajectory | None = None
        self._display_wake = threading.Condition()
        self._display_stop = False  # close(): the thread ends before the publisher is destroyed
        self._display_thread = threading.Thread(target=self._display_loop, name="display publisher", daemon=True)
        self._display_thread.start()
        self.core.trajectory_listeners.append(self._queue_display)

        self._input_group = MutuallyExclusiveCallbackGroup()
        self._service_group = ReentrantCallbackGroup()
        self._js_problem_logged = 0.0
        # /joint_states is read by a thread of its own (see _joint_state_loop), not the executor
        self._joint_states = TopicReader(self._monitor, JointState, "/joint_states", 1)
        self._monitor_stop = threading.Event()
        self._joint_state_thread = threading.Thread(target=self._joint_state_loop, name="current state monitor",
                                                    daemon=True)
        self._joint_state_thread.start()
        self.create_subscription(String, "/planning_server/planning_scene", self._on_planning_scene, INPUT_QOS,
                                 callback_group=self._input_group)
        self.create_subscription(String, "/planning_server/collision_object", self._on_collision_object, INPUT_QOS,
                                 callback_group=self._input_group)
        self.create_subscription(String, "/planning_server/attached_collision_object", self._on_attached_object, INPUT_QOS,
                                 callback_group=self._input_group)

        for name, handler in (("plan", self._srv_plan), ("execute", self._srv_execute),
                              ("plan_and_execute", self._srv_plan_and_execute), ("stop", self._srv_stop),
                              ("get_planning_scene", self._srv_get_planning_scene)):
            self.create_service(Trigger, f"~/{name}", handler, callback_group=self._service_group)

        self._rpc = JsonRpcServer(self)
        for method, handler in {
            "get_planning_scene": self._rpc_get_planning_scene,
            "apply_planning_scene": self._rpc_apply_planning_scene,
            "apply_collision_object": self._rpc_apply_collision_object,
            "attach_object": self._rpc_attach_object,
            "detach_object": self._rpc_detach_object,
            "get_objects": self._rpc_get_objects,
            "plan": lambda p: self.core.plan(p),
            "execute": lambda p: self.core.execute(p),
            "plan_and_execute": lambda p: self.core.plan_and_execute(p),
            "compute_cartesian_path": lambda p: self.core.compute_cartesian_path(p),
            "execute_task_solution": lambda p: self.core.execute_task_solution(p),
            "stop": self._rpc_stop,
            "get_state": self._rpc_get_state,
            **WaypointMethods(self.core, self._waypoint_store(model), lambda: self._params.get("goal.group")).methods(),
        }.items():
            self._rpc.register(method, handler)

        self._publish_scene()
        self.move_group = MoveGroupFace(self.core, *self._model_sources(), self.context, self._log)
        # Scene publication on a thread of its own, woken by changes (no executor timers: each
        # wake-up of the executor rebuilds its wait set over every service and action, 2 % of a
        # core idle at 12 wake-ups a second)
        self._scene_stop = threading.Event()
        self._scene_thread = threading.Thread(target=self._scene_loop, name="scene publisher", daemon=True)
        self._scene_thread.start()
        self.extra_nodes = [self.move_group]
        # MoveIt's warehouse services run beside move_group; ours on the move_group node
        self.warehouse = WarehouseServices(self.move_group, RobotStateStorage(self._config.get("warehouse_host")),
                                           self._log)
        self.move_group.publish_scene()
        self._monitor_spin = BackgroundSpin(self._monitor_executor, name="state monitor")
        self._warm_up(model)
        log.info(
            f"planning_server ready: robot '{model.name}', groups {model.group_names}, pipelines "
            f"{pipeline.pipeline_ids}, controllers "
            + ", ".join(f"{c.name} {list(c.joints)}" for c in controllers)
        )

    # ------------------------------------------------------------------ set-up
    def _warm_up(self, model: RobotModel) -> None:
        """What the first plan would otherwise pay out of its allowed_planning_time (the compiled
        kernels loaded, each group's once-per-model tables: core/jit_warm_up.py), done before
        the server says it is ready."""
        try:
            seconds = warm_up(model)
        except Exception as exc:  # a warm-up problem only costs the first request time
            self.get_logger().warning(f"warm-up skipped ({type(exc).__name__}: {exc}): the first plan pays for it")
            return
        self.get_logger().info(f"warmed up in {seconds:.2f} s (compiled kernels, each group's tables)")

    def _config_path(self, parameter: str, config_key: str) -> str | None:
        """A file parameter's value, else the robot_config directory's file of that kind, else None
        (the package's default)."""
        given = self._config.get(parameter)
        if given:
            return given
        found = getattr(self._robot_config, config_key) if self._robot_config is not None else None
        return str(found) if found is not None else None

    def _model_sources(self) -> tuple[str, str, dict | None, dict | None]:
        """URDF, SRDF, joint limits and kinematics as the parameters give them (the package's
        myCobot 280 files where none is given)."""
        urdf = self._config.get("robot_description")
        srdf = self._config.get("robot_description_semantic")
        if srdf and not urdf:
            raise ValueError("robot_description_semantic is set but robot_description (the URDF) is empty")
        if not urdf and self._robot_config is not None:
            urdf, srdf = self._robot_config.urdf.read_text(), self._robot_config.srdf.read_text()
        limits = load_yaml_file(self._config_path("joint_limits_file", "joint_limits"), "joint limits file")
        kinematics = load_yaml_file(self._config_path("kinematics_file", "kinematics"), "kinematics file")
        if not urdf:
            urdf = config_file("mycobot_280.urdf").read_text()
            srdf = config_file("mycobot_280.srdf").read_text()
            limits = limits if limits is not None else load_yaml_file(str(config_file("joint_limits.yaml")), "joint limits")
            kinematics = kinematics if kinematics is not None else load_yaml_file(
                str(config_file("kinematics.yaml")), "kinematics")
        return urdf, srdf or '<robot name=""/>', limits, kinematics

    def _waypoint_store(self, model: RobotModel) -> WaypointStore:
        """The waypoints_file's store (the package's myCobot waypoints by default), positions
        checked against the model's joint limits."""
        path = self._config.get("waypoints_file")
        if not path and self._is_package_robot():
            path = str(config_dir() / "waypoints" / "mycobot_waypoints.yaml")
        limits = {n: (float(lo), float(hi)) for n, lo, hi in zip(model.variable_names, model.lower_limits,
                                                                 model.upper_limits)}
        return WaypointStore(path or None, limits)

    def _is_package_robot(self) -> bool:
        """Whether the robot is the package's own myCobot 280 (no robot parameter given)."""
        return self._robot_config is None and not any(self._config.get(name) for name in (
            "robot_description", "robot_description_semantic", "joint_limits_file", "kinematics_file"))

    def _load_model(self) -> RobotModel:
        return self._planning_setup().robot_model()

    def _planning_setup(self) -> PlanningSetup:
        """What a planning worker process loads: this server's robot and planner files."""
        ompl = self._config_path("ompl_planning_file", "ompl_planning")
        cartesian = self._config.get("pilz_cartesian_limits_file") or None
        if self._is_package_robot():
            return PlanningSetup(ompl_config=ompl, cartesian_limits=cartesian)
        urdf, srdf, limits, kinematics = self._model_sources()
        dirs = tuple(str(d) for d in (*(self._robot_config.package_dirs if self._robot_config else ()),
                                      *package_share_dirs()))
        return PlanningSetup(urdf, srdf, limits, kinematics, dirs, ompl, cartesian)

    def _goal_group(self) -> str:
        params = getattr(self, "_params", None)  # None while the parameters are being declared
        return params.get("goal.group") if params is not None else "arm"

    def _execution_settings(self) -> ExecutionSettings:
        ex = "trajectory_execution."
        return ExecutionSettings(
            allowed_execution_duration_scaling=float(self._params.get(ex + "allowed_execution_duration_scaling")),
            allowed_goal_duration_margin=float(self._params.get(ex + "allowed_goal_duration_margin")),
            allowed_start_tolerance=float(self._params.get(ex + "allowed_start_tolerance")),
            execution_duration_monitoring=bool(self._params.get(ex + "execution_duration_monitoring")),
            goal_tolerance=float(self._params.get(ex + "goal_tolerance")),
            joint_state_timeout=float(self._params.get("joint_state_timeout")),
            limit_tolerance=float(self._params.get(ex + "limit_tolerance")),
            max_waypoint_distance=float(self._params.get(ex + "max_waypoint_distance")),
        )

    def _planning_defaults(self) -> PlanningDefaults:
        return PlanningDefaults(
            pipeline_id=self._params.get("planning_pipeline"),
            planner_id=self._params.get("planner_id"),
            planning_time=float(self._params.get("planning_time")),
            num_planning_attempts=int(self._params.get("planning_attempts")),
            max_velocity_scaling_factor=float(self._params.get("max_velocity_scaling_factor")),
            max_acceleration_scaling_factor=float(self._params.get("max_acceleration_scaling_factor")),
            sample_period=float(self._params.get("trajectory_sample_period")),
        )

    def _trajectory_cache_settings(self) -> trajectory_cache.TrajectoryCacheSettings:
        tc = "trajectory_cache."
        return trajectory_cache.TrajectoryCacheSettings(
            enabled=bool(self._params.get(tc + "enabled")),
            db_path=self._config.get(tc + "db_path"),
            cache_namespace=self._params.get(tc + "cache_namespace"),
            start_tolerance=float(self._params.get(tc + "start_tolerance")),
            goal_tolerance=float(self._params.get(tc + "goal_tolerance")),
            exact_match_precision=float(self._params.get(tc + "exact_match_precision")),
            cache_insert_policy=self._params.get(tc + "cache_insert_policy"),
            prune_worse_trajectories=bool(self._params.get(tc + "prune_worse_trajectories")),
            num_additional_trajectories_to_preserve_when_pruning_worse=int(
                self._params.get(tc + "num_additional_trajectories_to_preserve_when_pruning_worse")),
        )

    def _on_params(self, changed: dict[str, Any]) -> None:
        self.core.settings = self._execution_settings()
        self.core.defaults = self._planning_defaults()
        if any(name.startswith("trajectory_cache.") for name in changed):
            try:  # the parameters were checked when set: this only fails on a bug
                trajectory_cache.configure(self.core, self._trajectory_cache_settings())
            except TrajectoryCacheError as exc:
                self.get_logger().error(f"trajectory cache settings not applied: {exc}")
        for name in GOAL_TARGETS:
            if name in changed and changed[name]:
                self._goal_last_set = name
        if "scene_publish_rate" in changed:
            self._scene_dirty.set()  # the scene thread reads the new rate at once
        self.get_logger().info("parameters set: " + ", ".join(f"{k}={v!r}" for k, v in changed.items()))

    def _log(self, level: str, text: str) -> None:
        # Texts may echo request strings: log_safe escapes what rclpy's logging cannot encode.
        # fast_log: rclpy's own logger.info costs most of a millisecond a line (issue 26's overhead);
        # in a service handler an info line is written once the response is sent (after_response),
        # warnings and errors at once
        severe = level in ("error", "warning")
        fast_log.log(self.get_logger(), level if severe else "info", log_safe(text, limit=8000), depth=2,
                     defer=None if severe else after_response)

    def _on_feedback(self) -> None:
        self.core.executor.notify()

    def begin_shutdown(self) -> None:
        """SIGINT/SIGTERM (node_runtime.run_node, rclpy still up): cancel every running plan and
        stop the running execution; their goals end PREEMPTED and answer their clients."""
        self.get_logger().info("shutting down: stopping running plans and executions, refusing new ones")
        stop.shut_down(self.core)

    def busy(self) -> bool:
        """A plan, an execution or an action goal still running (its client not answered yet)."""
        return bool(self.core.executor.executing or self.core.running_plans() or self.move_group.active_goals())

    def close(self) -> None:
        """On shutdown: stop a running execution so the controllers hold where they are, then
        stop the state monitor."""
        if self.core.executor.executing:
            self.core.stop()
            deadline = time.monotonic() + 1.0  # let the execution send its stop commands
            while self.core.executor.executing and time.monotonic() < deadline:
                time.sleep(0.01)
        self._scene_stop.set()
        self._scene_dirty.set()
        self._scene_thread.join(1.0)
        with self._display_wake:
            self._display_stop = True
            self._display_wake.notify()
        self._display_thread.join(1.0)
        self._monitor_stop.set()
        self._joint_states.wake()
        self._joint_state_thread.join(1.0)
        self._joint_states.destroy()
        self._bus.close()
        self._monitor_spin.stop()
        self._monitor.destroy_node()
        self.move_group.close()
        self.warehouse.storage.close()
        if self.core.trajectory_cache is not None:
            self.core.trajectory_cache.cache.close()
        self.move_group.destroy_node()
        if self._workers is not None:
            self._workers.close()

    # ------------------------------------------------------------------ publishing
    def _publish_scene(self) -> None:
        """Publish the monitored scene (JSON and moveit_msgs) and the markers (periodically and after changes)."""
        with self._publish_lock:
            self._scene_dirty.clear()
            msg, attached = self.core.scene_snapshot()
            self._scene_pub.publish(String(data=msg.to_json()))
            self._publish_markers_locked(msg.world.collision_objects, attached, msg.robot_state.positions)
        if getattr(self, "move_group", None) is not None:
            self.move_group.publish_scene()

    def _publish_markers_locked(self, world: list[CollisionObject] | None, attached: list[CollisionObject],
                                positions: list[float]) -> None:
        """One MarkerArray: DELETEALL, then every object (world markers reused when ``world`` is None)."""
        stamp = self.get_clock().now().to_msg()
        clear = Marker()
        clear.action = Marker.DELETEALL
        if world is not None:
            self._world_markers = [m for obj in world for m in collision_object_to_markers(
                obj, ns=f"world_objects/{obj.id}", id_start=0, color=WORLD_COLOR, stamp=stamp)]
        markers = [clear] + self._world_markers
        for obj in attached:
            markers += collision_object_to_markers(obj, ns=f"attached_objects/{obj.id}", id_start=0,
                                                   color=ATTACHED_COLOR, stamp=stamp)
        self._marker_pub.publish(MarkerArray(markers=markers))
        self._marker_positions = np.asarray(positions, dtype=float)
        self._marker_time = time.monotonic()

    def _scene_loop(self) -> None:
        """Publish the scene on every change (the scene listeners set _scene_dirty) and every
        1 / scene_publish_rate s; while the robot carries objects, check every
        PUBLISH_CHECK_PERIOD s whether their markers must follow it."""
        last_full = time.monotonic()
        while not self._scene_stop.is_set():
            next_full = last_full + 1.0 / float(self._params.get("scene_publish_rate"))  # a new rate applies at once
            wait = max(0.0, next_full - time.monotonic())
            if self.core.has_attached_objects():
                wait = min(wait, PUBLISH_CHECK_PERIOD)
            self._scene_dirty.wait(wait)
            if self._scene_stop.is_set() or not self.context.ok():
                return
            try:
                if time.monotonic() >= next_full:
                    self._publish_scene()
                    last_full = time.monotonic()
                else:
                    self._publish_changes()
            except Exception as exc:  # a context shut down under us, or a conversion bug: say so, go on
                if self._scene_stop.is_set() or not self.context.ok():
                    return
                self.get_logger().error(f"publishing the planning scene failed: {type(exc).__name__}: {exc}")
                self._scene_stop.wait(PUBLISH_CHECK_PERIOD)

    def _publish_changes(self) -> None:
        """Publish the scene if it changed; else republish the markers when the robot carries
        objects and has moved (attached objects move with their link)."""
        if self._scene_dirty.is_set():
            self._publish_scene()
            return
        if time.monotonic() - self._marker_time < MARKER_FOLLOW_PERIOD or not self.core.has_attached_objects():
            return
        with self._publish_lock:
            positions, attached = self.core.attached_snapshot()
            last = self._marker_positions
            if last is None or last.shape != (len(positions),) or not np.allclose(last, positions, atol=1e-6, rtol=0):
                self._publish_markers_locked(None, attached, positions)  # world markers unchanged

    def _queue_display(self, trajectory: JointTrajectory) -> None:
        # a service's plan: the display thread is woken once the response is sent
        if not after_response(lambda: self._queue_display_now(trajectory)):
            self._queue_display_now(trajectory)

    def _queue_display_now(self, trajectory: JointTrajectory) -> None:
        with self._display_wake:
            self._display_next = trajectory
            self._display_wake.notify()

    def _display_loop(self) -> None:
        """Publishes each plan (the newest, if several queued) DISPLAY_DELAY after it. With nobody
        subscribed to /planned_path nothing is built (a few ms per plan); the plan is kept, and
        sent when a subscriber appears (looked for every DISPLAY_SUBSCRIBER_POLL s), so a late
        subscriber still gets the last plan, as the latched topic promises."""
        unsent: JointTrajectory | None = None
        while True:
            with self._display_wake:
                while (not self._display_stop and self._display_next is None
                       and (unsent is None or not self._display_listened())):
                    self._display_wake.wait(None if unsent is None else DISPLAY_SUBSCRIBER_POLL)
                if self._display_stop:
                    return
                fresh = self._display_next is not None
            if fresh:
                with self._display_wake:
                    self._display_wake.wait_for(lambda: self._display_stop, DISPLAY_DELAY)
            with self._display_wake:
                if self._display_stop:
                    return
                trajectory = self._display_next if self._display_next is not None else unsent
                self._display_next = None
            unsent = None
            try:
                if self._display_listened():
                    self._display_pub.publish(joint_trajectory_to_msg(trajectory, self.get_clock().now().to_msg()))
                else:
                    unsent = trajectory
                if fresh and getattr(self, "move_group", None) is not None:
                    self.move_group.publish_display(trajectory)  # (built only for a subscriber, not latched)
            except Exception as exc:  # a context shut down under us, or a conversion bug: say so, go on
                if not self.context.ok():
                    return
                self.get_logger().error(f"publishing the planned path failed: {type(exc).__name__}: {exc}")

    def _display_listened(self) -> bool:
        return self._display_pub.get_subscription_count() > 0

    # ------------------------------------------------------------------ topic inputs
    def _joint_state_loop(self) -> None:
        """The current state monitor: every /joint_states message while the robot moves (its
        positions changed within JOINT_STATES_FOLLOW s) or an execution runs, the newest one every
        JOINT_STATES_IDLE_PERIOD s while it stands still. At 100 Hz, taking every message of a
        robot standing still cost the idle node most of its 10-15 % of a core."""
        last: list[float] | None = None
        moved_at = -math.inf
        while not self._monitor_stop.is_set():
            try:
                if self.core.executor.executing or time.monotonic() - moved_at < JOINT_STATES_FOLLOW:
                    self._joint_states.wait(JOINT_STATES_IDLE_PERIOD)
                elif self._monitor_stop.wait(JOINT_STATES_IDLE_PERIOD):
                    return
                msg = self._joint_states.take_latest()
                if msg is None:
                    continue
                positions = msg.position.tolist() if hasattr(msg.position, "tolist") else list(msg.position)
                if positions != last:
                    last, moved_at = positions, time.monotonic()
                self._on_joint_state(msg)
            except Exception as exc:  # a context shut down under us, or a bug: say so, go on
                if self._monitor_stop.is_set() or not self.context.ok():
                    return
                self.get_logger().error(f"current state monitor: {type(exc).__name__}: {exc}")
                self._monitor_stop.wait(JOINT_STATES_IDLE_PERIOD)

    def _on_joint_state(self, msg: JointState) -> None:
        problem = self.core.update_joint_state(msg.name, msg.position)
        if problem is not None:
            now = time.monotonic()
            if now - self._js_problem_logged > 5.0:  # at 100 Hz, say it once in a while
                self._js_problem_logged = now
                self.get_logger().warning(f"ignoring /joint_states message: {problem}")

    def _topic_update(self, topic: str, msg: String, apply: Callable[[Any], Any]) -> None:
        """Decode (checked at the boundary like a request) and apply one scene update; a bad one
        is logged and changes nothing."""
        try:
            apply(decode_request(msg.data, f"message on {topic}"))
        except (RequestError, RpcError) as exc:
            self._log("warning", f"refused update on {topic}: {exc.message}")
        except Exception as exc:  # never let a bad message take the node down
            self._log("error", f"update on {topic} failed: {type(exc).__name__}: {exc}\n{traceback.format_exc()}")

    def _on_planning_scene(self, msg: String) -> None:
        self._topic_update("/planning_server/planning_scene", msg, self.core.apply_planning_scene)

    def _on_collision_object(self, msg: String) -> None:
        self._topic_update("/planning_server/collision_object", msg, lambda data: self.core.apply_collision_objects([data]))

    def _on_attached_object(self, msg: String) -> None:
        self._topic_update("/planning_server/attached_collision_object", msg, self.core.apply_attached_collision_object)

    # ------------------------------------------------------------------ Trigger services
    @staticmethod
    def _trigger(response: Trigger.Response, result: Mapping[str, Any], detail: str = "") -> Trigger.Response:
        code = MoveItErrorCode.from_dict(result["error_code"])
        response.success = bool(code)
        response.message = f"{code.name}: {detail or code.message}" if detail or code.message else code.name
        return response

    def _goal_request(self, response: Trigger.Response, what: str) -> dict[str, Any] | None:
        """The plan request the goal.* parameters describe; None (and ``response`` filled) if they
        do not describe one."""
        values = {k.split(".", 1)[1]: self._params.get(k)
                  for k in ("goal.group", "goal.named_target", "goal.joint_values", "goal.pose", "goal.link")}
        last = self._goal_last_set.split(".", 1)[1] if self._goal_last_set else None
        try:
            return goal_from_parameters(values, last)
        except RequestError as exc:
            response.success, response.message = False, f"INVALID_GOAL_CONSTRAINTS: {exc.message}"
            self.get_logger().warning(f"{what} refused: {exc.message}")
            return None

    def _srv_plan(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        params = self._goal_request(response, "plan")
        if params is None:
            return response
        result = self.core.plan(params)
        goal = params["goal"]
        target = (f"named target '{goal['named']}'" if "named" in goal else
                  f"joint values {goal['joints']}" if "joints" in goal else f"pose {goal['pose']}")
        detail = ""
        if result["trajectory"] is not None:
            points = result["trajectory"]["joint_trajectory"]["points"]
            detail = (f"planned '{params['group']}' to {target}: {points[-1]['time_from_start']:.3f} s trajectory, "
                      f"{len(points)} points, planning time {result['planning_time']:.3f} s")
        return self._trigger(response, result, detail)

    def _srv_execute(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        return self._trigger(response, self.core.execute({}))

    def _srv_plan_and_execute(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        params = self._goal_request(response, "plan_and_execute")
        if params is None:
            return response
        return self._trigger(response, self.core.plan_and_execute(params))

    def _srv_stop(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        result = self.core.stop()
        response.success = True
        response.message = result["message"]
        return response

    def _srv_get_planning_scene(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        response.success = True
        response.message = self.core.scene_msg().to_json()
        return response

    # ------------------------------------------------------------------ JSON-RPC
    @staticmethod
    def _check_keys(params: Mapping[str, Any], allowed: set[str], method: str) -> None:
        unknown = sorted(set(params) - allowed)
        if unknown:
            raise RpcError(BAD_REQUEST, f"{method}: unknown parameters {unknown}; known: {sorted(allowed)}")

    @staticmethod
    def _scene_rpc(fn: Callable[[], Any]) -> Any:
        try:
            return fn()
        except RequestError as exc:
            raise RpcError(exc.code, exc.message) from None

    def _rpc_get_planning_scene(self, params: Mapping[str, Any]) -> Any:
        self._check_keys(params, set(), "get_planning_scene")
        return self.core.get_planning_scene()

    def _rpc_apply_planning_scene(self, params: Mapping[str, Any]) -> Any:
        self._check_keys(params, {"scene"}, "apply_planning_scene")
        if "scene" not in params:
            raise RpcError(BAD_REQUEST, "apply_planning_scene needs a 'scene' (PlanningScene)")
        return self._scene_rpc(lambda: self.core.apply_planning_scene_json(params["scene"]))

    def _rpc_apply_collision_object(self, params: Mapping[str, Any]) -> Any:
        self._check_keys(params, {"object", "objects"}, "apply_collision_object")
        if ("object" in params) == ("objects" in params):
            raise RpcError(BAD_REQUEST, "apply_collision_object needs either 'object' or 'objects' (a list)")
        objects = [params["object"]] if "object" in params else params["objects"]
        return self._scene_rpc(lambda: self.core.apply_collision_objects(objects))

    def _rpc_attach_object(self, params: Mapping[str, Any]) -> Any:
        self._check_keys(params, {"object_id", "link_name", "touch_links", "weight", "attached_object"},
                         "attach_object")
        if "attached_object" in params:
            return self._scene_rpc(lambda: self.core.apply_attached_collision_object(params["attached_object"]))
        return self._scene_rpc(lambda: self.core.attach_object(
            params.get("object_id"), params.get("link_name") or None, params.get("touch_links"),
            params.get("weight", 0.0)))

    def _rpc_detach_object(self, params: Mapping[str, Any]) -> Any:
        self._check_keys(params, {"object_id"}, "detach_object")
        return self._scene_rpc(lambda: self.core.detach_object(params.get("object_id")))

    def _rpc_get_objects(self, params: Mapping[str, Any]) -> Any:
        self._check_keys(params, {"ids"}, "get_objects")
        return self._scene_rpc(lambda: self.core.get_objects(params.get("ids")))

    def _rpc_stop(self, params: Mapping[str, Any]) -> Any:
        return self.core.stop()

    def _rpc_get_state(self, params: Mapping[str, Any]) -> Any:
        return self.core.get_state(self._bus.summary())
