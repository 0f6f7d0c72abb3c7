"""move_group's stop (MoveIt: /trajectory_execution_event "stop"): the running execution stops
and every running plan is cancelled (they answer PREEMPTED)."""
from __future__ import annotations

from dataclasses import dataclass

from .move_group_context import MoveGroupContext

__all__ = ["StopResult", "shut_down", "stop"]


@dataclass
class StopResult:
    stopped: bool
    message: str
    cancelled_plans: int


def stop(ctx: MoveGroupContext) -> StopResult:
    cancels = ctx.running_plans()
    for context in cancels:
        context.terminate()
    stopped = ctx.executor.stop()
    parts = (["stopping the running execution"] if stopped else []) + (
        [f"cancelling {len(cancels)} running plan{'s' if len(cancels) != 1 else ''}"] if cancels else [])
    message = " and ".join(parts) if parts else "nothing is executing or planning"
    ctx.log("info", f"stop requested: {message}")
    return StopResult(stopped or bool(cancels), message, len(cancels))


def shut_down(ctx: MoveGroupContext) -> StopResult:
    """The process is going down (SIGINT/SIGTERM): stop as stop() does, and refuse every plan and
    every execution that starts afterwards (PREEMPTED), so that a request that was just arriving
    cannot keep the process, and its client, waiting."""
    ctx.shut_down()
    return stop(ctx)
