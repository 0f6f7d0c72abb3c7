"""Execution settings and the error every execution step raises (MoveIt's trajectory_execution.* parameters)."""
from __future__ import annotations

import math
from dataclasses import dataclass

from interfaces_py.msgs import MoveItErrorCode

from ..errors import PlanningError
from ..trajectory_processing.trajectory_limits import DEFAULT_LIMIT_TOLERANCE

SOURCE = "trajectory_execution"


class ExecutionError(PlanningError, ValueError):
    """Execution refused or failed before motion, with the MoveIt error code to report."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.message = message

    def error_code(self) -> MoveItErrorCode:
        return MoveItErrorCode(self.code, self.message, SOURCE)


@dataclass(frozen=True)
class ExecutionSettings:
    """MoveIt's trajectory_execution parameters (same names and defaults) plus our goal check."""

    allowed_execution_duration_scaling: float = 1.2
    allowed_goal_duration_margin: float = 0.5
    allowed_start_tolerance: float = 0.01  # rad (m); 0 disables the check
    execution_duration_monitoring: bool = True
    goal_tolerance: float = 0.02  # rad (m) between the last point and /joint_states; 0 disables
    joint_state_timeout: float = 1.0  # s: older joint states are stale
    #: relative slack on the joint velocity/acceleration limits a sent trajectory must keep
    limit_tolerance: float = DEFAULT_LIMIT_TOLERANCE

    def __post_init__(self) -> None:
        for name in ("allowed_execution_duration_scaling", "allowed_goal_duration_margin",
                     "allowed_start_tolerance", "goal_tolerance", "joint_state_timeout", "limit_tolerance"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        if self.allowed_execution_duration_scaling < 1.0:
            raise ValueError("allowed_execution_duration_scaling must be >= 1.0 "
                             f"(got {self.allowed_execution_duration_scaling}): a trajectory needs its own duration")
        if self.joint_state_timeout <= 0:
            raise ValueError("joint_state_timeout must be > 0")

    def allowed_duration(self, duration: float) -> float:
        return allowed_duration(duration, self.allowed_execution_duration_scaling, self.allowed_goal_duration_margin)


def allowed_duration(duration: float, scaling: float, margin: float) -> float:
    """MoveIt's limit on how long executing a trajectory of ``duration`` seconds may take."""
    return float(duration) * float(scaling) + float(margin)



def error_code(val: int, message: str) -> MoveItErrorCode:
    """A MoveItErrorCode whose source names trajectory execution."""
    return MoveItErrorCode(val, message, SOURCE)
