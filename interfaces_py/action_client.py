"""rclpy's ActionClient with its request/response race closed, for every client of the process.

Why: in rclpy 7.1.5 (what ros-jazzy-rclpy 7.1.6, the only Jazzy rclpy on PyPI, installs),
``send_goal_async`` sends the request first and only then records its sequence number. When an
executor spins the client on another thread (every node here that executes trajectories, every
test probe, every pymoveit2 user with its background executor), the response can be taken and
dispatched in between: rclpy logs "Ignoring unexpected goal response. There may be more than one
action server" and the future never completes (ros2/rclpy#1123, fixed upstream by
ros2/rclpy#1308 and its backports, not in this wheel). The same holds for cancel and result
requests. Seen here twice: the planning_server never learnt that the mock controller had accepted
a FollowJointTrajectory goal (it reported TIMED_OUT), and pymoveit2's ``wait_until_executed``
waited forever for a move_action goal the server had executed.

Importing this module fixes rclpy's own ``rclpy.action.ActionClient`` class in place (idempotent),
so clients built by code nobody here wrote (pymoveit2's MoveIt2, GripperInterface) are fixed too,
not only ours: each request is sent and recorded under a per-client lock, and the executor's
dispatch of a response waits for that lock before it looks the request up. The lock is never held
while a response is dispatched, so a done callback that sends the next request (the goal
response asking for the result) cannot deadlock. Written by hand because the fixed rclpy is not
installable here; test/ros/test_action_client_race.py shows the unfixed methods still lose the
response, and says when this module can go.
"""
from __future__ import annotations

import functools
import threading
from typing import Any, Callable

from rclpy.action import client as _client

__all__ = ["ActionClient", "UNFIXED_METHODS", "fix_rclpy_action_client"]

#: rclpy's ActionClient (fixed in place on import of this module).
ActionClient = _client.ActionClient

#: The methods the fix wraps, as rclpy has them: what test_action_client_race shows still races.
_SENDERS = ("send_goal_async", "_cancel_goal_async", "_get_result_async")
UNFIXED_METHODS: dict[str, Callable[..., Any]] = {
    name: getattr(getattr(ActionClient, name), "__wrapped__", getattr(ActionClient, name))
    for name in (*_SENDERS, "execute")}

_LOCK_ATTRIBUTE = "_mycobot_request_lock"
_creating = threading.Lock()


def _request_lock(client: Any) -> threading.Lock:
    """The client's request lock, made on first use (clients built before the fix get one too)."""
    lock = client.__dict__.get(_LOCK_ATTRIBUTE)
    if lock is None:
        with _creating:
            lock = client.__dict__.setdefault(_LOCK_ATTRIBUTE, threading.Lock())
    return lock


def _recorded_under_lock(send: Callable[..., Any]) -> Callable[..., Any]:
    @functools.wraps(send)
    def sender(self: Any, *args: Any, **kwargs: Any) -> Any:
        with _request_lock(self):
            return send(self, *args, **kwargs)
    sender._mycobot_fixed = True  # type: ignore[attr-defined]
    return sender


def _dispatched_after_recording(execute: Callable[..., Any]) -> Callable[..., Any]:
    @functools.wraps(execute)
    async def dispatch(self: Any, taken_data: Any) -> None:
        # a response taken while its request is being recorded waits here until it is recorded
        with _request_lock(self):
            pass
        await execute(self, taken_data)
    dispatch._mycobot_fixed = True  # type: ignore[attr-defined]
    return dispatch


def fix_rclpy_action_client() -> None:
    """Wrap rclpy's ActionClient request methods and response dispatch (once per process)."""
    if getattr(ActionClient.execute, "_mycobot_fixed", False):
        return
    for name in _SENDERS:
        setattr(ActionClient, name, _recorded_under_lock(UNFIXED_METHODS[name]))
    ActionClient.execute = _dispatched_after_recording(UNFIXED_METHODS["execute"])


fix_rclpy_action_client()
