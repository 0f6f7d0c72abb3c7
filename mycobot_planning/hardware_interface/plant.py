"""The Plant interface: ros2_control's split between the controller manager (controllers,
actions, joint_state broadcaster, limit checks; written once) and the hardware it drives.

A plant gives each controller its trajectory follower (JTC's goal handling: validation, limits,
start tolerance, preemption, interpolation, goal tolerance), keeps the followers' actual state in
step with the joints (``read``), sends the followers' desired state to the joints (``write``),
and reports the joint state the broadcaster publishes. The manager calls ``read``, updates the
due controllers and calls ``write`` once per control period, all under ``PlantHost.lock``; a plant
with I/O of its own pace (a serial link, a physics thread) may instead do both in its own thread
under the same lock and report goal changes through ``PlantHost.report``.
"""
from __future__ import annotations

import threading
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ..core.trajectory_execution.controllers_config import ControllerConfig
from ..mock_control.joint_trajectory_follower import FollowerState, JointTrajectoryFollower

#: A log line from a plant: (level "info" | "warning" | "error", text).
LogSink = Callable[[str, str], None]


@dataclass(frozen=True)
class ControllerSpec:
    """What a plant needs to build one controller's follower: the controller's configuration, the
    indices of its joints in the robot's variable vector, their limits from the robot model, the
    positions the model starts them at, and the controller's limit tolerance."""

    config: ControllerConfig
    indices: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    velocity_limits: np.ndarray
    acceleration_limits: np.ndarray
    initial_positions: np.ndarray
    limit_tolerance: float

    @property
    def is_gripper(self) -> bool:
        return self.config.type.endswith("GripperActionController")


@dataclass
class PlantHost:
    """The controller manager as a plant sees it: the lock every follower is used under, the
    manager's clock (s), a log sink, and ``report(follower, state)`` for a goal state change the
    plant caused outside the manager's loop (the manager logs and publishes it)."""

    lock: Any = field(default_factory=threading.Lock)
    clock: Callable[[], float] = lambda: 0.0
    log: LogSink = lambda level, text: None
    report: Callable[[JointTrajectoryFollower, FollowerState], None] = lambda follower, state: None


class Plant(ABC):
    """What moves the joints (see the module docstring). ``variable_names`` and
    ``default_positions`` are the robot model's variables, the layout of ``joint_state``."""

    def __init__(self, variable_names: tuple[str, ...] | list[str], default_positions: np.ndarray) -> None:
        self.variable_names = tuple(variable_names)
        self.positions = np.array(default_positions, dtype=float)
        self.velocities = np.zeros_like(self.positions)
        self.followers: dict[str, tuple[JointTrajectoryFollower, np.ndarray]] = {}
        self.host = PlantHost()

    @abstractmethod
    def create_follower(self, spec: ControllerSpec) -> JointTrajectoryFollower:
        """The follower of one controller over this plant's joints (not yet registered)."""

    def make_follower(self, spec: ControllerSpec) -> JointTrajectoryFollower:
        """Build and register the follower of ``spec``'s controller."""
        follower = self.create_follower(spec)
        self.followers[spec.config.name] = (follower, np.asarray(spec.indices, dtype=int))
        return follower

    def start(self, host: PlantHost) -> None:
        """Begin driving the joints (threads, I/O); ``host`` is the manager."""
        self.host = host

    def follower_time(self, now: float) -> float:
        """The time the followers run on (their goals' timing, path tolerance and goal_time) when
        the manager's clock reads ``now``: that clock itself, unless the plant keeps time of its
        own (a simulation that can fall behind real time). Under the lock."""
        return now

    def read(self, now: float) -> None:
        """Joints → followers (their measured state), before the controllers' update. Under the lock."""

    def write(self, now: float) -> None:
        """Followers → joints (their desired state), after the controllers' update. Under the lock."""

    def commanded(self, controller: str) -> None:
        """A goal was just accepted by ``controller`` (called outside the lock)."""

    def joint_state(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Positions and velocities of every robot variable now (the broadcaster's
        /joint_states), or None while the plant has no state to report (no readback yet). Under
        the lock. By default the followers' actual state over the model's defaults."""
        for follower, indices in self.followers.values():
            self.positions[indices] = follower.positions
            self.velocities[indices] = follower.velocities
        return self.positions, self.velocities

    def description(self) -> str:
        """What the plant is, for the manager's ready line ("" for the mock)."""
        return ""

    def state_source(self) -> str:
        """Where /joint_states come from, appended to the ready line ("" for commanded state)."""
        return ""

    def stats(self) -> dict[str, Any]:
        """Figures of the plant's I/O (rates, connection) for tests and benchmarks."""
        return {}

    def close(self) -> None:
        """On shutdown: stop the joints and release the hardware."""
