"""Options every action server of ours is created with (rclpy.action.ActionServer keywords).

rclpy's defaults lose and hoard results: its goal, cancel and result services keep 10 requests
(of 20 plan-only goals sent at once, 10 results were never delivered), and a finished goal's
result is kept 900 s (the planning_server's memory grew by each MoveGroup result, ~45 kB, through
a 400-goal soak: bench soak). Ours keep 1,000 requests and each result 60 s after its goal ends,
time enough for any client that asks for it (rclpy's and rclcpp's clients ask right after the
goal is accepted).

end_goal is how our servers end a goal by its outcome, one rule for all of them: succeeded,
canceled, or aborted with a warning that says why.
"""
from __future__ import annotations

from typing import Any, Protocol

from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

#: requests the goal, cancel and result services keep
ACTION_SERVICE_DEPTH = 1000
#: s a finished goal's result is kept for its client to ask
ACTION_RESULT_TIMEOUT = 60

ACTION_SERVER_OPTIONS: dict[str, Any] = {
    **{f"{kind}_service_qos_profile": QoSProfile(depth=ACTION_SERVICE_DEPTH, reliability=ReliabilityPolicy.RELIABLE,
                                                 durability=DurabilityPolicy.VOLATILE)
       for kind in ("goal", "result", "cancel")},
    "result_timeout": ACTION_RESULT_TIMEOUT,
}


class _Logger(Protocol):
    def warning(self, message: str) -> Any: ...


#: the outcomes end_goal knows by name; any other one aborts the goal
SUCCEEDED = "succeeded"
CANCELED = "canceled"
ABORTED = "aborted"


def end_goal(goal_handle: Any, outcome: str, logger: _Logger, message: str) -> None:
    """End a running goal: ``"succeeded"`` succeeds it, ``"canceled"`` marks it canceled, any
    other outcome aborts it after logging ``message`` as a warning."""
    if outcome == SUCCEEDED:
        goal_handle.succeed()
    elif outcome == CANCELED:
        goal_handle.canceled()
    else:
        logger.warning(message)
        goal_handle.abort()
