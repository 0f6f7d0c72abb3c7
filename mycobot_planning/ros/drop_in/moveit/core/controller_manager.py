"""``moveit.core.controller_manager``: moveit_py's ExecutionStatus."""
from __future__ import annotations

from interfaces_py.msgs import MoveItErrorCode

__all__ = ["ExecutionStatus"]

_STATUS = {MoveItErrorCode.SUCCESS: "SUCCEEDED", MoveItErrorCode.PREEMPTED: "PREEMPTED",
           MoveItErrorCode.TIMED_OUT: "TIMED_OUT", MoveItErrorCode.CONTROL_FAILED: "ABORTED"}


class ExecutionStatus:
    """How an execution ended: ``status`` is MoveIt's name (SUCCEEDED, PREEMPTED, TIMED_OUT,
    ABORTED, FAILED); truthy only when SUCCEEDED. ``error_code`` says why, as the planning_server
    reported it."""

    def __init__(self, error_code: MoveItErrorCode) -> None:
        self.error_code = error_code
        self.status = _STATUS.get(error_code.val, "FAILED")

    def __bool__(self) -> bool:
        return self.status == "SUCCEEDED"

    def __repr__(self) -> str:
        return f"ExecutionStatus({self.status}: {self.error_code.message})"
