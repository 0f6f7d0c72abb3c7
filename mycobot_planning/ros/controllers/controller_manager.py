"""The controller manager node, written once over a plant (ros2_control's split): joint
trajectory and gripper controllers with ros2_control's topics, services and actions, limit
checks, and a joint state broadcaster, whatever moves the joints.

The plant (mycobot_planning.hardware_interface.Plant, ROS-free) is the mock's kinematic
simulation (mock_controllers.py), the myCobot 280 over pymycobot (mycobot_driver.py), or a
physics simulation; a node module declares its plant's parameters and hands the plant to
:class:`ControllerManager`. The full story: docs/nodes.md, section controller manager and plants.
"""
from __future__ import annotations

import json
import math
import sys
import threading
import time
from typing import Any, Callable

import numpy as np
from builtin_interfaces.msg import Time as TimeMsg
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory

from interfaces_py.ros_conversions import duration_to_seconds
from mycobot_planning.core.robot_model.robot_config import RobotConfig
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.trajectory_execution.controllers_config import (
    ControllerConfig,
    ControllerManagerConfig,
    load_controllers_config,
)
from mycobot_planning.core.trajectory_processing.trajectory_limits import DEFAULT_LIMIT_TOLERANCE
from mycobot_planning.hardware_interface.plant import ControllerSpec, Plant, PlantHost
from mycobot_planning.mock_control.joint_trajectory_follower import (
    ControllerStatus,
    FollowerState,
    JointTrajectoryFollower,
    SubmitResult,
    TrajectoryCommand,
)
from mycobot_planning.paths import config_file, package_share_dirs
from mycobot_planning.ros import fast_log
from mycobot_planning.ros.controllers.controller_actions import ControllerActions
from mycobot_planning.ros.node_runtime import Parameters, ParameterSpec, load_yaml_file
from mycobot_planning.ros.stamped_cdr import StampedCdr
from mycobot_planning.ros.topic_reader import TopicReader

JOINT_STATES_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
#: Deep enough that a monitor never misses a status change in a burst of events.
STATE_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
COMMAND_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
#: A controller without a goal publishes controller_state every this many cycles (10 Hz at the
#: 100 Hz loop; every cycle while it follows a goal, as JTC does): it is a heartbeat then, and
#: two thirds of the idle node's cost went into it.
IDLE_STATE_DIVISOR = 10
#: s between two identical /<controller>/state messages of a controller holding still
STATE_KEEP_ALIVE = 1.0
MOVING_JOINT_TYPES = ("revolute", "continuous", "prismatic")

#: Builds a node's plant: (node, robot model, controllers) -> Plant. It may declare parameters.
PlantLoader = Callable[["ControllerManager", RobotModel, ControllerManagerConfig], Plant]


def _number(name: str):
    def check(value: Any) -> str | None:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return f"{name} must be a number, got {value!r}"
        return None

    return check


class Controller:
    """One controller over its follower: every call takes the manager's lock (given here), and
    what happens is logged and published on ``/<name>/state`` (JSON)."""

    def __init__(self, config: ControllerConfig, follower: JointTrajectoryFollower, indices: np.ndarray,
                 lock: Any, clock: Callable[[], float], logger: Any, state_pub: Any,
                 on_accepted: Callable[[str], None]) -> None:
        self.config = config
        self.name = config.name
        self.joints = config.joints
        self.indices = indices  # of its joints in the robot's variable vector
        self.lower = follower.lower.copy()
        self.upper = follower.upper.copy()
        self.velocity_limits = follower.velocity_limits.copy()
        self.is_gripper = config.type.endswith("GripperActionController")
        self.divisor = 1  # updated every divisor-th loop of the controller manager
        self.actions: ControllerActions | None = None
        self.command_reader: TopicReader | None = None  # /<name>/joint_trajectory, read by the control loop
        self._follower = follower
        self._lock = lock
        self._clock = clock
        self._logger = logger
        self._log_throttle = fast_log.Throttle(1.0)
        self._state_pub = state_pub
        self._on_accepted = on_accepted
        self._last_state_key: tuple = ()
        self._last_active = True  # until a cycle shows it holding still
        self._last_state_time = -math.inf

    def owns(self, follower: JointTrajectoryFollower) -> bool:
        return follower is self._follower

    def publish_event(self, state: FollowerState) -> None:
        self._state_pub.publish(String(data=json.dumps(state.to_dict())))

    def publish_cycle_state(self, state: FollowerState, now: float) -> None:
        """The state of one control cycle on ``/<name>/state``: when it differs from the last one
        published, else once every STATE_KEEP_ALIVE s (a controller holding still says so once a
        second, not a hundred times: that was a tenth of the idle node's cost)."""
        if not state.active and not self._last_active and now - self._last_state_time < STATE_KEEP_ALIVE \
                and self._last_state_key[:3] == (state.status, state.goal_id, state.message):
            return  # holding still, nothing new: the cheap test first (this runs at the controller rate)
        key = (state.status, state.goal_id, state.message, state.active,
               *(a.tobytes() for a in (state.desired_positions, state.desired_velocities, state.desired_accelerations,
                                       state.actual_positions, state.actual_velocities, state.actual_accelerations)))
        self._last_active = state.active
        if key == self._last_state_key and now - self._last_state_time < STATE_KEEP_ALIVE:
            return
        self._last_state_key, self._last_state_time = key, now
        self._state_pub.publish(String(data=json.dumps(state.to_dict())))

    def log_change(self, state: FollowerState) -> None:
        if state.status == ControllerStatus.SUCCEEDED:
            self._logger.info(f"{self.name}: {state.message}")
        elif state.status == ControllerStatus.FAILED:
            self._logger.error(f"{self.name}: {state.message}")
        else:
            self._logger.warning(f"{self.name}: {state.message}")

    # ------------------------------------------------------------------ called under the lock by the loop
    def update_locked(self, now: float, report_idle: bool) -> tuple[FollowerState | None, FollowerState | None]:
        """Advance the follower to ``now``: (the change, if any; its state). A controller holding
        still since its last published state gets no state (None) unless ``report_idle`` or its
        keep-alive is due: nothing in it can have changed (a goal or a stop makes it active, and
        publish_cycle_state would drop it), and copying it a hundred times a second was a third
        of the idle node's cost."""
        follower = self._follower
        if not report_idle and not follower.active and not self._last_active \
                and now - self._last_state_time < STATE_KEEP_ALIVE:
            return follower.update(now), None
        return follower.update(now), follower.state()

    # ------------------------------------------------------------------ thread-safe calls
    def submit(self, command: TrajectoryCommand) -> SubmitResult:
        """Hand a command (from the topic or an action goal) to the follower; logs and publishes
        what happened."""
        with self._lock:
            result = self._follower.submit(command, self._clock())
        if not result.accepted:
            self._logger.warning(f"{self.name}: rejected goal {result.goal_id}: {result.reason}")
        else:
            self._on_accepted(self.name)
        for event in result.events:
            if event.status in (ControllerStatus.PREEMPTED, ControllerStatus.EXECUTING):
                # a stream of commands (servo, the hybrid local planner: 100 a second) would log two
                # lines each; the state topic carries every one of them. Throttled here, not by
                # rclpy's throttle_duration_sec: that looks its caller up on every call (most of
                # the controllers' CPU while servoing)
                if self._log_throttle(event.status):
                    fast_log.log(self._logger, "info", f"{self.name}: {event.message}")
            elif event.status != ControllerStatus.ABORTED:  # the rejection was logged above
                self._logger.info(f"{self.name}: {event.message}")
            self.publish_event(event)
        return result

    def validate(self, command: TrajectoryCommand) -> str | None:
        """Why the follower would refuse ``command`` (joints, sizes, limits), or None."""
        with self._lock:
            return self._follower.validate(command)

    def state(self) -> FollowerState:
        with self._lock:
            return self._follower.state()

    def running_goal(self) -> str:
        """The goal being followed ("" when none)."""
        with self._lock:
            return self._follower.goal_id if self._follower.active else ""

    def stop(self, reason: str, smooth: bool = False) -> list[FollowerState]:
        """Stop the goal (if any) and hold; logs and publishes the event. ``smooth``: decelerate
        along the goal's path within the acceleration limits first (a cancelled goal)."""
        with self._lock:
            events = self._follower.stop(self._clock(), reason, smooth)
        if smooth and not events:
            self._logger.info(f"{self.name}: decelerating to a stop: {reason}")
        if events:
            self._logger.info(f"{self.name}: {events[0].message}")
            for event in events:
                self.publish_event(event)
        return events


class ControllerManager(Node):
    """The controller_manager (see the module docstring): ``plant_loader`` builds what stands
    behind the controllers."""

    def __init__(self, node_name: str, plant_loader: PlantLoader) -> None:
        super().__init__(node_name)
        self._lock = threading.Lock()
        self._closing = False
        self._params = Parameters(self, [
            ParameterSpec("robot_config", "",
                          "robot configuration directory (the setup assistant's output, or a folder with one URDF "
                          "and one SRDF): robot, joint limits and ros2_controllers.yaml come from it where the "
                          "parameters below leave them empty; empty: the package's myCobot 280", read_only=True),
            ParameterSpec("robot_description", "", "URDF of the robot (XML text); empty: the package's myCobot 280",
                          read_only=True),
            ParameterSpec("robot_description_semantic", "",
                          "SRDF of the robot (XML text); empty: the package's (or none with a custom URDF)",
                          read_only=True),
            ParameterSpec("controllers_file", "", "controllers YAML (ros2_control layout); empty: config/controllers.yaml",
                          read_only=True),
            ParameterSpec("joint_limits_file", "",
                          "joint_limits.yaml (MoveIt format) for a custom robot_description: the velocity and "
                          "acceleration limits trajectories are checked against; empty: the URDF's (myCobot: "
                          "config/joint_limits.yaml)", read_only=True),
            ParameterSpec("publish_rate", 100.0, "rate of /joint_states in Hz", range=(1.0, 1000.0),
                          validator=_number("publish_rate"), dynamic_typing=True),
            ParameterSpec("limit_tolerance", DEFAULT_LIMIT_TOLERANCE,
                          "relative slack on the joint velocity and acceleration limits: a trajectory exceeding "
                          "them by more is refused before anything moves (0.05: 5 %)", range=(0.0, 1.0),
                          read_only=True),
        ])
        self._robot_config = RobotConfig.load(self._params.get("robot_config")) if self._params.get("robot_config") \
            else None
        self.model = self._load_model()
        for warning in self.model.load_warnings:
            self.get_logger().warning(warning)
        from_config = self._robot_config.ros2_controllers if self._robot_config is not None else None
        controllers_file = self._params.get("controllers_file") or str(from_config or config_file("controllers.yaml"))
        self.config = load_controllers_config(controllers_file, self.model.variable_names)
        self.plant = plant_loader(self, self.model, self.config)

        self._control_group = MutuallyExclusiveCallbackGroup()
        self.controllers: dict[str, Controller] = {}
        limit_tolerance = float(self._params.get("limit_tolerance"))
        defaults = self.model.default_positions()
        for c in self.config.controllers:
            indices = np.array([self.model.variable_index(j) for j in c.joints], dtype=int)
            spec = ControllerSpec(c, indices, self.model.lower_limits[indices], self.model.upper_limits[indices],
                                  self.model.velocity_limits[indices], self.model.acceleration_limits[indices],
                                  defaults[indices], limit_tolerance)
            follower = self.plant.make_follower(spec)
            self.controllers[c.name] = self._make_endpoints(c, follower, indices)
        self._setup_broadcaster()
        # One loop for all controllers, on a thread of its own, as ros2_control's controller
        # manager runs them: an rclpy timer would wake the executor at every period, and its
        # wake-up (a wait set rebuilt in Python over every service and action of the node) costs
        # far more than our update does: 20 % of a core idle, against a few % for this thread.
        self._loop_count = 0
        #: the controllers when all of them run at the loop's rate (the usual case), else empty
        self._every_cycle = list(self.controllers.values()) if all(
            c.divisor == 1 for c in self.controllers.values()) else []
        self._loop_stop = threading.Event()
        self._loop_thread = threading.Thread(target=self._run_control_loop, name="controller manager loop", daemon=True)
        self.plant.start(PlantHost(lock=self._lock, clock=self.now, log=self._plant_log, report=self._plant_report))
        self._loop_thread.start()
        self._params.on_change(self._on_node_params)
        description = self.plant.description()
        self.get_logger().info(
            f"{node_name} ready: {self._controllers_summary()}; {description + '; ' if description else ''}"
            f"/joint_states with {len(self._js_names)} joints at {self._params.get('publish_rate'):g} Hz"
            f"{self.plant.state_source()}")

    # ------------------------------------------------------------------ set-up
    def _load_model(self) -> RobotModel:
        urdf = self._params.get("robot_description")
        srdf = self._params.get("robot_description_semantic")
        config = self._robot_config
        if not urdf and not srdf and config is None:
            return RobotModel.mycobot()
        if srdf and not urdf:
            raise ValueError("robot_description_semantic is set but robot_description (the URDF) is empty")
        if not urdf and config is not None:
            urdf, srdf = config.urdf.read_text(), config.srdf.read_text()
        limits_file = self._params.get("joint_limits_file") or (str(config.joint_limits) if config and config.joint_limits
                                                                 else "")
        limits = load_yaml_file(limits_file, "joint limits file")
        dirs = [*(config.package_dirs if config else ()), *package_share_dirs()]
        return RobotModel.from_strings(urdf, srdf or '<robot name=""/>', limits, package_dirs=dirs)

    def _make_endpoints(self, config: ControllerConfig, follower: JointTrajectoryFollower,
                        indices: np.ndarray) -> Controller:
        name = config.name
        c = Controller(config, follower, indices, self._lock, self._follower_now, self.get_logger(),
                       self.create_publisher(String, f"/{name}/state", STATE_QOS), self.plant.commanded)
        # read by the control loop at the start of each cycle, as ros2_control's JTC reads its
        # topic's realtime buffer in update(): a command stream (servo: 100 Hz) would otherwise wake
        # the executor for every message, and its Python wait-set rebuild cost more than the command
        c.command_reader = TopicReader(self, JointTrajectory, f"/{name}/joint_trajectory", COMMAND_QOS)
        self.create_service(Trigger, f"/{name}/stop", lambda req, resp, c=c: self._on_stop(c, resp),
                            callback_group=self._control_group)
        c.divisor = max(1, round(self.config.update_rate / config.update_rate))
        c.actions = ControllerActions(self, c)
        return c

    def _controllers_summary(self) -> str:
        return ", ".join(
            f"{c.name} ({len(c.joints)} joint{'s' if len(c.joints) > 1 else ''}, "
            f"{self.config.update_rate / c.divisor:g} Hz)" for c in self.controllers.values())

    def _setup_broadcaster(self) -> None:
        """/joint_states = S @ variables + offset: active joints copied, mimic joints derived."""
        names = [j for j in self.model.joint_names if self.model.joint(j).type in MOVING_JOINT_TYPES]
        n_var = len(self.model.variable_names)
        offset = np.array([self.model.mimic_values(np.zeros(n_var)).get(j, 0.0) for j in names])
        select = np.zeros((len(names), n_var))
        for col in range(n_var):
            unit = np.zeros(n_var)
            unit[col] = 1.0
            mimic = self.model.mimic_values(unit)
            for row, joint in enumerate(names):
                if joint == self.model.variable_names[col]:
                    select[row, col] = 1.0
                elif joint in mimic:
                    select[row, col] = mimic[joint] - offset[row]
        self._js_names = names
        self._js_select = select
        self._js_offset = offset
        self._js_msg = JointState()
        self._js_msg.name = names
        self._js_key = b""  # the plant's positions and velocities the serialized message holds
        self._js_cdr = StampedCdr()  # sent serialized: only the stamp changes while the joints hold
        self._js_pub = self.create_publisher(JointState, "/joint_states", JOINT_STATES_QOS)
        self._js_group = MutuallyExclusiveCallbackGroup()
        self._js_timer = None
        self._js_in_loop = False
        self._schedule_broadcaster(float(self._params.get("publish_rate")))

    def _schedule_broadcaster(self, rate: float) -> None:
        """At the controller manager's rate the broadcaster runs in its loop, right after the
        controllers (as ros2_control's joint_state_broadcaster does, and one rclpy timer wake-up
        per period instead of two); at any other rate it gets its own timer."""
        if self._js_timer is not None:
            self._js_timer.cancel()
            self.destroy_timer(self._js_timer)
            self._js_timer = None
        self._js_in_loop = math.isclose(rate, self.config.update_rate)
        if not self._js_in_loop:
            self._js_timer = self.create_timer(1.0 / rate, self._publish_joint_states, callback_group=self._js_group)

    def _on_node_params(self, changed: dict[str, Any]) -> None:
        if "publish_rate" in changed:
            self._schedule_broadcaster(float(changed["publish_rate"]))
            self.get_logger().info(f"/joint_states now at {changed['publish_rate']:g} Hz")

    # ------------------------------------------------------------------ the plant's side
    def now(self) -> float:
        """The manager's clock in seconds (the node's clock: ROS time)."""
        return self.now_ns() * 1e-9

    def _follower_now(self) -> float:
        """The followers' clock: the manager's as the plant runs on it (Plant.follower_time).
        Called under the lock, as the plant's methods are."""
        return self.plant.follower_time(self.now())

    def now_ns(self) -> int:
        """The node's clock in nanoseconds: ROS time, which is the system's clock unless simulated
        time overrides it (read here directly: rclpy's Clock.now() builds a Time object, a
        noticeable share of a 100 Hz loop's cost)."""
        clock = self.get_clock()
        if clock.ros_time_is_active:
            return clock.now().nanoseconds
        return time.time_ns()

    def _plant_log(self, level: str, text: str) -> None:
        if self._closing:  # rclpy's context is gone at shutdown: its logger cannot publish any more
            print(f"[{level.upper()}] [{self.get_name()}]: {text}", file=sys.stderr, flush=True)
            return
        # one call site per severity: rclpy refuses a call site whose severity changes
        log = self.get_logger()
        if level == "error":
            log.error(text)
        elif level == "warning":
            log.warning(text)
        else:
            log.info(text)

    def _plant_report(self, follower: JointTrajectoryFollower, state: FollowerState) -> None:
        for c in self.controllers.values():
            if c.owns(follower):
                c.log_change(state)
                c.publish_event(state)
                return

    # ------------------------------------------------------------------ callbacks
    def _run_control_loop(self) -> None:
        """_on_control_loop every 1 / update_rate s (monotonic deadlines; a late cycle is not
        made up for) until close() or the context goes down. A cycle that raises is logged and
        the loop goes on: one bad update must never stop the joints' publication."""
        period = 1.0 / self.config.update_rate
        deadline = time.monotonic()
        failures_logged = 0.0
        while not self._loop_stop.is_set():
            deadline += period
            delay = deadline - time.monotonic()
            if delay > 0.0:
                time.sleep(delay)  # at most a period; cheaper to wake from than an Event's wait
                if self._loop_stop.is_set():
                    return
            elif delay < -period:
                deadline = time.monotonic()
            if not self.context.ok():
                return
            try:
                self._on_control_loop()
            except Exception as exc:
                if self._closing or not self.context.ok():
                    return
                now = time.monotonic()
                if now - failures_logged > 5.0:
                    failures_logged = now
                    self.get_logger().error(f"control loop: {type(exc).__name__}: {exc}")

    def _take_commands(self) -> None:
        """Hand each controller the JointTrajectory messages that came since the last cycle, in order."""
        for c in self.controllers.values():
            for msg in c.command_reader.take_all():
                try:
                    self._on_trajectory(c, msg)
                except Exception as exc:  # one bad message must not cost the others or the cycle
                    self.get_logger().error(f"{c.name}: joint_trajectory message failed: {type(exc).__name__}: {exc}")

    def _on_control_loop(self) -> None:
        self._take_commands()
        due = self._every_cycle or [c for c in self.controllers.values() if self._loop_count % c.divisor == 0]
        report_idle = self._loop_count % IDLE_STATE_DIVISOR == 0
        self._loop_count += 1
        reports = []
        with self._lock:
            # One reading per cycle, the update's time and every stamp, taken under the lock: a
            # command submitted (with its own, later reading) while this cycle waited for the lock
            # would otherwise move the joints past the time their /joint_states is stamped with.
            ns = self.now_ns()
            now = self.plant.follower_time(ns * 1e-9)
            self.plant.read(now)
            for c in due:
                changed, state = c.update_locked(now, report_idle)
                reports.append((c, changed, state))
            self.plant.write(now)
            joint_states = self._js_in_loop and self._refresh_joint_states_locked()
        sec, nanosec = divmod(ns, 1_000_000_000)
        if joint_states:
            self._js_cdr.publish(self._js_pub, sec, nanosec)
        stamp = None
        for c, changed, state in reports:
            if changed is not None:
                c.log_change(changed)
            if state is None:
                continue
            c.publish_cycle_state(state, now)
            if state.active or report_idle:
                stamp = stamp or TimeMsg(sec=sec, nanosec=nanosec)
                c.actions.publish_state(state, stamp)

    def _on_trajectory(self, c: Controller, msg: JointTrajectory) -> None:
        stamp = msg.header.stamp
        start = None if stamp.sec == 0 and stamp.nanosec == 0 else stamp.sec + stamp.nanosec * 1e-9
        c.submit(TrajectoryCommand(
            joint_names=list(msg.joint_names),
            times=[duration_to_seconds(p.time_from_start) for p in msg.points],
            positions=[list(p.positions) for p in msg.points],
            velocities=[list(p.velocities) for p in msg.points],
            accelerations=[list(p.accelerations) for p in msg.points],
            start_time=start,
            goal_id=msg.header.frame_id,
        ))

    def _on_stop(self, c: Controller, response: Trigger.Response) -> Trigger.Response:
        events = c.stop("stop service called")
        if events:
            response.message = f"{c.name} stopped goal {events[0].goal_id} and holds its position"
        else:
            response.message = f"{c.name} was not executing a goal; it keeps holding its position"
        response.success = True
        return response

    def _refresh_joint_states_locked(self) -> bool:
        """Bring the serialized /joint_states up to the plant's state (under the lock); False
        while the plant has nothing to report. Only a change of the joints re-serializes: the
        message goes out as bytes with its stamp written in place (ros.stamped_cdr)."""
        state = self.plant.joint_state()
        if state is None:
            return False
        key = state[0].tobytes() + state[1].tobytes()
        if key != self._js_key:
            self._js_key = key
            msg = self._js_msg
            msg.position = (self._js_select @ state[0] + self._js_offset).tolist()
            msg.velocity = (self._js_select @ state[1]).tolist()
            self._js_cdr.update(msg)
        return True

    def _publish_joint_states(self) -> None:
        """The broadcaster at a rate of its own (publish_rate other than the update rate)."""
        with self._lock:
            ready = self._refresh_joint_states_locked()
        if ready:
            self._js_cdr.publish(self._js_pub, *divmod(self.now_ns(), 1_000_000_000))

    def close(self) -> None:
        """On shutdown (Ctrl-C, SIGTERM): the plant stops the joints and lets the hardware go."""
        self._closing = True
        self._loop_stop.set()
        if self._loop_thread.is_alive() and self._loop_thread is not threading.current_thread():
            self._loop_thread.join(1.0)
        for c in self.controllers.values():
            c.command_reader.destroy()
        self.plant.close()
