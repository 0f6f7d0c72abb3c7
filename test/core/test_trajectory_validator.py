"""The independent trajectory validator: it must accept what time parameterisation produces on
real robots and catch every kind of defect, including collisions *between* stored points."""
from __future__ import annotations

import numpy as np
import pytest

from interfaces_py.msgs import CollisionObject
from mycobot_planning.core import RobotModelError, RobotState
from mycobot_planning.core.planning_interface.planning_interface import time_group_path
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.trajectory_processing import TimedTrajectory
from mycobot_planning.core.trajectory_processing.trajectory_validator import (
    TrajectoryValidationError,
    ValidationReport,
    validate_trajectory,
)
from mycobot_planning.core.transforms import make_pose

from test_joint_interpolation import PANDA_READY, arm_state, ready


def timed(model, path, vs=1.0, acc=1.0, sample_period=None) -> TimedTrajectory:
    return time_group_path(model, model.group("arm"), np.asarray(path, dtype=float), vs, acc, sample_period)


def copy_traj(traj: TimedTrajectory, **changes) -> TimedTrajectory:
    fields = dict(
        joint_names=traj.joint_names,
        times=traj.times.copy(),
        positions=traj.positions.copy(),
        velocities=traj.velocities.copy(),
        accelerations=traj.accelerations.copy(),
        interpolation=traj.interpolation,
    )
    fields.update(changes)
    return TimedTrajectory(**fields)


def quintic_rest_to_rest(names, a, b, duration) -> TimedTrajectory:
    """Two stored points only: everything in between comes from the interpolation."""
    zeros = np.zeros((2, len(names)))
    return TimedTrajectory(names, [0.0, duration], np.array([a, b]), zeros, zeros.copy(), interpolation="quintic")


def box_at_link(model, state: RobotState, link: str, size=0.03) -> CollisionObject:
    return CollisionObject.box("box", [size] * 3, make_pose(state.frame_pose(link)[:3, 3]))


# ------------------------------------------------------------------------------- valid input
@pytest.mark.parametrize("sample_period", [None, 0.01])
def test_accepts_time_parameterized_mycobot_trajectories(mycobot, sample_period):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    path = [
        start.group_positions("arm"),
        [0.5, -0.4, 1.0, 0.8, 0.3, -0.5],
        [-0.6, 0.3, 0.6, 1.2, -0.4, 0.9],
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    ]
    for vs, acc in ((1.0, 1.0), (0.3, 0.6)):
        traj = timed(mycobot, path, vs, acc, sample_period)
        report = validate_trajectory(scene, traj, "arm", velocity_scaling=vs, acceleration_scaling=acc)
        assert isinstance(report, ValidationReport)
        assert report.valid and bool(report), report.problems
        assert report.problems == [] and report.contacts == [] and report.first_invalid_time is None
        # Dense: at least one checked state per resolution step of the longest joint motion.
        travel = np.max(np.sum(np.abs(np.diff(np.asarray(path), axis=0)), axis=0))
        assert report.checked_states >= travel / 0.005


def test_accepts_time_parameterized_panda_trajectories(panda):
    start = arm_state(panda, PANDA_READY)
    scene = PlanningScene(panda, start)
    assert scene.is_state_valid()
    path = [PANDA_READY, [0.6, -0.3, 0.3, -2.0, 0.4, 1.9, 0.3], [-0.5, -0.6, -0.2, -2.5, -0.3, 2.2, 1.2]]
    for vs, acc in ((1.0, 1.0), (0.5, 0.25)):
        traj = timed(panda, path, vs, acc)
        report = validate_trajectory(scene, traj, "arm", velocity_scaling=vs, acceleration_scaling=acc)
        assert report.valid, report.problems


def test_finer_resolution_checks_more_states(mycobot):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    traj = timed(mycobot, [start.group_positions("arm"), [1.0, 0.5, 0.5, 0.5, 0.5, 0.5]])
    coarse = validate_trajectory(scene, traj, "arm", resolution=0.05)
    fine = validate_trajectory(scene, traj, "arm", resolution=0.002)
    assert coarse.valid and fine.valid
    assert fine.checked_states > 10 * coarse.checked_states
    travel = float(np.max(np.abs(traj.positions[-1] - traj.positions[0])))  # joint 3 travels 1.07
    assert fine.checked_states >= travel / 0.002  # no gap longer than the resolution: >= 535 steps


def test_a_straight_motion_is_sampled_evenly_along_the_way(mycobot):
    """A rest-to-rest straight motion speeds up and slows down: its samples are spread evenly
    along the motion, every gap within the resolution and hardly more states than that needs
    (evenly in time, the fast middle needed halving: half again as many)."""
    from mycobot_planning.core.trajectory_processing.trajectory_validator import dense_samples

    start = ready(mycobot)
    traj = timed(mycobot, [start.group_positions("arm"), [1.0, 0.5, 0.5, 0.5, 0.5, 0.5]])
    ts, q, _, _, exhausted = dense_samples(traj, 0.002)
    steps = np.max(np.abs(np.diff(q, axis=0)), axis=1)
    travel = float(np.max(np.abs(traj.positions[-1] - traj.positions[0])))
    assert not exhausted and steps.max() <= 0.002
    assert len(ts) <= 1.1 * travel / 0.002
    assert np.all(np.diff(ts) > 0) and ts[0] == traj.times[0] and ts[-1] == traj.times[-1]



def test_compiled_sample_times_are_numpys(mycobot):
    """The compiled first sampling gives NumPy's interval counts (so as many states) and its
    times within rounding: straight motions (the even-along-the-motion placement), multi-point
    paths, a non-monotonic drive, and paths of more stored points than that placement takes."""
    from mycobot_planning.core.jit import numba_available
    from mycobot_planning.core.trajectory_processing.trajectory_validator import (
        _initial_times, _initial_times_numpy)

    if not numba_available():
        pytest.skip("numba is not installed (scripts/requirements.txt): only the NumPy version runs")
    rng = np.random.default_rng(11)
    start = ready(mycobot).group_positions("arm")
    trajectories = [timed(mycobot, [start, start + rng.uniform(-1.5, 1.5, 6)]) for _ in range(20)]
    trajectories += [timed(mycobot, start + np.cumsum(rng.uniform(-0.4, 0.4, (k, 6)), axis=0)) for k in (3, 5, 12, 40)]
    trajectories += [quintic_rest_to_rest([f"j{i}" for i in range(6)], start, start + 0.8, 1.5)]
    back_and_forth = TimedTrajectory([f"j{i}" for i in range(2)], np.array([0.0, 1.0]), np.array([[0.0, 0.0], [0.2, 0.1]]),
                                     np.array([[3.0, 0.0], [3.0, 0.0]]), np.zeros((2, 2)), interpolation="quintic")
    trajectories.append(back_and_forth)  # joint 0 overshoots and comes back: evenly in time
    for traj in trajectories:
        for resolution in (0.005, 0.002):
            ours, reference = _initial_times(traj, resolution), _initial_times_numpy(traj, resolution)
            assert ours.shape == reference.shape
            assert np.allclose(ours, reference, rtol=0.0, atol=1e-9 * traj.duration)
            assert ours[0] == traj.times[0] and ours[-1] == traj.times[-1] and np.all(np.diff(ours) > 0)


# ------------------------------------------------------------------------------- collisions
def test_catches_collision_between_free_waypoints(mycobot):
    a = np.array([-0.8, 0.0, 1.5708, 1.5708, 0.0, 0.0])
    b = np.array([0.8, 0.0, 1.5708, 1.5708, 0.0, 0.0])
    start = arm_state(mycobot, a)
    scene = PlanningScene(mycobot, start)
    # A small box where the flange passes halfway, far from both ends.
    scene.add_object(box_at_link(mycobot, arm_state(mycobot, (a + b) / 2), "link6_flange"))
    traj = quintic_rest_to_rest(list(mycobot.group("arm").joint_names), a, b, 2.0)
    for row in traj.positions:  # the premise: every stored point is collision-free
        assert scene.is_state_valid(arm_state(mycobot, row))

    report = validate_trajectory(scene, traj, "arm")
    assert not report.valid
    assert any("'box' (Object)" in c for c in report.contacts)
    collision = [p for p in report.problems if p.startswith("collision")]
    assert len(collision) == 1 and "'box' (Object)" in collision[0] and "t=" in collision[0]
    assert 0.0 < report.first_invalid_time < 1.0  # entered before the midpoint at t = 1 s
    assert not any("velocity" in p or "acceleration" in p for p in report.problems)


def test_catches_collision_inside_time_parameterized_segment(mycobot):
    a = np.array([-1.5, 0.0, 1.5708, 1.5708, 0.0, 0.0])
    b = np.array([1.5, 0.0, 1.5708, 1.5708, 0.0, 0.0])
    traj = timed(mycobot, [a, b])
    # Stored points: rest, end of acceleration, start of braking, rest. The box sits where the
    # robot is midway through the longest interval (the cruise at the velocity limit).
    gaps = np.max(np.abs(np.diff(traj.positions, axis=0)), axis=1)
    k = int(np.argmax(gaps))
    assert gaps[k] > 1.0
    t_mid = 0.5 * (traj.times[k] + traj.times[k + 1])
    q_mid, _, _ = traj.sample(t_mid)
    scene = PlanningScene(mycobot, arm_state(mycobot, a))
    scene.add_object(box_at_link(mycobot, arm_state(mycobot, q_mid), "link6_flange", size=0.02))
    for row in traj.positions:
        assert scene.is_state_valid(arm_state(mycobot, row))
    report = validate_trajectory(scene, traj, "arm")
    assert not report.valid
    assert traj.times[k] < report.first_invalid_time < t_mid
    assert any("'box' (Object)" in c and "(Robot link)" in c for c in report.contacts)


def test_other_joints_come_from_the_start_state(mycobot):
    """The gripper is not in 'arm': its value in start_state decides whether it collides."""
    a = np.array([0.0, 0.0, 1.5708, 1.5708, 0.0, 0.0])
    names = list(mycobot.group("arm").joint_names)
    traj = quintic_rest_to_rest(names, a, a + 0.1, 1.0)
    start = arm_state(mycobot, a)
    scene = PlanningScene(mycobot, start)
    assert validate_trajectory(scene, traj, "arm").valid
    other = start.copy()
    other.set_joint_positions({"gripper_controller": 0.1})
    assert validate_trajectory(scene, traj, "arm", start_state=other).valid  # same arm start


# ------------------------------------------------------------------------------- limits
def test_catches_velocity_limit_with_scaling(mycobot):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    traj = timed(mycobot, [start.group_positions("arm"), [1.5, 0.0, 0.0, 0.0, 0.0, 0.0]])
    assert validate_trajectory(scene, traj, "arm").valid
    report = validate_trajectory(scene, traj, "arm", velocity_scaling=0.5)
    assert not report.valid
    velocity = [p for p in report.problems if "velocity" in p]
    assert velocity and all("limit 1.396" in p and "t=" in p for p in velocity)
    assert any("joint link1_to_link2 velocity" in p for p in velocity)
    assert not any("acceleration" in p for p in report.problems)
    assert report.contacts == []


def test_catches_acceleration_limit(mycobot):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    traj = timed(mycobot, [start.group_positions("arm"), [0.3, 0.2, 1.2, 1.0, 0.1, 0.1]])
    report = validate_trajectory(scene, traj, "arm", acceleration_scaling=0.5)
    assert not report.valid
    assert any("acceleration" in p and "> limit 2.500" in p for p in report.problems)
    assert not any(" velocity " in p for p in report.problems)
    assert report.first_invalid_time == pytest.approx(traj.times[0])  # accelerates from the start


def test_catches_a_trajectory_played_too_fast(mycobot):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    traj = timed(mycobot, [start.group_positions("arm"), [0.0, 1.0, 0.5, 0.5, 0.0, 0.0]])
    fast = copy_traj(traj, times=traj.times / 2, velocities=traj.velocities * 2, accelerations=traj.accelerations * 4)
    report = validate_trajectory(scene, fast, "arm")
    assert any("joint link2_to_link3 velocity" in p for p in report.problems)
    assert any("joint link2_to_link3 acceleration" in p for p in report.problems)
    assert validate_trajectory(scene, fast, "arm", check_limits=False).valid


def test_catches_position_limit(mycobot):
    names = list(mycobot.group("arm").joint_names)
    a = np.zeros(6)
    b = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 2.9])
    scene = PlanningScene(mycobot, arm_state(mycobot, a))
    traj = quintic_rest_to_rest(names, a, b, 3.0)
    traj.positions[1, 5] = 3.2  # beyond link6_to_link6_flange's 3.05 (mutated after construction)
    report = validate_trajectory(scene, traj, "arm", check_limits=True)
    assert any("joint link6_to_link6_flange position" in p and "upper limit 3.0500" in p for p in report.problems)


# ------------------------------------------------------------------------------- structure
def test_catches_start_mismatch(mycobot):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    traj = timed(mycobot, [start.group_positions("arm"), np.zeros(6)])
    home = RobotState(mycobot)
    home.set_named("home", "arm")
    report = validate_trajectory(scene, traj, "arm", start_state=home)
    assert not report.valid
    (problem,) = [p for p in report.problems if "start state" in p]
    assert "link3_to_link4" in problem and "link4_to_link5" in problem and "link1_to_link2" not in problem
    assert report.first_invalid_time == pytest.approx(traj.times[0])
    # The scene's current state is the default start.
    scene.set_current_state(home)
    assert not validate_trajectory(scene, traj, "arm").valid


@pytest.mark.parametrize("resampled", [False, True])
def test_catches_position_jump(mycobot, resampled):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    traj = timed(mycobot, [start.group_positions("arm"), [0.5, 0.5, 0.5, 0.5, 0.5, 0.5]])
    if resampled:
        traj = traj.resample(0.01, keep_breakpoints=False)  # quintic over a 10 ms grid
    k = len(traj) // 2
    jumped = copy_traj(traj)
    jumped.positions[k:, 1] += 0.2  # link2_to_link3 teleports at point k and stays offset
    report = validate_trajectory(scene, jumped, "arm", check_limits=False)
    assert not report.valid
    jumps = [p for p in report.problems if "position jump" in p]
    assert jumps and all("link2_to_link3" in p for p in jumps)
    assert report.first_invalid_time == pytest.approx(traj.times[k], abs=0.011)


def test_catches_non_increasing_times(mycobot):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    traj = copy_traj(timed(mycobot, [start.group_positions("arm"), np.zeros(6)], sample_period=0.05))
    traj.times[5] = traj.times[4]  # mutated after construction: the constructor would refuse it
    report = validate_trajectory(scene, traj, "arm")
    assert not report.valid
    assert any("not strictly increasing" in p and "point 5" in p for p in report.problems)
    assert report.first_invalid_time == pytest.approx(traj.times[5])


def test_catches_not_at_rest(mycobot):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    full = timed(mycobot, [start.group_positions("arm"), np.zeros(6)], sample_period=0.01)
    half = len(full) // 2
    cut = TimedTrajectory(
        full.joint_names,
        full.times[:half],
        full.positions[:half],
        full.velocities[:half],
        full.accelerations[:half],
        interpolation=full.interpolation,
    )
    report = validate_trajectory(scene, cut, "arm")
    assert not report.valid
    (problem,) = report.problems
    assert problem.startswith("trajectory not at rest at the end") and "link3_to_link4" in problem
    assert report.first_invalid_time == pytest.approx(cut.times[-1])
    # Likewise a trajectory that starts moving.
    tail = TimedTrajectory(
        full.joint_names, full.times[half:], full.positions[half:], full.velocities[half:], full.accelerations[half:]
    )
    start.set_group_positions("arm", full.positions[half])
    report = validate_trajectory(scene, tail, "arm", start_state=start)
    assert any(p.startswith("trajectory not at rest at the start") for p in report.problems)


def test_reports_wrong_joints_and_nan(mycobot):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    traj = timed(mycobot, [start.group_positions("arm"), np.zeros(6)])
    report = validate_trajectory(scene, traj, "gripper")
    assert not report.valid and "do not match group 'gripper'" in report.problems[0]
    broken = copy_traj(traj)
    broken.velocities[1, 2] = np.nan
    report = validate_trajectory(scene, broken, "arm")
    assert not report.valid and "NaN" in report.problems[0]


def test_joint_order_may_differ_from_the_group(mycobot):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    traj = timed(mycobot, [start.group_positions("arm"), [0.3, 0.2, 0.1, 0.4, 0.5, 0.6]])
    order = [5, 4, 3, 2, 1, 0]
    flipped = TimedTrajectory(
        [traj.joint_names[i] for i in order],
        traj.times,
        traj.positions[:, order],
        traj.velocities[:, order],
        traj.accelerations[:, order],
        interpolation=traj.interpolation,
    )
    assert validate_trajectory(scene, flipped, "arm").valid


def test_single_point_trajectory(mycobot):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    traj = timed(mycobot, [start.group_positions("arm")])
    assert len(traj) == 1
    assert validate_trajectory(scene, traj, "arm").valid


def test_bad_calls_raise(mycobot):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    traj = timed(mycobot, [start.group_positions("arm"), np.zeros(6)])
    with pytest.raises(RobotModelError, match="unknown planning group 'legs'"):
        validate_trajectory(scene, traj, "legs")
    with pytest.raises(TrajectoryValidationError, match="resolution"):
        validate_trajectory(scene, traj, "arm", resolution=0.0)
    with pytest.raises(TrajectoryValidationError, match="velocity_scaling"):
        validate_trajectory(scene, traj, "arm", velocity_scaling=1.5)
    with pytest.raises(TrajectoryValidationError, match="acceleration_scaling"):
        validate_trajectory(scene, traj, "arm", acceleration_scaling=float("nan"))
    with pytest.raises(TrajectoryValidationError, match="tolerance"):
        validate_trajectory(scene, traj, "arm", tolerance=-1.0)
    with pytest.raises(TrajectoryValidationError, match="TimedTrajectory"):
        validate_trajectory(scene, traj.positions, "arm")
    with pytest.raises(ValueError):  # TrajectoryValidationError is a ValueError
        validate_trajectory(scene, traj, "arm", resolution=float("inf"))


def test_first_collision_gives_the_same_verdict_with_one_contact(mycobot):
    """first_collision=True (a planner trying a candidate): coarse to fine, stopping at the first
    colliding state; the verdict is the full check's, a valid trajectory is checked in full."""
    a = np.array([-0.8, 0.0, 1.5708, 1.5708, 0.0, 0.0])
    b = np.array([0.8, 0.0, 1.5708, 1.5708, 0.0, 0.0])
    start = arm_state(mycobot, a)
    scene = PlanningScene(mycobot, start)
    traj = quintic_rest_to_rest(list(mycobot.group("arm").joint_names), a, b, 2.0)
    free_full = validate_trajectory(scene, traj, "arm")
    free_quick = validate_trajectory(scene, traj, "arm", first_collision=True)
    assert free_full.valid and free_quick.valid and free_quick.checked_states == free_full.checked_states
    scene.add_object(box_at_link(mycobot, arm_state(mycobot, (a + b) / 2), "link6_flange"))
    full = validate_trajectory(scene, traj, "arm")
    quick = validate_trajectory(scene, traj, "arm", first_collision=True)
    assert not full.valid and not quick.valid
    assert len([p for p in quick.problems if p.startswith("collision")]) == 1
    assert quick.contacts and all("'box' (Object)" in c for c in quick.contacts)
    assert full.first_invalid_time <= quick.first_invalid_time <= traj.times[-1]


def test_the_validator_does_not_judge_with_the_checker_it_judges(mycobot):
    """The validator decides with the plain all-pairs check, not with the scene's fast checker
    (broad phase and pre-test) that the planners use: a fast checker that calls every state free
    does not make a colliding trajectory valid, and the report still names the contact."""
    a = np.array([-0.8, 0.0, 1.5708, 1.5708, 0.0, 0.0])
    b = np.array([0.8, 0.0, 1.5708, 1.5708, 0.0, 0.0])
    scene = PlanningScene(mycobot, arm_state(mycobot, a))
    scene.add_object(box_at_link(mycobot, arm_state(mycobot, (a + b) / 2), "link6_flange"))
    traj = quintic_rest_to_rest(list(mycobot.group("arm").joint_names), a, b, 2.0)
    compiled = scene._compiled()
    def broken(q):  # a broken fast path: the thread's checker and the planners' group checker
        return False

    compiled._thread_data().check = broken
    compiled.group_collides = lambda moving, q_ref: broken
    assert scene.is_state_valid(arm_state(mycobot, (a + b) / 2))  # the premise: it is broken
    for first_collision in (False, True):
        report = validate_trajectory(scene, traj, "arm", first_collision=first_collision)
        assert not report.valid
        assert report.contacts and all("'box' (Object)" in c for c in report.contacts)
        # A planner's own check of its output (all_pairs=False) is the fast checker: this one
        # passes the trajectory, which is why the fast checker is proved against the plain one.
        assert validate_trajectory(scene, traj, "arm", first_collision=first_collision, all_pairs=False).valid
