"""An rclpy ActionClient whose requests can be sent from any thread without losing the response.

Why: in rclpy 7.1.6 (Jazzy, the only Jazzy rclpy on PyPI), ``send_goal_async`` sends the
request first and only then records its sequence number. When an executor spins the client on
another thread (every node here that executes trajectories, and every test probe), the response
can be taken and dispatched in between: rclpy logs "Ignoring unexpected goal response. There may
be more than one action server" and the future never completes (ros2/rclpy#1123, fixed upstream
by ros2/rclpy#1308 and its backports, not in the Jazzy wheel). A CI run of this project lost a
FollowJointTrajectory goal response that way: the mock controller executed and finished the
trajectory, but the planning_server never asked for the result and reported TIMED_OUT.

The same holds for cancel and result requests. Written by hand because the fixed rclpy is not
installable here: each request is sent and recorded under one lock, and the executor's dispatch
waits for that lock before it looks a response up, so a response is never looked up before its
request is recorded. The lock is never held while a response is dispatched, so a done callback
that sends the next request (the goal response asking for the result) cannot deadlock.
"""
from __future__ import annotations

import threading
from typing import Any

from rclpy.action import ActionClient as _RclpyActionClient

__all__ = ["ActionClient"]


class ActionClient(_RclpyActionClient):
    """rclpy's ActionClient, same constructor and API, with the request/response race closed."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self._request_lock = threading.Lock()
        super().__init__(*args, **kwargs)

    def send_goal_async(self, goal: Any, feedback_callback: Any = None, goal_uuid: Any = None) -> Any:
        with self._request_lock:
            return super().send_goal_async(goal, feedback_callback=feedback_callback, goal_uuid=goal_uuid)

    def _cancel_goal_async(self, goal_handle: Any) -> Any:
        with self._request_lock:
            return super()._cancel_goal_async(goal_handle)

    def _get_result_async(self, goal_handle: Any) -> Any:
        with self._request_lock:
            return super()._get_result_async(goal_handle)

    async def execute(self, taken_data: Any) -> None:
        # A response taken while its request is being recorded waits here until it is recorded.
        with self._request_lock:
            pass
        await super().execute(taken_data)
