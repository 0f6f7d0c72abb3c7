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

A second loss, in the middleware: Fast DDS drops a response the server sends before it has
matched this client's response reader ("failed to send response (timeout): client will not
receive response"; seen on a loaded machine, the goal accepted and run, the client waiting
forever). The action's status topic lists every goal the server accepted, so a goal still waiting
for its response when the status lists it is completed from there (accepted), and the response,
should it come later, is dropped quietly. Without this a controller could run a trajectory whose
sender has no handle to cancel it.
"""
from __future__ import annotations

import functools
import threading
import weakref
from typing import Any, Callable

from action_msgs.msg import GoalStatus
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
#: per client: sequence numbers of goal requests completed from the status topic (a late response
#: to one of them is dropped)
_FROM_STATUS_ATTRIBUTE = "_mycobot_goals_from_status"
_FINAL = (GoalStatus.STATUS_SUCCEEDED, GoalStatus.STATUS_CANCELED, GoalStatus.STATUS_ABORTED)
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


def _accepted_from_status(client: Any, status_list: Any) -> None:
    """Complete the pending goal requests whose goals ``status_list`` lists: the server accepted
    them (it lists no other), their responses are lost or late."""
    pending = client._pending_goal_requests
    if not pending:
        return
    listed = {bytes(s.goal_info.goal_id.uuid): s.status for s in status_list}
    for sequence, future in list(pending.items()):
        goal_id = client._goal_sequence_number_to_goal_id.get(sequence)
        status = listed.get(bytes(goal_id.uuid)) if goal_id is not None else None
        if status is None or future.done():
            continue
        handle = _client.ClientGoalHandle(client, goal_id, client._action_type.Impl.SendGoalService.Response(
            accepted=True))
        handle._status = status
        if status not in _FINAL:  # rclpy keeps only running goals for later status updates
            client._goal_handles[bytes(goal_id.uuid)] = weakref.ref(handle)
        client.__dict__.setdefault(_FROM_STATUS_ATTRIBUTE, set()).add(sequence)
        future.set_result(handle)


def _dispatched_after_recording(execute: Callable[..., Any]) -> Callable[..., Any]:
    @functools.wraps(execute)
    async def dispatch(self: Any, taken_data: Any) -> None:
        # a response taken while its request is being recorded waits here until it is recorded
        with _request_lock(self):
            pass
        answered = self.__dict__.get(_FROM_STATUS_ATTRIBUTE)
        if answered and "goal" in taken_data and taken_data["goal"][0] in answered:
            answered.discard(taken_data["goal"][0])  # the status topic answered it already
            taken_data = {k: v for k, v in taken_data.items() if k != "goal"}
        await execute(self, taken_data)
        if "status" in taken_data:
            _accepted_from_status(self, taken_data["status"].status_list)
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
