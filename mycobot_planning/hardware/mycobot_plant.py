"""The real myCobot 280 as a plant of the controller manager (hardware_interface.plant): the
followers measure the arm's readback instead of simulating it, and the driver core's I/O thread
(driver.py) reads the arm back and streams its commands at its own pace, under the manager's
lock. /joint_states carry the readback; nothing is reported before the first one."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from ..core.trajectory_execution.controllers_config import ControllerConfig
from ..hardware_interface.plant import ControllerSpec, Plant, PlantHost
from .driver import ArmLink, DriverConfig, DriverCore
from .follower import MeasuredTrajectoryFollower

GRIPPER_TYPE_SUFFIX = "GripperActionController"


@dataclass(frozen=True)
class TrackingSettings:
    """How goals are judged against the readback (the node's parameters of the same names)."""

    path_tolerance: float = 0.2
    goal_time: float = 2.0
    gripper_goal_time: float = 3.0
    gripper_allow_stalling: bool = True


class MyCobotPlant(Plant):
    """The arm over pymycobot: exactly one joint trajectory controller with the 6 arm joints and
    at most one gripper controller with one joint (ValueError otherwise)."""

    def __init__(self, variable_names: Sequence[str], default_positions: np.ndarray, config: DriverConfig,
                 controllers: Sequence[ControllerConfig], tracking: TrackingSettings = TrackingSettings(),
                 link_factory: Callable[[DriverConfig], ArmLink] | None = None) -> None:
        super().__init__(variable_names, default_positions)
        config.check()
        self.config = config
        self.tracking = tracking
        self._link_factory = link_factory
        arms = [c for c in controllers if not c.type.endswith(GRIPPER_TYPE_SUFFIX)]
        grippers = [c for c in controllers if c.type.endswith(GRIPPER_TYPE_SUFFIX)]
        if len(arms) != 1 or len(arms[0].joints) != 6:
            raise ValueError("the myCobot driver needs exactly one joint trajectory controller with the 6 arm "
                             f"joints (joints 1-6 in order); the controllers file has {[c.name for c in arms]}")
        if len(grippers) > 1 or (grippers and len(grippers[0].joints) != 1):
            raise ValueError("the myCobot driver drives at most one gripper controller with one joint")
        self.arm_controller = arms[0].name
        self.gripper_controller = grippers[0].name if grippers else None
        self.core: DriverCore | None = None

    def create_follower(self, spec: ControllerSpec) -> MeasuredTrajectoryFollower:
        c, t = spec.config, self.tracking
        if c.name == self.gripper_controller:
            lo, hi = self.config.gripper_limits()
            path_tolerance, goal_time, allow_stalling = math.inf, t.gripper_goal_time, t.gripper_allow_stalling
        else:
            lo, hi = self.config.firmware_limits()
            path_tolerance, goal_time, allow_stalling = t.path_tolerance, t.goal_time, False
        lower, upper = np.maximum(spec.lower, lo), np.minimum(spec.upper, hi)
        return MeasuredTrajectoryFollower(
            c.joints, lower, upper, np.clip(spec.initial_positions, lower, upper), goal_tolerance=c.goal_tolerance,
            start_tolerance=c.start_tolerance, name=c.name, velocity_limits=spec.velocity_limits,
            acceleration_limits=spec.acceleration_limits, limit_tolerance=spec.limit_tolerance,
            path_tolerance=path_tolerance, goal_time=goal_time, allow_stalling=allow_stalling)

    def start(self, host: PlantHost) -> None:
        super().start(host)
        arm = self.followers[self.arm_controller][0]
        gripper = self.followers[self.gripper_controller][0] if self.gripper_controller else None
        self.core = DriverCore(self.config, arm, gripper, lock=host.lock, clock=host.clock, on_event=host.log,
                               on_change=host.report, link_factory=self._link_factory)
        self.core.start()

    def commanded(self, controller: str) -> None:
        if self.core is not None:
            self.core.wake()  # the first command goes out now, not at the end of the period

    def joint_state(self) -> tuple[np.ndarray, np.ndarray] | None:
        arm = self.followers.get(self.arm_controller)
        if arm is None or not arm[0].measured:
            return None  # no readback yet: publish nothing rather than a made-up state
        return super().joint_state()

    def description(self) -> str:
        c = self.config
        return (f"myCobot 280 {c.model} on {c.port} at {c.baud} baud, commands and readback at "
                f"{c.command_rate:g} Hz")

    def state_source(self) -> str:
        return " from the arm's readback"

    def stats(self) -> dict[str, Any]:
        return self.core.stats() if self.core is not None else {}

    def close(self) -> None:
        """Stop the arm (the library's stop), then close the port."""
        core, self.core = self.core, None
        if core is not None:
            core.close(stop_arm=True)
