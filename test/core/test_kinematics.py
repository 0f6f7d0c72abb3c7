"""Inverse kinematics: round trips, distinct solutions, ik_frame offsets, limits, bad input."""
from __future__ import annotations

import math
import re
from typing import Any, Callable

import numpy as np
import pytest

from mycobot_planning.core import KinematicsError, RobotModel, RobotState
from mycobot_planning.core.kinematics.ik_solver import IKSolver, solve_ik, state_distance
from mycobot_planning.core.transforms import make_pose


def random_reachable_poses(model: RobotModel, group: str, count: int, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    jmg = model.group(group)
    poses = []
    for _ in range(count):
        state = RobotState(model)
        state.set_group_positions(group, rng.uniform(model.lower_limits[jmg.variable_indices], model.upper_limits[jmg.variable_indices]))
        poses.append(state.frame_pose(jmg.tip_link))
    return poses


def round_trips(solver: IKSolver, poses: list[np.ndarray], rng: np.random.Generator,
                check: Callable[[RobotState, np.ndarray], None], **solve_options: Any) -> int:
    """How many of ``poses`` the solver solves; ``check(first solution, pose)`` on each solved one."""
    solved = 0
    for pose in poses:
        solutions = solver.solve(pose, rng=rng, **solve_options)
        if solutions:
            solved += 1
            check(solutions[0], pose)
    return solved


def test_round_trip_success_rate_on_1000_poses(mycobot: RobotModel):
    solver = IKSolver(mycobot, "arm")
    rng = np.random.default_rng(7)
    poses = random_reachable_poses(mycobot, "arm", 1000, seed=11)

    def check(solution: RobotState, pose: np.ndarray) -> None:
        reached = solution.frame_pose("link6_flange")
        assert np.allclose(reached[:3, 3], pose[:3, 3], atol=1e-4)
        assert np.allclose(reached[:3, :3], pose[:3, :3], atol=1e-3)
        assert solution.satisfies_bounds()

    # Bounded by descents, not by the 50 ms kinematics.yaml timeout, so that a loaded machine
    # cannot turn this into a timing test (the bench measures the timeout-bound solver).
    solved = round_trips(solver, poses, rng, check, timeout=2.0, attempts=60)
    assert solved / len(poses) >= 0.995


def test_multiple_distinct_solutions(mycobot: RobotModel):
    pose = random_reachable_poses(mycobot, "arm", 1, seed=4)[0]  # a pose with 8 IK branches in limits
    solutions = solve_ik(mycobot, "arm", pose, max_solutions=4, min_solution_distance=0.5, timeout=0.5, rng=1)
    assert len(solutions) >= 2
    for i, a in enumerate(solutions):
        assert np.allclose(a.frame_pose("link6_flange"), pose, atol=1e-4)
        for b in solutions[i + 1 :]:
            assert state_distance(a.group_positions("arm"), b.group_positions("arm")) >= 0.5


def test_seed_is_kept_for_nearby_targets(mycobot: RobotModel):
    """A small move from the seed must stay on the seed's branch (Cartesian paths rely on it)."""
    seed = RobotState(mycobot)
    seed.set_named("ready")
    seed.set_joint_positions({"link1_to_link2": 0.3, "link5_to_link6": 0.4})
    target = seed.frame_pose("link6_flange")
    target[:3, 3] += [0.003, -0.002, 0.001]
    solution = solve_ik(mycobot, "arm", target, seed=seed, rng=0)[0]
    assert np.max(np.abs(solution.group_positions("arm") - seed.group_positions("arm"))) < 0.1


def test_ik_frame_offset(mycobot: RobotModel):
    """MTC's ik_frame: solve for a point rigidly attached to the flange (a TCP 10 cm out)."""
    offset = make_pose([0.0, 0.0, 0.1], rpy=[0.0, 0.0, math.pi / 4])
    state = RobotState(mycobot)
    state.set_group_positions("arm", [0.3, -0.4, 0.8, 0.5, -0.3, 0.2])
    target = state.frame_pose("link6_flange") @ offset
    solution = solve_ik(mycobot, "arm", target, ik_frame_offset=offset, rng=0)[0]
    assert np.allclose(solution.frame_pose("link6_flange") @ offset, target, atol=1e-4)


def test_position_only(mycobot: RobotModel):
    state = RobotState(mycobot)
    state.set_named("ready")
    target = make_pose(state.frame_pose("link6_flange")[:3, 3] + [0.02, 0.03, -0.02], rpy=[1.0, 2.0, 3.0])
    solution = solve_ik(mycobot, "arm", target, position_only=True, rng=0)[0]
    assert np.allclose(solution.frame_pose("link6_flange")[:3, 3], target[:3, 3], atol=1e-4)


def test_unreachable_pose_returns_nothing(mycobot: RobotModel):
    target = make_pose([1.0, 0.0, 0.3])  # far beyond the 0.28 m reach
    assert solve_ik(mycobot, "arm", target, timeout=0.02, rng=0) == []


def test_collision_aware_rejects_invalid_solutions(mycobot: RobotModel):
    pose = random_reachable_poses(mycobot, "arm", 1, seed=4)[0]
    all_solutions = solve_ik(mycobot, "arm", pose, max_solutions=4, min_solution_distance=0.5, timeout=0.5, rng=1)
    forbidden = all_solutions[0].group_positions("arm")

    def validity(state: RobotState) -> bool:
        return state_distance(state.group_positions("arm"), forbidden) > 0.2

    filtered = solve_ik(mycobot, "arm", pose, max_solutions=4, min_solution_distance=0.5, timeout=0.5, rng=1, scene=validity)
    assert filtered
    assert all(validity(s) for s in filtered)


def test_reproducible_with_seed(mycobot: RobotModel):
    pose = random_reachable_poses(mycobot, "arm", 1, seed=9)[0]
    a = solve_ik(mycobot, "arm", pose, max_solutions=3, min_solution_distance=0.3, rng=42, timeout=1.0)
    b = solve_ik(mycobot, "arm", pose, max_solutions=3, min_solution_distance=0.3, rng=42, timeout=1.0)
    assert [s.positions.tolist() for s in a] == [s.positions.tolist() for s in b]


def test_panda_ik_round_trip(panda: RobotModel):
    solver = IKSolver(panda, "arm")
    rng = np.random.default_rng(0)
    poses = random_reachable_poses(panda, "arm", 100, seed=1)

    def check(solution: RobotState, pose: np.ndarray) -> None:
        assert np.allclose(solution.frame_pose("panda_hand_tcp"), pose, atol=1e-4)

    assert round_trips(solver, poses, rng, check) >= 98


@pytest.mark.parametrize(
    "kwargs,message",
    [
        ({"target_pose": np.full((4, 4), np.nan)}, "NaN"),
        ({"target_pose": np.eye(3)}, "4x4"),
        ({"group": "legs"}, "unknown planning group 'legs'"),
        ({"link": "nowhere"}, "unknown link or frame 'nowhere'"),
        ({"max_solutions": 0}, "max_solutions"),
        ({"timeout": -1.0}, "timeout"),
    ],
)
def test_bad_requests(mycobot: RobotModel, kwargs: dict, message: str):
    args = {"model": mycobot, "group": "arm", "target_pose": make_pose([0.1, 0.0, 0.2])}
    args.update(kwargs)
    with pytest.raises(KinematicsError if kwargs.get("group") is None else ValueError) as info:
        solve_ik(**args)
    assert message in str(info.value)


def test_collision_aware_ik_with_planning_scene(mycobot: RobotModel):
    """With a scene, every returned solution is collision-free; without, some of them collide."""
    from interfaces_py.msgs import CollisionObject
    from mycobot_planning.core import PlanningScene

    scene = PlanningScene(mycobot)
    scene.add_object(CollisionObject.box("table", [0.10, 0.20, 0.03], make_pose([0.22, 0.12, -0.015])))
    target = make_pose([0.17, 0.04, 0.16], rpy=[math.pi, 0.0, 0.0])
    unchecked = solve_ik(mycobot, "arm", target, max_solutions=4, min_solution_distance=0.5, timeout=0.5, rng=0)
    assert any(not scene.is_state_valid(s) for s in unchecked)
    checked = solve_ik(mycobot, "arm", target, max_solutions=4, min_solution_distance=0.5, timeout=0.5, rng=0, scene=scene)
    assert checked
    assert all(scene.is_state_valid(s) for s in checked)


def test_refine_stays_on_the_seed_branch(mycobot: RobotModel):
    solver = IKSolver(mycobot, "arm")
    seed = RobotState(mycobot)
    seed.set_group_positions("arm", [0.3, -0.4, 0.8, 0.5, -0.3, 0.2])
    target = seed.frame_pose("link6_flange")
    target[:3, 3] += [0.002, 0.001, -0.002]
    refined = solver.refine(target, seed)
    assert refined is not None
    assert np.allclose(refined.frame_pose("link6_flange"), target, atol=1e-5)
    assert np.max(np.abs(refined.positions - seed.positions)) < 0.05
    assert solver.refine(make_pose([2.0, 0.0, 0.0]), seed) is None


def test_batched_descents_converge_where_single_descents_do(mycobot: RobotModel, monkeypatch):
    """Without its early abort the batch runs the same Gauss-Newton per start: it converges for
    every start a lone descent converges from, to a state at the target."""
    import mycobot_planning.core.kinematics.ik_solver as kinematics

    monkeypatch.setattr(kinematics, "ABORT_ITERATION", 10**6)
    solver = IKSolver(mycobot, "arm")
    jmg = mycobot.group("arm")
    rng = np.random.default_rng(3)
    base = mycobot.default_positions()
    single_total = batch_total = 0
    for pose in random_reachable_poses(mycobot, "arm", 8, seed=21):
        target = pin_se3(pose)
        starts = rng.uniform(solver._sample_lower, solver._sample_upper, size=(12, len(jmg.variable_indices)))
        budgets = np.full(12, 15)
        final, converged = solver._descend_batch(base, starts, budgets, target, False)
        for k, start in enumerate(starts):
            full = base.copy()
            full[jmg.variable_indices] = start
            single = solver._descend(full, target, False, 15)
            single_total += single
            batch_total += bool(converged[k])
            if single:
                assert converged[k]
            if converged[k]:
                state = RobotState(mycobot, base.copy())
                state.set_group_positions("arm", final[k])
                assert np.allclose(state.frame_pose(jmg.tip_link), pose, atol=1e-4)
                assert state.satisfies_bounds()
    assert single_total > 0
    assert batch_total - single_total <= 2  # at most the final iterate's extra check


def test_solve_with_attempts_counts_every_start(mycobot: RobotModel):
    """An unreachable target: exactly ``attempts`` descents, whatever the batching."""
    solver = IKSolver(mycobot, "arm")
    seen = []
    original = solver._descend_batch

    def counting(base, starts, budgets, target, position_only):
        seen.append(len(starts))
        return original(base, starts, budgets, target, position_only)

    solver._descend_batch = counting  # type: ignore[method-assign]
    assert solver.solve(make_pose([1.0, 1.0, 1.0]), rng=0, timeout=5.0, attempts=24, max_solutions=8) == []
    assert 1 + sum(seen) == 24  # the first start runs alone, the rest in batches


def pin_se3(pose: np.ndarray):
    import pinocchio as pin

    return pin.SE3(pose[:3, :3].copy(), pose[:3, 3].copy())


def test_batched_descents_drop_only_starts_still_far_off(mycobot: RobotModel):
    """The early abort keeps every start that a lone descent brings within ABORT_ERROR by
    ABORT_ITERATION steps, and whatever converges is at the target."""
    import mycobot_planning.core.kinematics.ik_solver as kinematics

    solver = IKSolver(mycobot, "arm")
    jmg = mycobot.group("arm")
    rng = np.random.default_rng(9)
    base = mycobot.default_positions()
    pose = random_reachable_poses(mycobot, "arm", 1, seed=5)[0]
    target = pin_se3(pose)
    starts = rng.uniform(solver._sample_lower, solver._sample_upper, size=(40, len(jmg.variable_indices)))
    final, converged = solver._descend_batch(base, starts, np.full(40, 15), target, False)
    import pinocchio as pin

    for k, start in enumerate(starts):
        full = base.copy()
        full[jmg.variable_indices] = start
        close = solver._descend(full.copy(), target, False, 15)
        probe = full.copy()
        solver._descend(probe, target, False, kinematics.ABORT_ITERATION)
        state = RobotState(mycobot, probe)
        error = np.linalg.norm(pin.log6(pin_se3(state.frame_pose(jmg.tip_link)).actInv(target)).vector)
        if close and error <= kinematics.ABORT_ERROR * 0.99:
            assert converged[k]
        if converged[k]:
            done = RobotState(mycobot, base.copy())
            done.set_group_positions("arm", final[k])
            assert np.allclose(done.frame_pose(jmg.tip_link), pose, atol=1e-4)


@pytest.mark.parametrize("pose", [
    make_pose([0.1, 0.2, 0.3], rpy=[0.3, -0.2, 1.0]),
    make_pose([0.1, 0.2, 0.3], rpy=[0.3, -0.2, 1.0]).tolist(),
    np.diag([1.0, 1.0, -1.0, 1.0]),  # a reflection
    np.diag([1.0, 1.0, 1.0001, 1.0]),  # not orthonormal
    np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 1.0, 0], [0, 0, 0.1, 1.0]]),  # bottom row
    np.full((4, 4), np.nan),
    np.eye(3),
    "pose",
])
def test_fast_target_check_gives_check_poses_verdict(pose):
    from mycobot_planning.core.kinematics.ik_solver import _target_pose
    from mycobot_planning.core.transforms import check_pose

    try:
        expected = check_pose(pose, "IK target pose")
    except ValueError as exc:
        with pytest.raises(ValueError, match=re.escape(str(exc).split(":")[0])):
            _target_pose(pose, "IK target pose")
    else:
        assert np.array_equal(_target_pose(pose, "IK target pose"), expected)


def test_descents_reach_targets_with_joints_at_their_limits(panda: RobotModel):
    """Targets whose solutions hold a joint at a limit (the Panda's elbow and wrist): a step
    that would pass the limit stops there and the other joints take up the rest, so a single
    descent from a table seed converges where merely clamping the step used to stall."""
    jmg = panda.group("arm")
    low, high = panda.lower_limits[jmg.variable_indices], panda.upper_limits[jmg.variable_indices]
    rng = np.random.default_rng(3)
    solver = IKSolver(panda, "arm")
    solved = 0
    for _ in range(20):
        values = rng.uniform(low, high)
        values[3], values[5] = high[3], low[5]  # panda_joint4 at its upper, panda_joint6 at its lower limit
        state = RobotState(panda)
        state.set_group_positions("arm", values)
        target = state.frame_pose(jmg.tip_link)
        solutions = solver.solve(target, rng=rng, attempts=1 + solver.options.seed_neighbours)
        if solutions:
            solved += 1
            reached = solutions[0].frame_pose(jmg.tip_link)
            assert np.allclose(reached, target, atol=1e-4)
            assert solutions[0].satisfies_bounds()
    assert solved >= 18


def test_fast_target_check_never_accepts_what_check_pose_refuses():
    """Poses perturbed around the orthonormality and last-row tolerances: the fast check
    accepts only what check_pose accepts, and refuses with check_pose's own message."""
    from scipy.spatial.transform import Rotation

    from mycobot_planning.core.kinematics.ik_solver import _target_pose
    from mycobot_planning.core.transforms import check_pose

    rng = np.random.default_rng(0)
    accepted = 0
    for k in range(3000):
        pose = np.eye(4)
        pose[:3, :3] = Rotation.random(random_state=k).as_matrix()
        pose[:3, 3] = rng.uniform(-1, 1, 3)
        scale = 10.0 ** rng.uniform(-9, -4)
        pose[rng.integers(0, 4), rng.integers(0, 4)] += rng.choice([-1.0, 1.0]) * scale
        try:
            expected = check_pose(pose, "IK target pose")
        except ValueError as exc:
            with pytest.raises(ValueError, match=re.escape(str(exc))):
                _target_pose(pose, "IK target pose")
        else:
            assert _target_pose(pose, "IK target pose") is expected
            accepted += 1
    assert 0 < accepted < 3000


def test_the_seed_tables_orientation_weight_follows_the_arms_reach():
    """0.27 m per metre of reach: the myCobot keeps the 0.05 m it was tuned at, the Panda (three
    times the reach) gets three times the weight, and an explicit option still wins."""
    from mycobot_planning.core.kinematics.ik_solver import ORIENTATION_WEIGHT_PER_REACH, IKOptions
    from mycobot_planning.paths import example_robot_data_dir

    mycobot = IKSolver(RobotModel.mycobot(), "arm")
    assert mycobot._orientation_weight == pytest.approx(0.05, abs=0.002)
    assert 0.17 < mycobot._reach() < 0.21  # m: the myCobot 280's flange
    root = example_robot_data_dir() / "panda_description"
    panda_model = RobotModel.from_files(root / "urdf" / "panda.urdf", root / "srdf" / "panda.srdf")
    panda = IKSolver(panda_model, "arm", "panda_hand")
    assert panda._orientation_weight == pytest.approx(ORIENTATION_WEIGHT_PER_REACH * panda._reach())
    assert panda._orientation_weight > 2.5 * mycobot._orientation_weight
    fixed = IKSolver(panda_model, "arm", "panda_hand", options=IKOptions(orientation_weight=0.3))
    assert fixed._orientation_weight == 0.3
    tree, _ = fixed._seed_table(False)
    assert np.max(np.abs(tree.data[:, 3:])) == pytest.approx(0.3, rel=1e-3)  # rotation entries reach ±1
    pose = make_pose([0.4, 0.1, 0.4], rpy=[math.pi, 0.0, 0.0])
    assert panda.solve(pose, max_solutions=1) and fixed.solve(pose, max_solutions=1)
