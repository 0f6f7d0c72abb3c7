"""The plan and Cartesian path capabilities with the trajectory cache enabled, without ROS
(MoveGroupJsonFace on an idle controller bus, as test_request_budgets): a repeated request is
answered from the cache, started at the actual state, counted in get_state; an obstacle that
appears on a cached path gets the entry refused and a new plan made (never a stale trajectory
into a changed world); a bad database changes nothing."""
from __future__ import annotations

import numpy as np
import pytest

from interfaces_py.msgs import CollisionObject, JointTrajectory, MoveItErrorCode, PlanningScene as PlanningSceneMsg, \
    PlanningSceneWorld
from mycobot_planning.capabilities import plan, trajectory_cache
from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.core.robot_trajectory.robot_trajectory import joint_trajectory_to_timed
from mycobot_planning.core.trajectory_cache import TrajectoryCacheError
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory
from mycobot_planning.core.transforms import make_pose, matrix_to_quat
from test_request_budgets import ARM, _core

GOAL = [1.0, -1.0, -0.8, 0.3, 0.5, 0.8]
REQUEST = {"group": "arm", "goal": {"joints": GOAL}, "seed": 3}


@pytest.fixture()
def core(mycobot, pipeline):
    core = _core(mycobot, pipeline)
    trajectory_cache.configure(core, trajectory_cache.TrajectoryCacheSettings(enabled=True))
    return core


def _timed(result):
    return joint_trajectory_to_timed(_msg(result))


def _msg(result):
    return JointTrajectory.from_dict(result["trajectory"]["joint_trajectory"])


def _ok(result) -> bool:
    return result["error_code"]["val"] == MoveItErrorCode.SUCCESS


def _status(core) -> dict:
    return core.get_state()["trajectory_cache"]


def test_disabled_by_default(mycobot, pipeline):
    core = _core(mycobot, pipeline)
    assert core.get_state()["trajectory_cache"] == {"enabled": False}
    result = core.plan(REQUEST)
    assert _ok(result) and "trajectory_cache" not in result


def test_a_repeated_request_is_answered_from_the_cache(core):
    first = core.plan(REQUEST)
    assert _ok(first) and first["trajectory_cache"] == "miss"
    second = core.plan(REQUEST)
    assert _ok(second) and second["trajectory_cache"] == "hit"
    assert second["error_code"]["source"] == "trajectory_cache"
    assert second["planner_id"] == first["planner_id"]
    np.testing.assert_allclose(_msg(second).points[-1].positions, GOAL, atol=1e-4)
    status = _status(core)
    assert (status["hits"], status["misses"], status["inserted"], status["entries"]) == (1, 1, 1, 1)
    assert status["enabled"] and status["db_path"] == ":memory:" and status["cache_namespace"] == "mycobot_280"
    # the hit became the last plan: execute() would run it
    assert core.last_plan is not None and core.last_plan[1] == "arm"


def test_a_hit_starts_at_the_actual_state(core, mycobot):
    assert _ok(core.plan(REQUEST))
    names = list(mycobot.variable_names)
    actual = [0.006, -0.004, 0.0, 0.003, 0.0, 0.0, 0.0]  # within start_tolerance / 2 of the cached start
    assert core.update_joint_state(names, actual) is None
    result = core.plan(REQUEST)
    assert result["trajectory_cache"] == "hit"
    np.testing.assert_allclose(_msg(result).points[0].positions, actual[:6], atol=1e-9)
    state = RobotState(mycobot)
    state.set_joint_positions(dict(zip(names, actual)))
    assert validate_trajectory(core.scene_copy(), _timed(result), "arm", state).valid
    # outside the start tolerance: a miss, planned from there
    far = [0.05, 0, 0, 0, 0, 0, 0]
    assert core.update_joint_state(names, far) is None
    assert core.plan(REQUEST)["trajectory_cache"] == "miss"


def _blocker_on(core, mycobot, result) -> CollisionObject:
    """A small box around the flange halfway along ``result``'s trajectory (clear of its ends)."""
    trajectory = _timed(result)
    q, _, _ = trajectory.sample(trajectory.duration / 2)
    state = RobotState(mycobot)
    state.set_joint_positions(dict(zip(ARM, q)))
    position = state.frame_pose("link6_flange")[:3, 3]
    return CollisionObject.box("blocker", [0.03, 0.03, 0.03], make_pose(list(position)))


def test_an_obstacle_on_a_cached_path_gets_the_entry_refused_and_a_new_plan(core, mycobot):
    first = core.plan(REQUEST)
    assert first["trajectory_cache"] == "miss"
    core.apply_collision_objects([_blocker_on(core, mycobot, first).to_dict()])
    scene = core.scene_copy()
    start = scene.current_state.copy()
    assert not validate_trajectory(scene, _timed(first), "arm", start).valid  # the cached path is blocked now
    second = core.plan(REQUEST)
    assert _ok(second), second["error_code"]
    assert second["trajectory_cache"] == "miss"  # the entry was refused, a new plan made
    assert validate_trajectory(scene, _timed(second), "arm", start).valid
    status = _status(core)
    assert (status["refused"], status["hits"], status["misses"]) == (1, 0, 2)
    # the new plan went in (a new entry beside the refused one, or in its place); asked again,
    # the entry valid in this world answers
    third = core.plan(REQUEST)
    assert third["trajectory_cache"] == "hit"
    assert validate_trajectory(scene, _timed(third), "arm", start).valid
    # the obstacle gone, entries are valid again: a hit, not a plan
    core.apply_planning_scene({"is_diff": True, "world": {"collision_objects": [
        {"id": "blocker", "operation": CollisionObject.REMOVE}]}})
    assert core.plan(REQUEST)["trajectory_cache"] == "hit"


def test_a_scene_diff_of_the_request_is_the_world_a_hit_is_checked_in(core, mycobot):
    first = core.plan(REQUEST)
    blocker = _blocker_on(core, mycobot, first)
    diff = PlanningSceneMsg(world=PlanningSceneWorld(collision_objects=[blocker]), is_diff=True)
    request = MotionPlanRequest("arm", JointGoal(dict(zip(ARM, GOAL)), 1e-4), seed=3)
    result = plan.plan(core, request, scene_diff=diff)
    assert result.trajectory_cache == "miss" and _status(core)["refused"] == 1


def test_cartesian_paths_are_cached_too(core, mycobot):
    names = list(mycobot.variable_names)
    start = [0.0, -0.6, -1.2, 0.2, 0.0, 0.0, 0.0]
    assert core.update_joint_state(names, start) is None
    state = RobotState(mycobot)
    state.set_joint_positions(dict(zip(names, start)))
    tip = state.frame_pose("link6_flange")
    target = tip.copy()
    target[2, 3] -= 0.03
    waypoint = [float(v) for v in target[:3, 3]] + [float(v) for v in matrix_to_quat(target[:3, :3])]
    request = {"group": "arm", "waypoints": [waypoint], "eef_step": 0.005}
    first = core.compute_cartesian_path(request)
    assert first["fraction"] == pytest.approx(1.0), first["error_code"]
    assert first["trajectory_cache"] == "miss"
    second = core.compute_cartesian_path(request)
    assert second["trajectory_cache"] == "hit" and second["fraction"] == 1.0 and second["stop_reason"] == "complete"
    status = _status(core)
    assert (status["cartesian_hits"], status["cartesian_misses"], status["cartesian_entries"]) == (1, 1, 1)
    assert status["entries"] == 0
    # a coarser step is served by the finer cached path; a finer one is not
    assert core.compute_cartesian_path({**request, "eef_step": 0.01})["trajectory_cache"] == "hit"
    assert core.compute_cartesian_path({**request, "eef_step": 0.002})["trajectory_cache"] == "miss"
    # avoid_collisions false is never cached
    assert "trajectory_cache" not in core.compute_cartesian_path({**request, "avoid_collisions": False})


def test_a_bad_database_changes_nothing(core, tmp_path):
    bad = tmp_path / "bad.sqlite"
    bad.write_bytes(b"\x00garbage" * 64)
    before = core.trajectory_cache
    with pytest.raises(TrajectoryCacheError, match="not a trajectory cache"):
        trajectory_cache.configure(core, trajectory_cache.TrajectoryCacheSettings(enabled=True, db_path=str(bad)))
    assert core.trajectory_cache is before and _status(core)["db_path"] == ":memory:"
    with pytest.raises(TrajectoryCacheError, match="unknown cache_insert_policy"):
        trajectory_cache.configure(core, trajectory_cache.TrajectoryCacheSettings(cache_insert_policy="Nope"))


def test_settings_change_keeps_the_entries_of_the_same_database(core, tmp_path):
    assert _ok(core.plan(REQUEST))
    kept = trajectory_cache.configure(core, trajectory_cache.TrajectoryCacheSettings(enabled=True, start_tolerance=0.1))
    assert kept.settings.start_tolerance == 0.1 and _status(core)["entries"] == 1
    trajectory_cache.configure(core, trajectory_cache.TrajectoryCacheSettings(enabled=False))
    assert "trajectory_cache" not in core.plan(REQUEST) and _status(core)["enabled"] is False
    path = tmp_path / "c.sqlite"
    trajectory_cache.configure(core, trajectory_cache.TrajectoryCacheSettings(enabled=True, db_path=str(path)))
    assert _status(core)["entries"] == 0 and core.plan(REQUEST)["trajectory_cache"] == "miss"
    assert path.exists()


def test_a_failing_cache_never_fails_a_plan(core):
    assert _ok(core.plan(REQUEST))
    core.trajectory_cache.cache.close()  # every query now fails
    result = core.plan(REQUEST)
    assert _ok(result) and result["trajectory_cache"] == "miss"
    status = _status(core)
    assert "closed" in status["last_problem"] and status["entries"] == -1
