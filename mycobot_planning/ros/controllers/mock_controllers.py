"""Mock ros2_control: joint trajectory controllers and a joint state broadcaster in one node.

The full story: docs/nodes.md, section mycobot_planning.ros.controllers.mock_controllers.
"""
from __future__ import annotations

import json
import math
import threading
from typing import Any

import numpy as np
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory

from interfaces_py.ros_conversions import duration_to_seconds
from mycobot_planning.core.trajectory_execution.controllers_config import ControllerConfig, load_controllers_config
from mycobot_planning.core.robot_model.robot_config import RobotConfig
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.trajectory_processing.trajectory_limits import DEFAULT_LIMIT_TOLERANCE
from mycobot_planning.mock_control.joint_trajectory_follower import (
    ControllerStatus,
    FollowerState,
    JointTrajectoryFollower,
    SubmitResult,
    TrajectoryCommand,
)
from mycobot_planning.ros.controllers.controller_actions import ControllerActions
from mycobot_planning.ros.node_runtime import Parameters, ParameterSpec, load_yaml_file
from mycobot_planning.paths import config_file, package_share_dirs

NODE_NAME = "controller_manager"
JOINT_STATES_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
#: Deep enough that a monitor never misses a status change in a burst of events.
STATE_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
COMMAND_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
MOVING_JOINT_TYPES = ("revolute", "continuous", "prismatic")


def _number(name: str):
    def check(value: Any) -> str | None:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return f"{name} must be a number, got {value!r}"
        return None

    return check


# Numeric parameters use dynamic typing so that `ros2 param set ... 1` (an integer) works too.
def _finite(name: str):
    def check(value: Any) -> str | None:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            return f"{name} must be a finite number of seconds (negative disables), got {value!r}"
        return None

    return check


class _Controller:
    """One controller's ROS endpoints around its follower."""

    def __init__(self, config: ControllerConfig, follower: JointTrajectoryFollower, indices: np.ndarray):
        self.config = config
        self.follower = follower
        self.indices = indices  # of its joints in the robot's variable vector
        self.state_pub = None
        self.subscription = None
        self.service = None
        self.actions = None  # ControllerActions: the control_msgs action servers
        self.divisor = 1  # updated every divisor-th loop of the controller manager


class MockControllerManager(Node):
    """The controller_manager stand-in (see docs/nodes.md (mycobot_planning.ros.controllers.mock_controllers)).

    What the joints are is a "plant" behind four hooks (``_configure_plant``, ``_make_follower``,
    ``_start_plant``, ``_ready_text``): here simulated (fault injection, initial positions); the
    hardware driver (ros/controllers/mycobot_driver.py) overrides them to drive the real arm with the same
    controllers, actions and broadcaster."""

    NODE_NAME = NODE_NAME

    def __init__(self) -> None:
        super().__init__(self.NODE_NAME)
        self._lock = threading.Lock()
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
        self._positions = self.model.default_positions()
        self._velocities = np.zeros_like(self._positions)
        self._controllers: dict[str, _Controller] = {}
        self._configure_plant()

        self._control_group = MutuallyExclusiveCallbackGroup()
        for c in self.config.controllers:
            indices = np.array([self.model.variable_index(j) for j in c.joints], dtype=int)
            follower = self._make_follower(c, indices)
            self._controllers[c.name] = self._make_endpoints(_Controller(c, follower, indices))
        self._setup_broadcaster()
        # One loop for all controllers, as ros2_control's controller manager runs them: one timer
        # callback per period instead of one per controller keeps the node cheap in rclpy (its
        # executor costs far more per wake-up than our update does).
        self._loop_count = 0
        self._control_timer = self.create_timer(1.0 / self.config.update_rate, self._on_control_loop,
                                                callback_group=self._control_group)
        self._start_plant()
        self._params.on_change(self._on_node_params)
        self.get_logger().info(self._ready_text())

    # ------------------------------------------------------------------ the plant (simulated here)
    def _configure_plant(self) -> None:
        """Parameters of what stands behind the controllers: the mock's fault injection and
        initial positions."""
        owner = {j: c.name for c in self.config.controllers for j in c.joints}
        specs = []
        for c in self.config.controllers:
            specs.append(ParameterSpec(
                f"{c.name}.fail_after", -1.0,
                f"fault injection: {c.name} aborts each goal with status 'failed' this many seconds after it "
                "starts (negative disables)", validator=_finite(f"{c.name}.fail_after"), dynamic_typing=True))
            specs.append(ParameterSpec(
                f"{c.name}.stall_after", -1.0,
                f"fault injection: {c.name}'s joints stop moving this many seconds after a goal starts while it "
                "keeps reporting 'executing' (negative disables)", validator=_finite(f"{c.name}.stall_after"),
                dynamic_typing=True))
        for i, joint in enumerate(self.model.variable_names):
            controller = owner.get(joint)
            specs.append(ParameterSpec(
                f"initial_positions.{joint}", float(self._positions[i]),
                f"position of {joint} at start-up (rad or m); setting it later moves the joint there at once "
                f"while {controller or 'nothing'} is not executing a goal",
                validator=self._initial_position_check(joint, i, controller), dynamic_typing=True))
        self._fault_params = Parameters(self, specs)
        for i, joint in enumerate(self.model.variable_names):
            self._positions[i] = float(self._fault_params.get(f"initial_positions.{joint}"))

    def _make_follower(self, c: ControllerConfig, indices: np.ndarray) -> JointTrajectoryFollower:
        follower = JointTrajectoryFollower(
            c.joints, self.model.lower_limits[indices], self.model.upper_limits[indices],
            self._positions[indices], goal_tolerance=c.goal_tolerance, start_tolerance=c.start_tolerance,
            name=c.name, velocity_limits=self.model.velocity_limits[indices],
            acceleration_limits=self.model.acceleration_limits[indices],
            limit_tolerance=float(self._params.get("limit_tolerance")))
        follower.fail_after = float(self._fault_params.get(f"{c.name}.fail_after"))
        follower.stall_after = float(self._fault_params.get(f"{c.name}.stall_after"))
        return follower

    def _start_plant(self) -> None:
        self._fault_params.on_change(self._on_fault_params)

    def _controllers_summary(self) -> str:
        return ", ".join(
            f"{c.config.name} ({len(c.config.joints)} joint{'s' if len(c.config.joints) > 1 else ''}, "
            f"{self.config.update_rate / c.divisor:g} Hz)" for c in self._controllers.values())

    def _ready_text(self) -> str:
        return (f"controller_manager ready: {self._controllers_summary()}; /joint_states with "
                f"{len(self._js_names)} joints at {self._params.get('publish_rate'):g} Hz")

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

    def _make_endpoints(self, c: _Controller) -> _Controller:
        name = c.config.name
        c.state_pub = self.create_publisher(String, f"/{name}/state", STATE_QOS)
        c.subscription = self.create_subscription(
            JointTrajectory, f"/{name}/joint_trajectory", lambda msg, c=c: self._on_trajectory(c, msg),
            COMMAND_QOS, callback_group=self._control_group)
        c.service = self.create_service(
            Trigger, f"/{name}/stop", lambda req, resp, c=c: self._on_stop(c, resp),
            callback_group=self._control_group)
        c.divisor = max(1, round(self.config.update_rate / c.config.update_rate))
        c.actions = ControllerActions(self, c)
        return c

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

    # ------------------------------------------------------------------ parameters
    def _initial_position_check(self, joint: str, index: int, controller: str | None):
        lower, upper = self.model.lower_limits[index], self.model.upper_limits[index]

        def check(value: Any) -> str | None:
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                return f"initial_positions.{joint} must be a finite number, got {value!r}"
            if not lower <= value <= upper:
                return f"initial_positions.{joint} = {value} is outside the joint's limits [{lower}, {upper}]"
            c = self._controllers.get(controller) if controller else None
            if c is not None and c.follower.active:
                return (f"{controller} is executing goal {c.follower.goal_id}; stop it before setting "
                        f"initial_positions.{joint}")
            return None

        return check

    def _on_fault_params(self, changed: dict[str, Any]) -> None:
        moved: dict[str, float] = {}
        with self._lock:
            for name, value in changed.items():
                prefix, _, key = name.partition(".")
                if prefix == "initial_positions":
                    moved[key] = float(value)
                    continue
                follower = self._controllers[prefix].follower
                setattr(follower, key, float(value))
                self.get_logger().info(f"{prefix}: {key} = {value}" + (" (disabled)" if value < 0 else ""))
            if moved:
                for joint, value in moved.items():
                    self._positions[self.model.variable_index(joint)] = value
                for c in self._controllers.values():
                    if any(j in moved for j in c.config.joints):
                        c.follower.reset_positions(self._positions[c.indices])
                self.get_logger().info(f"joints moved to {moved}")

    def _on_node_params(self, changed: dict[str, Any]) -> None:
        if "publish_rate" in changed:
            self._schedule_broadcaster(float(changed["publish_rate"]))
            self.get_logger().info(f"/joint_states now at {changed['publish_rate']:g} Hz")

    # ------------------------------------------------------------------ callbacks
    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _on_control_loop(self) -> None:
        now = self._now()
        due = [c for c in self._controllers.values() if self._loop_count % c.divisor == 0]
        self._loop_count += 1
        reports = []
        with self._lock:
            for c in due:
                changed = c.follower.update(now)
                self._copy_out(c)
                reports.append((c, changed, c.follower.state()))
        if self._js_in_loop:
            self._publish_joint_states()
        stamp = self.get_clock().now().to_msg()
        for c, changed, state in reports:
            if changed is not None:
                self._log_change(c, changed)
            c.state_pub.publish(String(data=json.dumps(state.to_dict())))
            c.actions.publish_state(state, stamp)

    def _copy_out(self, c: _Controller) -> None:
        self._positions[c.indices] = c.follower.positions
        self._velocities[c.indices] = c.follower.velocities

    def _log_change(self, c: _Controller, state: FollowerState) -> None:
        log = self.get_logger()
        if state.status == ControllerStatus.SUCCEEDED:
            log.info(f"{c.config.name}: {state.message}")
        elif state.status == ControllerStatus.FAILED:
            log.error(f"{c.config.name}: {state.message}")
        else:
            log.warning(f"{c.config.name}: {state.message}")

    def _on_trajectory(self, c: _Controller, msg: JointTrajectory) -> None:
        stamp = msg.header.stamp
        start = None if stamp.sec == 0 and stamp.nanosec == 0 else stamp.sec + stamp.nanosec * 1e-9
        command = TrajectoryCommand(
            joint_names=list(msg.joint_names),
            times=[duration_to_seconds(p.time_from_start) for p in msg.points],
            positions=[list(p.positions) for p in msg.points],
            velocities=[list(p.velocities) for p in msg.points],
            accelerations=[list(p.accelerations) for p in msg.points],
            start_time=start,
            goal_id=msg.header.frame_id,
        )
        self.submit(c, command)

    def submit(self, c: _Controller, command: TrajectoryCommand) -> SubmitResult:
        """Hand a command (from the topic or an action goal) to the controller's follower; logs and
        publishes what happened."""
        with self._lock:
            result = c.follower.submit(command, self._now())
            self._copy_out(c)
        log = self.get_logger()
        name = c.config.name
        if not result.accepted:
            log.warning(f"{name}: rejected goal {result.goal_id}: {result.reason}")
        for event in result.events:
            if event.status != ControllerStatus.ABORTED:  # the rejection was logged above
                log.info(f"{name}: {event.message}")
            c.state_pub.publish(String(data=json.dumps(event.to_dict())))
        return result

    def follower_state(self, c: _Controller) -> FollowerState:
        with self._lock:
            return c.follower.state()

    def stop(self, c: _Controller, reason: str) -> list[FollowerState]:
        """Stop the controller's goal (if any) and hold; logs and publishes the event."""
        with self._lock:
            events = c.follower.stop(self._now(), reason)
            self._copy_out(c)
        if events:
            self.get_logger().info(f"{c.config.name}: {events[0].message}")
            for event in events:
                c.state_pub.publish(String(data=json.dumps(event.to_dict())))
        return events

    def _on_stop(self, c: _Controller, response: Trigger.Response) -> Trigger.Response:
        events = self.stop(c, "stop service called")
        name = c.config.name
        if events:
            response.message = f"{name} stopped goal {events[0].goal_id} and holds its position"
        else:
            response.message = f"{name} was not executing a goal; it keeps holding its position"
        response.success = True
        return response

    def _publish_joint_states(self) -> None:
        with self._lock:
            positions = self._js_select @ self._positions + self._js_offset
            velocities = self._js_select @ self._velocities
        msg = self._js_msg
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.position = positions.tolist()
        msg.velocity = velocities.tolist()
        self._js_pub.publish(msg)
