"""Unit tests for mock_control.joint_trajectory_follower: the mock controllers' logic, without ROS.

Time is passed in explicitly, so every assertion here is exact and instantaneous.
"""
from __future__ import annotations

import math
import re

import numpy as np
import pytest

from mycobot_planning.core.errors import StateError
from mycobot_planning.core.trajectory_processing import time_parameterize
from mycobot_planning.core.trajectory_execution.controllers_config import ControllerConfigError, load_controllers_config
from mycobot_planning.mock_control.joint_trajectory_follower import (
    ControllerStatus,
    JointTrajectoryFollower,
    TrajectoryCommand,
)
from mycobot_planning.paths import config_file

S = ControllerStatus
JOINTS = ["j1", "j2"]
CONTRACT_KEYS = {"joint_names", "desired", "actual", "error", "active", "status", "message", "goal_id"}


def follower(**kwargs) -> JointTrajectoryFollower:
    kwargs.setdefault("name", "arm_controller")
    return JointTrajectoryFollower(JOINTS, [-2.0, -2.0], [2.0, 2.0], **kwargs)


def command(times, positions, velocities=None, accelerations=None, names=JOINTS, goal_id="", start_time=None):
    return TrajectoryCommand.from_arrays(names, times, positions, velocities, accelerations,
                                         goal_id=goal_id, start_time=start_time)


def run_to(f: JointTrajectoryFollower, t_end: float, t0: float = 0.0, dt: float = 0.01) -> list[str]:
    """Update every dt until t_end; the statuses seen along the way."""
    seen = []
    for t in np.arange(t0, t_end + 1e-12, dt):
        f.update(float(t))
        if not seen or seen[-1] != f.status:
            seen.append(f.status)
    return seen


# ---------------------------------------------------------------- state and interpolation


def test_idle_follower_holds_initial_positions_and_reports_contract_fields():
    f = follower(initial_positions=[0.5, -0.25])
    state = f.state().to_dict()
    assert set(state) == CONTRACT_KEYS
    assert state["status"] == S.IDLE and state["active"] is False and state["goal_id"] == ""
    assert state["actual"]["positions"] == [0.5, -0.25] == state["desired"]["positions"]
    assert state["error"]["positions"] == [0.0, 0.0]
    assert f.update(3.0) is None and f.positions.tolist() == [0.5, -0.25]


def test_default_initial_positions_are_zero_clipped_into_limits():
    f = JointTrajectoryFollower(["a", "b"], [0.1, -1.0], [1.0, 1.0])
    assert f.positions.tolist() == [0.1, 0.0]


def test_bad_initial_positions_are_refused():
    with pytest.raises(StateError, match="j2 = 3 is outside its limits"):
        follower(initial_positions=[0.0, 3.0])
    with pytest.raises(StateError, match="need 2 values"):
        follower(initial_positions=[0.0])


@pytest.mark.parametrize(
    "velocities, accelerations, q_mid, qd_mid",
    [
        (None, None, 0.5, 1.0),  # linear: constant slope
        ([[0.0, 0.0], [0.0, 0.0]], None, 0.5, 1.5),  # cubic Hermite 3x^2 - 2x^3
        ([[0.0, 0.0], [0.0, 0.0]], [[0.0, 0.0], [0.0, 0.0]], 0.5, 1.875),  # quintic 10x^3-15x^4+6x^5
    ],
)
def test_interpolation_matches_jtc_spline_kind(velocities, accelerations, q_mid, qd_mid):
    f = follower()
    f.submit(command([0.0, 1.0], [[0.0, 0.0], [1.0, -1.0]], velocities, accelerations), now=10.0)
    f.update(10.5)
    desired = f.state()
    assert desired.desired_positions == pytest.approx([q_mid, -q_mid], abs=1e-12)
    assert desired.desired_velocities == pytest.approx([qd_mid, -qd_mid], abs=1e-12)
    assert f.positions == pytest.approx([q_mid, -q_mid], abs=1e-12)  # perfect tracking


def test_cubic_reproduces_a_time_parameterized_trajectory_exactly(mycobot):
    """time_parameterize's pieces are cubics: sending position+velocity must reproduce them."""
    arm = mycobot.group("arm")
    path = np.array([np.zeros(6), [0.5, -0.3, 0.8, 0.2, -0.4, 1.0], [0.2, 0.4, 0.1, -0.6, 0.3, 0.0]])
    traj = time_parameterize(path, mycobot.velocity_limits[arm.variable_indices],
                             mycobot.acceleration_limits[arm.variable_indices])
    f = JointTrajectoryFollower(arm.joint_names, mycobot.lower_limits[arm.variable_indices],
                                mycobot.upper_limits[arm.variable_indices], name="arm_controller")
    f.submit(command(traj.times, traj.positions, traj.velocities, names=arm.joint_names), now=100.0)
    for t in np.linspace(0.0, traj.duration, 137):
        f.update(100.0 + float(t))
        q, qd, _ = traj.sample(float(t))
        assert f.positions == pytest.approx(q, abs=1e-9)
        assert f.velocities == pytest.approx(qd, abs=1e-7)
    assert run_to(f, 100.0 + traj.duration + 0.05, 100.0 + traj.duration) == [S.SUCCEEDED]
    assert f.positions.tolist() == traj.positions[-1].tolist()


def test_quintic_reproduces_a_quintic_polynomial():
    coeffs = np.array([0.1, 0.4, -0.3, 0.2, 0.05, -0.02])

    def poly(t, der=0):
        return float(np.polyval(np.polyder(coeffs[::-1], der), t)) if der else float(np.polyval(coeffs[::-1], t))

    times = [0.0, 0.7, 2.0]
    pos = [[poly(t), 0.0] for t in times]
    vel = [[poly(t, 1), 0.0] for t in times]
    acc = [[poly(t, 2), 0.0] for t in times]
    f = follower(initial_positions=[0.1, 0.0])
    f.submit(command(times, pos, vel, acc), now=0.0)
    for t in np.linspace(0.0, 2.0, 41)[:-1]:  # at the end it holds (velocity 0)
        f.update(float(t))
        assert f.positions[0] == pytest.approx(poly(t), abs=1e-12)
        assert f.velocities[0] == pytest.approx(poly(t, 1), abs=1e-12)


def test_goal_succeeds_at_its_end_and_holds_the_last_point():
    f = follower()
    result = f.submit(command([0.5, 1.0], [[0.5, 0.5], [1.0, -1.0]], goal_id="g1"), now=0.0)
    assert result.accepted and result.goal_id == "g1"
    assert [e.status for e in result.events] == [S.EXECUTING]
    assert f.active and f.status == S.EXECUTING
    assert f.update(0.99) is None
    changed = f.update(1.0)
    assert changed is not None and changed.status == S.SUCCEEDED and changed.goal_id == "g1"
    assert not changed.active
    f.update(5.0)
    assert f.positions.tolist() == [1.0, -1.0] and f.velocities.tolist() == [0.0, 0.0]
    assert f.state().status == S.SUCCEEDED


def test_first_point_in_the_future_is_approached_from_the_current_state():
    f = follower(initial_positions=[0.2, 0.2])
    f.submit(command([1.0], [[1.2, -0.8]]), now=0.0)  # single point at t=1
    f.update(0.5)
    assert f.positions == pytest.approx([0.7, -0.3])
    f.update(1.0)
    assert f.status == S.SUCCEEDED and f.positions.tolist() == [1.2, -0.8]


def test_joint_order_of_the_command_does_not_matter():
    f = follower()
    f.submit(command([1.0], [[-1.0, 1.0]], names=["j2", "j1"]), now=0.0)
    f.update(1.0)
    assert f.positions.tolist() == [1.0, -1.0]


def test_header_stamp_in_the_future_delays_the_first_point_and_in_the_past_starts_now():
    f = follower()
    f.submit(command([0.0, 1.0], [[0.0, 0.0], [1.0, 1.0]], start_time=2.0), now=0.0)
    f.update(2.0)
    assert f.positions.tolist() == [0.0, 0.0] and f.status == S.EXECUTING
    f.update(2.5)
    assert f.positions == pytest.approx([0.5, 0.5])
    f.update(3.0)
    assert f.status == S.SUCCEEDED

    g = follower()
    g.submit(command([0.0, 1.0], [[0.0, 0.0], [1.0, 1.0]], start_time=-50.0), now=10.0)
    g.update(10.5)
    assert g.positions == pytest.approx([0.5, 0.5])  # not mid-trajectory, no jump


# ---------------------------------------------------------------- preemption, stop


def test_preemption_continues_from_the_current_state_without_a_jump():
    f = follower()
    vel = [[0.0, 0.0], [0.0, 0.0]]
    f.submit(command([0.0, 2.0], [[0.0, 0.0], [1.5, 1.5]], vel, goal_id="old"), now=0.0)
    f.update(1.0)
    q_before, qd_before = f.positions.copy(), f.velocities.copy()
    assert qd_before[0] > 0.5
    result = f.submit(command([1.0, 2.0], [[0.0, 0.0], [-1.0, -1.0]], vel, goal_id="new"), now=1.0)
    assert result.accepted
    assert [(e.goal_id, e.status) for e in result.events] == [("old", S.PREEMPTED), ("new", S.EXECUTING)]
    assert not result.events[0].active and result.events[1].active
    assert f.positions.tolist() == q_before.tolist()
    assert f.velocities.tolist() == qd_before.tolist()  # cubic from the current velocity
    f.update(1.001)
    assert np.max(np.abs(f.positions - q_before)) < 0.01
    run_to(f, 3.0, 1.01)
    assert f.status == S.SUCCEEDED and f.goal_id == "new" and f.positions.tolist() == [-1.0, -1.0]


def test_first_point_at_time_zero_must_match_the_current_position():
    f = follower(initial_positions=[0.0, 0.0], start_tolerance=0.05)
    far = f.submit(command([0.0, 1.0], [[0.3, 0.0], [1.0, 1.0]]), now=0.0)
    assert not far.accepted and "start tolerance" in far.reason and "j1" in far.reason
    assert f.status == S.IDLE and f.positions.tolist() == [0.0, 0.0]
    near = f.submit(command([0.0, 1.0], [[0.01, 0.0], [1.0, 1.0]]), now=0.0)
    assert near.accepted


def test_stop_holds_position_and_is_reported_once():
    f = follower()
    f.submit(command([2.0], [[1.0, 1.0]], goal_id="g"), now=0.0)
    f.update(1.0)
    held = f.positions.copy()
    events = f.stop(1.0, "stop service called")
    assert [(e.goal_id, e.status, e.active) for e in events] == [("g", S.STOPPED, False)]
    assert "stop service called" in events[0].message
    f.update(5.0)
    assert f.positions.tolist() == held.tolist() and f.status == S.STOPPED
    assert f.stop(6.0) == []  # nothing left to stop


def test_smooth_stop_decelerates_along_the_path_within_the_limits_then_reports_stopped():
    """A cancelled goal (issue 29): the joints slow down along the goal's own path within the
    acceleration limits and the goal is STOPPED once they are at rest; a second stop changes
    nothing; without acceleration limits the stop is at once."""
    limits = [4.0, 4.0]
    f = follower(velocity_limits=[3.0, 3.0], acceleration_limits=limits)
    traj = time_parameterize([[0.0, 0.0], [1.5, -0.75]], [2.0, 2.0], limits, joint_names=JOINTS)
    f.submit(command(traj.times, traj.positions, traj.velocities, traj.accelerations, goal_id="g"), now=0.0)
    f.update(0.5)
    at_stop, speed = f.positions.copy(), np.abs(f.velocities).copy()
    assert speed[0] > 1.0
    assert f.stop(0.5, "canceled by its client", smooth=True) == []  # not at rest yet
    assert f.status == S.EXECUTING and "stopping" in f.state().message
    assert f.stop(0.51, "again", smooth=True) == []
    positions, velocities = [], []
    t = 0.5
    while f.status == S.EXECUTING and t < 3.0:
        t += 0.002
        f.update(t)
        positions.append(f.positions.copy())
        velocities.append(f.velocities.copy())
    assert f.status == S.STOPPED and "canceled by its client" in f.state().message
    velocities = np.array(velocities)
    accelerations = np.diff(velocities, axis=0) / 0.002
    assert np.all(np.abs(accelerations) <= np.array(limits) * 1.05 + 1e-6)
    assert np.allclose(velocities[-1], 0.0)
    travelled = np.array(positions[-1]) - at_stop
    # along the path (joint 2 moves minus half of joint 1) and about v^2 / (2 a) beyond the stop point
    assert travelled[0] > 0 and travelled[1] == pytest.approx(-0.5 * travelled[0], abs=1e-6)
    assert speed[0] ** 2 / (2 * limits[0]) * 0.9 <= travelled[0] <= speed[0] ** 2 / (2 * limits[0] * 0.9) * 1.3
    held = f.positions.copy()
    f.update(5.0)
    assert np.allclose(f.positions, held)
    unlimited = follower()
    unlimited.submit(command([2.0], [[1.0, 1.0]], goal_id="u"), now=0.0)
    unlimited.update(1.0)
    assert [e.status for e in unlimited.stop(1.0, "cancel", smooth=True)] == [S.STOPPED]


def test_empty_trajectory_means_stop():
    f = follower()
    f.submit(command([2.0], [[1.0, 1.0]], goal_id="g"), now=0.0)
    result = f.submit(TrajectoryCommand(JOINTS, [], []), now=0.5)
    assert result.accepted and [e.status for e in result.events] == [S.STOPPED]
    assert f.positions == pytest.approx([0.25, 0.25]) and not f.active


# ---------------------------------------------------------------- malformed commands


MALFORMED = {
    "unknown joint": (TrajectoryCommand(["j1", "j2", "elbow"], [1.0], [[0, 0, 0]]), "unknown joint ['elbow']"),
    "missing joint": (TrajectoryCommand(["j1"], [1.0], [[0.0]]), "missing joint ['j2']"),
    "duplicate joint": (TrajectoryCommand(["j1", "j1"], [1.0], [[0, 0]]), "appears twice"),
    "no joint names": (TrajectoryCommand([], [1.0], [[]]), "joint_names is empty"),
    "decreasing time": (TrajectoryCommand(JOINTS, [1.0, 0.5], [[0, 0], [1, 1]]), "must strictly increase"),
    "repeated time": (TrajectoryCommand(JOINTS, [1.0, 1.0], [[0, 0], [1, 1]]), "points[1].time_from_start"),
    "negative time": (TrajectoryCommand(JOINTS, [-1.0, 1.0], [[0, 0], [1, 1]]), "negative"),
    "NaN time": (TrajectoryCommand(JOINTS, [math.nan], [[0, 0]]), "must be finite"),
    "NaN position": (TrajectoryCommand(JOINTS, [1.0, 2.0], [[0, 0], [math.nan, 1]]), "points[1].positions[0] (j1) is nan"),
    "inf velocity": (TrajectoryCommand(JOINTS, [1.0], [[0, 0]], [[0, math.inf]]), "velocities[1] (j2) is inf"),
    "outside limits": (TrajectoryCommand(JOINTS, [1.0], [[0.0, 2.5]]), "puts j2 at 2.5, outside its limits [-2, 2]"),
    "position size": (TrajectoryCommand(JOINTS, [1.0, 2.0], [[0, 0], [1]]), "points[1].positions has 1 values, expected 2"),
    "velocities on some points": (TrajectoryCommand(JOINTS, [1.0, 2.0], [[0, 0], [1, 1]], [[0, 0], []]),
                                  "points[1].velocities has 0 values"),
    "accelerations only": (TrajectoryCommand(JOINTS, [1.0], [[0, 0]], [], [[0, 0]]), "without velocities"),
    "times vs points": (TrajectoryCommand(JOINTS, [1.0, 2.0], [[0, 0]]), "2 time stamps for 1 points"),
}


@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_malformed_command_is_rejected_with_a_reason_and_no_motion(case):
    bad, reason = MALFORMED[case]
    f = follower(initial_positions=[0.1, 0.2])
    assert reason in (f.validate(bad) or "")
    result = f.submit(bad, now=0.0)
    assert not result.accepted and reason in result.reason
    [event] = result.events
    assert event.status == S.ABORTED and event.message == f"rejected: {result.reason}"
    assert event.goal_id == result.goal_id != ""
    f.update(3.0)
    assert f.status == S.IDLE and f.positions.tolist() == [0.1, 0.2]


def test_rejected_command_leaves_the_executing_goal_running():
    f = follower()
    f.submit(command([2.0], [[1.0, 1.0]], goal_id="good"), now=0.0)
    result = f.submit(command([1.0], [[5.0, 0.0]], goal_id="bad"), now=0.5)
    assert not result.accepted and result.events[0].goal_id == "bad" and result.events[0].active
    assert f.goal_id == "good" and f.status == S.EXECUTING
    f.update(2.0)
    assert f.status == S.SUCCEEDED and f.positions.tolist() == [1.0, 1.0]


def test_valid_command_passes_validation():
    assert follower().validate(command([0.5, 1.0], [[0, 0], [1, 1]], [[0, 0], [0, 0]])) is None


# ---------------------------------------------------------------- fault injection


def test_fail_after_aborts_with_failed_at_that_time_and_holds():
    f = follower()
    f.fail_after = 0.5
    f.submit(command([2.0], [[1.0, 1.0]], goal_id="g"), now=10.0)
    seen = run_to(f, 13.0, 10.0, dt=0.03)
    assert seen == [S.EXECUTING, S.FAILED]
    state = f.state()
    assert not state.active and "fail_after" in state.message and state.goal_id == "g"
    assert f.positions == pytest.approx([0.25, 0.25])  # where the trajectory was at t = 0.5 s
    assert f.velocities.tolist() == [0.0, 0.0]


def test_fail_after_set_late_never_moves_the_joints_back():
    f = follower()
    f.submit(command([2.0], [[1.0, 1.0]]), now=0.0)
    f.update(1.0)
    f.fail_after = 0.2  # already passed
    changed = f.update(1.01)
    assert changed.status == S.FAILED
    assert f.positions == pytest.approx([0.5, 0.5])


def test_stall_after_freezes_the_joints_but_keeps_executing_then_reports_stalled():
    f = follower()
    f.stall_after = 0.5
    f.submit(command([2.0], [[1.0, 1.0]], goal_id="g"), now=0.0)
    f.update(1.5)
    state = f.state()
    assert state.status == S.EXECUTING and state.active
    assert state.actual_positions == pytest.approx([0.25, 0.25])
    assert state.desired_positions == pytest.approx([0.75, 0.75])  # the command keeps going
    assert state.to_dict()["error"]["positions"] == pytest.approx([0.5, 0.5])
    changed = f.update(2.0)
    assert changed.status == S.STALLED and changed.active and "stall_after" in changed.message
    f.update(10.0)
    assert f.status == S.STALLED and f.positions == pytest.approx([0.25, 0.25])
    # A new goal starts from where the joints really are, and runs normally once stalls are off.
    f.stall_after = -1.0
    result = f.submit(command([1.0], [[-1.0, -1.0]], goal_id="next"), now=10.0)
    assert [e.status for e in result.events] == [S.PREEMPTED, S.EXECUTING]
    f.update(10.5)
    assert f.positions == pytest.approx([-0.375, -0.375])
    f.update(11.0)
    assert f.status == S.SUCCEEDED


def test_stall_after_the_end_of_the_trajectory_changes_nothing():
    f = follower()
    f.stall_after = 5.0
    f.submit(command([1.0], [[1.0, 1.0]]), now=0.0)
    f.update(1.0)
    assert f.status == S.SUCCEEDED


def test_reset_positions_only_when_idle():
    f = follower()
    f.reset_positions([0.3, -0.3])
    assert f.positions.tolist() == [0.3, -0.3] and f.state().desired_positions.tolist() == [0.3, -0.3]
    with pytest.raises(StateError, match="outside its limits"):
        f.reset_positions([3.0, 0.0])
    f.submit(command([1.0], [[1.0, 1.0]], goal_id="g"), now=0.0)
    with pytest.raises(StateError, match="executing goal g"):
        f.reset_positions([0.0, 0.0])


def test_time_going_backwards_is_ignored():
    f = follower()
    f.submit(command([1.0], [[1.0, 1.0]]), now=5.0)
    f.update(5.5)
    f.update(5.2)
    assert f.positions == pytest.approx([0.5, 0.5])


# ---------------------------------------------------------------- controllers.yaml


def test_shipped_controllers_yaml_matches_the_robot(mycobot):
    config = load_controllers_config(config_file("controllers.yaml"), mycobot.variable_names)
    by_name = {c.name: c for c in config.controllers}
    assert list(by_name) == ["arm_controller", "grip_action_controller"]
    assert list(by_name["arm_controller"].joints) == list(mycobot.group("arm").joint_names)
    assert by_name["arm_controller"].update_rate == 100.0
    assert by_name["grip_action_controller"].joints == ("gripper_controller",)
    assert by_name["grip_action_controller"].goal_tolerance == 0.01
    assert config.broadcasters == ("joint_state_broadcaster",)


def _config(joints_a, joints_b=None, type_b="joint_trajectory_controller/JointTrajectoryController"):
    data = {"controller_manager": {"ros__parameters": {
        "update_rate": 50, "a": {"type": "joint_trajectory_controller/JointTrajectoryController"}}},
        "a": {"ros__parameters": {"joints": joints_a}}}
    if joints_b is not None:
        data["controller_manager"]["ros__parameters"]["b"] = {"type": type_b}
        data["b"] = {"ros__parameters": {"joints": joints_b}}
    return data


def test_a_real_gripper_action_controller_entry_loads_as_a_one_joint_controller(mycobot):
    data = _config(["link1_to_link2"], ["x"], type_b="position_controllers/GripperActionController")
    data["b"] = {"ros__parameters": {"joint": "gripper_controller", "goal_tolerance": 0.02}}
    config = load_controllers_config(data, mycobot.variable_names)
    gripper = config.controllers[1]
    assert gripper.joints == ("gripper_controller",) and gripper.goal_tolerance == 0.02


def test_controller_update_rate_defaults_to_the_manager_rate():
    config = load_controllers_config(_config(["x"]), ["x"])
    assert config.controllers[0].update_rate == 50.0


@pytest.mark.parametrize(
    "data, message",
    [
        (_config(["gripper_base_to_gripper_left2"]), "not an active joint"),  # a mimic joint
        (_config(["link1_to_link2"], ["link1_to_link2"]), "belongs to both a and b"),
        (_config(["link1_to_link2"], ["gripper_controller"], type_b="foo/Bar"), "type 'foo/Bar'"),
        (_config([]), "non-empty list"),
        ({**_config(["link1_to_link2"]), "a": {"ros__parameters": {"joints": ["link1_to_link2"], "update_rate": 60}}},
         "a.update_rate (60 Hz) exceeds controller_manager.update_rate (50 Hz)"),
        ({"controller_manager": {}}, "missing 'controller_manager: ros__parameters:'"),
        ({"controller_manager": {"ros__parameters": {"a": {"type": "joint_trajectory_controller/JointTrajectoryController"}}}},
         "missing 'a: ros__parameters:'"),
    ],
)
def test_bad_controllers_config_is_refused_with_the_reason(mycobot, data, message):
    with pytest.raises(ControllerConfigError, match=re.escape(message)):
        load_controllers_config(data, mycobot.variable_names)


def test_missing_controllers_file_is_reported():
    with pytest.raises(ControllerConfigError, match="cannot read controllers file"):
        load_controllers_config("/nonexistent/controllers.yaml")
