"""The real myCobot 280: the mock controllers' controller_manager with the simulated joints
replaced by the arm, over pymycobot on a serial port.

    ros2 run mycobot_planning mycobot_driver --ros-args -p port:=/dev/ttyUSB0 -p baud:=115200

It offers exactly what mock_controllers offers (same ControllerActions, same follower, same
/joint_states broadcaster with the mimic finger joints): arm_controller
(/arm_controller/follow_joint_trajectory, joint_trajectory, controller_state, state, stop) and
grip_action_controller (/grip_action_controller/gripper_cmd, ...), so the planning_server and
every node work unchanged. /joint_states carries the arm's own readback (nothing is published
before the first one). The I/O with the arm is mycobot_planning.hardware.driver (ROS-free); the
full story is docs/hardware.md.
"""
from __future__ import annotations

import json
import math
import sys
from typing import Any

import numpy as np
from std_msgs.msg import String

from mycobot_planning.core.trajectory_execution.controllers_config import ControllerConfig
from mycobot_planning.hardware.driver import MODEL_DEFAULTS, DriverConfig, DriverCore
from mycobot_planning.hardware.follower import MeasuredTrajectoryFollower
from mycobot_planning.ros.controllers.mock_controllers import MockControllerManager
from mycobot_planning.ros.node_runtime import Parameters, ParameterSpec

GRIPPER_TYPE_SUFFIX = "GripperActionController"


def _positive(name: str):
    def check(value: Any) -> str | None:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
            return f"{name} must be a positive number, got {value!r}"
        return None

    return check


def _directions(value: Any) -> str | None:
    if any(v not in (1, -1) for v in value):
        return f"joint_directions must hold 1 or -1 for each joint, got {list(value)}"
    return None


class MyCobotDriver(MockControllerManager):
    """controller_manager's controllers on the real arm (see the module docstring)."""

    NODE_NAME = "mycobot_driver"

    # ------------------------------------------------------------------ the plant: the arm
    def _configure_plant(self) -> None:
        self._hw = Parameters(self, [
            ParameterSpec("port", "", "serial port of the arm (e.g. /dev/ttyUSB0, or the emulator's link); "
                          "empty: the model's default (M5: /dev/ttyUSB0, Pi: /dev/ttyAMA0)", read_only=True),
            ParameterSpec("baud", 0, "baud rate; 0: the model's default (M5: 115200, Pi: 1000000)",
                          range=(0, 4000000), read_only=True),
            ParameterSpec("model", "M5", "model variant: M5 (USB serial to the M5Stack base) or Pi "
                          "(Raspberry Pi talking to the Atom on its UART)",
                          validator=lambda v: None if v in MODEL_DEFAULTS else
                          f"model must be one of {sorted(MODEL_DEFAULTS)}, got {v!r}", read_only=True),
            ParameterSpec("command_rate", 25.0, "Hz of the I/O loop: one get_angles readback and (while a goal "
                          "runs) one send_angles command per period", range=(1.0, 200.0), read_only=True,
                          validator=_positive("command_rate"), dynamic_typing=True),
            ParameterSpec("lookahead", 0.0, "s ahead of now each command aims at along the trajectory; 0: one "
                          "command period", range=(0.0, 1.0), read_only=True, dynamic_typing=True),
            ParameterSpec("joint_offsets", [0.0] * 6, "degrees added to joints 1-6 after the direction: "
                          "arm angle = direction * degrees(joint position) + offset", array_size=6, read_only=True),
            ParameterSpec("joint_directions", [1, 1, 1, 1, 1, 1], "1 or -1 per joint 1-6: the arm's sense of "
                          "rotation against the URDF's", array_size=6, validator=_directions, read_only=True),
            ParameterSpec("full_speed", 160.0, "deg/s of a joint at the arm's speed 100 (the speed byte of "
                          "send_angles is a percentage of it)", read_only=True, validator=_positive("full_speed"),
                          dynamic_typing=True),
            ParameterSpec("speed_scaling", 1.0, "factor on the speed each command asks for: above 1 the arm "
                          "catches up faster (and may overshoot the trajectory's timing), below 1 it lags more",
                          range=(0.1, 5.0), read_only=True, dynamic_typing=True),
            ParameterSpec("path_tolerance", 0.2, "rad: a goal is aborted (and the arm stopped) when a readback "
                          "is farther than this from the trajectory's desired position; a goal's own "
                          "path_tolerance applies too", range=(0.001, 10.0), read_only=True, dynamic_typing=True),
            ParameterSpec("goal_time", 2.0, "s after a trajectory's end for the arm to come within the goal "
                          "tolerance, else the goal is aborted", range=(0.0, 60.0), read_only=True,
                          dynamic_typing=True),
            ParameterSpec("gripper_open_position", 0.0, "gripper joint position (rad) when open",
                          read_only=True, dynamic_typing=True),
            ParameterSpec("gripper_closed_position", -0.5, "gripper joint position (rad) when closed",
                          read_only=True, dynamic_typing=True),
            ParameterSpec("gripper_open_value", 100, "gripper value (0-100) when open", range=(0, 100),
                          read_only=True),
            ParameterSpec("gripper_closed_value", 0, "gripper value (0-100) when closed", range=(0, 100),
                          read_only=True),
            ParameterSpec("gripper_full_speed", 200.0, "gripper value units per second at speed 100",
                          read_only=True, validator=_positive("gripper_full_speed"), dynamic_typing=True),
            ParameterSpec("gripper_allow_stalling", True, "a gripper move that stops short of its goal after "
                          "the move's end (the fingers closed on an object) succeeds, as GripperActionController's "
                          "allow_stalling", read_only=True),
            ParameterSpec("gripper_goal_time", 3.0, "s after a gripper move's end for the gripper to arrive",
                          range=(0.0, 60.0), read_only=True, dynamic_typing=True),
            ParameterSpec("reconnect_period", 1.0, "s between two attempts to reopen a lost port",
                          range=(0.1, 60.0), read_only=True, dynamic_typing=True),
            ParameterSpec("status_period", 0.25, "s between two get_error_information queries",
                          range=(0.02, 10.0), read_only=True, dynamic_typing=True),
        ])
        p = self._hw.get
        model = p("model")
        port, baud = MODEL_DEFAULTS[model]
        self.hw_config = DriverConfig(
            port=p("port") or port, baud=int(p("baud")) or baud, model=model,
            command_rate=float(p("command_rate")), lookahead=float(p("lookahead")),
            joint_offsets_deg=[float(v) for v in p("joint_offsets")],
            joint_directions=[int(v) for v in p("joint_directions")],
            full_speed_deg_s=float(p("full_speed")), speed_scaling=float(p("speed_scaling")),
            gripper_open_position=float(p("gripper_open_position")),
            gripper_closed_position=float(p("gripper_closed_position")),
            gripper_open_value=int(p("gripper_open_value")), gripper_closed_value=int(p("gripper_closed_value")),
            gripper_full_speed=float(p("gripper_full_speed")), reconnect_period=float(p("reconnect_period")),
            status_period=float(p("status_period")))
        self.hw_config.check()
        arms = [c for c in self.config.controllers if not c.type.endswith(GRIPPER_TYPE_SUFFIX)]
        grippers = [c for c in self.config.controllers if c.type.endswith(GRIPPER_TYPE_SUFFIX)]
        if len(arms) != 1 or len(arms[0].joints) != 6:
            raise ValueError("the myCobot driver needs exactly one joint trajectory controller with the 6 arm "
                             f"joints (joints 1-6 in order); the controllers file has {[c.name for c in arms]}")
        if len(grippers) > 1 or (grippers and len(grippers[0].joints) != 1):
            raise ValueError("the myCobot driver drives at most one gripper controller with one joint")
        self._arm_name = arms[0].name
        self._gripper_name = grippers[0].name if grippers else None
        self._core: DriverCore | None = None
        self._closing = False

    def _make_follower(self, c: ControllerConfig, indices: np.ndarray) -> MeasuredTrajectoryFollower:
        lower = self.model.lower_limits[indices].copy()
        upper = self.model.upper_limits[indices].copy()
        p = self._hw.get
        if c.name == self._gripper_name:
            lo, hi = self.hw_config.gripper_limits()
            lower, upper = np.maximum(lower, lo), np.minimum(upper, hi)
            path_tolerance, goal_time = math.inf, float(p("gripper_goal_time"))
            allow_stalling = bool(p("gripper_allow_stalling"))
        else:
            lo, hi = self.hw_config.firmware_limits()
            lower, upper = np.maximum(lower, lo), np.minimum(upper, hi)
            path_tolerance, goal_time = float(p("path_tolerance")), float(p("goal_time"))
            allow_stalling = False
        return MeasuredTrajectoryFollower(
            c.joints, lower, upper, np.clip(self._positions[indices], lower, upper),
            goal_tolerance=c.goal_tolerance, start_tolerance=c.start_tolerance, name=c.name,
            velocity_limits=self.model.velocity_limits[indices],
            acceleration_limits=self.model.acceleration_limits[indices],
            limit_tolerance=float(self._params.get("limit_tolerance")),
            path_tolerance=path_tolerance, goal_time=goal_time, allow_stalling=allow_stalling)

    def _start_plant(self) -> None:
        arm = self._controllers[self._arm_name]
        gripper = self._controllers[self._gripper_name] if self._gripper_name else None
        self._by_follower = {id(c.follower): c for c in self._controllers.values()}
        self._core = DriverCore(self.hw_config, arm.follower, gripper.follower if gripper else None,
                                lock=self._lock, clock=self._now, on_event=self._on_driver_event,
                                on_change=self._on_driver_change)
        self._core.start()

    def _ready_text(self) -> str:
        c = self.hw_config
        return (f"mycobot_driver ready: {self._controllers_summary()}; myCobot 280 {c.model} on {c.port} at "
                f"{c.baud} baud, commands and readback at {c.command_rate:g} Hz; /joint_states with "
                f"{len(self._js_names)} joints at {self._params.get('publish_rate'):g} Hz from the arm's readback")

    # ------------------------------------------------------------------ callbacks
    def _on_driver_event(self, level: str, text: str) -> None:
        if self._closing:  # rclpy's context is gone at shutdown: its logger cannot publish any more
            print(f"[{level.upper()}] [{self.NODE_NAME}]: {text}", file=sys.stderr, flush=True)
            return
        # one call site per severity: rclpy refuses a call site whose severity changes
        log = self.get_logger()
        if level == "error":
            log.error(text)
        elif level == "warning":
            log.warning(text)
        else:
            log.info(text)

    def _on_driver_change(self, follower: MeasuredTrajectoryFollower, state: Any) -> None:
        c = self._by_follower.get(id(follower))
        if c is None:
            return
        self._log_change(c, state)
        c.state_pub.publish(String(data=json.dumps(state.to_dict())))

    def _publish_joint_states(self) -> None:
        arm = self._controllers.get(self._arm_name)
        if arm is None or not arm.follower.measured:
            return  # no readback yet: publish nothing rather than a made-up state
        super()._publish_joint_states()

    def submit(self, c: Any, command: Any) -> Any:
        result = super().submit(c, command)
        if result.accepted and self._core is not None:
            self._core.wake()  # the first command goes out now, not at the end of the period
        return result

    def driver_stats(self) -> dict[str, Any]:
        return self._core.stats() if self._core else {}

    def close(self) -> None:
        """On shutdown (Ctrl-C, SIGTERM): stop the arm, then close the port."""
        self._closing = True
        if self._core is not None:
            self._core.close(stop_arm=True)
            self._core = None
