"""What the three hybrid planning nodes (manager, global planner, local planner) share as MoveIt
runs them, each a component serving one action: that action server, and knowing when the node is
going down, so a goal still running ends with it instead of waiting for an answer nobody reads."""
from __future__ import annotations

from typing import Any, Callable

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.node import Node

from mycobot_planning.ros.action_servers import ACTION_SERVER_OPTIONS

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
