"""core/trajectory_cache (MoveIt's trajectory_cache), ROS-free: keys and fuzzy matching within the
start and goal tolerances, the insert policies, persistence of a file database across reopening,
refusal of corrupt and foreign files, the Cartesian key, stitching a hit to the actual start, and
concurrent use from several threads."""
from __future__ import annotations

import sqlite3
import threading

import numpy as np
import pytest

from mycobot_planning.core.kinematic_constraints.kinematic_constraints import JointPathConstraint, PathConstraints
from mycobot_planning.core.planning_interface.planning_interface import (
    JointGoal,
    MotionPlanRequest,
    NamedGoal,
    PoseGoal,
    time_group_path,
)
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.core.trajectory_cache import (
    AlwaysInsertNeverPrunePolicy,
    BestSeenExecutionTimePolicy,
    CacheValue,
    CartesianBestSeenExecutionTimePolicy,
    GetCartesianPathRequest,
    Options,
    TrajectoryCache,
    TrajectoryCacheError,
    cache_insert_policy,
    cartesian_path_request_features,
    motion_plan_request_features,
    stitch_to_start,
)
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory
from mycobot_planning.core.transforms import make_pose
from mycobot_planning.core.warehouse.robot_state_storage import RobotStateStorage

GOAL = np.array([1.0, -1.0, -0.8, 0.3, 0.5, 0.8])
START_TOL, GOAL_TOL = 0.02, 0.002
NS = "mycobot_280"


def _start(model, values=None) -> RobotState:
    state = RobotState(model)
    if values is not None:
        state.set_group_positions("arm", np.asarray(values, dtype=float))
    return state


def _request(model, start=None, goal=GOAL, **kwargs) -> MotionPlanRequest:
    names = model.group("arm").joint_names
    settings = {"pipeline_id": "ompl", "planner_id": "RRTConnectkConfigDefault", "max_velocity_scaling_factor": 1.0,
                "max_acceleration_scaling_factor": 1.0, **kwargs}
    request = MotionPlanRequest("arm", JointGoal(dict(zip(names, goal)), 1e-4), **settings)
    request.start_state = start if start is not None else _start(model)
    return request


def _trajectory(model, start, goal=GOAL, scaling=1.0):
    return time_group_path(model, model.group("arm"), np.array([start, goal]), scaling, scaling)


def _value(model, start=np.zeros(6), goal=GOAL, scaling=1.0, planning_time=0.05) -> CacheValue:
    return CacheValue(_trajectory(model, start, goal, scaling), planning_time, 1.0, "arm[RRTConnectkConfigDefault]")


@pytest.fixture()
def cache():
    c = TrajectoryCache()
    yield c
    c.close()


def _insert(cache, model, request, value, policy=None):
    key = motion_plan_request_features(model, request)
    return cache.insert_trajectory(NS, key, value, policy or BestSeenExecutionTimePolicy())


def _fetch(cache, model, request, start_tol=START_TOL, goal_tol=GOAL_TOL):
    return cache.fetch_all_matching_trajectories(NS, motion_plan_request_features(model, request), start_tol, goal_tol)


# ---------------------------------------------------------------- matching
def test_fetch_matches_within_the_start_and_goal_tolerances_and_not_outside(cache, mycobot):
    inserted, _ = _insert(cache, mycobot, _request(mycobot), _value(mycobot))
    assert inserted and cache.count_trajectories(NS) == 1
    exact = _fetch(cache, mycobot, _request(mycobot))
    assert len(exact) == 1 and exact[0].trajectory is not None
    np.testing.assert_allclose(exact[0].trajectory.positions[-1], GOAL)
    # value in [cached - tol/2, cached + tol/2]: 0.4 tol in, 0.6 tol out, per joint
    near_start = _start(mycobot, [0.4 * START_TOL, 0, 0, -0.4 * START_TOL, 0, 0])
    assert len(_fetch(cache, mycobot, _request(mycobot, near_start))) == 1
    far_start = _start(mycobot, [0.6 * START_TOL, 0, 0, 0, 0, 0])
    assert _fetch(cache, mycobot, _request(mycobot, far_start)) == []
    near_goal = GOAL + np.array([0, 0, 0.4 * GOAL_TOL, 0, 0, 0])
    assert len(_fetch(cache, mycobot, _request(mycobot, goal=near_goal))) == 1
    far_goal = GOAL + np.array([0, 0, 0.6 * GOAL_TOL, 0, 0, 0])
    assert _fetch(cache, mycobot, _request(mycobot, goal=far_goal)) == []
    # the start tolerance does not apply to goals, nor the goal tolerance to starts
    assert _fetch(cache, mycobot, _request(mycobot, goal=far_goal), start_tol=1.0, goal_tol=GOAL_TOL) == []
    assert _fetch(cache, mycobot, _request(mycobot, far_start), start_tol=START_TOL, goal_tol=1.0) == []
    # joints outside the group are part of the start state
    gripper = _start(mycobot)
    gripper.set_joint_positions({"gripper_controller": -0.5})
    assert _fetch(cache, mycobot, _request(mycobot, gripper)) == []


def test_group_planner_scaling_and_path_constraints_are_keys(cache, mycobot):
    _insert(cache, mycobot, _request(mycobot), _value(mycobot, scaling=0.5))
    slower = _request(mycobot, max_velocity_scaling_factor=0.4)
    assert _fetch(cache, mycobot, slower) == []  # planned at 0.5: too fast for a 0.4 request
    faster = _request(mycobot)
    faster.max_velocity_scaling_factor = 0.0  # MoveIt: 0 means 1.0, and 0.5 <= 1.0 serves it
    assert len(_fetch(cache, mycobot, faster)) == 1
    other_planner = _request(mycobot)
    other_planner.pipeline_id, other_planner.planner_id = "pilz_industrial_motion_planner", "PTP"
    assert _fetch(cache, mycobot, other_planner) == []
    constrained = _request(mycobot, path_constraints=PathConstraints(
        joints=(JointPathConstraint("link1_to_link2", 0.5, 1.0, 1.0),)))
    assert _fetch(cache, mycobot, constrained) == []
    assert _fetch(cache, mycobot, _request(mycobot)) != []
    assert cache.fetch_all_matching_trajectories("another_robot", motion_plan_request_features(
        mycobot, _request(mycobot)), START_TOL, GOAL_TOL) == []


def test_a_named_goal_shares_the_entries_of_its_joint_values(cache, mycobot):
    names = mycobot.named_state_names("arm")
    assert names
    values = mycobot.named_state(names[0], "arm")
    goal = np.array([values[n] for n in mycobot.group("arm").joint_names])
    _insert(cache, mycobot, _request(mycobot, goal=goal), _value(mycobot, goal=goal))
    named = _request(mycobot)
    named.goal = NamedGoal(names[0], 1e-4)
    assert len(_fetch(cache, mycobot, named)) == 1


def test_pose_goals_match_on_position_and_orientation(cache, mycobot):
    request = _request(mycobot)
    request.goal = PoseGoal(make_pose([0.15, 0.05, 0.2], rpy=[np.pi, 0, 0]))
    _insert(cache, mycobot, request, _value(mycobot))
    same = _request(mycobot)
    same.goal = PoseGoal(make_pose([0.15, 0.05 + 0.4 * GOAL_TOL, 0.2], rpy=[np.pi, 0, 0]))
    assert len(_fetch(cache, mycobot, same)) == 1
    moved = _request(mycobot)
    moved.goal = PoseGoal(make_pose([0.15, 0.05 + 0.6 * GOAL_TOL, 0.2], rpy=[np.pi, 0, 0]))
    assert _fetch(cache, mycobot, moved) == []
    turned = _request(mycobot)
    turned.goal = PoseGoal(make_pose([0.15, 0.05, 0.2], rpy=[np.pi, 0, 0.1]))
    assert _fetch(cache, mycobot, turned) == []
    other_link = _request(mycobot)
    other_link.goal = PoseGoal(request.goal.pose, link="link5")
    assert _fetch(cache, mycobot, other_link) == []


# ---------------------------------------------------------------- policies
def test_best_seen_execution_time_inserts_only_faster_and_prunes_slower(mycobot):
    cache = TrajectoryCache(Options(num_additional_trajectories_to_preserve_when_pruning_worse=0))
    request = _request(mycobot)
    slow, fast, slower = (_value(mycobot, scaling=s) for s in (0.5, 1.0, 0.3))
    assert slow.execution_time_s > fast.execution_time_s
    assert _insert(cache, mycobot, request, slow)[0]
    inserted, reason = _insert(cache, mycobot, request, slower)
    assert not inserted and "not better" in reason
    assert cache.count_trajectories(NS) == 1
    inserted, reason = _insert(cache, mycobot, request, fast)
    assert inserted and "pruned 1" in reason
    entries = _fetch(cache, mycobot, request)
    assert len(entries) == 1 and entries[0].execution_time_s == pytest.approx(fast.execution_time_s)
    # a nearby (fuzzy-matching) but not exactly equal key is not competition: no pruning
    near = _request(mycobot, _start(mycobot, [0.001, 0, 0, 0, 0, 0]))
    assert _insert(cache, mycobot, near, _value(mycobot, start=[0.001, 0, 0, 0, 0, 0], scaling=0.5))[0]
    assert cache.count_trajectories(NS) == 2
    cache.close()


def test_best_seen_keeps_the_preserved_best_entries_as_moveit_does(cache, mycobot):
    # num_additional_trajectories_to_preserve_when_pruning_worse = 1 (the default): the best
    # matching entry is kept even when the new one is better
    request = _request(mycobot)
    assert _insert(cache, mycobot, request, _value(mycobot, scaling=0.3))[0]
    assert _insert(cache, mycobot, request, _value(mycobot, scaling=0.5))[0]
    assert cache.count_trajectories(NS) == 2  # 0.3's entry was the best seen: kept
    assert _insert(cache, mycobot, request, _value(mycobot, scaling=1.0))[0]
    times = sorted(e.execution_time_s for e in _fetch(cache, mycobot, request))
    assert len(times) == 2 and times[0] == pytest.approx(_value(mycobot).execution_time_s)


def test_always_insert_never_prunes_and_fetch_sorts_by_execution_time(cache, mycobot):
    request = _request(mycobot)
    for scaling in (0.5, 1.0, 0.3, 1.0):
        assert _insert(cache, mycobot, request, _value(mycobot, scaling=scaling), AlwaysInsertNeverPrunePolicy())[0]
    entries = _fetch(cache, mycobot, request)
    assert len(entries) == 4
    times = [e.execution_time_s for e in entries]
    assert times == sorted(times)
    best = cache.fetch_best_matching_trajectory(NS, motion_plan_request_features(mycobot, request), START_TOL,
                                                GOAL_TOL)
    assert best is not None and best.execution_time_s == times[0] and best.trajectory is not None
    slowest = cache.fetch_best_matching_trajectory(NS, motion_plan_request_features(mycobot, request), START_TOL,
                                                   GOAL_TOL, ascending=False)
    assert slowest.execution_time_s == times[-1]
    with pytest.raises(TrajectoryCacheError, match="cannot sort by"):
        cache.fetch_all_matching_trajectories(NS, motion_plan_request_features(mycobot, request), START_TOL,
                                              GOAL_TOL, sort_by="colour")


def test_policies_by_name_and_their_cartesian_variants():
    assert isinstance(cache_insert_policy("BestSeenExecutionTimePolicy"), BestSeenExecutionTimePolicy)
    assert isinstance(cache_insert_policy("BestSeenExecutionTimePolicy", cartesian=True),
                      CartesianBestSeenExecutionTimePolicy)
    assert cache_insert_policy("AlwaysInsertNeverPrunePolicy", True).name == "CartesianAlwaysInsertNeverPrunePolicy"
    with pytest.raises(ValueError, match="known: BestSeenExecutionTimePolicy"):
        cache_insert_policy("KeepEverythingForever")


# ---------------------------------------------------------------- persistence and bad files
def test_a_file_database_persists_across_reopening(tmp_path, mycobot):
    path = tmp_path / "cache" / "trajectories.sqlite"
    first = TrajectoryCache(Options(str(path)))
    value = _value(mycobot)
    assert _insert(first, mycobot, _request(mycobot), value)[0]
    first.close()
    second = TrajectoryCache(Options(str(path)))
    entries = _fetch(second, mycobot, _request(mycobot))
    assert len(entries) == 1
    stored = entries[0].trajectory
    for name in ("times", "positions", "velocities", "accelerations"):
        np.testing.assert_array_equal(getattr(stored, name), getattr(value.trajectory, name))
    assert stored.interpolation == value.trajectory.interpolation
    assert entries[0].planner_id == "arm[RRTConnectkConfigDefault]"
    assert entries[0].planning_time_s == pytest.approx(0.05)
    second.close()


def test_a_corrupt_file_is_refused_with_a_clear_error_and_left_alone(tmp_path):
    path = tmp_path / "corrupt.sqlite"
    garbage = b"this is not a database" * 100
    path.write_bytes(garbage)
    with pytest.raises(TrajectoryCacheError, match="not a trajectory cache: not a usable SQLite database"):
        TrajectoryCache(Options(str(path)))
    assert path.read_bytes() == garbage


def test_a_cache_file_with_damaged_pages_is_refused(tmp_path, mycobot):
    path = tmp_path / "damaged.sqlite"
    cache = TrajectoryCache(Options(str(path)))
    for k in range(20):
        goal = GOAL * (1.0 - 0.01 * k)
        _insert(cache, mycobot, _request(mycobot, goal=goal), _value(mycobot, goal=goal), AlwaysInsertNeverPrunePolicy())
    cache.close()
    data = bytearray(path.read_bytes())
    assert len(data) > 4 * 4096
    for i in range(4096 + 100, 4 * 4096, 7):  # garble pages after the header page
        data[i] ^= 0x5A
    path.write_bytes(bytes(data))
    with pytest.raises(TrajectoryCacheError, match="not a trajectory cache"):
        TrajectoryCache(Options(str(path)))


def test_a_foreign_sqlite_file_is_refused(tmp_path):
    path = tmp_path / "warehouse.sqlite"
    RobotStateStorage(str(path)).close()  # the warehouse's robot states: another schema
    with pytest.raises(TrajectoryCacheError, match="SQLite database of something else.*robot_states"):
        TrajectoryCache(Options(str(path)))
    other = tmp_path / "other_version.sqlite"
    TrajectoryCache(Options(str(other))).close()
    with sqlite3.connect(other) as db:
        db.execute("UPDATE trajectory_cache_meta SET value = '99' WHERE key = 'version'")
    with pytest.raises(TrajectoryCacheError, match="cannot read.*version '99'"):
        TrajectoryCache(Options(str(other)))


def test_a_damaged_row_is_reported_not_returned(tmp_path, mycobot):
    path = tmp_path / "rows.sqlite"
    cache = TrajectoryCache(Options(str(path)))
    _insert(cache, mycobot, _request(mycobot), _value(mycobot))
    cache.close()
    with sqlite3.connect(path) as db:
        db.execute("UPDATE move_group_trajectory_cache SET trajectory = x'00ff'")
    cache = TrajectoryCache(Options(str(path)))
    with pytest.raises(TrajectoryCacheError, match="entry 1 cannot be read"):
        _fetch(cache, mycobot, _request(mycobot))
    cache.close()


def test_bad_options_are_refused():
    with pytest.raises(TrajectoryCacheError, match="exact_match_precision"):
        TrajectoryCache(Options(exact_match_precision=-1.0))
    with pytest.raises(TrajectoryCacheError, match="num_additional_trajectories"):
        TrajectoryCache(Options(num_additional_trajectories_to_preserve_when_pruning_worse=-2))


# ---------------------------------------------------------------- Cartesian
def _cartesian(model, start=None, waypoints=None, **kwargs) -> GetCartesianPathRequest:
    return GetCartesianPathRequest(
        "arm", start if start is not None else _start(model),
        waypoints if waypoints is not None else [make_pose([0.15, 0.0, 0.20], rpy=[np.pi, 0, 0]),
                                                  make_pose([0.15, 0.05, 0.20], rpy=[np.pi, 0, 0])], **kwargs)


def test_the_cartesian_key_is_waypoints_step_and_jump_threshold(cache, mycobot):
    def fetch(request, min_fraction=1.0):
        return cache.fetch_all_matching_cartesian_trajectories(
            NS, cartesian_path_request_features(mycobot, request), START_TOL, GOAL_TOL, min_fraction)

    stored = _cartesian(mycobot, max_step=0.01, jump_threshold=2.0)
    policy = CartesianBestSeenExecutionTimePolicy()
    assert cache.insert_cartesian_trajectory(NS, cartesian_path_request_features(mycobot, stored),
                                             _value(mycobot), policy)[0]
    assert cache.count_cartesian_trajectories(NS) == 1 and cache.count_trajectories(NS) == 0
    assert len(fetch(stored)) == 1
    assert len(fetch(_cartesian(mycobot, max_step=0.02, jump_threshold=2.0))) == 1  # a finer step serves a coarser
    assert fetch(_cartesian(mycobot, max_step=0.005, jump_threshold=2.0)) == []
    assert len(fetch(_cartesian(mycobot, max_step=0.01))) == 1  # no threshold asked: any
    assert fetch(_cartesian(mycobot, max_step=0.01, jump_threshold=1.0)) == []  # a stricter threshold
    assert fetch(_cartesian(mycobot, max_step=0.01, jump_threshold=2.0,
                            waypoints=[make_pose([0.15, 0.0, 0.20], rpy=[np.pi, 0, 0])])) == []
    shifted = [make_pose([0.15, 0.0, 0.20], rpy=[np.pi, 0, 0]), make_pose([0.15, 0.06, 0.20], rpy=[np.pi, 0, 0])]
    assert fetch(_cartesian(mycobot, max_step=0.01, jump_threshold=2.0, waypoints=shifted)) == []
    assert fetch(_cartesian(mycobot, max_step=0.01, jump_threshold=2.0, link="link5")) == []
    partial = CacheValue(_value(mycobot).trajectory, 0.01, 0.5)
    other = _cartesian(mycobot, max_step=0.01, jump_threshold=2.0, waypoints=shifted)
    cache.insert_cartesian_trajectory(NS, cartesian_path_request_features(mycobot, other), partial,
                                      CartesianBestSeenExecutionTimePolicy())
    assert fetch(other, min_fraction=1.0) == [] and len(fetch(other, min_fraction=0.5)) == 1


# ---------------------------------------------------------------- stitching
def test_a_hit_is_stitched_to_the_actual_start(mycobot):
    cached = _trajectory(mycobot, np.zeros(6), GOAL)
    actual = _start(mycobot, [0.008, -0.005, 0, 0, 0.003, 0])
    stitched = stitch_to_start(mycobot, "arm", cached, actual)
    np.testing.assert_allclose(stitched.positions[0], actual.group_positions("arm"), atol=1e-12)
    np.testing.assert_allclose(stitched.positions[-1], GOAL, atol=1e-12)
    assert stitched.duration > cached.duration
    scene = PlanningScene(mycobot)
    assert validate_trajectory(scene, stitched, "arm", actual).valid
    assert not validate_trajectory(scene, cached, "arm", actual).valid  # unstitched: starts elsewhere
    assert stitch_to_start(mycobot, "arm", cached, _start(mycobot)) is cached


# ---------------------------------------------------------------- threads
def test_concurrent_inserts_and_fetches_from_several_threads(mycobot):
    cache = TrajectoryCache()
    errors: list[BaseException] = []
    goals = [GOAL + 0.05 * k for k in range(4)]

    def work(k: int) -> None:
        try:
            for _ in range(10):
                request = _request(mycobot, goal=goals[k])
                _insert(cache, mycobot, request, _value(mycobot, goal=goals[k]), AlwaysInsertNeverPrunePolicy())
                assert _fetch(cache, mycobot, request)
        except BaseException as exc:  # reported below
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    assert cache.count_trajectories(NS) == 40
    cache.close()
