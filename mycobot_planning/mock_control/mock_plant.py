"""The mock controllers' plant: joints that are exactly where their controllers command them
(the follower's desired state is the actual one), with fault injection (a goal that fails, joints
that stall) and joints that can be put anywhere while no goal moves them. The controller manager
node drives it like any other plant (hardware_interface.plant)."""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from ..hardware_interface.plant import ControllerSpec, Plant
from .joint_trajectory_follower import JointTrajectoryFollower

#: the faults a mock controller can be given (s after a goal starts; negative disables)
FAULTS = ("fail_after", "stall_after")


class MockPlant(Plant):
    """``initial_positions``: joint name -> position at start-up (others: the model's defaults);
    ``faults``: controller -> {fault: seconds} injected from the start."""

    def __init__(self, variable_names: Sequence[str], default_positions: np.ndarray,
                 initial_positions: Mapping[str, float] | None = None,
                 faults: Mapping[str, Mapping[str, float]] | None = None) -> None:
        super().__init__(variable_names, default_positions)
        for joint, value in (initial_positions or {}).items():
            self.positions[self.variable_names.index(joint)] = float(value)
        self._faults = {name: dict(values) for name, values in (faults or {}).items()}

    def create_follower(self, spec: ControllerSpec) -> JointTrajectoryFollower:
        c = spec.config
        follower = JointTrajectoryFollower(
            c.joints, spec.lower, spec.upper, self.positions[spec.indices], goal_tolerance=c.goal_tolerance,
            start_tolerance=c.start_tolerance, name=c.name, velocity_limits=spec.velocity_limits,
            acceleration_limits=spec.acceleration_limits, limit_tolerance=spec.limit_tolerance)
        for fault, seconds in self._faults.get(c.name, {}).items():
            self._check_fault(fault)
            setattr(follower, fault, float(seconds))
        return follower

    @staticmethod
    def _check_fault(fault: str) -> None:
        if fault not in FAULTS:
            raise ValueError(f"unknown fault '{fault}'; faults: {', '.join(FAULTS)}")

    def set_fault(self, controller: str, fault: str, seconds: float) -> None:
        """Inject ``fault`` (one of FAULTS) into ``controller``'s next goals (negative: off)."""
        self._check_fault(fault)
        with self.host.lock:
            setattr(self.followers[controller][0], fault, float(seconds))

    def executing_goal(self, controller: str) -> str:
        """The goal ``controller`` is executing ("" when none)."""
        with self.host.lock:
            follower = self.followers[controller][0]
            return follower.goal_id if follower.active else ""

    def move_joints(self, positions: Mapping[str, float]) -> None:
        """Put joints somewhere else at once (the simulator's "initial position"); refused
        (StateError) for a controller that is executing a goal."""
        with self.host.lock:
            self.joint_state()  # the controlled joints' current positions into self.positions
            for joint, value in positions.items():
                self.positions[self.variable_names.index(joint)] = float(value)
            for follower, indices in self.followers.values():
                if any(j in positions for j in follower.joint_names):
                    follower.reset_positions(self.positions[indices])
