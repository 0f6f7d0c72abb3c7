"""The real myCobot 280: the controller manager over the arm's plant (hardware/mycobot_plant.py),
over pymycobot on a serial port.

    ros2 run mycobot_planning mycobot_driver --ros-args -p port:=/dev/ttyUSB0 -p baud:=115200

It offers exactly what mock_controllers offers (the same ControllerManager node: same actions,
same follower, same /joint_states broadcaster with the mimic finger joints): arm_controller
(/arm_controller/follow_joint_trajectory, joint_trajectory, controller_state, state, stop) and
grip_action_controller (/grip_action_controller/gripper_cmd, ...), so the planning_server and
every node work unchanged. /joint_states carries the arm's own readback (nothing is published
before the first one). The I/O with the arm is mycobot_planning.hardware.driver (ROS-free); the
full story is docs/hardware.md.
"""
from __future__ import annotations

import math
from typing import Any

from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.trajectory_execution.controllers_config import ControllerManagerConfig
from mycobot_planning.hardware.driver import MODEL_DEFAULTS, DriverConfig
from mycobot_planning.hardware.mycobot_plant import MyCobotPlant, TrackingSettings
from mycobot_planning.ros.controllers.controller_manager import ControllerManager
from mycobot_planning.ros.node_runtime import Parameters, ParameterSpec

NODE_NAME = "mycobot_driver"


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


def load_mycobot_plant(node: ControllerManager, model: RobotModel, config: ControllerManagerConfig) -> MyCobotPlant:
    """The arm's plant with its parameters on ``node`` (port, baud, model, rates, calibration,
    tolerances)."""
    hw = Parameters(node, [
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
    p = hw.get
    model_name = p("model")
    port, baud = MODEL_DEFAULTS[model_name]
    driver_config = DriverConfig(
        port=p("port") or port, baud=int(p("baud")) or baud, model=model_name,
        command_rate=float(p("command_rate")), lookahead=float(p("lookahead")),
        joint_offsets_deg=[float(v) for v in p("joint_offsets")],
        joint_directions=[int(v) for v in p("joint_directions")],
        full_speed_deg_s=float(p("full_speed")), speed_scaling=float(p("speed_scaling")),
        gripper_open_position=float(p("gripper_open_position")),
        gripper_closed_position=float(p("gripper_closed_position")),
        gripper_open_value=int(p("gripper_open_value")), gripper_closed_value=int(p("gripper_closed_value")),
        gripper_full_speed=float(p("gripper_full_speed")), reconnect_period=float(p("reconnect_period")),
        status_period=float(p("status_period")))
    tracking = TrackingSettings(path_tolerance=float(p("path_tolerance")), goal_time=float(p("goal_time")),
                                gripper_goal_time=float(p("gripper_goal_time")),
                                gripper_allow_stalling=bool(p("gripper_allow_stalling")))
    return MyCobotPlant(model.variable_names, model.default_positions(), driver_config, config.controllers, tracking)


def mycobot_driver() -> ControllerManager:
    """The node ``mycobot_driver`` of ``ros2 run mycobot_planning mycobot_driver``."""
    return ControllerManager(NODE_NAME, load_mycobot_plant)
