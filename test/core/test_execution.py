"""Execution planning and monitoring (core/trajectory_execution/) and the planning server's ROS-free logic
(capabilities/), on simulated controllers and a simulated clock: no ROS, no sleeps.

The simulated controllers follow the mock controllers' contract (goal id = the command's
frame_id, statuses executing/succeeded/failed/aborted/stalled/stopped), so what passes here is
what the integration tests exercise with the real processes.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from interfaces_py.msgs import (
    AttachedCollisionObject,
    CollisionObject,
    JointTrajectory,
    JointTrajectoryPoint,
    MoveItErrorCode,
    PlanningScene as PlanningSceneMsg,
    RobotState as RobotStateMsg,
    RobotTrajectory,
)
from mycobot_planning.core import PlanningScene
from mycobot_planning.core.trajectory_execution import ControllerInfo, ControllerState, ExecutionError, ExecutionSettings, TrajectoryExecutionManager, allowed_duration, check_controllers, check_start_state, load_controllers, parse_task_solution, parse_trajectory, prepare_trajectory, select_controllers, split_trajectory
from mycobot_planning.core.robot_trajectory.robot_trajectory import timed_to_joint_trajectory
from mycobot_planning.capabilities.json_face import (
    MoveGroupJsonFace,
    RequestError,
    goal_from_parameters,
    pose_from_json,
)
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory
from mycobot_planning.core.trajectory_processing import TimedTrajectory
from mycobot_planning.core.transforms import make_pose
from mycobot_planning.paths import config_file

ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6", "link6_to_link6_flange"]
CONTROLLERS = [ControllerInfo("arm_controller", tuple(ARM)), ControllerInfo("grip_action_controller", ("gripper_controller",))]
SUCCESS, CONTROL_FAILED, TIMED_OUT, PREEMPTED = (MoveItErrorCode.SUCCESS, MoveItErrorCode.CONTROL_FAILED,
                                                 MoveItErrorCode.TIMED_OUT, MoveItErrorCode.PREEMPTED)


# ---------------------------------------------------------------------------- simulation
class SimController:
    """A joint trajectory controller on simulated time (linear interpolation between points)."""

    def __init__(self, info: ControllerInfo, positions: dict[str, float]) -> None:
        self.info = info
        self.positions = positions  # shared with the bus: the "robot"
        self.fail_after: float | None = None
        self.stall_after: float | None = None
        self.reject = False
        self.claim_success_early = False  # reports success without moving
        self.dead = False  # the process is gone: no more reports, no more motion
        self.goal: JointTrajectory | None = None
        self.start = 0.0
        self.states: dict[str, ControllerState] = {}
        self.latest: ControllerState | None = None
        self.sent: list[JointTrajectory] = []
        self.stops = 0

    def _report(self, status: str, goal_id: str, now: float, message: str = "") -> None:
        state = ControllerState(status, status == "executing", message, goal_id, self.info.joints, now)
        self.states[goal_id] = state
        self.latest = state

    def send(self, trajectory: JointTrajectory, now: float) -> None:
        self.sent.append(trajectory)
        if self.reject:
            self._report("aborted", trajectory.frame_id, now, "rejected: start point too far")
            return
        self.goal, self.start = trajectory, now
        self._report("executing", trajectory.frame_id, now)
        if self.claim_success_early:
            self.goal = None
            self._report("succeeded", trajectory.frame_id, now)

    def update(self, now: float) -> None:
        if self.dead:
            return
        goal = self.goal
        if goal is None:  # an idle controller keeps reporting its last state (ros2_control's rate)
            if self.latest is not None:
                self.latest = dataclasses.replace(self.latest, received=now)
            return
        t = now - self.start
        if self.fail_after is not None and t >= self.fail_after:
            self.goal = None
            self._report("failed", goal.frame_id, now, "fault injected")
            return
        times = [p.time_from_start for p in goal.points]
        if self.stall_after is not None:
            t = min(t, self.stall_after)
        for j, name in enumerate(goal.joint_names):
            self.positions[name] = float(np.interp(t, times, [p.positions[j] for p in goal.points]))
        if self.stall_after is not None and now - self.start >= times[-1]:
            self._report("stalled", goal.frame_id, now, "goal not reached")
        elif t >= times[-1]:
            self.goal = None
            self._report("succeeded", goal.frame_id, now)
        else:
            self._report("executing", goal.frame_id, now)

    def stop(self, now: float) -> None:
        self.stops += 1
        if self.goal is not None:
            self._report("stopped", self.goal.frame_id, now, "stop service called")
            self.goal = None


class SimBus:
    """ControllerBus + simulated clock + the robot's joint positions."""

    def __init__(self, model, controllers=CONTROLLERS) -> None:
        self.now = 100.0
        self.positions: dict[str, float] = {n: 0.0 for n in model.variable_names}
        self.controllers = {c.name: SimController(c, self.positions) for c in controllers}
        self.available = {c.name: True for c in controllers}
        self.joint_state_age: float | None = 0.0
        self.hooks: list[tuple[float, callable]] = []  # (time, action) run once when the clock passes it
        self.waits = 0

    # ControllerBus
    def is_available(self, controller: str) -> bool:
        return self.available[controller]

    def send(self, controller: str, trajectory: JointTrajectory) -> None:
        self.controllers[controller].send(trajectory, self.now)

    def stop(self, controller: str) -> None:
        self.controllers[controller].stop(self.now)

    def controller_state(self, controller: str, goal_id: str | None = None) -> ControllerState | None:
        c = self.controllers[controller]
        return c.latest if goal_id is None else c.states.get(goal_id)

    # the manager's other inputs
    def current_positions(self):
        if self.joint_state_age is None:
            return None, None
        return dict(self.positions), self.joint_state_age

    def clock(self) -> float:
        return self.now

    def wait(self, dt: float) -> None:
        self.waits += 1
        assert self.waits < 100_000, "simulation did not terminate"
        self.now += dt
        for c in self.controllers.values():
            c.update(self.now)
        due = [h for h in self.hooks if h[0] <= self.now]
        self.hooks = [h for h in self.hooks if h[0] > self.now]
        for _, action in due:
            action()


def make_manager(model, bus: SimBus, **settings) -> TrajectoryExecutionManager:
    return TrajectoryExecutionManager(model, CONTROLLERS, bus, bus.current_positions, ExecutionSettings(**settings),
                                      clock=bus.clock, wait=bus.wait, poll_period=0.01)


def arm_trajectory(start, goal, duration=1.0, n=11, extra: dict | None = None) -> JointTrajectory:
    """Linear joint motion of the arm (plus optional other joints) over `duration` seconds."""
    start, goal = np.asarray(start, float), np.asarray(goal, float)
    names = list(ARM) + list(extra or {})
    points = []
    for k in range(n):
        s = k / (n - 1)
        values = list(start + s * (goal - start)) + [a + s * (b - a) for a, b in (extra or {}).values()]
        points.append(JointTrajectoryPoint(positions=values, time_from_start=s * duration))
    return JointTrajectory(joint_names=names, points=points)


GOAL = [0.3, -0.2, 0.5, 0.4, 0.1, -0.3]


def as_controller_executes(jt: JointTrajectory, dt: float = 0.002) -> TimedTrajectory:
    """The motion a joint trajectory controller makes from position+velocity points (cubic
    Hermite per interval), sampled densely with exact q, qd, qdd, for the validator."""
    times = np.array([p.time_from_start for p in jt.points])
    q = np.array([p.positions for p in jt.points])
    v = np.array([p.velocities for p in jt.points])
    ts = np.union1d(np.arange(times[0], times[-1], dt), times)
    k = np.clip(np.searchsorted(times, ts, side="right") - 1, 0, len(times) - 2)
    h = (times[k + 1] - times[k])[:, None]
    s = (ts - times[k])[:, None] / h
    p0, p1, m0, m1 = q[k], q[k + 1], v[k] * h, v[k + 1] * h
    c2 = 3 * (p1 - p0) - 2 * m0 - m1
    c3 = 2 * (p0 - p1) + m0 + m1
    pos = p0 + s * (m0 + s * (c2 + s * c3))
    vel = (m0 + s * (2 * c2 + 3 * s * c3)) / h
    acc = (2 * c2 + 6 * s * c3) / (h * h)
    return TimedTrajectory(jt.joint_names, ts, pos, vel, acc, interpolation="quintic")


# ---------------------------------------------------------------------------- controllers file
def test_package_controllers_file_lists_arm_and_gripper_controllers(mycobot):
    controllers = load_controllers(config_file("controllers.yaml"))
    assert [(c.name, c.joints) for c in controllers] == [(c.name, c.joints) for c in CONTROLLERS]
    check_controllers(mycobot, controllers)
    assert controllers[0].command_topic == "/arm_controller/joint_trajectory"
    assert controllers[0].state_topic == "/arm_controller/state"
    assert controllers[0].stop_service == "/arm_controller/stop"


def test_moveit_and_plain_controller_layouts_are_understood():
    moveit = {"moveit_simple_controller_manager": {"controller_names": ["a"], "a": {"joints": ["j1", "j2"]}}}
    assert load_controllers(moveit) == [ControllerInfo("a", ("j1", "j2"))]
    plain = {"controllers": {"b": {"joints": ["j3"]}}}
    assert load_controllers(plain) == [ControllerInfo("b", ("j3",))]


@pytest.mark.parametrize("data, problem", [
    ({"controllers": {"b": {"joints": []}}}, "non-empty 'joints'"),
    ({"controllers": {"b": {"joints": ["j", "j"]}}}, "twice"),
    ({"something": 1}, "no controllers found"),
    ({"controller_manager": {"ros__parameters": {"jsb": {"type": "joint_state_broadcaster/JointStateBroadcaster"}}}},
     "no controllers of type"),
])
def test_malformed_controller_configurations_are_refused_with_the_reason(data, problem):
    with pytest.raises(ValueError, match=problem):
        load_controllers(data)


def test_unreadable_controllers_file_names_the_file(tmp_path):
    with pytest.raises(ValueError, match="cannot read controllers file"):
        load_controllers(tmp_path / "missing.yaml")


def test_controllers_driving_unknown_or_mimic_joints_are_refused(mycobot):
    with pytest.raises(ValueError, match="not active joints"):
        check_controllers(mycobot, [ControllerInfo("c", ("nope",))])
    with pytest.raises(ValueError, match="not active joints"):
        check_controllers(mycobot, [ControllerInfo("c", ("gripper_base_to_gripper_left2",))])


# ---------------------------------------------------------------------------- preparation
def test_allowed_duration_is_moveits_formula():
    assert allowed_duration(2.0, 1.2, 0.5) == pytest.approx(2.9)
    assert ExecutionSettings().allowed_duration(1.0) == pytest.approx(1.7)
    assert ExecutionSettings(allowed_execution_duration_scaling=2.0, allowed_goal_duration_margin=0.0).allowed_duration(
        1.5) == pytest.approx(3.0)


@pytest.mark.parametrize("kwargs", [{"allowed_execution_duration_scaling": 0.9}, {"allowed_goal_duration_margin": -1},
                                    {"allowed_start_tolerance": math.nan}, {"joint_state_timeout": 0.0}])
def test_invalid_execution_settings_are_refused(kwargs):
    with pytest.raises(ValueError):
        ExecutionSettings(**kwargs)


def test_prepare_drops_mimic_joints_and_keeps_the_rest(mycobot):
    traj = JointTrajectory(joint_names=["gripper_controller", "gripper_base_to_gripper_left2"],
                           points=[JointTrajectoryPoint(positions=[0.0, 0.0], time_from_start=0.0),
                                   JointTrajectoryPoint(positions=[-0.3, -0.3], time_from_start=0.5)])
    prepared = prepare_trajectory(mycobot, traj, max_waypoint_distance=0.0)
    assert prepared.joint_names == ["gripper_controller"]
    assert [p.positions for p in prepared.points] == [[0.0], [-0.3]]
    # by default also dense: points on the controller's line every 0.1 (positions only: linear)
    dense = prepare_trajectory(mycobot, traj)
    assert [p.positions[0] for p in dense.points] == pytest.approx([0.0, -0.1, -0.2, -0.3])
    assert [p.time_from_start for p in dense.points] == pytest.approx([0.0, 0.5 / 3, 1.0 / 3, 0.5])


@pytest.mark.parametrize("names, points, problem", [
    (ARM, [], "no points"),
    (["nope"], [([0.0], 0.0)], "does not have"),
    (["gripper_base_to_gripper_left2"], [([0.0], 0.0)], "without their source"),
    (ARM, [([0.0] * 5 + [9.0], 0.0)], "outside the joint limits"),
    (ARM, [([0.0] * 6, 0.0), ([0.1] * 6, 0.0)], "not after the previous point"),
])
def test_prepare_refuses_bad_trajectories_naming_the_problem(mycobot, names, points, problem):
    traj = JointTrajectory(joint_names=names,
                           points=[JointTrajectoryPoint(positions=p, time_from_start=t) for p, t in points])
    with pytest.raises(ExecutionError, match=problem) as info:
        prepare_trajectory(mycobot, traj)
    assert info.value.code == MoveItErrorCode.INVALID_MOTION_PLAN


def test_parse_trajectory_reports_nan_and_malformed_input():
    good = arm_trajectory([0] * 6, GOAL)
    assert parse_trajectory(RobotTrajectory(good, "arm").to_dict()) == (good, "arm")
    assert parse_trajectory(good.to_dict()) == (good, "")
    bad = good.to_dict()
    bad["points"][3]["positions"][1] = math.nan
    with pytest.raises(ExecutionError, match=r"points\[3\].positions\[1\]: must be finite"):
        parse_trajectory(bad)
    with pytest.raises(ExecutionError, match="malformed JSON"):
        parse_trajectory("{not json")
    with pytest.raises(ExecutionError, match="must be a RobotTrajectory or JointTrajectory"):
        parse_trajectory(42)


def test_split_sends_each_controller_all_its_joints_with_goal_ids():
    traj = arm_trajectory([0] * 6, GOAL, extra={"gripper_controller": (0.0, -0.3)})
    commands = split_trajectory(traj, CONTROLLERS, goal_id="g7")
    assert [(c.name, t.joint_names, t.frame_id) for c, t in commands] == [
        ("arm_controller", ARM, "g7/arm_controller"),
        ("grip_action_controller", ["gripper_controller"], "g7/grip_action_controller"),
    ]
    assert commands[0][1].points[-1].positions == pytest.approx(GOAL)
    assert commands[1][1].points[-1].positions == pytest.approx([-0.3])
    assert [p.time_from_start for p in commands[1][1].points] == [p.time_from_start for p in traj.points]


def test_split_holds_controller_joints_the_trajectory_does_not_move():
    traj = JointTrajectory(joint_names=["link1_to_link2"],
                           points=[JointTrajectoryPoint(positions=[0.0], time_from_start=0.0),
                                   JointTrajectoryPoint(positions=[0.5], time_from_start=1.0)])
    current = {name: 0.1 * i for i, name in enumerate(ARM)}
    ((controller, command),) = split_trajectory(traj, CONTROLLERS, current)
    assert controller.name == "arm_controller" and command.joint_names == ARM
    assert [p.positions for p in command.points] == [[0.0] + [current[n] for n in ARM[1:]],
                                                     [0.5] + [current[n] for n in ARM[1:]]]
    assert all(v == 0.0 for p in command.points for v in p.velocities[1:])
    with pytest.raises(ExecutionError, match="current values are unknown"):
        split_trajectory(traj, CONTROLLERS, None)


def test_joints_without_a_controller_and_unknown_controller_names_are_control_failures():
    traj = arm_trajectory([0] * 6, GOAL, extra={"gripper_controller": (0.0, -0.3)})
    with pytest.raises(ExecutionError, match=r"no controller drives joints \['gripper_controller'\]") as info:
        select_controllers(traj.joint_names, CONTROLLERS, ["arm_controller"])
    assert info.value.code == CONTROL_FAILED
    with pytest.raises(ExecutionError, match="unknown controllers"):
        select_controllers(traj.joint_names, CONTROLLERS, ["left_arm_controller"])


def test_start_tolerance_names_the_farthest_joint():
    traj = arm_trajectory([0.0] * 6, GOAL)
    current = {n: 0.0 for n in ARM}
    check_start_state(traj, current, 0.01)
    current["link3_to_link4"] = 0.3
    with pytest.raises(ExecutionError, match=r"0\.3000 away .* at joint 'link3_to_link4'") as info:
        check_start_state(traj, current, 0.01)
    assert info.value.code == MoveItErrorCode.START_STATE_INVALID
    check_start_state(traj, current, 0.0)  # disabled


def test_timed_trajectory_becomes_a_message_starting_at_zero_and_ending_at_the_goal():
    times = np.array([2.0, 2.5, 3.0])
    positions = np.array([[0.0], [0.5], [1.0]])
    timed = TimedTrajectory(["link1_to_link2"], times, positions, np.array([[0.0], [1.5], [0.0]]), np.zeros((3, 1)))
    msg = timed_to_joint_trajectory(timed)
    assert [p.time_from_start for p in msg.points] == [0.0, 0.5, 1.0]
    dense = timed_to_joint_trajectory(timed, 0.1)
    assert len(dense.points) == 11 and dense.points[-1].positions == [1.0] and dense.duration == pytest.approx(1.0)


# ---------------------------------------------------------------------------- monitoring
def test_successful_execution_reaches_the_goal_within_the_trajectory_duration(mycobot):
    bus = SimBus(mycobot)
    manager = make_manager(mycobot, bus)
    result = manager.execute(arm_trajectory([0] * 6, GOAL, duration=1.0))
    assert result.success, result.message
    assert result.controllers == ["arm_controller"]
    assert [bus.positions[n] for n in ARM] == pytest.approx(GOAL)
    assert 1.0 <= result.duration <= 1.05
    assert result.allowed_duration == pytest.approx(1.7)
    assert bus.controllers["arm_controller"].stops == 0
    assert not manager.executing and manager.last_result["error_code"]["val"] == SUCCESS


def test_arm_and_gripper_trajectory_runs_on_both_controllers(mycobot):
    bus = SimBus(mycobot)
    result = make_manager(mycobot, bus).execute(arm_trajectory([0] * 6, GOAL, extra={"gripper_controller": (0, -0.4)}))
    assert result.success and sorted(result.controllers) == ["arm_controller", "grip_action_controller"]
    assert bus.positions["gripper_controller"] == pytest.approx(-0.4)


def test_controller_failure_is_reported_at_once_and_the_other_controller_stopped(mycobot):
    bus = SimBus(mycobot)
    bus.controllers["grip_action_controller"].fail_after = 0.3
    result = make_manager(mycobot, bus).execute(arm_trajectory([0] * 6, GOAL, extra={"gripper_controller": (0, -0.4)}))
    assert result.error_code.val == CONTROL_FAILED
    assert "controller 'grip_action_controller' failed the trajectory: fault injected" in result.message
    assert 0.3 <= result.duration < 0.35  # reported when it happens, not at the deadline
    assert bus.controllers["arm_controller"].stops == 1 and bus.controllers["arm_controller"].goal is None


def test_stalled_controller_times_out_at_scaled_duration_plus_margin(mycobot):
    bus = SimBus(mycobot)
    bus.controllers["arm_controller"].stall_after = 0.4
    result = make_manager(mycobot, bus).execute(arm_trajectory([0] * 6, GOAL, duration=2.0))
    assert result.error_code.val == TIMED_OUT
    assert result.duration == pytest.approx(2.0 * 1.2 + 0.5, abs=0.02)
    assert "exceeded the allowed 2.900 s (duration 2.000 s x 1.2 + 0.5 s)" in result.message
    assert "'arm_controller' is stalled" in result.message
    assert bus.controllers["arm_controller"].stops == 1


def test_rejected_goal_is_a_control_failure_with_the_controllers_reason(mycobot):
    bus = SimBus(mycobot)
    bus.controllers["arm_controller"].reject = True
    result = make_manager(mycobot, bus).execute(arm_trajectory([0] * 6, GOAL))
    assert result.error_code.val == CONTROL_FAILED and "aborted the trajectory: rejected" in result.message
    assert result.duration < 0.05


def test_a_previous_goals_success_is_not_taken_for_this_goal(mycobot):
    bus = SimBus(mycobot)
    manager = make_manager(mycobot, bus)
    assert manager.execute(arm_trajectory([0] * 6, GOAL, duration=0.5))
    arm = bus.controllers["arm_controller"]
    arm.send = lambda trajectory, now: arm.sent.append(trajectory)  # goes deaf: never reports the new goal
    result = manager.execute(arm_trajectory(GOAL, [0] * 6, duration=0.5))
    assert result.error_code.val == TIMED_OUT and "'arm_controller' never reported this goal" in result.message
    assert arm.latest.status == "succeeded"  # the old goal's report was there all along


def test_a_controller_that_stops_reporting_is_declared_lost_within_the_state_timeout(mycobot):
    bus = SimBus(mycobot)
    bus.hooks.append((bus.now + 0.5, lambda: setattr(bus.controllers["arm_controller"], "dead", True)))
    result = make_manager(mycobot, bus, joint_state_timeout=0.3).execute(arm_trajectory([0] * 6, GOAL, duration=3.0))
    assert result.error_code.val == CONTROL_FAILED
    assert "controller 'arm_controller' stopped reporting: no state for 0.3" in result.message
    assert "while /joint_states still arrive" in result.message
    assert result.duration == pytest.approx(0.8, abs=0.05)  # simulated time: not the 4.1 s deadline


def test_a_lost_controller_whose_joint_states_stopped_too_is_reported_so(mycobot):
    bus = SimBus(mycobot)

    def die() -> None:
        bus.controllers["arm_controller"].dead = True
        bus.joint_state_age = None  # the same process published /joint_states

    bus.hooks.append((bus.now + 0.5, die))
    result = make_manager(mycobot, bus, joint_state_timeout=0.3).execute(arm_trajectory([0] * 6, GOAL, duration=3.0))
    assert result.error_code.val == CONTROL_FAILED
    assert "stopped reporting" in result.message and "and /joint_states stopped too" in result.message


def test_controllers_claiming_success_must_also_bring_the_joints_to_the_goal(mycobot):
    bus = SimBus(mycobot)
    bus.controllers["arm_controller"].claim_success_early = True
    result = make_manager(mycobot, bus).execute(arm_trajectory([0] * 6, GOAL, duration=1.0))
    assert result.error_code.val == CONTROL_FAILED
    assert "controllers reported success but joint 'link3_to_link4' is still 0.5000 from the goal" in result.message
    trusting = make_manager(mycobot, SimBus(mycobot), goal_tolerance=0.0)
    trusting.bus.controllers["arm_controller"].claim_success_early = True
    assert trusting.execute(arm_trajectory([0] * 6, GOAL)).success


def test_stop_during_execution_preempts_and_stops_the_controllers(mycobot):
    bus = SimBus(mycobot)
    manager = make_manager(mycobot, bus)
    bus.hooks.append((bus.now + 0.4, manager.stop))
    result = manager.execute(arm_trajectory([0] * 6, GOAL, duration=1.0))
    assert result.error_code.val == PREEMPTED and result.message.startswith("execution stopped on request; at rest")
    arm = bus.controllers["arm_controller"]
    assert arm.stops == 0 and len(arm.sent) == 2  # the stop is a second goal along the path, not a cancel
    stop = arm.sent[1]
    assert stop.points[-1].velocities == [0.0] * 6
    assert 0.0 < bus.positions["link3_to_link4"] < 0.5  # stopped mid-way
    assert bus.positions["link3_to_link4"] == stop.points[-1].positions[2]  # at rest where the stop ends
    assert manager.stop() is False  # nothing left to stop


def test_a_second_execution_while_one_runs_is_refused_not_queued(mycobot):
    bus = SimBus(mycobot)
    manager = make_manager(mycobot, bus)
    second = []
    bus.hooks.append((bus.now + 0.2, lambda: second.append(manager.execute(arm_trajectory(GOAL, [0] * 6)))))
    first = manager.execute(arm_trajectory([0] * 6, GOAL, duration=1.0))
    assert first.success
    assert second[0].error_code.val == MoveItErrorCode.FAILURE
    assert "another execution (trajectory) is in progress" in second[0].message
    assert len(bus.controllers["arm_controller"].sent) == 1


@pytest.mark.parametrize("age, problem", [(None, "no joint state received"), (5.0, "5.00 s old")])
def test_missing_or_stale_joint_states_refuse_execution(mycobot, age, problem):
    bus = SimBus(mycobot)
    bus.joint_state_age = age
    result = make_manager(mycobot, bus).execute(arm_trajectory([0] * 6, GOAL))
    assert result.error_code.val == MoveItErrorCode.ROBOT_STATE_STALE and problem in result.message
    assert not bus.controllers["arm_controller"].sent


def test_a_trajectory_that_does_not_move_succeeds_without_the_controllers(mycobot):
    bus = SimBus(mycobot)
    bus.available["arm_controller"] = False
    still = JointTrajectory(joint_names=ARM, points=[JointTrajectoryPoint(positions=[0.0] * 6)])
    result = make_manager(mycobot, bus).execute(still)
    assert result.success and "already at the trajectory's only point" in result.message
    assert not bus.controllers["arm_controller"].sent


def test_a_start_waits_for_joints_still_settling_and_refuses_joints_at_rest(mycobot):
    """A real arm ends a step within goal_tolerance (0.02) and settles onto its last point
    afterwards; the next step's start (allowed_start_tolerance 0.01) waits for it as MoveIt's
    waitForRobotToStop does, sending nothing meanwhile. Joints at rest and still off are refused
    once seen at rest, not after the full wait."""
    bus = SimBus(mycobot)
    manager = make_manager(mycobot, bus)
    bus.positions["link1_to_link2"] = 0.018
    start = bus.now
    for k in range(1, 10):  # settling: 0.018 -> 0.0 over 0.18 s
        bus.hooks.append((start + 0.02 * k - 1e-6, lambda k=k: bus.positions.update({"link1_to_link2": 0.018 - 0.002 * k})))
    sent_at = []
    send = bus.send
    bus.send = lambda controller, trajectory: (sent_at.append(bus.now), send(controller, trajectory))
    result = manager.execute(arm_trajectory([0] * 6, GOAL))
    assert result.success, result.message
    assert sent_at and sent_at[0] >= start + 0.18 - 1e-9  # sent once at rest (after 0.18 s), not while moving

    bus = SimBus(mycobot)
    manager = make_manager(mycobot, bus)
    bus.positions["link1_to_link2"] = 0.015
    start = bus.now
    result = manager.execute(arm_trajectory([0] * 6, GOAL))
    assert result.error_code.val == MoveItErrorCode.START_STATE_INVALID and "0.0150" in result.message
    assert bus.now - start < 0.1  # at rest at the first poll: refused then
    assert not bus.controllers["arm_controller"].sent


def test_start_far_from_the_robot_or_absent_controller_sends_nothing(mycobot):
    bus = SimBus(mycobot)
    manager = make_manager(mycobot, bus)
    result = manager.execute(arm_trajectory([0.2] + [0] * 5, GOAL))
    assert result.error_code.val == MoveItErrorCode.START_STATE_INVALID and "link1_to_link2" in result.message
    bus.available["arm_controller"] = False
    result = manager.execute(arm_trajectory([0] * 6, GOAL))
    assert result.error_code.val == CONTROL_FAILED
    assert "controller 'arm_controller' is not running (no action server on /arm_controller/follow_joint_trajectory)" in result.message
    assert not bus.controllers["arm_controller"].sent


# ---------------------------------------------------------------------------- task solutions
def _attach_diff(object_id: str) -> dict:
    attached = AttachedCollisionObject(link_name="link6_flange", object=CollisionObject(id=object_id, operation=0,
                                       primitives=[{"type": 1, "dimensions": [0.02, 0.02, 0.02]}],
                                       primitive_poses=[{}], frame_id="link6_flange"),
                                       touch_links=["link6_flange", "gripper_base"])
    return PlanningSceneMsg(robot_state=RobotStateMsg(attached_collision_objects=[attached], is_diff=True),
                            is_diff=True).to_dict()


def _detach_diff(object_id: str) -> dict:
    detach = AttachedCollisionObject(link_name="link6_flange",
                                     object=CollisionObject(id=object_id, operation=CollisionObject.REMOVE))
    return PlanningSceneMsg(robot_state=RobotStateMsg(attached_collision_objects=[detach], is_diff=True),
                            is_diff=True).to_dict()


def _solution(second_goal=None, after2=None):
    first = arm_trajectory([0] * 6, GOAL, duration=0.5)
    second = arm_trajectory(second_goal or GOAL, [0] * 6, duration=0.5)
    return {"steps": [
        {"name": "approach", "group": "arm", "trajectory": RobotTrajectory(first, "arm").to_dict(),
         "scene_diff_after": _attach_diff("cube")},
        {"name": "retreat", "group": "arm", "trajectory": second.to_dict(), "controller": "arm_controller",
         "scene_diff_after": after2 if after2 is not None else _detach_diff("cube")},
    ]}


def _live(model):
    scene = PlanningScene(model)
    return scene, (lambda diff: scene.apply_planning_scene_msg(diff))


def test_task_solution_applies_each_scene_diff_after_its_trajectory(mycobot):
    bus = SimBus(mycobot)
    scene, apply = _live(mycobot)
    seen = []
    manager = make_manager(mycobot, bus)
    original_execute = manager._execute

    def spy(trajectory, controllers, description):
        seen.append((description, scene.attached_object_ids()))
        return original_execute(trajectory, controllers, description)

    manager._execute = spy
    result = manager.execute_solution(parse_task_solution(_solution()), apply, scene.copy())
    assert result.success, result.error_code
    assert result.steps_completed == 2 and result.failed_step is None
    assert seen == [("step 0 ('approach')", []), ("step 1 ('retreat')", ["cube"])]
    assert result.applied == ["step 0 ('approach'): scene_diff_after", "step 1 ('retreat'): scene_diff_after"]
    assert scene.attached_object_ids() == [] and scene.world_object_ids() == ["cube"]


def test_failed_step_keeps_its_scene_diff_unapplied_and_says_what_was_applied(mycobot):
    bus = SimBus(mycobot)
    scene, apply = _live(mycobot)
    manager = make_manager(mycobot, bus)
    bus.hooks.append((bus.now + 0.7, lambda: setattr(bus.controllers["arm_controller"], "fail_after", 0.1)))
    result = manager.execute_solution(parse_task_solution(_solution()), apply, scene.copy())
    assert result.error_code.val == CONTROL_FAILED and result.failed_step == 1 and result.steps_completed == 1
    assert "step 1 ('retreat') failed: controller 'arm_controller' failed the trajectory" in result.error_code.message
    assert "Its scene_diff_after was not applied" in result.error_code.message
    assert "Applied scene diffs: step 0 ('approach'): scene_diff_after." in result.error_code.message
    assert scene.attached_object_ids() == ["cube"]  # attached after step 0, still attached: consistent


def test_solution_with_an_impossible_scene_diff_is_refused_before_any_motion(mycobot):
    bus = SimBus(mycobot)
    scene, apply = _live(mycobot)
    steps = parse_task_solution(_solution(after2=_detach_diff("ghost")))
    result = make_manager(mycobot, bus).execute_solution(steps, apply, scene.copy())
    assert result.error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN
    assert "step 1 ('retreat'): scene_diff_after cannot be applied" in result.error_code.message
    assert "ghost" in result.error_code.message
    assert not bus.controllers["arm_controller"].sent and scene.attached_object_ids() == []


def test_solution_whose_steps_do_not_join_is_refused_before_any_motion(mycobot):
    bus = SimBus(mycobot)
    scene, apply = _live(mycobot)
    steps = parse_task_solution(_solution(second_goal=[0.9] + GOAL[1:]))
    result = make_manager(mycobot, bus).execute_solution(steps, apply, scene.copy())
    assert result.error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN
    assert "step 1 ('retreat') starts at link1_to_link2=0.9000 but the previous steps end at 0.3000" in result.error_code.message
    assert not bus.controllers["arm_controller"].sent


def test_scene_diff_before_is_applied_before_the_motion_and_reported_on_failure(mycobot):
    bus = SimBus(mycobot)
    scene, apply = _live(mycobot)
    bus.controllers["arm_controller"].reject = True
    steps = parse_task_solution([{"name": "grab", "scene_diff_before": _attach_diff("cube"),
                                  "trajectory": arm_trajectory([0] * 6, GOAL).to_dict()}])
    result = make_manager(mycobot, bus).execute_solution(steps, apply, scene.copy())
    assert result.error_code.val == CONTROL_FAILED and result.failed_step == 0
    assert "Applied scene diffs: step 0 ('grab'): scene_diff_before." in result.error_code.message
    assert scene.attached_object_ids() == ["cube"]


def test_scene_diffs_never_move_the_robot_and_never_replace_the_world(mycobot):
    (step,) = parse_task_solution([{"scene_diff": {"robot_state": {"joint_names": ["link1_to_link2"], "positions": [1.0]},
                                                   "world": {"collision_objects": []}}}])
    assert step.scene_diff_after.is_diff and step.scene_diff_after.robot_state.joint_names == []
    scene, apply = _live(mycobot)
    scene.add_object(CollisionObject.box("table", [0.1, 0.1, 0.1]))
    result = make_manager(mycobot, SimBus(mycobot)).execute_solution([step], apply, scene.copy())
    assert result.success and scene.world_object_ids() == ["table"]
    assert scene.current_state.positions[0] == 0.0


@pytest.mark.parametrize("data, problem", [
    ({}, "needs a 'steps' list"),
    ({"steps": []}, "non-empty list"),
    ({"steps": [{"trajectry": {}}]}, r"step 0: unknown keys \['trajectry'\]"),
    ({"steps": [{"name": "x"}, {"name": "bad", "trajectory": {"joint_names": ["a"], "points": [{"positions": []}]}}]},
     r"step 1 \('bad'\) trajectory"),
    ({"steps": [{"scene_diff_after": {"world": 3}}]}, "step 0 scene_diff_after"),
    ({"steps": [{"controller": 5}]}, "controller names must be"),
])
def test_malformed_task_solutions_are_refused_naming_the_step(data, problem):
    with pytest.raises(ExecutionError, match=problem):
        parse_task_solution(data)


def test_mtc_style_solution_fields_are_accepted():
    traj = arm_trajectory([0] * 6, GOAL)
    (step,) = parse_task_solution({"sub_trajectory": [{
        "info": {"id": 3}, "trajectory": RobotTrajectory(traj, "arm").to_dict(),
        "scene_diff": _attach_diff("cube"), "execution_info": {"controller_names": ["arm_controller"]}}]})
    assert step.group == "arm" and step.controllers == ("arm_controller",) and step.scene_diff_after is not None


# ---------------------------------------------------------------------------- planning server core
@pytest.fixture()
def server(mycobot, pipeline):
    bus = SimBus(mycobot)
    core = MoveGroupJsonFace(mycobot, pipeline, CONTROLLERS, bus, ExecutionSettings(), clock=bus.clock)
    core.bus = bus

    def wait(dt: float) -> None:  # the simulated robot moves, /joint_states reports it
        bus.wait(dt)
        _feed(core)

    core.executor._wait = wait
    return core


def _feed(core, positions=None):
    names = list(core.bus.positions)
    if positions:
        core.bus.positions.update(positions)
    values = [core.bus.positions[n] for n in names]
    mimic = ["gripper_base_to_gripper_left2"]
    assert core.update_joint_state(names + mimic + ["other_robot_joint"], values + [0.0, 7.0]) is None


def test_joint_states_set_the_scene_state_ignoring_mimic_and_foreign_joints(server):
    _feed(server, {"link2_to_link3": 0.4})
    assert server.scene.current_state.joint_position("link2_to_link3") == 0.4
    assert "NaN" in server.update_joint_state(["link1_to_link2"], [math.nan])
    assert "2 names but 1 positions" in server.update_joint_state(["link1_to_link2", "link2_to_link3"], [0.0])
    assert server.scene.current_state.joint_position("link2_to_link3") == 0.4


def test_planning_refuses_a_missing_or_stale_current_state(server):
    result = server.plan({"group": "arm", "goal": {"named": "ready"}})
    assert result["error_code"]["val"] == MoveItErrorCode.ROBOT_STATE_STALE
    assert "no joint state received" in result["error_code"]["message"] and result["trajectory"] is None
    _feed(server)
    server.bus.now += 5.0
    result = server.plan({"group": "arm", "goal": {"named": "ready"}})
    assert result["error_code"]["val"] == MoveItErrorCode.ROBOT_STATE_STALE and "5.00 s old" in result["error_code"]["message"]
    complete = {"joint_names": list(server.model.variable_names), "positions": [0.0] * 7}
    assert server.plan({"goal": {"named": "ready"}, "start_state": complete})["error_code"]["val"] == SUCCESS


@pytest.mark.parametrize("goal", [{"named": "ready"}, {"joints": [0.2, -0.3, 0.4, 0.1, 0.2, 0.3]},
                                  {"joints": dict(zip(ARM, [0.1] * 6))},
                                  {"pose": [0.12, -0.06, 0.22, 1.0, 0.0, 0.0, 0.0]}])
def test_planned_trajectories_start_at_the_current_state_and_pass_the_validator(server, goal):
    _feed(server, {"link1_to_link2": 0.1})
    shown = []
    server.trajectory_listeners.append(shown.append)
    result = server.plan({"group": "arm", "goal": goal, "seed": 1})
    assert result["error_code"]["val"] == SUCCESS, result["error_code"]
    trajectory = RobotTrajectory.from_dict(result["trajectory"])
    jt = trajectory.joint_trajectory
    assert trajectory.group_name == "arm" and jt.joint_names == ARM and shown == [jt]
    assert jt.points[0].positions[0] == pytest.approx(0.1)
    assert all(not p.accelerations for p in jt.points)  # controllers use cubic Hermite: exact for planned motion
    report = validate_trajectory(server.scene_copy(), as_controller_executes(jt), "arm", tolerance=1e-6)
    assert report.valid, report.problems


@pytest.mark.parametrize("request_, code, text", [
    ({"group": "legs", "goal": {"named": "ready"}}, MoveItErrorCode.INVALID_GROUP_NAME, "unknown planning group"),
    ({"group": "arm"}, MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "needs a 'goal'"),
    ({"goal": {"named": "ready", "joints": [0] * 6}}, MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "exactly one"),
    ({"goal": {"named": "nowhere"}}, MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "nowhere"),
    ({"goal": {"joints": [0.1, "x", 0, 0, 0, 0]}}, MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "joints[1]"),
    ({"goal": {"joints": [0.1] * 5}}, MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "5 values"),
    ({"goal": {"pose": [0.1, 0.1, 0.1]}}, MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "7 numbers"),
    ({"goal": {"named": "ready"}, "planing_time": 1}, MoveItErrorCode.INVALID_MOTION_PLAN, "unknown keys"),
    ({"goal": {"named": "ready"}, "max_velocity_scaling_factor": 3.0}, MoveItErrorCode.INVALID_MOTION_PLAN, "(0, 1]"),
    ({"goal": {"named": "ready"}, "pipeline_id": "trajopt"}, MoveItErrorCode.INVALID_MOTION_PLAN, "unknown planning pipeline"),
    ({"goal": {"named": "ready"}, "start_state": {"joint_names": ["x"], "positions": [0.0]}},
     MoveItErrorCode.INVALID_ROBOT_STATE, "does not have"),
])
def test_bad_plan_requests_get_error_codes_never_exceptions(server, request_, code, text):
    _feed(server)
    result = server.plan(request_)
    assert result["error_code"]["val"] == code and result["trajectory"] is None
    assert text in result["error_code"]["message"]


def test_execute_runs_the_last_plan_and_refuses_after_a_failed_plan(server):
    _feed(server)
    assert server.execute({})["error_code"]["message"].endswith("nothing has been planned yet")
    assert server.plan({"goal": {"named": "ready"}})["error_code"]["val"] == SUCCESS
    result = server.execute({})
    assert result["error_code"]["val"] == SUCCESS and result["controllers"] == ["arm_controller"]
    assert server.bus.positions["link3_to_link4"] == pytest.approx(1.5708, abs=1e-3)
    server.plan({"goal": {"named": "nowhere"}})
    message = server.execute({})["error_code"]["message"]
    assert "no plan to execute: the last planning request failed" in message


def test_execute_refuses_trajectories_with_nan_or_unknown_joints(server):
    _feed(server)
    bad = arm_trajectory([0] * 6, GOAL).to_dict()
    bad["points"][2]["positions"][0] = math.nan
    assert "must be finite" in server.execute({"trajectory": bad})["error_code"]["message"]
    unknown = JointTrajectory(joint_names=["elbow"], points=[JointTrajectoryPoint(positions=[0.0])]).to_dict()
    result = server.execute({"trajectory": unknown})
    assert result["error_code"]["val"] == MoveItErrorCode.INVALID_MOTION_PLAN and "'elbow'" in result["error_code"]["message"]
    assert not server.bus.controllers["arm_controller"].sent


def test_scene_updates_are_all_or_nothing_and_unknown_ids_are_named(server):
    changes = []
    server.scene_listeners.append(lambda: changes.append(1))
    box = CollisionObject.box("box", [0.05, 0.05, 0.05], make_pose([0.2, 0.0, 0.3])).to_dict()
    bad = dict(box, id="bad", primitives=[{"type": 1, "dimensions": [0.1, -1.0, 0.1]}])
    with pytest.raises(RequestError, match=r"collision object 1: .*BOX y must be > 0"):
        server.apply_collision_objects([box, bad])
    assert server.scene.world_object_ids() == [] and changes == []
    assert server.apply_collision_objects([box])["ids"] == ["box"]
    with pytest.raises(RequestError, match=r"unknown collision object 'nope' \(known: 'box'\)") as info:
        server.apply_collision_objects([{"id": "nope", "operation": CollisionObject.REMOVE}])
    assert info.value.code == MoveItErrorCode.INVALID_OBJECT_NAME
    with pytest.raises(RequestError, match="malformed JSON"):
        server.apply_collision_objects(["{oops"])
    assert server.scene.world_object_ids() == ["box"] and changes == [1]


def test_attached_object_defaults_to_the_flange_and_follows_the_joint_state(server):
    _feed(server)
    server.apply_collision_objects([CollisionObject.box("cube", [0.02] * 3, make_pose([0.1, 0.0, 0.4])).to_dict()])
    result = server.attach_object("cube")
    assert result["link_name"] == "link6_flange" and "gripper_left1" in result["touch_links"]
    before = server.get_objects()["attached_object_poses"]["cube"]["position"]
    _feed(server, {"link1_to_link2": 1.0})
    after = server.get_objects()["attached_object_poses"]["cube"]["position"]
    flange = server.scene.current_state.frame_pose("link6_flange")
    relative = AttachedCollisionObject.from_dict(server.get_objects()["attached_objects"]["cube"]).object.pose.to_matrix()
    assert after == pytest.approx((flange @ relative)[:3, 3].tolist(), abs=1e-9)
    assert not np.allclose(before, after)
    (obj, attached), = server.marker_objects()
    assert attached and obj.pose.position == pytest.approx(after)
    with pytest.raises(RequestError, match="unknown collision object 'table'"):
        server.detach_object("table")
    server.detach_object("cube")
    assert server.get_objects()["objects"]["cube"]["pose"]["position"] == pytest.approx(after)


def test_goal_from_parameters_uses_the_target_set_last():
    values = {"group": "arm", "named_target": "ready", "joint_values": [0.1] * 6, "pose": [], "link": ""}
    assert goal_from_parameters(values)["goal"] == {"named": "ready"}
    assert goal_from_parameters(values, "joint_values")["goal"] == {"joints": [0.1] * 6}
    pose = dict(values, pose=[0.1, 0, 0.2, 0, 0, 0, 1], link="link6_flange")
    assert goal_from_parameters(pose, "pose")["goal"] == {"pose": [0.1, 0, 0.2, 0, 0, 0, 1], "link": "link6_flange"}
    with pytest.raises(RequestError, match="no goal set"):
        goal_from_parameters({"group": "arm", "named_target": "", "joint_values": [], "pose": []})


def test_pose_json_forms_agree():
    expected = make_pose([0.1, 0.2, 0.3], quat_xyzw=[0, 0, 0.6, 0.8])
    for form in ([0.1, 0.2, 0.3, 0, 0, 0.6, 0.8], {"position": [0.1, 0.2, 0.3], "orientation": [0, 0, 0.6, 0.8]},
                 expected.tolist()):
        assert pose_from_json(form) == pytest.approx(expected)
    for bad in ([0.1, math.nan, 0, 0, 0, 0, 1], [0, 0, 0, 0, 0, 0, 0], "pose", [[1, 2], [3, 4]]):
        with pytest.raises(RequestError):
            pose_from_json(bad)


def test_joint_trajectory_round_trip_keeps_the_spline():
    """A planned (cubic) trajectory sent without accelerations comes back as the same spline."""
    from mycobot_planning.core import time_parameterize
    from mycobot_planning.core.robot_trajectory.robot_trajectory import joint_trajectory_to_timed, timed_to_joint_trajectory

    path = np.array([[0.0, 0.0], [0.5, 0.2], [0.9, -0.3]])
    timed = time_parameterize(path, [1.0, 1.0], [2.0, 2.0])
    msg = timed_to_joint_trajectory(timed)
    assert all(not p.accelerations for p in msg.points)
    back = joint_trajectory_to_timed(msg)
    ts = np.linspace(0.0, timed.duration, 97)
    for a, b in zip(timed.sample(ts), back.sample(ts)):
        assert np.allclose(a, b, atol=1e-9)
