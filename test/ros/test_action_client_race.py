"""interfaces_py.action_client: a goal sent from one thread while another spins the client is
never lost (ros2/rclpy#1123, seen in CI runs: the planning_server never learnt that the mock
controller had accepted a FollowJointTrajectory goal and reported TIMED_OUT; pymoveit2 waited
forever for a move_action goal the server had executed). The fix is made to rclpy's own class,
so the clients pymoveit2 builds get it too.

The race needs the response to be dispatched between "request sent" and "request recorded",
which is rare on its own; here the client's handle is wrapped so that the sending thread pauses
right after the send, which makes the response arrive inside that window every time."""
from __future__ import annotations

import time
from typing import Any

import pytest
from control_msgs.action import GripperCommand
from rclpy.action import ActionClient as RclpyActionClient
from rclpy.action import ActionServer

from interfaces_py.action_client import UNFIXED_METHODS, ActionClient
from ros_testing import ProbeNode, use_session_domain, wait_until

PAUSE_AFTER_SEND = 0.3  # s: long enough for the executor to take and dispatch the response


class _SlowToRecord:
    """The client's rcl handle, pausing after each request is sent (a thread preempted there)."""

    def __init__(self, handle: Any) -> None:
        self._handle = handle

    def __getattr__(self, name: str) -> Any:
        return getattr(self._handle, name)

    def __enter__(self) -> Any:
        return self._handle.__enter__()

    def __exit__(self, *exc: Any) -> Any:
        return self._handle.__exit__(*exc)

    def _paused(self, send: Any, request: Any) -> int:
        sequence = send(request)
        time.sleep(PAUSE_AFTER_SEND)
        return sequence

    def send_goal_request(self, request: Any) -> int:
        return self._paused(self._handle.send_goal_request, request)

    def send_result_request(self, request: Any) -> int:
        return self._paused(self._handle.send_result_request, request)

    def send_cancel_request(self, request: Any) -> int:
        return self._paused(self._handle.send_cancel_request, request)


@pytest.fixture
def probe():
    use_session_domain()
    probe = ProbeNode("action_race_probe")

    def execute(goal_handle: Any) -> Any:
        goal_handle.succeed()
        result = GripperCommand.Result()
        result.position = goal_handle.request.command.position
        result.reached_goal = True
        return result

    probe.server = ActionServer(probe.node, GripperCommand, "/race_test/gripper_cmd", execute)
    probe.spin_in_background()
    try:
        yield probe
    finally:
        probe.close()


def _send_and_wait(client: Any) -> tuple[Any, Any]:
    """(goal handle or None, result or None) of one goal sent from this (non-executor) thread."""
    client._client_handle = _SlowToRecord(client._client_handle)
    goal = GripperCommand.Goal()
    goal.command.position = 0.25
    future = client.send_goal_async(goal)
    if not wait_until(future.done, 3.0):
        return None, None
    handle = future.result()
    result = handle.get_result_async()
    return handle, (result.result().result if wait_until(result.done, 3.0) else None)


class UnfixedActionClient(RclpyActionClient):
    """rclpy's ActionClient as the wheel installs it, without interfaces_py's fix."""

    send_goal_async = UNFIXED_METHODS["send_goal_async"]
    _cancel_goal_async = UNFIXED_METHODS["_cancel_goal_async"]
    _get_result_async = UNFIXED_METHODS["_get_result_async"]
    execute = UNFIXED_METHODS["execute"]


def test_rclpy_own_class_is_the_fixed_one():
    """pymoveit2 builds rclpy.action.ActionClient itself: the fix must be on that class."""
    assert ActionClient is RclpyActionClient
    for name, unfixed in UNFIXED_METHODS.items():
        assert getattr(RclpyActionClient, name) is not unfixed, f"{name} is not fixed"
        assert getattr(RclpyActionClient, name).__wrapped__ is unfixed


@pytest.mark.parametrize("make", [ActionClient, RclpyActionClient], ids=["interfaces_py", "rclpy.action"])
def test_goal_and_result_responses_arrive_although_the_sender_is_slow_to_record_them(probe, make):
    client = make(probe.node, GripperCommand, "/race_test/gripper_cmd")
    assert client.wait_for_server(timeout_sec=10.0)
    handle, result = _send_and_wait(client)
    assert handle is not None and handle.accepted, "the goal response was lost"
    assert result is not None and result.reached_goal and result.position == pytest.approx(0.25), \
        "the result response was lost"


def test_the_unfixed_client_loses_the_goal_response_in_the_same_situation(probe):
    """Why the fix exists: if this starts failing, the installed rclpy has the upstream fix
    (ros2/rclpy#1308) and interfaces_py/action_client.py can go."""
    client = UnfixedActionClient(probe.node, GripperCommand, "/race_test/gripper_cmd")
    assert client.wait_for_server(timeout_sec=10.0)
    handle, _ = _send_and_wait(client)
    assert handle is None, "rclpy's ActionClient no longer loses the response: drop the workaround"


@pytest.mark.parametrize("make", [ActionClient, RclpyActionClient], ids=["interfaces_py", "rclpy.action"])
def test_a_goal_response_lost_in_the_middleware_is_answered_by_the_status_topic(probe, make):
    """Fast DDS drops a response the server sends before it has matched the client's reader (seen
    on a loaded machine). Here the client never sees a goal response: the goal still completes as
    accepted from the action's status topic, its result arrives, and the response, delivered late,
    is dropped without a warning or an error."""
    client = make(probe.node, GripperCommand, "/race_test/gripper_cmd")
    assert client.wait_for_server(timeout_sec=10.0)
    held: list[Any] = []
    execute = type(client).execute

    async def lossy(taken_data: Any) -> None:
        if "goal" in taken_data:
            held.append(taken_data["goal"])
        await execute(client, {k: v for k, v in taken_data.items() if k != "goal"})

    client.execute = lossy
    goal = GripperCommand.Goal()
    goal.command.position = 0.25
    future = client.send_goal_async(goal)
    assert wait_until(future.done, 5.0), "the goal was never answered"
    handle = future.result()
    assert handle.accepted
    result = handle.get_result_async()
    assert wait_until(result.done, 5.0) and result.result().result.reached_goal
    assert wait_until(lambda: bool(held), 5.0), "the server's response never reached the client at all"
    late = execute(client, {"goal": held[0]})  # the response arriving after all
    with pytest.raises(StopIteration):
        late.send(None)
    assert not client.__dict__.get("_mycobot_goals_from_status"), "the late response was not recognised"
