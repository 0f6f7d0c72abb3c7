"""Hybrid planning's ROS-free logic: the planner logic state machines (MoveIt's
SinglePlanExecution and ReplanInvalidatedTrajectory) and the local planner's loop
(SimpleSampler + ForwardTrajectory) driving a simulated arm."""
from __future__ import annotations

import numpy as np
import pytest

from interfaces_py.msgs import CollisionObject, JointTrajectory, MoveItErrorCode, Pose
from mycobot_planning.core.hybrid_planning import (
    ForwardTrajectory,
    HybridPlanningAction as A,
    HybridPlanningEvent as E,
    LocalFeedback,
    ReplanInvalidatedTrajectory,
    SimpleSampler,
    SinglePlanExecution,
    StuckDetector,
    planner_logic,
)
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.core.robot_trajectory.robot_trajectory import TimedTrajectory
from mycobot_planning.core.trajectory_processing.time_parameterization import time_parameterize

START = np.array([0.0, -0.8, -0.8, 0.0, 0.0, 0.0])
GOAL = np.array([1.2, -0.8, -0.8, 0.0, 0.0, 0.0])
PERIOD = 0.01


# ------------------------------------------------------------------------ planner logic
@pytest.mark.parametrize("name", ["moveit::hybrid_planning/SinglePlanExecution",
                                  "moveit_hybrid_planning/SinglePlanExecution", "SinglePlanExecution"])
def test_moveits_plugin_names_select_the_logic(name):
    assert type(planner_logic(name)) is SinglePlanExecution
    assert type(planner_logic(name.replace("SinglePlanExecution", "ReplanInvalidatedTrajectory"))) \
        is ReplanInvalidatedTrajectory


def test_an_unknown_logic_is_refused_naming_the_known_ones():
    with pytest.raises(ValueError, match="ReplanInvalidatedTrajectory"):
        planner_logic("moveit::hybrid_planning/Whatever")


def test_single_plan_execution_plans_once_then_follows_the_plan():
    logic = SinglePlanExecution()
    assert logic.react(E.HYBRID_PLANNING_REQUEST_RECEIVED).action is A.SEND_GLOBAL_SOLVER_REQUEST
    assert logic.react(E.GLOBAL_SOLUTION_AVAILABLE).action is A.DO_NOTHING
    assert logic.react(E.GLOBAL_PLANNING_ACTION_SUCCESSFUL).action is A.SEND_LOCAL_SOLVER_REQUEST
    assert logic.react(E.GLOBAL_PLANNING_ACTION_SUCCESSFUL).action is A.DO_NOTHING  # never a second local planner
    assert logic.react_to_feedback(LocalFeedback.COLLISION_AHEAD).action is A.DO_NOTHING
    assert logic.react(E.LOCAL_PLANNING_ACTION_SUCCESSFUL).action is A.RETURN_HP_SUCCESS


@pytest.mark.parametrize("event, source", [(E.GLOBAL_PLANNING_ACTION_ABORTED, "Global"),
                                           (E.GLOBAL_PLANNING_ACTION_REJECTED, "Global"),
                                           (E.LOCAL_PLANNING_ACTION_ABORTED, "Local"),
                                           (E.LOCAL_PLANNING_ACTION_REJECTED, "Local")])
def test_a_failed_planner_fails_the_run_with_planning_failed(event, source):
    reaction = ReplanInvalidatedTrajectory().react(event)
    assert reaction.action is A.RETURN_HP_FAILURE
    assert reaction.error_code == MoveItErrorCode.PLANNING_FAILED
    assert reaction.message.startswith(f"{source} planner failed")


@pytest.mark.parametrize("feedback", [LocalFeedback.COLLISION_AHEAD, LocalFeedback.LOCAL_PLANNER_STUCK])
def test_replan_invalidated_trajectory_replans_on_collision_or_stuck(feedback):
    logic = ReplanInvalidatedTrajectory()
    logic.react(E.HYBRID_PLANNING_REQUEST_RECEIVED)
    logic.react(E.GLOBAL_PLANNING_ACTION_SUCCESSFUL)
    assert logic.react_to_feedback(feedback).action is A.SEND_GLOBAL_SOLVER_REQUEST
    assert logic.react(E.GLOBAL_PLANNING_ACTION_SUCCESSFUL).action is A.DO_NOTHING  # the local planner follows on
    assert logic.react_to_feedback("something else").action is A.DO_NOTHING


# ------------------------------------------------------------------------ local planner
def global_trajectory(mycobot, start=START, goal=GOAL, scaling=0.3) -> TimedTrajectory:
    names = list(mycobot.group("arm").joint_names)
    index = [mycobot.variable_index(n) for n in names]
    return time_parameterize(np.array([start, goal]), mycobot.velocity_limits[index],
                             mycobot.acceleration_limits[index], velocity_scaling=scaling,
                             acceleration_scaling=scaling, joint_names=names, sample_period=PERIOD)


class SimulatedArm:
    """A position-controlled arm that follows each command's points from where it is (linear
    between the points), as a JointTrajectoryController does with a new goal; an empty
    trajectory stops it where it is."""

    def __init__(self, names, q):
        self.names = list(names)
        self.q = np.array(q, dtype=float)
        self.command: tuple[float, np.ndarray, np.ndarray] | None = None
        self.commands: list[JointTrajectory] = []
        self.lead_in_speeds: list[np.ndarray] = []

    def send(self, cmd: JointTrajectory, now: float) -> None:
        self.commands.append(cmd)
        if len(cmd.points) == 1:  # the speed the controller is asked for to get there from where it is
            self.lead_in_speeds.append(np.abs(np.array(cmd.points[0].positions) - self.q) / cmd.points[0].time_from_start)
        if not cmd.points:
            self.command = None
            return
        times = np.array([0.0] + [p.time_from_start for p in cmd.points]) + now
        points = np.vstack([self.q] + [p.positions for p in cmd.points])
        self.command = (now, times, points)

    def advance(self, now: float) -> None:
        if self.command is not None:
            _, times, points = self.command
            self.q = np.array([np.interp(now, times, points[:, j]) for j in range(len(self.names))])

    def joints(self) -> dict[str, float]:
        return dict(zip(self.names, self.q))


def run(solver: ForwardTrajectory, arm: SimulatedArm, scene=None, seconds=10.0, on_step=None):
    feedback, now = [], 0.0
    while now < seconds:
        arm.advance(now)
        if on_step is not None:
            on_step(now, arm)
        out = solver.step(arm.joints(), now, scene)
        if out.feedback:
            feedback.append((now, out.feedback))
        if out.done:
            return True, feedback, now
        if out.trajectory is not None:
            arm.send(out.trajectory, now)
        now += PERIOD
    return False, feedback, now


def test_the_sampler_waits_for_an_arm_that_lags_behind(mycobot):
    sampler = SimpleSampler(global_trajectory(mycobot))
    assert sampler.advance(START, 1.0) and sampler.time == pytest.approx(1.0)
    assert not sampler.advance(START, 0.5)  # the arm has not followed: the reference waits
    assert sampler.advance(sampler.reference()[0] + 0.03, 100.0) and sampler.at_end


def test_the_stuck_detector_fires_after_five_still_iterations():
    detector = StuckDetector()
    assert [detector.update(m) for m in (1e-5,) * 4] == [False] * 4
    assert detector.update(1e-3) is False  # moving resets the count
    assert [detector.update(0.0) for _ in range(5)] == [False] * 4 + [True]


def test_the_local_planner_brings_the_arm_to_the_goal_within_the_velocity_limits(mycobot):
    trajectory = global_trajectory(mycobot)
    solver = ForwardTrajectory(mycobot, trajectory, PERIOD)
    arm = SimulatedArm(solver.joint_names, START)
    done, feedback, took = run(solver, arm, PlanningScene(mycobot))
    assert done and feedback == []
    assert np.max(np.abs(arm.q - GOAL)) <= 0.01
    assert took < trajectory.duration + 0.5  # it keeps the global trajectory's pace
    assert all(len(cmd.points) == 1 for cmd in arm.commands)
    assert np.all(np.array(arm.lead_in_speeds) <= solver.velocity_limits)


def test_at_full_speed_the_arm_keeps_the_global_trajectorys_pace(mycobot):
    start, goal = np.array(START), np.array([1.5, 0.5, 0.7, -1.0, 1.2, 0.8])
    trajectory = global_trajectory(mycobot, start, goal, scaling=1.0)
    solver = ForwardTrajectory(mycobot, trajectory, PERIOD)
    arm = SimulatedArm(solver.joint_names, start)
    done, feedback, took = run(solver, arm, PlanningScene(mycobot))
    assert done and feedback == []
    # the arm follows `lead` behind the reference, so the gate measures to where the reference was
    assert took < trajectory.duration + 2 * solver.lead
    assert np.all(np.array(arm.lead_in_speeds) <= solver.velocity_limits)


def box_on_the_path(mycobot, solver: ForwardTrajectory, fraction: float) -> CollisionObject:
    q, _, _ = solver.timed.sample(solver.timed.duration * fraction)
    state = RobotState(mycobot)
    state.set_joint_positions(dict(zip(solver.joint_names, q)))
    where = state.frame_pose("link6_flange")[:3, 3]
    return CollisionObject.box("box", [0.04] * 3, Pose.from_matrix(np.block([[np.eye(3), where[:, None]],
                                                                             [np.zeros((1, 3)), np.ones((1, 1))]])))


def test_a_box_on_the_path_ahead_stops_the_arm_before_it_and_reports_once(mycobot):
    solver = ForwardTrajectory(mycobot, global_trajectory(mycobot), PERIOD)
    arm = SimulatedArm(solver.joint_names, START)
    scene = PlanningScene(mycobot)
    box = box_on_the_path(mycobot, solver, 0.8)

    def add_box(now, _arm):
        if abs(now - 0.5) < PERIOD / 2:
            scene.add_object(box)
            solver.scene_changed()

    done, feedback, _ = run(solver, arm, scene, seconds=4.0, on_step=add_box)
    assert not done and [f for _, f in feedback][:1] == [LocalFeedback.COLLISION_AHEAD]
    assert feedback.count((feedback[0][0], LocalFeedback.COLLISION_AHEAD)) == 1
    assert solver.holding and solver.collision is not None
    state = RobotState(mycobot)
    state.set_joint_positions(arm.joints())
    assert not scene.is_state_colliding(state)  # held short of the box
    stop = arm.commands[-1]
    assert len(stop.points) > 1 and stop.points[-1].velocities == pytest.approx([0.0] * 6)
    # the stuck detector stays quiet while the arm is held
    assert LocalFeedback.LOCAL_PLANNER_STUCK not in [f for _, f in feedback]

    # the box goes away: the motion goes on to the goal
    scene.remove_object("box")
    solver.scene_changed()
    done, _, _ = run(solver, arm, scene)
    assert done and np.max(np.abs(arm.q - GOAL)) <= 0.01


def test_an_arm_that_does_not_follow_makes_the_local_planner_stuck(mycobot):
    solver = ForwardTrajectory(mycobot, global_trajectory(mycobot), PERIOD)
    arm = SimulatedArm(solver.joint_names, START)
    arm.send = lambda cmd, now: None  # the controller ignores every command
    done, feedback, _ = run(solver, arm, seconds=1.5)
    assert not done and feedback and feedback[0][1] == LocalFeedback.LOCAL_PLANNER_STUCK
    assert feedback[0][0] >= 1.0  # a resting arm counts only after the start-up grace


def test_a_cancel_stops_the_arm_along_its_path(mycobot):
    solver = ForwardTrajectory(mycobot, global_trajectory(mycobot), PERIOD)
    arm = SimulatedArm(solver.joint_names, START)
    run(solver, arm, seconds=0.8)
    stop = solver.stop(arm.joints())
    assert stop is not None and len(stop.points) > 1
    assert stop.points[-1].velocities == pytest.approx([0.0] * 6)
    assert solver.stop(arm.joints()) is None  # held already
    assert solver.holding
