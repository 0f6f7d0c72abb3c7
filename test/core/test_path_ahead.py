"""Reacting while moving (issue 29), ROS-free: the path ahead re-checked on scene changes
(core/trajectory_execution/path_ahead.py), the stop along the path, the execution manager that
stops short of an object appearing on the path, and move_group's replanning (capabilities/move_action).

The controllers and the clock are simulated (test_execution's SimBus); the path watch runs on a
real thread, so each simulated step after a scene change waits until the watch has checked it.
"""
from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from interfaces_py.msgs import CollisionObject, MoveItErrorCode
from mycobot_planning.capabilities import move_action
from mycobot_planning.capabilities.json_face import RequestError
from mycobot_planning.core import PlanningScene, RobotState
from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest, time_group_path
from mycobot_planning.core.robot_trajectory.robot_trajectory import TimedTrajectory, timed_to_joint_trajectory
from mycobot_planning.core.trajectory_execution import ExecutionSettings, SolutionStep, TrajectoryExecutionManager
from mycobot_planning.core.trajectory_execution.path_ahead import PathAhead, stopping_trajectory
from mycobot_planning.core.trajectory_processing.trajectory_limits import DEFAULT_LIMIT_TOLERANCE
from mycobot_planning.core.transforms import make_pose
from test_execution import ARM, CONTROLLERS, SimBus, _feed, server  # noqa: F401 (fixtures)

INVALIDATED = MoveItErrorCode.MOTION_PLAN_INVALIDATED_BY_ENVIRONMENT_CHANGE
#: the arm's pose for the sweep: joint 1 turns from -1.2 to +1.2 rad, the others hold this
POSE = [0.0, -0.8, -0.6, 0.0, 0.0, 0.0]


def sweep(model, start=-1.2, end=1.2, scaling=0.3):
    a, b = list(POSE), list(POSE)
    a[0], b[0] = start, end
    return time_group_path(model, model.group("arm"), np.array([a, b]), scaling, scaling, None)


def arm_state(model, values) -> RobotState:
    state = RobotState(model)
    state.set_group_positions("arm", values)
    return state


def flange_box(model, joint1: float, size=0.06, name="intruder") -> CollisionObject:
    values = list(POSE)
    values[0] = joint1
    where = arm_state(model, values).frame_pose("link6_flange")[:3, 3]
    return CollisionObject.box(name, [size] * 3, make_pose(where))


def collides(scene: PlanningScene, model, values) -> bool:
    state = np.array(scene.current_state.positions, dtype=float)
    state[[model.variable_index(n) for n in ARM]] = values
    return bool(scene.colliding_rows(np.arange(len(state)), None, state[None, :], all_pairs=True)[0])


# ------------------------------------------------------------------------------- the path ahead
def test_first_collision_is_the_earliest_contact_ahead(mycobot):
    traj = sweep(mycobot)
    scene = PlanningScene(mycobot)
    scene.set_current_state(dict(zip(ARM, traj.positions[0])))
    path = PathAhead(mycobot, traj)
    assert path.first_collision(scene, 0.0) is None
    scene.add_object(flange_box(mycobot, 0.0))
    hit = path.first_collision(scene, 0.0)
    assert hit is not None and 0.0 < hit.free_until < hit.time < traj.duration / 2
    assert any("intruder" in c for c in hit.contacts) and "intruder" in hit.message()
    # exact: the plain all-pairs check agrees on both sides of the first contact, and every
    # state checked before it is free
    q_hit = traj.sample(traj.times[0] + hit.time)[0]
    q_free = traj.sample(traj.times[0] + hit.free_until)[0]
    assert collides(scene, mycobot, q_hit) and not collides(scene, mycobot, q_free)
    before = path.positions[path.times <= hit.free_until]
    assert not any(collides(scene, mycobot, q) for q in before[:: max(1, len(before) // 40)])
    # checked from past the box, the rest of the path is free; from just before it, still found
    assert path.first_collision(scene, traj.duration * 0.75) is None
    again = path.first_collision(scene, hit.free_until)
    assert again is not None and again.time == pytest.approx(hit.time)


def test_objects_away_from_the_path_do_not_invalidate_it(mycobot):
    traj = sweep(mycobot)
    scene = PlanningScene(mycobot)
    scene.add_object(CollisionObject.box("far", [0.05] * 3, make_pose([0.6, 0.6, 0.3])))
    assert PathAhead(mycobot, traj).first_collision(scene, 0.0) is None


# ------------------------------------------------------------------------------- the stop
@pytest.mark.parametrize("fraction", [0.05, 0.3, 0.5, 0.8])
def test_stop_follows_the_path_within_the_acceleration_limits(mycobot, fraction):
    traj = sweep(mycobot, scaling=1.0)
    limits = mycobot.acceleration_limits[[mycobot.variable_index(n) for n in traj.joint_names]]
    t0 = traj.duration * fraction
    plan = stopping_trajectory(traj, t0, limits)
    assert plan is not None and plan.rest_at >= t0
    stop = plan.trajectory
    # what a controller makes of the stop's points (quintic through q, qd, qdd), densely
    ts = np.linspace(0.0, stop.duration, 2000)
    q, qd, qdd = stop.sample(ts)
    assert np.all(np.abs(qdd) <= limits * (1 + DEFAULT_LIMIT_TOLERANCE) + 1e-6)
    assert np.allclose(stop.velocities[-1], 0.0)
    # on the path: joint 1 moves monotonically between where it was at t0 and the rest point,
    # and the other joints never leave the path's values
    start = traj.sample(traj.times[0] + t0)[0]
    rest = traj.sample(traj.times[0] + plan.rest_at)[0]
    assert np.allclose(stop.positions[0], start) and np.allclose(stop.positions[-1], rest)
    assert np.all(np.diff(q[:, 0]) >= -1e-9)
    assert np.allclose(q[:, 1:], np.array(POSE[1:]), atol=1e-9)
    # and no faster than the path itself
    assert np.all(np.abs(qd[:, 0]) <= np.max(np.abs(traj.velocities[:, 0])) * (1 + 1e-6))


def test_no_stop_when_the_obstacle_is_nearer_than_the_braking_distance(mycobot):
    traj = sweep(mycobot, scaling=1.0)
    limits = mycobot.acceleration_limits[[mycobot.variable_index(n) for n in traj.joint_names]]
    t0 = traj.duration / 2
    plan = stopping_trajectory(traj, t0, limits)
    assert stopping_trajectory(traj, t0, limits, stop_before=plan.rest_at + 1e-6) is not None
    assert stopping_trajectory(traj, t0, limits, stop_before=t0 + 0.5 * (plan.rest_at - t0)) is None


# ------------------------------------------------------------------------------- the execution
class Intrusion:
    """Scene changes at set simulated times; each simulated step after a change waits (in real
    time) until the path watch has finished a check that began after it (a check of an older
    scene finishing meanwhile does not count), so the outcome does not depend on thread timing."""

    def __init__(self, manager: TrajectoryExecutionManager, bus: SimBus, scene_box: list[PlanningScene]) -> None:
        self.manager, self.bus, self.scene = manager, bus, scene_box
        self.pending = 0
        manager._wait = self.wait

    def at(self, delay: float, change) -> None:
        def act() -> None:
            change(self.scene[0])
            self.manager.scene_changed()
            self.pending = self.manager.watch_stats["changes"]
        self.bus.hooks.append((self.bus.now + delay, act))

    def wait(self, dt: float) -> None:
        if self.pending:
            end = time.monotonic() + 10.0
            while self.manager.watch_stats["changes_checked"] < self.pending and time.monotonic() < end:
                time.sleep(0.001)
            self.pending = 0
        self.bus.wait(dt)


def watched_manager(model, bus: SimBus, scene: PlanningScene) -> tuple[TrajectoryExecutionManager, Intrusion]:
    holder = [scene]
    manager = TrajectoryExecutionManager(model, CONTROLLERS, bus, bus.current_positions, ExecutionSettings(),
                                         clock=bus.clock, wait=bus.wait, poll_period=0.01,
                                         scene_source=lambda: holder[0].copy())
    return manager, Intrusion(manager, bus, holder)


def start_sweep(model, bus: SimBus, traj):
    bus.positions.update(zip(ARM, traj.positions[0]))
    return timed_to_joint_trajectory(traj, 0.01)


def test_execution_stops_short_of_an_object_appearing_on_the_path(mycobot):
    bus = SimBus(mycobot)
    traj = sweep(mycobot)
    jt = start_sweep(mycobot, bus, traj)
    scene = PlanningScene(mycobot)
    manager, intrusion = watched_manager(mycobot, bus, scene)
    intrusion.at(traj.duration * 0.25, lambda s: s.add_object(flange_box(mycobot, 0.0)))
    result = manager.execute(jt)
    assert result.error_code.val == INVALIDATED, result.message
    assert "intruder" in result.message and "at rest at" in result.message
    arm = bus.controllers["arm_controller"]
    assert len(arm.sent) == 2 and arm.stops == 0  # the trajectory, then the stop along it
    final = [bus.positions[n] for n in ARM]
    assert -1.2 < final[0] < 0.0  # stopped on the way, before the box at joint 1 = 0
    assert not collides(scene, mycobot, final)
    # every state the simulated arm went through during the stop is free in the final scene
    stop = arm.sent[1]
    for point in stop.points:
        assert not collides(scene, mycobot, point.positions)
    assert manager.watch_stats["checks"] >= 1


def sweep_with_a_box(model, joint1: float):
    """A sweep ready to run on a SimBus, its empty scene, and a 4 cm box where the flange passes
    at ``joint1`` with a copy of the scene holding it (to judge by)."""
    bus = SimBus(model)
    traj = sweep(model)
    jt = start_sweep(model, bus, traj)
    scene = PlanningScene(model)
    box = flange_box(model, joint1, size=0.04)
    judge = scene.copy()
    judge.add_object(box)
    return bus, traj, jt, scene, box, judge


def start_late(bus: SimBus, lag: float, at_second_send: list | None = None):
    """The arm controller starts its first goal ``lag`` s after it was sent (accepted late, so it
    runs behind the execution's clock); ``at_second_send`` gets the arm's positions when the next
    goal (the stop) is sent."""
    arm = bus.controllers["arm_controller"]
    original = arm.send

    def send(trajectory, now):
        if at_second_send is not None and len(arm.sent) == 1:
            at_second_send.append([bus.positions[n] for n in trajectory.joint_names])
        original(trajectory, now)
        if len(arm.sent) == 1:
            arm.start = now + lag
    arm.send = send
    return arm


def test_an_arm_behind_the_clock_is_checked_from_where_it_is(mycobot):
    """A controller that accepted the goal late runs behind the execution's clock: an object
    appearing on the stretch of path between the arm and the clock's time must still stop it (a
    check from the clock's time alone finds the rest of the path free and the arm runs through)."""
    bus, traj, jt, scene, box, judge = sweep_with_a_box(mycobot, 0.0)
    path = PathAhead(mycobot, traj)
    hit = path.first_collision(judge, 0.0)
    last = max(t for t, q in zip(path.times, path.positions) if collides(judge, mycobot, q))
    manager, intrusion = watched_manager(mycobot, bus, scene)
    start_late(bus, last - hit.time + 0.3)
    # on the clock the path has left the box; the arm has not reached it yet
    intrusion.at(last + 0.05, lambda s: s.add_object(box))
    result = manager.execute(jt)
    assert result.error_code.val == INVALIDATED, result.message
    final = [bus.positions[n] for n in ARM]
    assert final[0] < 0.0 and not collides(judge, mycobot, final)


def test_a_stop_of_an_arm_behind_the_clock_begins_where_the_arm_is(mycobot):
    """The stop along the path of an arm running 0.5 s behind the clock starts at the arm's own
    position (a stop from where the clock says would first jump the arm ahead along the path)."""
    bus, traj, jt, scene, box, judge = sweep_with_a_box(mycobot, 0.3)
    hit = PathAhead(mycobot, traj).first_collision(judge, 0.0)
    manager, intrusion = watched_manager(mycobot, bus, scene)
    at_stop: list[list[float]] = []
    arm = start_late(bus, 0.5, at_stop)
    intrusion.at(hit.free_until - 0.1, lambda s: s.add_object(box))
    result = manager.execute(jt)
    assert result.error_code.val == INVALIDATED, result.message
    assert "at rest at" in result.message  # a stop along the path, not a halt
    stop = arm.sent[1]
    assert np.max(np.abs(np.array(stop.points[0].positions) - np.array(at_stop[0]))) < 0.05
    final = [bus.positions[n] for n in ARM]
    assert final[0] < 0.3 and not collides(judge, mycobot, final)


def test_a_task_solution_stops_at_the_step_whose_path_became_invalid(mycobot):
    """MTC cannot replan a solution: its execution stops at the step whose path is blocked and
    the error names that step; the steps before it ran, those after it did not."""
    bus = SimBus(mycobot)
    there = sweep(mycobot, -1.2, -0.6)
    across = sweep(mycobot, -0.6, 1.2)
    back = sweep(mycobot, 1.2, 0.0)
    bus.positions.update(zip(ARM, there.positions[0]))
    scene = PlanningScene(mycobot)
    manager, intrusion = watched_manager(mycobot, bus, scene)
    steps = [SolutionStep("approach", "arm", timed_to_joint_trajectory(there, 0.01)),
             SolutionStep("sweep", "arm", timed_to_joint_trajectory(across, 0.01)),
             SolutionStep("return", "arm", timed_to_joint_trajectory(back, 0.01))]
    # during the second step: the first takes there.duration (+ a poll period or two)
    intrusion.at(there.duration + 0.3 * across.duration, lambda s: s.add_object(flange_box(mycobot, 0.3)))
    result = manager.execute_solution(steps, lambda diff: None)
    assert result.error_code.val == INVALIDATED, result.message
    assert result.failed_step == 1 and result.steps_completed == 1
    assert "step 1 ('sweep')" in result.message and "intruder" in result.message
    assert len(bus.controllers["arm_controller"].sent) == 3  # approach, sweep, the stop; never 'return'
    final = [bus.positions[n] for n in ARM]
    assert -0.6 < final[0] < 0.3 and not collides(scene, mycobot, final)


@pytest.mark.parametrize("change", ["far object", "removed object"])
def test_scene_changes_off_the_path_do_not_stop_the_execution(mycobot, change):
    bus = SimBus(mycobot)
    traj = sweep(mycobot)
    jt = start_sweep(mycobot, bus, traj)
    scene = PlanningScene(mycobot)
    if change == "removed object":
        scene.add_object(CollisionObject.box("gone", [0.05] * 3, make_pose([0.6, 0.6, 0.3])))
        act = (lambda s: s.remove_object("gone"))
    else:
        act = (lambda s: s.add_object(CollisionObject.box("far", [0.05] * 3, make_pose([0.6, 0.6, 0.3]))))
    manager, intrusion = watched_manager(mycobot, bus, scene)
    intrusion.at(traj.duration * 0.25, act)
    result = manager.execute(jt)
    assert result.success, result.message
    assert manager.watch_stats["checks"] == 1
    assert bus.positions["link1_to_link2"] == pytest.approx(1.2)


def test_a_burst_of_scene_updates_is_coalesced_and_the_invalidating_one_still_stops(mycobot):
    """1,000 updates arrive at once (far objects), then one on the path: the watch checks far
    fewer scenes than updates, the execution goes on meanwhile, and the last one still stops it."""
    bus = SimBus(mycobot)
    traj = sweep(mycobot)
    jt = start_sweep(mycobot, bus, traj)
    scene = PlanningScene(mycobot)
    manager, intrusion = watched_manager(mycobot, bus, scene)
    updates = []

    def storm(s: PlanningScene) -> None:
        for k in range(1000):
            s.add_object(CollisionObject.box(f"far{k % 5}", [0.02] * 3, make_pose([0.6, 0.6, 0.3 + 0.01 * (k % 5)])))
            manager.scene_changed()
            updates.append(k)

    intrusion.at(traj.duration * 0.1, storm)
    intrusion.at(traj.duration * 0.25, lambda s: s.add_object(flange_box(mycobot, 0.0)))
    result = manager.execute(jt)
    assert len(updates) == 1000
    assert result.error_code.val == INVALIDATED, result.message
    assert manager.watch_stats["checks"] < 100
    assert bus.positions["link1_to_link2"] < 0.0


def test_stop_requests_are_idempotent_and_decelerate(mycobot):
    bus = SimBus(mycobot)
    traj = sweep(mycobot, scaling=1.0)
    jt = start_sweep(mycobot, bus, traj)
    manager = TrajectoryExecutionManager(mycobot, CONTROLLERS, bus, bus.current_positions, ExecutionSettings(),
                                         clock=bus.clock, wait=bus.wait, poll_period=0.01)
    stops: list[bool] = []
    for k in range(20):  # a stop storm
        bus.hooks.append((bus.now + traj.duration * 0.4 + 0.001 * k, lambda: stops.append(manager.stop())))
    result = manager.execute(jt)
    assert result.error_code.val == MoveItErrorCode.PREEMPTED and "at rest" in result.message
    assert stops[0] is True
    arm = bus.controllers["arm_controller"]
    assert len(arm.sent) == 2  # one stop, however many requests
    stop = arm.sent[1]
    assert stop.points[-1].velocities == [0.0] * 6
    assert manager.stop() is False


# ------------------------------------------------------------------------------- replanning
def _drive(core, scene_change_at: float | None, change=None) -> None:
    """The simulated robot moves, /joint_states reports it; ``change`` applies to the live
    scene ``scene_change_at`` s into the first execution, and each step after it waits for
    the path watch."""
    bus = core.bus
    state = {"pending": 0, "armed": scene_change_at is not None}

    def wait(dt: float) -> None:
        if state["armed"] and core.executor.executing:
            state["armed"] = False

            def act() -> None:
                state["pending"] = core.executor.watch_stats["checks"] + 1
                change(core)
            bus.hooks.append((bus.now + scene_change_at, act))
        if state["pending"]:
            end = time.monotonic() + 10.0
            while core.executor.watch_stats["checks"] < state["pending"] and time.monotonic() < end:
                time.sleep(0.001)
            state["pending"] = 0
        bus.wait(dt)
        _feed(core)

    core.executor._wait = wait


def _sweep_with_intruder(server, mycobot) -> tuple[list[float], list[float]]:
    """The arm at the sweep's start; a 5 cm box appears on its path 0.8 s into the first
    execution. Returns (start, goal)."""
    start, goal = list(POSE), list(POSE)
    start[0], goal[0] = -1.2, 1.2
    _start(server, start)
    box = flange_box(mycobot, 0.0, size=0.05)
    _drive(server, 0.8, lambda core: core.apply_collision_objects([box]))
    return start, goal


def _request(values) -> MotionPlanRequest:
    return MotionPlanRequest(group="arm", goal=JointGoal(dict(zip(ARM, values))), allowed_planning_time=10.0,
                             max_velocity_scaling_factor=0.3, max_acceleration_scaling_factor=0.3,
                             pipeline_id="ompl", planner_id="RRTConnectkConfigDefault", seed=7)


def _start(core, values) -> None:
    core.bus.positions.update(zip(ARM, values))
    _feed(core)


@pytest.mark.parametrize("replan", [False, True])
def test_move_with_and_without_replanning(server, mycobot, replan):
    start, goal = _sweep_with_intruder(server, mycobot)
    replans: list[int] = []
    options = move_action.Replanning.checked(replan, 3, 0.0)
    planned, executed = move_action.plan_and_execute(server, [(_request(goal), "")], replanning=options,
                                                     on_replan=replans.append)
    final = [server.bus.positions[n] for n in ARM]
    scene = server.scene_copy()
    assert not collides(scene, mycobot, final)
    if not replan:
        assert executed.error_code.val == INVALIDATED, executed.message
        assert replans == []
    else:
        assert executed.success, executed.message
        assert replans == [1] and "after 1 replan" in executed.message
        assert np.allclose(final, goal, atol=0.02)
        # the replanned path went around the box: every state of it is free in the final scene
        path = PathAhead(mycobot, planned.trajectory)
        assert path.first_collision(scene, 0.0) is None
        # and kept the replan's clearance from it (grown boxes), checked with exact distances
        base = np.array(scene.current_state.positions, dtype=float)
        nearest = np.inf
        for row in path.positions[::4]:
            values = base.copy()
            values[path.indices] = row
            nearest = min(nearest, scene.distance(RobotState(mycobot, values), include_self=False).min_distance)
        assert nearest >= move_action.REPLAN_CLEARANCE * 0.9, nearest


@pytest.mark.parametrize("attempts, delay, problem", [
    (-1, 0.0, "replan_attempts must be >= 0"),
    (2, float("nan"), "replan_delay must be a number"),
    (2, -0.5, "replan_delay must be a number"),
    (2, 1e9, "replan_delay must be a number"),
])
def test_bad_replanning_options_are_refused(attempts, delay, problem):
    with pytest.raises(RequestError, match=problem):
        move_action.Replanning.checked(True, attempts, delay)


def test_huge_replan_attempts_are_capped():
    said = []
    options = move_action.Replanning.checked(True, 10**9, 0.5, lambda level, text: said.append(text))
    assert options.attempts == move_action.MAX_REPLAN_ATTEMPTS and "capped" in said[0]


def test_cancel_while_waiting_to_replan_ends_the_goal(server, mycobot):
    start, goal = _sweep_with_intruder(server, mycobot)
    cancel = threading.Event()
    replans: list[int] = []
    options = move_action.Replanning.checked(True, 3, 5.0)
    timer = threading.Timer(0.0, cancel.set)

    def on_invalidated_wait() -> bool:
        if server.executor.last_result and not timer.is_alive() and not cancel.is_set():
            timer.start()
        return cancel.is_set()

    _, executed = move_action.plan_and_execute(server, [(_request(goal), "")], replanning=options,
                                               cancelled=on_invalidated_wait, on_replan=replans.append)
    assert executed.error_code.val == MoveItErrorCode.PREEMPTED and "waiting to replan" in executed.message
    assert replans == []


def test_the_json_face_replans_too(server, mycobot):
    start, goal = _sweep_with_intruder(server, mycobot)
    reply = server.plan_and_execute({"group": "arm", "goal": {"joints": dict(zip(ARM, goal))}, "seed": 7,
                                     "max_velocity_scaling_factor": 0.3, "max_acceleration_scaling_factor": 0.3,
                                     "replan": True, "replan_attempts": 2, "replan_delay": 0.0})
    assert reply["error_code"]["val"] == MoveItErrorCode.SUCCESS, reply["error_code"]
    assert "after 1 replan" in reply["error_code"]["message"]
    for bad, words in (({"replan": "yes"}, "replan must be true or false"),
                       ({"replan": True, "replan_attempts": -3}, "replan_attempts must be >= 0"),
                       ({"replan": True, "replan_delay": float("inf")}, "replan_delay must be")):
        reply = server.plan_and_execute({"group": "arm", "goal": {"joints": dict(zip(ARM, start))}, **bad})
        assert reply["error_code"]["val"] == MoveItErrorCode.INVALID_MOTION_PLAN and words in reply["error_code"]["message"]


def test_a_stop_on_a_path_at_its_acceleration_limit_stays_within_the_controllers_tolerance(mycobot):
    """A planned path may touch its limits within the controllers' 5 % tolerance; where it brakes
    that hard itself, the stop follows it instead of adding braking on top (a stop goal over the
    tolerance is refused by the controller)."""
    traj = sweep(mycobot, scaling=1.0)
    over = TimedTrajectory(traj.joint_names, traj.times, traj.positions, traj.velocities * 1.0,
                           traj.accelerations, interpolation=traj.interpolation)
    limits = mycobot.acceleration_limits[[mycobot.variable_index(n) for n in traj.joint_names]] * 0.98
    for fraction in np.linspace(0.05, 0.95, 19):
        plan = stopping_trajectory(over, traj.duration * fraction, limits)
        assert plan is not None
        # the points, what a controller checks before it accepts a goal
        assert np.all(np.abs(plan.trajectory.accelerations) <= limits * (1 + DEFAULT_LIMIT_TOLERANCE) + 1e-6)
        # and its spline between them, near the limits at worst
        q, qd, qdd = plan.trajectory.sample(np.linspace(0.0, plan.trajectory.duration, 400))
        assert np.all(np.abs(qdd) <= limits * 1.1), fraction
