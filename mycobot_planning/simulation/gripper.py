"""The gripper's command and state with the semantics of control_msgs/GripperCommand.

A command is a position and a max effort; the state says where the finger joint is, the effort
its servo exerts, whether it reached the goal (within ``goal_tolerance``) or stalled (it stopped
moving, slower than ``stall_velocity_threshold`` for ``stall_timeout``, away from the goal:
what happens when the fingers close on an object). These are ros2_control's
GripperActionController's rules and parameter names, so a plant adapter passes them through.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .errors import CommandError
from .settings import GripperSettings


@dataclass(frozen=True)
class GripperCommand:
    """control_msgs/GripperCommand: ``position`` of the gripper joint (rad or m, as the URDF),
    ``max_effort`` the most the servo may push (N m or N; 0: the joint's effort limit)."""

    position: float
    max_effort: float = 0.0


@dataclass(frozen=True)
class GripperState:
    """What a GripperCommand action reports (feedback and result), plus what the pads touch.

    ``active``: a command is being executed (neither reached nor stalled yet); ``contacts``: the
    objects the finger pads touch, by name."""

    position: float
    velocity: float
    effort: float
    stalled: bool
    reached_goal: bool
    active: bool
    command: GripperCommand | None
    contacts: tuple[str, ...] = ()


class GripperGoalTracker:
    """Follows one command: rate-limited target, reached / stalled by the controller's rules."""

    def __init__(self, joint: str, lower: float, upper: float, max_velocity: float, effort_limit: float,
                 settings: GripperSettings) -> None:
        self.joint = joint
        self.lower, self.upper = float(lower), float(upper)
        self.max_velocity = float(max_velocity) if math.isfinite(max_velocity) and max_velocity > 0 else 0.5
        self.effort_limit = float(effort_limit)
        self.settings = settings
        self.command: GripperCommand | None = None
        self.target = 0.0  # where the servo is told to go now (ramps towards the command)
        self.reached = False
        self.stalled = False
        self._last_movement = 0.0

    def check(self, command: GripperCommand) -> GripperCommand:
        """The command, or CommandError saying why it is refused (NaN, outside the limits)."""
        position, effort = command.position, command.max_effort
        if not isinstance(position, (int, float)) or not math.isfinite(position):
            raise CommandError(f"gripper command: position must be a finite number, got {position!r}")
        if not isinstance(effort, (int, float)) or not math.isfinite(effort) or effort < 0:
            raise CommandError(f"gripper command: max_effort must be a finite number >= 0, got {effort!r}")
        if not self.lower - 1e-9 <= position <= self.upper + 1e-9:
            raise CommandError(f"gripper command: {self.joint} = {position:g} is outside its limits "
                               f"[{self.lower:g}, {self.upper:g}]")
        return GripperCommand(float(position), float(effort))

    def start(self, command: GripperCommand, position: float, now: float) -> None:
        self.command = self.check(command)
        self.target = float(position)
        self.reached = False
        self.stalled = False
        self._last_movement = now

    def hold(self, position: float) -> None:
        """No goal: hold ``position`` (start-up, reset)."""
        self.command = None
        self.target = float(position)
        self.reached = False
        self.stalled = False

    def effort_bound(self) -> float:
        """The servo's force limit for the current command."""
        if self.command is not None and self.command.max_effort > 0:
            return min(self.command.max_effort, self.effort_limit)
        return self.effort_limit

    def advance(self, dt: float) -> float:
        """Move the servo target towards the commanded position at the joint's velocity limit."""
        if self.command is not None:
            step = self.max_velocity * dt
            delta = self.command.position - self.target
            self.target = self.command.position if abs(delta) <= step else self.target + math.copysign(step, delta)
        return self.target

    def update(self, position: float, velocity: float, now: float) -> None:
        """GripperActionController's rules, once per step: reached within goal_tolerance; stalled
        when slower than stall_velocity_threshold for stall_timeout without reaching it."""
        if self.command is None or self.reached or self.stalled:
            return
        s = self.settings
        if abs(position - self.command.position) <= s.goal_tolerance:
            self.reached = True
        elif abs(velocity) > s.stall_velocity_threshold or self.target != self.command.position:
            self._last_movement = now
        elif now - self._last_movement > s.stall_timeout:
            self.stalled = True

    @property
    def active(self) -> bool:
        return self.command is not None and not (self.reached or self.stalled)
