"""MoveIt Servo's parameters (names and defaults of moveit_servo's servo_parameters.yaml, without
the ``moveit_servo.`` prefix the node puts before them), status codes and command types."""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields


class StatusCode:
    """moveit_msgs/ServoStatus codes (moveit_servo::StatusCode)."""

    INVALID = -1
    NO_WARNING = 0
    DECELERATE_FOR_APPROACHING_SINGULARITY = 1
    HALT_FOR_SINGULARITY = 2
    DECELERATE_FOR_LEAVING_SINGULARITY = 3
    DECELERATE_FOR_COLLISION = 4
    HALT_FOR_COLLISION = 5
    JOINT_BOUND = 6


STATUS_MESSAGES = {
    StatusCode.INVALID: "Invalid",
    StatusCode.NO_WARNING: "No warnings",
    StatusCode.DECELERATE_FOR_APPROACHING_SINGULARITY: "Moving closer to a singularity, decelerating",
    StatusCode.HALT_FOR_SINGULARITY: "Very close to a singularity, emergency stop",
    StatusCode.DECELERATE_FOR_LEAVING_SINGULARITY: "Moving away from a singularity, decelerating",
    StatusCode.DECELERATE_FOR_COLLISION: "Close to a collision, decelerating",
    StatusCode.HALT_FOR_COLLISION: "Collision detected, emergency stop",
    StatusCode.JOINT_BOUND: "Close to a joint bound (position or velocity), halting",
}


class CommandType:
    """moveit_msgs/srv/ServoCommandType's constants."""

    JOINT_JOG = 0
    TWIST = 1
    POSE = 2
    NAMES = {0: "JOINT_JOG", 1: "TWIST", 2: "POSE"}


COMMAND_IN_TYPES = ("unitless", "speed_units")


@dataclass
class ServoParameters:
    """What the computation reads (the node's other parameters: topics, output type, threads)."""

    move_group_name: str = "arm"
    publish_period: float = 0.01
    max_expected_latency: float = 0.1
    incoming_command_timeout: float = 0.1
    command_in_type: str = "unitless"
    scale_linear: float = 0.4
    scale_rotational: float = 0.8
    scale_joint: float = 0.5
    apply_twist_commands_about_ee_frame: bool = True
    pose_tracking_linear_tolerance: float = 0.001
    pose_tracking_angular_tolerance: float = 0.01
    check_collisions: bool = True
    collision_check_rate: float = 10.0
    self_collision_proximity_threshold: float = 0.01
    scene_collision_proximity_threshold: float = 0.02
    lower_singularity_threshold: float = 17.0
    hard_stop_singularity_threshold: float = 30.0
    leaving_singularity_threshold_multiplier: float = 2.0
    singularity_step_scale: float = 0.01
    joint_limit_margins: list[float] = field(default_factory=lambda: [0.1])
    halt_all_joints_in_joint_mode: bool = True
    halt_all_joints_in_cartesian_mode: bool = True
    override_velocity_scaling_factor: float = 0.0
    butterworth_filter_coeff: float = 1.5
    use_smoothing: bool = True

    def problems(self, dof: int | None = None) -> list[str]:
        """Why these values cannot be used (empty when they can)."""
        out = []
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, float) and not math.isfinite(value):
                out.append(f"{f.name} must be finite, got {value}")
        positive = ("publish_period", "max_expected_latency", "incoming_command_timeout", "scale_linear",
                    "scale_rotational", "scale_joint", "pose_tracking_linear_tolerance",
                    "pose_tracking_angular_tolerance", "collision_check_rate",
                    "self_collision_proximity_threshold", "scene_collision_proximity_threshold",
                    "lower_singularity_threshold", "hard_stop_singularity_threshold",
                    "leaving_singularity_threshold_multiplier", "singularity_step_scale")
        out += [f"{name} must be > 0, got {getattr(self, name)}" for name in positive if not getattr(self, name) > 0]
        if self.command_in_type not in COMMAND_IN_TYPES:
            out.append(f"command_in_type must be one of {list(COMMAND_IN_TYPES)}, got '{self.command_in_type}'")
        if not self.hard_stop_singularity_threshold > self.lower_singularity_threshold:
            out.append("hard_stop_singularity_threshold must be greater than lower_singularity_threshold")
        if not 0.0 <= self.override_velocity_scaling_factor <= 1.0:
            out.append("override_velocity_scaling_factor must be within [0, 1]")
        if not self.butterworth_filter_coeff > 1.0:
            out.append(f"butterworth_filter_coeff must be > 1, got {self.butterworth_filter_coeff}")
        margins = list(self.joint_limit_margins)
        if not margins or any(not math.isfinite(m) or m < 0 for m in margins):
            out.append("joint_limit_margins must hold finite values >= 0")
        elif dof is not None and len(margins) not in (1, dof):
            out.append(f"joint_limit_margins must have 1 or {dof} values (one per joint), got {len(margins)}")
        return out
