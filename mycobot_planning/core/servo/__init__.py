"""MoveIt Servo's computation without ROS: twist, joint jog and pose commands turned into the next
joint positions of a planning group, scaled to the joint velocity limits, slowed and halted near
singularities, collisions and joint limits, and smoothed. The servo_node
(mycobot_planning.ros.servo) feeds it commands and robot states and publishes what it returns.

The full story: docs/servo.md.
"""
from .parameters import ServoParameters, StatusCode, STATUS_MESSAGES, CommandType
from .smoothing import ButterworthFilter
from .servo import (
    CommandError,
    JointJogCommand,
    PoseCommand,
    Servo,
    ServoStep,
    TwistCommand,
    collision_velocity_scale,
)

__all__ = [
    "ButterworthFilter",
    "CommandError",
    "CommandType",
    "JointJogCommand",
    "PoseCommand",
    "STATUS_MESSAGES",
    "Servo",
    "ServoParameters",
    "ServoStep",
    "StatusCode",
    "TwistCommand",
    "collision_velocity_scale",
]
