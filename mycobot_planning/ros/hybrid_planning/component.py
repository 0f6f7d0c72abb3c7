"""What the three hybrid planning nodes (manager, global planner, local planner) share as MoveIt
runs them, each a component serving one action: that action server, and knowing when the node is
going down, so a goal still running ends with it instead of waiting for an answer nobody reads,
and answering every goal, even one whose run raised."""
from __future__ import annotations

from typing import Any, Callable

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.node import Node

from mycobot_planning.ros.action_servers import ACTION_SERVER_OPTIONS, end_goal

__all__ = ["HybridPlanningComponent"]


class HybridPlanningComponent(Node):
    """A node serving one action (see :meth:`serve`), closed with :meth:`close`."""

    def __init__(self, node_name: str, **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self._closing = False
        self._server: ActionServer | None = None

    def serve(self, action_type: Any, name: str, execute: Callable[[Any], Any], callback_group: Any) -> None:
        """Serve ``action_type`` on ``name`` with ``execute``, accepting every goal and cancel (as
        MoveIt's components do: ``execute`` judges a goal and answers it)."""
        self._server = ActionServer(self, action_type, name, execute,
                                    goal_callback=lambda goal: GoalResponse.ACCEPT,
                                    cancel_callback=lambda handle: CancelResponse.ACCEPT,
                                    callback_group=callback_group, **ACTION_SERVER_OPTIONS)

    def close(self) -> None:
        self._closing = True
        if self._server is not None:
            self._server.destroy()

    def going_down(self) -> bool:
        """SIGINT/SIGTERM or close(): nothing can reach a client (nor, for the local planner, the
        controller) any more."""
        return self._closing or not self.context.ok()

    def end(self, goal_handle: Any, result: Any, outcome: str, message: str) -> Any:
        """``result``, after ending the goal by ``outcome`` (action_servers.end_goal; ``message`` is
        the warning of an abort) unless the node is going down: then the goal ends with it."""
        if not self.going_down():
            end_goal(goal_handle, outcome, self.get_logger(), message)
        return result

    def answer_always(self, goal_handle: Any, run: Callable[[Any], Any], result_type: Any, what: str,
                      fail: Callable[[Exception], Any]) -> Any:
        """``run(goal_handle)``'s answer; if it raises, the error is logged (as ``what`` failed) and
        ``fail(exc)`` answers the goal, or an empty ``result_type()`` while the node goes down."""
        try:
            return run(goal_handle)
        except Exception as exc:  # never leave a goal without an answer
            if self.going_down():
                return result_type()
            self.get_logger().error(f"{what} failed: {type(exc).__name__}: {exc}")
            return fail(exc)
