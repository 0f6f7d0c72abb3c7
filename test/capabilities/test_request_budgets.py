"""The planning server's core refuses requests that cannot be right or would never end, lets
several clients plan at once, and stop() ends running plans (issue 13).

No ROS here: MoveGroupJsonFace with a controller bus that is never used (nothing executes).
"""
from __future__ import annotations

import json
import threading
import time

import numpy as np
import pytest

from interfaces_py.json_rpc import BAD_REQUEST, MAX_REQUEST_BYTES, RpcError, decode_request, log_safe
from interfaces_py.msgs import JointTrajectory, JointTrajectoryPoint, MoveItErrorCode
from mycobot_planning.core.trajectory_execution import ControllerInfo, ExecutionSettings
from interfaces_py.msgs import WORKSPACE_BOUND
from mycobot_planning.capabilities import stop
from mycobot_planning.capabilities.cartesian_path import MAX_WAYPOINTS
from mycobot_planning.capabilities.json_face import MoveGroupJsonFace
from mycobot_planning.capabilities.plan import MAX_PLANNING_ATTEMPTS, MAX_PLANNING_TIME
from mycobot_planning.core.robot_model.robot_model import RobotModel

ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6", "link6_to_link6_flange"]
INTERNAL_NAMES = ("IndexError", "KeyError", "TypeError", "ValueError", "Traceback", "AttributeError")


class IdleBus:
    """A controller bus for a server that only plans here."""

    def is_available(self, controller: str) -> bool:
        return False

    def send(self, controller, trajectory) -> None:
        raise AssertionError("nothing may be sent to a controller in these tests")

    def stop(self, controller: str) -> None:
        pass

    def controller_state(self, controller, goal_id=None):
        return None


def _core(model: RobotModel, pipeline) -> MoveGroupJsonFace:
    core = MoveGroupJsonFace(model, pipeline, [ControllerInfo("arm_controller", tuple(ARM))], IdleBus(),
                              ExecutionSettings())
    names = list(model.variable_names)
    assert core.update_joint_state(names, [0.0] * len(names)) is None
    return core


@pytest.fixture()
def core(mycobot, pipeline) -> MoveGroupJsonFace:
    return _core(mycobot, pipeline)


def _error(result) -> tuple[int, str]:
    return result["error_code"]["val"], result["error_code"]["message"]


@pytest.mark.parametrize("change, code, words", [
    ({"allowed_planning_time": 1e9}, MoveItErrorCode.INVALID_MOTION_PLAN, f"{MAX_PLANNING_TIME:g}"),
    ({"allowed_planning_time": -1.0}, MoveItErrorCode.INVALID_MOTION_PLAN, "allowed_planning_time"),
    ({"num_planning_attempts": 10 ** 9}, MoveItErrorCode.INVALID_MOTION_PLAN, f"{MAX_PLANNING_ATTEMPTS}"),
    ({"num_planning_attempts": -3}, MoveItErrorCode.INVALID_MOTION_PLAN, "num_planning_attempts"),
    ({"max_velocity_scaling_factor": 7.0}, MoveItErrorCode.INVALID_MOTION_PLAN, "max_velocity_scaling_factor"),
    ({"max_acceleration_scaling_factor": -0.5}, MoveItErrorCode.INVALID_MOTION_PLAN, "max_acceleration_scaling"),
    ({"goal": {"named": "ready", "tolerance": -1}}, MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "negative"),
    ({"goal": {"pose": [0.15, 0, 0.2, 1, 0, 0, 0], "position_tolerance": -0.01}},
     MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "position_tolerance must not be negative"),
    ({"goal": {"pose": [1e308, 0, 0.2, 1, 0, 0, 0]}}, MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "workspace bound"),
    ({"goal": {"pose": {"position": [0.1, -5e3, 0.1]}}}, MoveItErrorCode.INVALID_GOAL_CONSTRAINTS,
     "workspace bound"),
    ({"start_state": {"joint_names": ["link2_to_link3"], "positions": [9.0]}}, MoveItErrorCode.INVALID_ROBOT_STATE,
     "link2_to_link3=9 outside"),
])
def test_plan_requests_beyond_their_bounds_are_refused_with_the_bound(core, change, code, words):
    request = {"group": "arm", "goal": {"named": "ready"}, **change}
    val, message = _error(core.plan(request))
    assert val == code and words in message, message
    assert not any(name in message for name in INTERNAL_NAMES), message


def test_a_planner_that_raises_is_answered_without_its_exception_text(mycobot):
    class Broken:
        def plan(self, scene, request):
            raise IndexError("index 4000 is out of bounds for axis 0 with size 4000")

    logged = []
    core = _core(mycobot, Broken())
    core._log = lambda level, text: logged.append((level, text))
    val, message = _error(core.plan({"group": "arm", "goal": {"named": "ready"}}))
    assert val == MoveItErrorCode.FAILURE and "internal error" in message
    assert not any(name in message for name in INTERNAL_NAMES), message
    assert any(level == "error" and "IndexError" in text for level, text in logged)  # the log has the details


def test_cartesian_requests_with_too_many_waypoints_or_an_unknown_frame_are_refused(core):
    far = [0.9, 0.0, 0.2, 1.0, 0.0, 0.0, 0.0]
    val, message = _error(core.compute_cartesian_path({"group": "arm", "waypoints": [far] * (MAX_WAYPOINTS + 1)}))
    assert val == MoveItErrorCode.INVALID_MOTION_PLAN and f"at most {MAX_WAYPOINTS}" in message
    val, message = _error(core.compute_cartesian_path({"group": "arm", "waypoints": [far], "frame": "mars"}))
    assert val == MoveItErrorCode.FRAME_TRANSFORM_FAILURE and "unknown frame 'mars'" in message
    val, message = _error(core.compute_cartesian_path(
        {"group": "arm", "waypoints": [[WORKSPACE_BOUND * 2, 0, 0, 0, 0, 0, 1]]}))
    assert val == MoveItErrorCode.INVALID_GOAL_CONSTRAINTS and "workspace bound" in message


def test_cartesian_waypoints_in_a_link_frame_are_posed_at_the_start_state(core):
    """2 cm along the flange's own z axis: the same motion whether given in the flange frame or,
    transformed by hand, in the world frame."""
    core.update_joint_state(ARM, [0.0, -0.5, -0.8, 0.3, 0.0, 0.0])
    flange = core.scene.current_state.frame_pose("link6_flange")
    step = np.eye(4)
    step[2, 3] = 0.02
    local = core.compute_cartesian_path({"group": "arm", "frame": "link6_flange", "link": "link6_flange",
                                         "waypoints": [step.tolist()]})
    world = core.compute_cartesian_path({"group": "arm", "link": "link6_flange",
                                         "waypoints": [(flange @ step).tolist()]})
    assert local["error_code"]["val"] == MoveItErrorCode.SUCCESS, local["error_code"]
    assert local["fraction"] == pytest.approx(1.0) and world["fraction"] == pytest.approx(1.0)
    last = lambda r: r["trajectory"]["joint_trajectory"]["points"][-1]["positions"]  # noqa: E731
    assert np.allclose(last(local), last(world), atol=1e-6)


def _long_request() -> dict:
    # Every attempt solves quickly, but 1,000 attempts of an easy goal keep the planner busy for
    # many seconds: the request is legitimate and long.
    return {"group": "arm", "goal": {"joints": [0.5, -0.3, -0.4, 0.2, 0.1, 0.0]}, "allowed_planning_time": 120.0,
            "num_planning_attempts": MAX_PLANNING_ATTEMPTS}


def _start(core, request) -> tuple[threading.Thread, dict]:
    out: dict = {}
    thread = threading.Thread(target=lambda: out.update(core.plan(request)), daemon=True)
    thread.start()
    return thread, out


def _wait_running(core, count: int = 1, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while core.get_state()["planning"] < count:
        assert time.monotonic() < deadline, "the plan did not start"
        time.sleep(0.01)


def test_stop_cancels_a_running_plan_with_preempted(core):
    thread, out = _start(core, _long_request())
    _wait_running(core)
    answer = core.stop()
    assert answer["stopped"] and answer["cancelled_plans"] == 1 and "cancelling 1 running plan" in answer["message"]
    thread.join(30.0)
    assert not thread.is_alive()
    val, message = _error(out)
    assert val == MoveItErrorCode.PREEMPTED and "cancelled" in message
    assert core.stop()["message"] == "nothing is executing or planning"


def test_after_shut_down_a_plan_that_was_just_arriving_and_any_execution_answer_preempted(core):
    """SIGTERM's begin_shutdown (stop.shut_down) can come between a move_action goal's PLANNING
    feedback and its plan's start: that plan must not run its whole planning time afterwards
    (a CI run's client got no answer), nor may an execution start once the process goes down."""
    thread, out = _start(core, _long_request())
    _wait_running(core)
    answer = stop.shut_down(core)
    assert answer.cancelled_plans == 1
    thread.join(30.0)
    assert not thread.is_alive() and _error(out)[0] == MoveItErrorCode.PREEMPTED
    late = core.plan({"group": "arm", "goal": {"named": "ready"}, "allowed_planning_time": 5.0})
    assert _error(late) == (MoveItErrorCode.PREEMPTED, "planning refused: move_group is shutting down")
    assert core.running_plans() == []
    motion = JointTrajectory(joint_names=list(ARM), points=[
        JointTrajectoryPoint(positions=[0.0] * 6, time_from_start=0.0),
        JointTrajectoryPoint(positions=[0.1] * 6, time_from_start=1.0)])
    refused = core.executor.execute(motion)
    assert refused.error_code.val == MoveItErrorCode.PREEMPTED and "shutting down" in refused.error_code.message


def test_a_short_plan_is_answered_while_another_clients_long_plan_runs(mycobot, pipeline):
    """Both plans on the one model and pipeline, each in a planning context of its own."""
    core = _core(mycobot, pipeline)
    long_thread, long_out = _start(core, _long_request())
    _wait_running(core)
    short = core.plan({"group": "arm", "goal": {"named": "ready"}, "allowed_planning_time": 5.0})
    assert short["error_code"]["val"] == MoveItErrorCode.SUCCESS, short["error_code"]
    assert long_thread.is_alive() and not long_out  # the long plan was still running meanwhile
    core.stop()
    long_thread.join(30.0)
    assert long_out["error_code"]["val"] == MoveItErrorCode.PREEMPTED


def test_four_plans_run_at_once_on_the_one_model_and_stop_ends_them_all(mycobot, pipeline):
    """No bound but the callers': four long plans with different goals are all running at the same
    time (one model, one pipeline, a planning context each), then stop ends every one of them."""
    core = _core(mycobot, pipeline)
    goals = ([0.5, -0.3, -0.4, 0.2, 0.1, 0.0], [-0.5, 0.3, 0.4, 0.0, 0.2, 0.1], [0.3, 0.3, -0.3, 0.1, -0.2, 0.4],
             [-0.4, -0.2, 0.5, -0.3, 0.0, -0.1])
    started = [_start(core, {**_long_request(), "goal": {"joints": goal}}) for goal in goals]
    _wait_running(core, 4)
    answer = core.stop()
    assert answer["cancelled_plans"] == 4 and "cancelling 4 running plans" in answer["message"], answer
    for thread, out in started:
        thread.join(30.0)
        assert not thread.is_alive()
        assert out["error_code"]["val"] == MoveItErrorCode.PREEMPTED, out["error_code"]
    assert core.get_state()["planning"] == 0


# ---------------------------------------------------------------------------- the JSON boundary
@pytest.mark.parametrize("text, words", [
    ('{"id": "a", "method": "plan", "params": {"group": "t\\ud800x"}}', "lone surrogate"),
    ('{"id": "a", "method": "x", "params": {"t\\udfffx": 1}}', "not valid Unicode"),
    ("[" * 5000 + "]" * 5000, "nested more than"),
    ('{"id": "a", "params": ' + "[" * 100 + "]" * 100 + "}", "nested more than"),
    ("{garbage", "malformed JSON"),
])
def test_wire_json_is_checked_once_at_the_boundary(text, words):
    with pytest.raises(RpcError) as info:
        decode_request(text)
    assert info.value.code == BAD_REQUEST and words in info.value.message
    info.value.message.encode("utf-8")  # safe to log and to answer


def test_oversized_requests_are_refused_before_decoding():
    with pytest.raises(RpcError, match=f"the limit is {MAX_REQUEST_BYTES} bytes"):
        decode_request(" " * (MAX_REQUEST_BYTES + 1))


def test_log_safe_escapes_what_logging_cannot_encode():
    text = log_safe("bad\ud800id\x00\x07 caf\u00e9\nnext")
    text.encode("utf-8")
    assert text == "bad\\ud800id\\x00\\x07 caf\u00e9\nnext"
    assert log_safe("x" * 50, limit=10).startswith("x" * 10 + "... (40 more")
    assert json.loads(json.dumps({"m": log_safe("\ud800")}))["m"] == "\\ud800"
