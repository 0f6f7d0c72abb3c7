"""servo_keyboard_input: MoveIt Servo's keyboard teleop (moveit_servo's servo_keyboard_input demo)
for servo_node, with MoveIt's key map:

* arrow keys: +-x (up/down) and +-y (right/left); ``.`` / ``;``: -z / +z (Cartesian jog, unitless 1.0)
* ``w`` / ``e``: twists in the world (base) frame / the end-effector frame
* ``1`` ... ``6`` (as many as the group has joints): jog that joint; ``r`` reverses the direction
* ``j`` / ``t``: switch servo_node to joint jog / twist commands (~/switch_command_type)
* ``q``: quit

Each key press sends one command, as MoveIt's does: hold a key (the terminal's key repeat) to
keep the arm moving; servo_node halts it incoming_command_timeout after the last one.
Parameters: ``servo_node`` (the servo's node name), ``base_frame``, ``ee_frame``, ``joint_names``.
"""
from __future__ import annotations

import os
import select
import sys
import termios
import tty
from dataclasses import dataclass, field
from typing import Callable

from control_msgs.msg import JointJog
from geometry_msgs.msg import TwistStamped
from moveit_msgs.srv import ServoCommandType
from rclpy.node import Node

from mycobot_planning.ros.node_runtime import Parameters, ParameterSpec

MYCOBOT_ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6",
               "link6_to_link6_flange"]
ARROWS = {"A": "up", "B": "down", "C": "right", "D": "left"}
#: MoveIt's servo_keyboard_input: key -> (linear axis, sign)
LINEAR_KEYS = {"up": (0, 1.0), "down": (0, -1.0), "right": (1, 1.0), "left": (1, -1.0), ".": (2, -1.0), ";": (2, 1.0)}
HELP = """Reading from keyboard
---------------------------
All commands are in the planning frame
Use arrow keys and the '.' and ';' keys to Cartesian jog
Use 'w' to Cartesian jog in the world frame, and 'e' for the End-Effector frame
Use 1|2|3|4|5|6 keys to joint jog. 'r' to reverse the direction of jogging.
Use 'j' to select joint jog.
Use 't' to select twist
Use 'q' to quit."""


def split_keys(data: str) -> list[str]:
    """Bytes read from a terminal as keys: arrow escape sequences (ESC [ A..D) become "up",
    "down", "right", "left"; anything else one key per character."""
    keys, i = [], 0
    while i < len(data):
        if data[i] == "\x1b" and data[i + 1:i + 2] in ("[", "O") and data[i + 2:i + 3] in ARROWS:
            keys.append(ARROWS[data[i + 2]])
            i += 3
        elif data[i] == "\x1b":
            i += 1
        else:
            keys.append(data[i])
            i += 1
    return keys


@dataclass
class KeyMap:
    """What each key does (MoveIt's map); state: the twist frame and the jog direction."""

    base_frame: str
    ee_frame: str
    joint_names: list[str]
    frame: str = ""
    direction: float = 1.0
    log: Callable[[str], None] = field(default=print)

    def __post_init__(self) -> None:
        self.frame = self.frame or self.base_frame

    def handle(self, key: str) -> tuple[str, object] | None:
        """("twist", (linear, angular, frame)), ("jog", (name, velocity)), ("switch", type),
        ("quit", None) or None (a key without a meaning, or one that only changes state)."""
        if key in LINEAR_KEYS:
            axis, sign = LINEAR_KEYS[key]
            linear = [0.0, 0.0, 0.0]
            linear[axis] = sign
            return "twist", (linear, [0.0, 0.0, 0.0], self.frame)
        if key.isdigit() and 1 <= int(key) <= len(self.joint_names):
            return "jog", (self.joint_names[int(key) - 1], self.direction)
        if key == "r":
            self.direction = -self.direction
            self.log(f"joint jog direction reversed ({'+' if self.direction > 0 else '-'})")
        elif key == "w":
            self.frame = self.base_frame
            self.log(f"twists in the world frame ({self.base_frame})")
        elif key == "e":
            self.frame = self.ee_frame
            self.log(f"twists in the end-effector frame ({self.ee_frame})")
        elif key == "j":
            return "switch", ServoCommandType.Request.JOINT_JOG
        elif key == "t":
            return "switch", ServoCommandType.Request.TWIST
        elif key == "q":
            return "quit", None
        return None


class KeyboardServo(Node):
    """See the module docstring."""

    def __init__(self) -> None:
        super().__init__("servo_keyboard_input")
        params = Parameters(self, [
            ParameterSpec("servo_node", "/servo_node", "the servo node's name (its topics and services are under it)",
                          non_empty=True, read_only=True),
            ParameterSpec("base_frame", "base_link", "frame of twists after 'w'", non_empty=True),
            ParameterSpec("ee_frame", "link6_flange", "frame of twists after 'e'", non_empty=True),
            ParameterSpec("joint_names", MYCOBOT_ARM, "joints of keys 1, 2, ...", non_empty=True,
                          array_type=__import__("rclpy.parameter", fromlist=["Parameter"]).Parameter.Type.STRING_ARRAY),
        ])
        servo = params.get("servo_node").rstrip("/")
        self.keys = KeyMap(params.get("base_frame"), params.get("ee_frame"), list(params.get("joint_names")),
                           log=self._say)
        self._twist = self.create_publisher(TwistStamped, f"{servo}/delta_twist_cmds", 10)
        self._jog = self.create_publisher(JointJog, f"{servo}/delta_joint_cmds", 10)
        self._switch = self.create_client(ServoCommandType, f"{servo}/switch_command_type")

    def _say(self, text: str) -> None:
        sys.stdout.write(text + "\r\n")
        sys.stdout.flush()

    def switch(self, kind: int) -> None:
        if not self._switch.wait_for_service(timeout_sec=2.0):
            self._say(f"{self._switch.srv_name} is not available: is servo_node running?")
            return
        self._switch.call_async(ServoCommandType.Request(command_type=kind))
        self._say("joint jog mode" if kind == ServoCommandType.Request.JOINT_JOG else "twist mode")

    def press(self, key: str) -> bool:
        """Act on one key; False after 'q'."""
        action = self.keys.handle(key)
        if action is None:
            return True
        kind, value = action
        stamp = self.get_clock().now().to_msg()
        if kind == "twist":
            linear, angular, frame = value
            msg = TwistStamped()
            msg.header.stamp, msg.header.frame_id = stamp, frame
            msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z = linear
            msg.twist.angular.x, msg.twist.angular.y, msg.twist.angular.z = angular
            self._twist.publish(msg)
        elif kind == "jog":
            name, velocity = value
            msg = JointJog()
            msg.header.stamp, msg.header.frame_id = stamp, self.keys.base_frame
            msg.joint_names, msg.velocities = [name], [velocity]
            self._jog.publish(msg)
        elif kind == "switch":
            self.switch(int(value))
        elif kind == "quit":
            return False
        return True


def key_loop(node: KeyboardServo, fd: int, spin_once: Callable[[], None]) -> None:
    """Read keys from the terminal ``fd`` (raw mode) until 'q' or Ctrl-C."""
    node._say(HELP)
    node.switch(ServoCommandType.Request.TWIST)
    old = termios.tcgetattr(fd)
    tty.setcbreak(fd)
    try:
        while True:
            spin_once()
            ready, _, _ = select.select([fd], [], [], 0.05)
            if not ready:
                continue
            data = os.read(fd, 64).decode("utf-8", "replace")
            if not data or "\x03" in data:
                return
            for key in split_keys(data):
                if not node.press(key):
                    return
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, old)
