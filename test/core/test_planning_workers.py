"""Planning in worker processes (core/planning_interface/planning_workers.py): the same answers as
the in-process pipeline, plans stopped from the caller, parameter changes carried over, what the
workers lack planned at home, a dead worker replaced."""
from __future__ import annotations

import dataclasses
import multiprocessing
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from interfaces_py.msgs import CollisionObject, MoveItErrorCode
from mycobot_planning.core import PlanningScene, RobotState
from mycobot_planning.core.planners.joint_interpolation import JointInterpolationPlanner
from mycobot_planning.core.planning_interface.planner_manager import register_planner, unregister_planner
from mycobot_planning.core.planning_interface.planning_context import PlanningContext
from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest, PoseGoal
from mycobot_planning.core.planning_interface.planning_workers import PlanningSetup, PlanningWorkers
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory
from mycobot_planning.core.transforms import make_pose

READY_TIMEOUT = 120.0
GOAL = [1.0, -1.0, -0.8, 0.3, 0.5, 0.8]


@pytest.fixture(scope="module")
def setup():
    return PlanningSetup()


@pytest.fixture(scope="module")
def workers(setup):
    model, pipeline = setup()
    pool = PlanningWorkers(pipeline, setup, 2)
    assert pool.wait_ready(READY_TIMEOUT), "the planning workers did not start"
    yield pool
    pool.close()


def _box_scene(model) -> PlanningScene:
    scene = PlanningScene(model)
    scene.add_object(CollisionObject.box("box", [0.05, 0.05, 0.05], make_pose([0.0, 0.15, 0.25])))
    return scene


def _requests(scene: PlanningScene) -> list[MotionPlanRequest]:
    start = scene.current_state.copy()
    tip = start.frame_pose("link6_flange") if start.model.has_link("link6_flange") else None
    pose = (tip if tip is not None else start.frame_pose(start.model.group("arm").tip_link)) @ make_pose([0.0, 0.03, 0.03])
    return [
        MotionPlanRequest("arm", JointGoal(GOAL), start_state=start, pipeline_id="ompl", seed=1,
                          num_planning_attempts=3),
        MotionPlanRequest("arm", PoseGoal(pose), start_state=start, pipeline_id="ompl", seed=2),
        MotionPlanRequest("arm", JointGoal([0.5, 0.2, 0.3, -0.2, 0.1, 0.2]), start_state=start,
                          pipeline_id="pilz_industrial_motion_planner", planner_id="PTP"),
        MotionPlanRequest("arm", JointGoal([0.4, -0.3, 0.2, 0.1, 0.3, -0.2]), start_state=start,
                          pipeline_id="stomp", seed=4),
    ]


def test_workers_answer_as_the_pipeline_does_with_four_plans_at_once(workers: PlanningWorkers):
    """Four seeded requests of four planners, sent at once from four threads to two workers:
    each path is the one the in-process pipeline plans, and valid in the caller's scene."""
    model = PlanningSetup().robot_model()
    scene = _box_scene(model)
    requests = _requests(scene)
    local = [workers.pipeline.plan(scene.copy(), r) for r in requests]
    answers: list = [None] * len(requests)

    def run(k: int) -> None:
        answers[k] = PlanningContext(workers, scene.copy(), requests[k]).solve()

    threads = [threading.Thread(target=run, args=(k,)) for k in range(len(requests))]
    for t in threads:
        t.start()
    for t in threads:
        t.join(120.0)
    for request, mine, theirs in zip(requests, local, answers):
        label = f"{request.pipeline_id}/{request.planner_id or 'default'}"
        assert mine.success and theirs is not None and theirs.success, (label, mine.error_code, theirs)
        np.testing.assert_allclose(theirs.trajectory.positions, mine.trajectory.positions, atol=1e-12, err_msg=label)
        assert theirs.start_state is request.start_state
        report = validate_trajectory(scene, theirs.trajectory, "arm", request.start_state)
        assert report.valid, (label, report.problems)


def test_a_changed_scene_reaches_the_workers(workers: PlanningWorkers):
    """The workers rebuild their scene when the caller's world changes: a box on the straight
    path makes the joint interpolation's answer a collision failure there too."""
    model = PlanningSetup().robot_model()
    scene = PlanningScene(model)
    start = scene.current_state.copy()
    request = MotionPlanRequest("arm", JointGoal(GOAL), start_state=start, pipeline_id="joint_interpolation")
    assert workers.plan(scene.copy(), request).success
    middle = scene.current_state.copy()
    positions = middle.positions
    positions[model.group("arm").variable_indices] = np.asarray(GOAL) / 2
    middle = RobotState(model, positions)
    tip = middle.frame_pose(model.group("arm").tip_link)
    scene.add_object(CollisionObject.box("in_the_way", [0.06, 0.06, 0.06], tip))
    local = workers.pipeline.plan(scene.copy(), request)
    remote = workers.plan(scene.copy(), request)
    assert not local.success
    assert remote.error_code.val == local.error_code.val, (remote.error_code, local.error_code)
    # the caller keeps the last world's message while the world stays (a copy shares it); a
    # change of the world (here back to the empty one) is sent again
    token = scene.content_token
    assert scene.copy().content_token is token
    assert not workers.plan(scene.copy(), request).success
    scene.remove_object("in_the_way")
    assert scene.content_token is not token
    assert workers.plan(scene.copy(), request).success


def test_planner_parameter_changes_reach_the_workers(workers: PlanningWorkers):
    """set_planner_params on the caller's pipeline, passed on by parameters_changed: the workers
    plan with the new STOMP parameters (the path equals the local one, which differs from the
    path with the defaults)."""
    model = PlanningSetup().robot_model()
    scene = PlanningScene(model)
    request = MotionPlanRequest("arm", JointGoal([0.4, -0.3, 0.2, 0.1, 0.3, -0.2]),
                                start_state=scene.current_state.copy(), pipeline_id="stomp", seed=9)
    before = workers.plan(scene.copy(), request)
    stomp = workers.pipeline.manager("stomp")
    defaults = stomp.planner_params("STOMP")
    change = {"num_timesteps": "25"}
    try:
        assert stomp.set_planner_params("STOMP", change) is None
        workers.parameters_changed("stomp", "STOMP", change, False)
        local = workers.pipeline.plan(scene.copy(), request)
        remote = workers.plan(scene.copy(), request)
    finally:
        stomp.set_planner_params("STOMP", defaults)
        workers.parameters_changed("stomp", "STOMP", defaults, False)
    assert before.success and local.success and remote.success
    np.testing.assert_allclose(remote.path, local.path, atol=1e-12)
    assert remote.path.shape != before.path.shape or not np.allclose(remote.path, before.path)


def _long_request(scene: PlanningScene, allowed: float) -> MotionPlanRequest:
    """A plan that runs for most of ``allowed``: 1000 attempts around the box, MoveIt's
    num_planning_attempts keeping the shortest, so only a stop ends it early."""
    return MotionPlanRequest("arm", JointGoal(GOAL), start_state=scene.current_state.copy(), pipeline_id="ompl",
                             allowed_planning_time=allowed, num_planning_attempts=1000, seed=1)


def test_a_terminated_context_stops_the_workers_plan(workers: PlanningWorkers):
    """terminate() in the caller ends the worker's running plan: PREEMPTED, as in process."""
    scene = _box_scene(PlanningSetup().robot_model())
    context = PlanningContext(workers, scene, _long_request(scene, 120.0))
    timer = threading.Timer(0.5, context.terminate)
    timer.start()
    response = context.solve()
    timer.cancel()
    assert response.error_code.val == MoveItErrorCode.PREEMPTED, response.error_code


def test_a_planner_the_workers_lack_plans_in_the_calling_process(setup):
    """A planner registered at run time exists only where it was registered: its requests are
    planned by the caller's own pipeline."""

    class Straight(JointInterpolationPlanner):
        pipeline_id = "straight_here_only"

    register_planner("straight_here_only", lambda settings: Straight())
    try:
        model, pipeline = setup()
        pool = PlanningWorkers(pipeline, setup, 1)
        try:
            assert pool.wait_ready(READY_TIMEOUT)
            scene = PlanningScene(model)
            request = MotionPlanRequest("arm", JointGoal([0.2, 0.1, 0.0, 0.0, 0.0, 0.0]),
                                        start_state=scene.current_state.copy(), pipeline_id="straight_here_only")
            response = pool.plan(scene, request)
            assert response.success, response.error_code
        finally:
            pool.close()
    finally:
        unregister_planner("straight_here_only")


def test_a_worker_that_dies_is_replaced_and_its_request_fails_clearly(setup):
    model, pipeline = setup()
    others = {p.pid for p in multiprocessing.active_children()}  # the module's workers: not this test's to kill
    pool = PlanningWorkers(pipeline, setup, 1)
    try:
        assert pool.wait_ready(READY_TIMEOUT)
        before = {p.pid for p in multiprocessing.active_children()} - others
        assert len(before) == 1, before
        scene = _box_scene(model)
        request = _long_request(scene, 120.0)

        def kill_worker() -> None:
            for pid in before:
                os.kill(pid, signal.SIGKILL)

        timer = threading.Timer(0.5, kill_worker)
        timer.start()
        response = pool.plan(scene, request)
        timer.cancel()
        assert response.error_code.val == MoveItErrorCode.FAILURE
        assert "worker process ended" in response.error_code.message
        assert pool.wait_ready(READY_TIMEOUT), "no new worker after the old one died"
        free = PlanningScene(model)
        again = pool.plan(free, MotionPlanRequest("arm", JointGoal([0.2, 0.1, 0.0, 0.0, 0.0, 0.0]),
                                                 start_state=free.current_state.copy(), pipeline_id="ompl", seed=1))
        assert again.success, again.error_code
        assert not before & {p.pid for p in multiprocessing.active_children()}
    finally:
        pool.close()


def test_workers_refuse_a_count_below_one(setup):
    model, pipeline = setup()
    with pytest.raises(ValueError, match="at least 1"):
        PlanningWorkers(pipeline, setup, 0)


_ORPHAN_SCRIPT = """
import multiprocessing, sys, time
from mycobot_planning.core.planning_interface.planning_workers import PlanningSetup, PlanningWorkers
if __name__ == "__main__":
    setup = PlanningSetup()
    pool = PlanningWorkers(setup.planning_pipeline(), setup, 2)
    assert pool.wait_ready(120.0)
    print(" ".join(str(p.pid) for p in multiprocessing.active_children()), flush=True)
    time.sleep(600)
"""


def test_workers_exit_when_their_server_is_killed(tmp_path):
    """SIGKILL runs no clean-up in the server: its workers notice and exit (no orphans)."""
    script = tmp_path / "server.py"
    script.write_text(_ORPHAN_SCRIPT)
    server = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True,
                              env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))
    try:
        pids = [int(p) for p in server.stdout.readline().split()]
        assert len(pids) >= 2, pids
    finally:
        server.kill()
        server.wait(10)

    def alive(pid: int) -> bool:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        return True

    deadline = time.monotonic() + 20.0
    while any(alive(pid) for pid in pids) and time.monotonic() < deadline:
        time.sleep(0.1)
    left = [pid for pid in pids if alive(pid)]
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    assert not left, f"worker processes {left} outlived their killed server"


def test_split_attempts_cuts_consecutive_runs():
    from mycobot_planning.core.planning_interface.planning_workers import split_attempts

    assert split_attempts(4, 2) == [(0, 2), (2, 2)]
    assert split_attempts(5, 2) == [(0, 3), (3, 2)]
    assert split_attempts(2, 8) == [(0, 1), (1, 1)]
    assert split_attempts(7, 1) == [(0, 7)]
    for attempts in range(1, 12):
        for parts in range(1, 6):
            runs = split_attempts(attempts, parts)
            assert [first for first, _ in runs] == list(np.cumsum([0] + [n for _, n in runs])[:-1])
            assert sum(n for _, n in runs) == attempts and min(n for _, n in runs) >= 1


def test_best_of_attempts_keeps_the_shortest_and_the_earlier_on_ties():
    from mycobot_planning.core.planning_interface.planning_interface import MotionPlanResponse
    from mycobot_planning.core.planning_interface.planning_workers import best_of_attempts

    def solved(length: float, time: float) -> MotionPlanResponse:
        return MotionPlanResponse(MoveItErrorCode(MoveItErrorCode.SUCCESS, f"{length}"), trajectory=object(),
                                  planning_time=time, path=np.array([[0.0, 0.0], [length, 0.0]]))

    failed = MotionPlanResponse(MoveItErrorCode(MoveItErrorCode.PLANNING_FAILED, "no"), planning_time=0.4)
    best = best_of_attempts([solved(2.0, 0.1), solved(1.0, 0.2), solved(1.0, 0.3), failed])
    assert best.error_code.message == "1.0" and best.planning_time == 0.4
    assert best is not None and best_of_attempts([failed, solved(3.0, 0.1)]).error_code.message == "3.0"
    timed_out = MotionPlanResponse(MoveItErrorCode(MoveItErrorCode.TIMED_OUT, "late"), planning_time=0.5)
    assert best_of_attempts([failed, timed_out]).error_code.val == MoveItErrorCode.TIMED_OUT


def test_attempts_split_between_idle_workers_give_the_single_process_answer(workers: PlanningWorkers, monkeypatch):
    """A seeded request of 6 OMPL attempts around the box (and one of a pose goal, whose IK goals
    come from the seed too) goes to both idle workers, 3 attempts each: the answer is the path
    the in-process pipeline plans with all 6."""
    model = PlanningSetup().robot_model()
    scene = _box_scene(model)
    joint, pose = _requests(scene)[:2]
    sent = []
    pool = workers._pool
    submit = pool.submit

    def counted(fn, slot, key, msg, positions, request, changes):
        sent.append((request.first_attempt, request.num_planning_attempts))
        return submit(fn, slot, key, msg, positions, request, changes)

    monkeypatch.setattr(pool, "submit", counted)
    for request in (dataclasses.replace(joint, num_planning_attempts=6), dataclasses.replace(pose, num_planning_attempts=4)):
        sent.clear()
        local = workers.pipeline.plan(scene.copy(), request)
        remote = workers.plan(scene.copy(), request)
        assert sorted(sent) == [(0, request.num_planning_attempts // 2),
                                (request.num_planning_attempts // 2, request.num_planning_attempts // 2)], sent
        assert local.success and remote.success, (local.error_code, remote.error_code)
        np.testing.assert_allclose(remote.path, local.path, atol=1e-12)
        np.testing.assert_allclose(remote.trajectory.positions, local.trajectory.positions, atol=1e-12)
    workers.parallel_attempts = False
    try:
        sent.clear()
        assert workers.plan(scene.copy(), dataclasses.replace(joint, num_planning_attempts=6)).success
        assert sent == [(0, 6)]
    finally:
        workers.parallel_attempts = True
