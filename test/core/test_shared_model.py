"""One RobotModel shared by every thread, the data per computation (Pinocchio's model/data split).

Threads switch every microsecond in these tests (sys.setswitchinterval), so a buffer two threads
shared would be overwritten between one thread's kinematics call and its read of the result:
each answer must equal the one computed alone, in one thread."""
from __future__ import annotations

import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager

import numpy as np
import pytest

from interfaces_py.msgs import CollisionObject, MoveItErrorCode
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.kinematics import ik_solver
from mycobot_planning.core.kinematics.ik_solver import IKSolver, thread_ik_solver
from mycobot_planning.core.planners.cartesian.cartesian_path import compute_cartesian_path
from mycobot_planning.core.planning_interface.planning_context import PlanningContext
from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest, PoseGoal
from mycobot_planning.core.planning_interface.planning_pipeline import PlanningPipeline
from mycobot_planning.core.transforms import make_pose
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory

THREADS = 8


@contextmanager
def _switch_often():
    before = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        yield
    finally:
        sys.setswitchinterval(before)


def _in_threads(count: int, work) -> list:
    """work(k) for k in range(count), each in its own thread, all started together."""
    barrier = threading.Barrier(count)

    def run(k: int):
        barrier.wait(30.0)
        return work(k)

    with _switch_often(), ThreadPoolExecutor(count) as pool:
        return list(pool.map(run, range(count)))


def _table_scene(model: RobotModel) -> PlanningScene:
    scene = PlanningScene(model)
    scene.add_object(CollisionObject.box("table", [0.6, 1.2, 0.04], make_pose([0.55, 0.0, 0.2])))
    return scene


def _valid_states(scene: PlanningScene, group: str, count: int, seed: int) -> list[RobotState]:
    model = scene.robot_model
    jmg = model.group(group)
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count:
        state = RobotState(model)
        positions = state.positions
        positions[jmg.variable_indices] = rng.uniform(model.lower_limits[jmg.variable_indices],
                                                      model.upper_limits[jmg.variable_indices])
        state = RobotState(model, positions)
        if scene.is_state_valid(state):
            out.append(state)
    return out


# ---------------------------------------------------------------------------- four plans at once
@pytest.fixture(scope="module")
def moveit_panda() -> RobotModel:
    """The Panda as panda_moveit_config names it, with its joint limits (the industrial planner's
    LIN needs the real acceleration limits)."""
    return RobotModel.panda()


def test_four_plans_at_once_on_one_model_are_each_valid(moveit_panda: RobotModel):
    """OMPL (a joint goal and a pose goal), the industrial planner's LIN and joint interpolation,
    four different goals, from four threads at once on one model, one pipeline and copies of one
    scene: each trajectory reaches its goal and passes the trajectory validator."""
    scene = _table_scene(moveit_panda)
    pipeline = PlanningPipeline()
    start = RobotState(moveit_panda)
    start.set_named("ready")
    scene.set_current_state(start)
    arm = moveit_panda.group("panda_arm")
    joint_goal = _valid_states(scene, "panda_arm", 1, seed=3)[0]
    pose_goal = start.frame_pose("panda_link8") @ make_pose([0.0, 0.1, -0.05])
    lin_goal = start.frame_pose("panda_link8") @ make_pose([0.05, -0.05, 0.05])
    small = start.positions[arm.variable_indices] + np.array([0.3, -0.2, 0.2, 0.3, -0.2, 0.3, 0.2])
    requests = [
        MotionPlanRequest("panda_arm", JointGoal(joint_goal.positions[arm.variable_indices]), start_state=start,
                          pipeline_id="ompl", planner_id="RRTConnectkConfigDefault", seed=1),
        MotionPlanRequest("panda_arm", PoseGoal(pose_goal, link="panda_link8"), start_state=start,
                          pipeline_id="ompl", seed=2),
        MotionPlanRequest("panda_arm", PoseGoal(lin_goal, link="panda_link8"), start_state=start,
                          pipeline_id="pilz_industrial_motion_planner", planner_id="LIN",
                          max_velocity_scaling_factor=0.1, max_acceleration_scaling_factor=0.1),
        MotionPlanRequest("panda_arm", JointGoal(small), start_state=start, pipeline_id="joint_interpolation"),
    ]
    contexts = [PlanningContext(pipeline, scene.copy(), request) for request in requests]
    responses = _in_threads(len(contexts), lambda k: contexts[k].solve())
    for request, response in zip(requests, responses):
        label = f"{request.pipeline_id}/{request.planner_id or 'default'}"
        assert response.success, (label, response.error_code)
        trajectory = response.trajectory
        report = validate_trajectory(scene, trajectory, "panda_arm", start)
        assert report.valid, (label, report.problems)
        end = start.copy()
        positions = end.positions
        positions[arm.variable_indices] = trajectory.positions[-1]
        end = RobotState(moveit_panda, positions)
        if isinstance(request.goal, JointGoal):
            assert np.allclose(trajectory.positions[-1], request.goal.values, atol=1e-3), label
        else:
            assert np.allclose(end.frame_pose("panda_link8")[:3, 3], request.goal.pose[:3, 3], atol=1e-3), label


def test_a_terminated_context_answers_preempted(mycobot: RobotModel):
    """terminate() from another thread ends a running sampling planner (MoveIt's terminate)."""
    scene = PlanningScene(mycobot)
    scene.add_object(CollisionObject.box("wall", [0.02, 2.0, 2.0], make_pose([0.0, 0.0, 0.0])))  # through the base
    start = RobotState(mycobot)
    request = MotionPlanRequest("arm", JointGoal([1.0, 0.5, 0.5, 0.0, 0.0, 0.0]), start_state=start,
                                pipeline_id="ompl", allowed_planning_time=60.0, seed=1)
    context = PlanningContext(PlanningPipeline(), scene, request)
    timer = threading.Timer(0.5, context.terminate)
    timer.start()
    response = context.solve()
    timer.cancel()
    assert response.error_code.val in (MoveItErrorCode.PREEMPTED, MoveItErrorCode.START_STATE_IN_COLLISION), \
        response.error_code
    context.clear()
    with pytest.raises(RuntimeError, match="cleared"):
        context.solve()


# ---------------------------------------------------------------------------- no shared scratch
@pytest.mark.parametrize("robot", ["mycobot", "panda"])
def test_concurrent_kinematics_match_the_single_threaded_answers(robot: str, request):
    """FK, Jacobians, IK (seeded search and refinement) and Cartesian steps on many threads at
    once give exactly what one thread alone gives."""
    model: RobotModel = request.getfixturevalue(robot)
    group = "arm"
    tip = model.group(group).tip_link
    scene = PlanningScene(model)
    states = _valid_states(scene, group, 12, seed=7)
    targets = [s.frame_pose(tip) for s in states]
    seed = RobotState(model)

    def answers(solver: IKSolver) -> list:
        out = []
        for state, target in zip(states, targets):
            found = solver.solve(target, seed=seed, rng=5, timeout=60.0, attempts=64)
            refined = solver.refine(target, state)
            out.append((state.frame_pose(tip), state.jacobian(tip, group), sorted(state.frame_poses(
                model.link_names).items())[0][1],
                found[0].positions if found else None,
                refined.positions if refined is not None else None))
        return out

    alone = answers(IKSolver(model, group))
    together = _in_threads(THREADS, lambda k: answers(IKSolver(model, group)))
    for result in together:
        for mine, reference in zip(result, alone):
            for a, b in zip(mine, reference):
                if a is None or b is None:
                    assert a is b
                else:
                    np.testing.assert_array_equal(a, b)


def test_a_threads_kept_solver_is_its_own_and_answers_as_a_new_one(mycobot: RobotModel):
    """thread_ik_solver: one solver per thread and arguments, reused there, never shared with
    another thread, and its answers after other queries those of a solver built for the query."""
    group = "arm"
    tip = mycobot.group(group).tip_link
    scene = PlanningScene(mycobot)
    states = _valid_states(scene, group, 8, seed=11)
    seed = RobotState(mycobot)
    offset = make_pose([0.0, 0.0, 0.05])

    def answers(get) -> list:
        out = []
        for state in states:
            target = state.frame_pose(tip)
            found = get(None).solve(target, seed=seed, rng=3, timeout=60.0, attempts=64)
            refined = get(offset).refine(target @ offset, state)
            out.append((found[0].positions if found else None, refined.positions if refined is not None else None))
        return out

    fresh = answers(lambda off: IKSolver(mycobot, group, None, off))
    kept = answers(lambda off: thread_ik_solver(mycobot, group, None, off))
    assert len(kept) == len(fresh) == 8 and all(found is not None for found, _ in fresh)
    for pair, reference in zip(kept, fresh):
        for a, b in zip(pair, reference):
            assert (a is None and b is None) or np.array_equal(a, b)
    assert thread_ik_solver(mycobot, group) is thread_ik_solver(mycobot, group)
    assert thread_ik_solver(mycobot, group, None, offset) is not thread_ik_solver(mycobot, group)
    mine = thread_ik_solver(mycobot, group)
    others = _in_threads(4, lambda k: thread_ik_solver(mycobot, group))
    assert len({id(s) for s in others} | {id(mine)}) == 5
    for k in range(ik_solver.THREAD_SOLVERS_KEPT):  # the least recently used is dropped beyond the bound
        thread_ik_solver(mycobot, group, None, make_pose([0.0, 0.0, 0.001 * (k + 1)]))
    assert thread_ik_solver(mycobot, group) is not mine


def test_concurrent_cartesian_paths_match_the_single_threaded_path(panda: RobotModel):
    scene = PlanningScene(panda)
    start = RobotState(panda)
    start.set_named("default")
    tip = start.frame_pose("panda_link8")
    waypoints = [tip @ make_pose([0.0, 0.0, 0.1]), tip @ make_pose([0.1, 0.05, 0.1])]

    def path(_k: int) -> np.ndarray:
        result = compute_cartesian_path(scene.copy(), "arm", start.copy(), waypoints, link="panda_link8",
                                        eef_step=0.005)
        assert result.fraction == pytest.approx(1.0)
        return np.asarray(result.trajectory.positions)

    alone = path(0)
    for result in _in_threads(4, path):
        np.testing.assert_array_equal(result, alone)


def test_concurrent_collision_queries_on_copies_of_one_scene_match_one_thread(panda: RobotModel):
    """Copies of one scene share its compiled geometry; verdicts, contacts and distances from
    many threads at once are the one-thread answers (each thread checks with its own buffers)."""
    scene = _table_scene(panda)
    jmg = panda.group("arm")
    rng = np.random.default_rng(11)
    rows = rng.uniform(panda.lower_limits[jmg.variable_indices], panda.upper_limits[jmg.variable_indices], (300, 7))
    reference = RobotState(panda)

    def answers(k: int) -> tuple:
        local = scene.copy() if k % 2 else scene  # the scene itself and copies, from several threads
        check = local.validity_checker("arm", reference, check_bounds=False)
        verdicts = [check(row) for row in rows]
        batch = local.colliding_rows("arm", reference, rows)
        states = [RobotState(panda, np.concatenate([row, reference.positions[7:]])) for row in rows[:40]]
        contacts = [str(local.check_collision(s, max_contacts=2)) for s in states]
        distances = [local.distance(s).min_distance for s in states]
        return verdicts, list(batch), contacts, distances

    alone = answers(0)
    assert 0 < sum(alone[1]) < len(rows)  # both verdicts occur
    for result in _in_threads(THREADS, answers):
        assert result == alone


# ---------------------------------------------------------------------------- the model is immutable
def test_the_model_refuses_changes_and_holds_no_scratch_data(mycobot: RobotModel):
    assert not hasattr(mycobot, "pin_data")
    with pytest.raises(AttributeError, match="immutable"):
        mycobot.name = "other"
    with pytest.raises(AttributeError, match="immutable"):
        mycobot.lower_limits = np.zeros(7)
    with pytest.raises(AttributeError, match="immutable"):
        del mycobot.root_link
    for array in (mycobot.lower_limits, mycobot.upper_limits, mycobot.velocity_limits,
                  mycobot.acceleration_limits, mycobot.group("arm").variable_indices, mycobot.jacobian_map()):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 0
    with pytest.raises(Exception):  # frozen dataclasses
        mycobot.group("arm").tip_link = "link1"
    with pytest.raises(Exception):
        mycobot.joint("link1_to_link2").lower = 0.0
