"""Tests for mycobot_planning.core.trajectory_processing (Ruckig-based, path-following)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import ruckig

from mycobot_planning.core.trajectory_processing import TimedTrajectory, TimeParameterizationError, retime, time_parameterize

VMAX = np.array([2.0, 1.5, 1.0, 2.5, 3.0, 1.2])
AMAX = np.array([4.0, 3.0, 2.0, 5.0, 6.0, 2.5])
JMAX = np.array([40.0, 30.0, 20.0, 50.0, 60.0, 25.0])
REL = 1e-6


def random_path(n: int = 20, d: int = 6, seed: int = 0, scale: float = 1.0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.cumsum(rng.uniform(-scale, scale, size=(n, d)), axis=0)


def dist_to_polyline(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Euclidean distance of each point to the piecewise-linear path."""
    best = np.full(points.shape[0], np.inf)
    for a, b in zip(path[:-1], path[1:]):
        ab = b - a
        t = np.clip((points - a) @ ab / (ab @ ab), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(points - (a + t[:, None] * ab), axis=1))
    return best


def fine(traj: TimedTrajectory, n: int = 20001):
    ts = np.linspace(traj.times[0], traj.times[-1], n)
    q, qd, qdd = traj.sample(ts)
    return ts, q, qd, qdd


def assert_within_limits(traj, vmax, amax, n=20001):
    ts, q, qd, qdd = fine(traj, n)
    assert np.all(np.abs(qd) <= vmax * (1 + REL) + 1e-12)
    assert np.all(np.abs(qdd) <= amax * (1 + REL) + 1e-12)
    # The reported velocities must be the real ones: velocity derived from positions obeys the
    # limit too, and velocity never jumps by more than the acceleration limit allows.
    dt = np.diff(ts)[:, None]
    assert np.all(np.abs(np.diff(q, axis=0) / dt) <= vmax * (1 + 1e-4))
    assert np.all(np.abs(np.diff(qd, axis=0)) <= amax * dt * (1 + 1e-4) + 1e-12)


def trapezoid_duration(length: float, v: float, a: float) -> float:
    if length >= v * v / a:
        return length / v + v / a
    return 2.0 * math.sqrt(length / a)


# ------------------------------------------------------------------------- limits and geometry
@pytest.mark.parametrize("vs,as_", [(1.0, 1.0), (0.5, 0.3), (0.1, 1.0)])
@pytest.mark.parametrize("jerk", [None, JMAX])
@pytest.mark.parametrize("period", [None, 0.01])
def test_limits_respected(vs, as_, jerk, period):
    path = random_path(seed=1)
    traj = time_parameterize(path, VMAX, AMAX, max_jerk=jerk, velocity_scaling=vs,
                             acceleration_scaling=as_, sample_period=period)
    assert_within_limits(traj, VMAX * vs, AMAX * as_)
    # Stored points (what a controller receives) respect them too.
    assert np.all(np.abs(traj.velocities) <= VMAX * vs * (1 + REL))
    assert np.all(np.abs(traj.accelerations) <= AMAX * as_ * (1 + REL))


def test_limits_active():
    """Time-optimal-ish: on a long single segment the limiting joint reaches its max speed."""
    traj = time_parameterize([[0.0] * 6, [10.0] * 6], VMAX, AMAX)
    _, _, qd, _ = fine(traj)
    ratio = np.max(np.abs(qd), axis=0) / VMAX
    assert ratio.max() == pytest.approx(1.0, rel=1e-9)


@pytest.mark.parametrize("jerk", [None, JMAX])
@pytest.mark.parametrize("period", [None, 0.01])
def test_passes_through_every_waypoint_and_stays_on_path(jerk, period):
    path = random_path(seed=2)
    traj = time_parameterize(path, VMAX, AMAX, max_jerk=jerk, sample_period=period)
    assert traj.waypoint_times.shape == (path.shape[0],)
    assert np.all(np.diff(traj.waypoint_times) > 0)
    q, _, _ = traj.sample(traj.waypoint_times)
    np.testing.assert_allclose(q, path, atol=1e-9)
    # Waypoints are stored points, so a controller interpolating the points hits them too.
    for w in path:
        assert np.min(np.max(np.abs(traj.positions - w), axis=1)) < 1e-9
    _, qf, _, _ = fine(traj)
    assert dist_to_polyline(qf, path).max() < 1e-6
    assert dist_to_polyline(traj.positions, path).max() < 1e-9


@pytest.mark.parametrize("jerk", [None, JMAX])
def test_starts_and_ends_at_rest(jerk):
    path = random_path(seed=3)
    traj = time_parameterize(path, VMAX, AMAX, max_jerk=jerk, sample_period=0.01)
    for idx in (0, -1):
        np.testing.assert_array_equal(traj.velocities[idx], 0.0)
    np.testing.assert_array_equal(traj.accelerations[-1], 0.0)
    if jerk is not None:  # acceleration is continuous, so it starts at 0 too
        np.testing.assert_array_equal(traj.accelerations[0], 0.0)
    else:  # stored accelerations are what follows the instant: it starts accelerating
        assert np.linalg.norm(traj.accelerations[0]) > 0.0
    _, qd, _ = traj.sample([1e-4, traj.duration - 1e-4])
    assert np.all(np.abs(qd) <= AMAX * 1e-4 * (1 + 1e-6))
    np.testing.assert_allclose(traj.positions[0], path[0], atol=1e-12)
    np.testing.assert_allclose(traj.positions[-1], path[-1], atol=1e-12)
    assert traj.times[0] == 0.0


def test_scaling_slows_down():
    path = random_path(seed=4)
    full = time_parameterize(path, VMAX, AMAX).duration
    assert time_parameterize(path, VMAX, AMAX, velocity_scaling=0.5).duration > full
    assert time_parameterize(path, VMAX, AMAX, acceleration_scaling=0.5).duration > full
    both = time_parameterize(path, VMAX, AMAX, velocity_scaling=0.5, acceleration_scaling=0.5)
    # Halving every limit at least... exactly doubles time for the same profile shapes? Not
    # exactly (v and a scale differently), but it must be slower than either alone.
    assert both.duration > time_parameterize(path, VMAX, AMAX, velocity_scaling=0.5).duration


# ------------------------------------------------------------------------- analytic durations
@pytest.mark.parametrize("length", [0.1, 0.5, 3.0])  # triangle, triangle, trapezoid
def test_single_segment_matches_trapezoid(length):
    v, a = 1.0, 2.0
    traj = time_parameterize([[0.0], [length]], v, a)
    assert traj.duration == pytest.approx(trapezoid_duration(length, v, a), rel=1e-9)


def test_single_segment_multi_joint_uses_limiting_joint():
    start = np.zeros(3)
    goal = np.array([2.0, -1.0, 0.5])
    vmax = np.array([1.0, 0.25, 2.0])
    amax = np.array([1.0, 1.0, 0.1])
    traj = time_parameterize([start, goal], vmax, amax)
    # Staying on the line means one shared profile shape: along the arc length the limits are
    # min_j vmax_j L/|g_j| and min_j amax_j L/|g_j| (here velocity from joint 1, acceleration
    # from joint 2), which is slower than any single joint's own trapezoid (4.47 s).
    length = np.linalg.norm(goal)
    v_s = np.min(vmax * length / np.abs(goal))
    a_s = np.min(amax * length / np.abs(goal))
    expected = trapezoid_duration(length, v_s, a_s)
    assert expected == pytest.approx(5.25)
    assert traj.duration == pytest.approx(expected, rel=1e-9)
    _, qd, qdd = traj.sample(np.linspace(0, traj.duration, 2001))
    assert np.max(np.abs(qd[:, 1])) == pytest.approx(vmax[1], rel=1e-9)
    assert np.max(np.abs(qdd[:, 2])) == pytest.approx(amax[2], rel=1e-9)


def test_single_segment_jerk_limited_duration():
    # Long move reaching v and a: T = L/v + v/a + a/j for rest-to-rest.
    L, v, a, j = 5.0, 1.0, 2.0, 10.0
    traj = time_parameterize([[0.0], [L]], v, a, max_jerk=j)
    assert traj.duration == pytest.approx(L / v + v / a + a / j, rel=1e-9)


def test_single_segment_matches_ruckig_phase_synchronisation():
    """Our 1-D projection equals a multi-DoF Ruckig call with Synchronization.Phase."""
    start, goal = np.zeros(6), np.array([0.3, -1.2, 0.8, 2.0, -0.4, 0.1])
    otg, inp, out = ruckig.Ruckig(6), ruckig.InputParameter(6), ruckig.Trajectory(6)
    inp.current_position, inp.target_position = start.tolist(), goal.tolist()
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = VMAX.tolist(), AMAX.tolist(), JMAX.tolist()
    inp.synchronization = ruckig.Synchronization.Phase
    assert otg.calculate(inp, out) == ruckig.Result.Working
    traj = time_parameterize([start, goal], VMAX, AMAX, max_jerk=JMAX)
    assert traj.duration == pytest.approx(out.duration, rel=1e-9)
    for t in np.linspace(0.0, out.duration, 37):
        np.testing.assert_allclose(traj.sample(t)[0], out.at_time(t)[0], atol=1e-9)


def test_stays_on_line_where_ruckig_phase_sync_falls_back():
    """Ruckig's multi-DoF Phase synchronisation falls back to Time synchronisation when the
    scaled profile would break another joint's limit, and then leaves the straight line."""
    start = np.array([-0.664, 0.872, 0.549, 0.306, -0.654, -0.123])
    goal = np.array([0.171, -0.196, 0.786, 0.102, -0.822, 0.751])
    otg, inp, out = ruckig.Ruckig(6), ruckig.InputParameter(6), ruckig.Trajectory(6)
    inp.current_position, inp.target_position = start.tolist(), goal.tolist()
    inp.max_velocity, inp.max_acceleration = VMAX.tolist(), AMAX.tolist()
    inp.max_jerk = [math.inf] * 6
    inp.synchronization = ruckig.Synchronization.Phase
    otg.calculate(inp, out)
    ruckig_q = np.array([out.at_time(t)[0] for t in np.linspace(0, out.duration, 201)])
    assert dist_to_polyline(ruckig_q, np.stack([start, goal])).max() > 1e-2  # the fallback

    traj = time_parameterize([start, goal], VMAX, AMAX)
    _, q, _, _ = fine(traj)
    assert dist_to_polyline(q, np.stack([start, goal])).max() < 1e-12
    assert_within_limits(traj, VMAX, AMAX)
    assert traj.duration >= out.duration  # staying on the line can only cost time


# ------------------------------------------------------------------------- jerk
def test_jerk_limit_respected():
    path = random_path(seed=5)
    traj = time_parameterize(path, VMAX, AMAX, max_jerk=JMAX, acceleration_scaling=0.7)
    assert traj.interpolation == "cubic"
    ts = np.linspace(0.0, traj.duration, 40001)
    _, _, qdd = traj.sample(ts)
    # Acceleration is continuous and changes no faster than the jerk limit allows.
    assert np.all(np.abs(np.diff(qdd, axis=0)) <= JMAX * np.diff(ts)[:, None] * (1 + 1e-6) + 1e-9)
    # Acceleration is continuous in the jerk-limited case (no steps at breakpoints).
    _, _, qdd_left = traj.sample(traj.times[1:] - 1e-9)
    np.testing.assert_allclose(qdd_left, traj.accelerations[1:], atol=1e-6)
    assert_within_limits(traj, VMAX, AMAX * 0.7)
    assert traj.duration > time_parameterize(path, VMAX, AMAX, acceleration_scaling=0.7).duration


def test_jerk_infinite_equals_none():
    path = random_path(seed=6)
    a = time_parameterize(path, VMAX, AMAX)
    b = time_parameterize(path, VMAX, AMAX, max_jerk=math.inf)
    assert a.duration == pytest.approx(b.duration, rel=1e-12)


# ------------------------------------------------------------------------- waypoints handling
@pytest.mark.parametrize("jerk", [None, 20.0])
def test_collinear_waypoints_are_passed_without_stopping(jerk):
    path = np.linspace([0.0, 0.0], [3.0, 1.5], 31)
    straight = time_parameterize(path[[0, -1]], 1.0, 2.0, max_jerk=jerk)
    dense = time_parameterize(path, 1.0, 2.0, max_jerk=jerk)
    assert dense.duration == pytest.approx(straight.duration, rel=1e-9)
    inner = dense.sample(dense.waypoint_times[1:-1])[1]
    assert np.all(np.linalg.norm(inner, axis=1) > 0.1)
    np.testing.assert_allclose(dense.sample(dense.waypoint_times)[0], path, atol=1e-12)
    # Same motion as the single segment, waypoints are just stamped on it.
    ts = np.linspace(0.0, dense.duration, 1001)
    np.testing.assert_allclose(dense.sample(ts)[0], straight.sample(ts)[0], atol=1e-9)


def test_interpolated_path_with_corners_matches_its_corners_only():
    corners = random_path(n=6, seed=13)
    dense = np.concatenate([np.linspace(a, b, 7, endpoint=False)
                            for a, b in zip(corners[:-1], corners[1:])] + [corners[-1:]])
    a = time_parameterize(corners, VMAX, AMAX, max_jerk=JMAX)
    b = time_parameterize(dense, VMAX, AMAX, max_jerk=JMAX)
    assert b.duration == pytest.approx(a.duration, rel=1e-9)
    np.testing.assert_allclose(b.sample(b.waypoint_times)[0], dense, atol=1e-9)


def test_corner_stops_without_tolerance():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    traj = time_parameterize(path, 1.0, 2.0)
    _, qd, _ = traj.sample(traj.waypoint_times[1])
    np.testing.assert_allclose(qd, 0.0, atol=1e-12)
    assert traj.duration == pytest.approx(2 * trapezoid_duration(1.0, 1.0, 2.0), rel=1e-9)


def test_single_waypoint_and_duplicates():
    one = time_parameterize([[0.1, 0.2, 0.3]], 1.0, 1.0)
    assert len(one) == 1 and one.duration == 0.0
    q, qd, qdd = one.sample(5.0)
    np.testing.assert_allclose(q, [0.1, 0.2, 0.3])
    np.testing.assert_array_equal(qd, 0.0)
    same = time_parameterize([[0.1, 0.2, 0.3]] * 4, 1.0, 1.0, sample_period=0.01)
    assert len(same) == 1

    path = random_path(n=6, seed=7)
    dup = np.repeat(path, 3, axis=0)
    a = time_parameterize(path, VMAX, AMAX)
    b = time_parameterize(dup, VMAX, AMAX)
    assert b.duration == pytest.approx(a.duration, rel=1e-12)
    np.testing.assert_array_equal(b.path, path)


# ------------------------------------------------------------------------- corner blending
def test_path_tolerance_blends_corners():
    path = random_path(n=12, seed=8, scale=0.5)
    tol = 1e-3
    strict = time_parameterize(path, VMAX, AMAX)
    blended = time_parameterize(path, VMAX, AMAX, path_tolerance=tol)
    assert blended.duration < strict.duration
    _, qf, _, _ = fine(blended, 40001)
    assert dist_to_polyline(qf, path).max() <= tol * (1 + 1e-9)
    q, _, _ = blended.sample(blended.waypoint_times)
    assert np.all(np.linalg.norm(q - path, axis=1) <= tol * (1 + 1e-9))
    np.testing.assert_allclose(q[[0, -1]], path[[0, -1]], atol=1e-12)
    assert_within_limits(blended, VMAX, AMAX, n=40001)


def test_cartesian_like_dense_curve_with_tolerance_does_not_crawl():
    """A densely sampled smooth curve (like a Cartesian path in joint space)."""
    s = np.linspace(0.0, 1.0, 101)
    path = np.stack([np.sin(2 * s), np.cos(2 * s) - 1.0, s], axis=1)
    strict = time_parameterize(path, 1.0, 2.0)
    blended = time_parameterize(path, 1.0, 2.0, path_tolerance=1e-4)
    assert blended.duration < 0.5 * strict.duration
    _, qf, _, _ = fine(blended, 40001)
    assert dist_to_polyline(qf, path).max() <= 1e-4 * (1 + 1e-9)
    assert_within_limits(blended, np.ones(3), 2.0 * np.ones(3), n=40001)


# ------------------------------------------------------------------------- sampling
def test_sample_reproduces_stored_points_and_resample():
    path = random_path(n=8, seed=9)
    traj = time_parameterize(path, VMAX, AMAX, max_jerk=JMAX)
    q, qd, qdd = traj.sample(traj.times)
    np.testing.assert_allclose(q, traj.positions, atol=1e-12)
    np.testing.assert_allclose(qd, traj.velocities, atol=1e-12)
    np.testing.assert_allclose(qdd, traj.accelerations, atol=1e-9)

    res = traj.resample(0.01, keep_breakpoints=False)
    assert res.interpolation == "quintic"
    assert res.duration == pytest.approx(traj.duration, abs=1e-12)
    assert np.all(np.diff(res.times)[:-1] == pytest.approx(0.01, abs=1e-12))
    assert np.diff(res.times)[-1] <= 0.01 * 1.01 + 1e-12
    # Exact samples of the original.
    q2, qd2, _ = traj.sample(res.times)
    np.testing.assert_allclose(res.positions, q2, atol=1e-12)
    np.testing.assert_allclose(res.velocities, qd2, atol=1e-12)
    # Quintic between 10 ms samples stays close to the exact (jerk-limited) motion.
    ts = np.linspace(0.0, traj.duration, 5001)
    np.testing.assert_allclose(res.sample(ts)[0], traj.sample(ts)[0], atol=1e-6)

    # Default keeps breakpoints: exact everywhere, and equal to sample_period output.
    kept = traj.resample(0.01)
    assert kept.interpolation == "cubic"
    assert np.all(np.isin(traj.times, kept.times))
    assert np.max(np.diff(kept.times)) <= 0.01 * 1.01 + 1e-12
    for a, b in zip(kept.sample(ts), traj.sample(ts)):
        np.testing.assert_allclose(a, b, atol=1e-12)
    direct = time_parameterize(path, VMAX, AMAX, max_jerk=JMAX, sample_period=0.01)
    np.testing.assert_array_equal(direct.times, kept.times)


def test_sample_period_output_is_exact_and_includes_waypoints():
    path = random_path(n=5, seed=10)
    exact = time_parameterize(path, VMAX, AMAX)
    dense = time_parameterize(path, VMAX, AMAX, sample_period=0.01)
    assert dense.duration == pytest.approx(exact.duration, rel=1e-12)
    assert np.max(np.diff(dense.times)) <= 0.01 * 1.01 + 1e-12
    assert np.all(np.isin(exact.waypoint_times, dense.times))
    assert np.all(np.isin(exact.times, dense.times))
    q, qd, qdd = exact.sample(dense.times)
    np.testing.assert_allclose(dense.positions, q, atol=1e-12)
    np.testing.assert_allclose(dense.velocities, qd, atol=1e-12)


def test_sample_scalar_and_clamping():
    traj = time_parameterize([[0.0, 0.0], [1.0, 2.0]], 1.0, 1.0, joint_names=["a", "b"])
    q, qd, qdd = traj.sample(0.3)
    assert q.shape == (2,) and qd.shape == (2,) and qdd.shape == (2,)
    np.testing.assert_allclose(traj.sample(-1.0)[0], [0.0, 0.0])
    np.testing.assert_allclose(traj.sample(1e3)[0], [1.0, 2.0])
    assert traj.joint_names == ["a", "b"]


# ------------------------------------------------------------------------- retime
def test_retime_trajectory_and_path():
    path = random_path(seed=11)
    traj = time_parameterize(path, VMAX, AMAX, joint_names=[f"j{i}" for i in range(6)],
                             sample_period=0.01)
    slow = retime(traj, VMAX, AMAX, velocity_scaling=0.3, acceleration_scaling=0.3)
    assert slow.duration > traj.duration
    assert slow.joint_names == traj.joint_names
    np.testing.assert_array_equal(slow.path, path)
    # Re-timing back to full speed gives the original timing (path, not samples, is re-timed).
    again = retime(slow, VMAX, AMAX)
    assert again.duration == pytest.approx(traj.duration, rel=1e-12)
    assert retime(path, VMAX, AMAX).duration == pytest.approx(traj.duration, rel=1e-12)
    # A bare TimedTrajectory (no path) is re-timed through its positions.
    bare = TimedTrajectory(["a"], [0.0, 1.0, 2.0], [[0.0], [1.0], [2.0]],
                           [[0.0], [1.0], [0.0]], [[0.0], [0.0], [0.0]])
    assert retime(bare, 1.0, 1.0).duration == pytest.approx(trapezoid_duration(2.0, 1.0, 1.0))


# ------------------------------------------------------------------------- bad input
GOOD = np.array([[0.0, 0.0], [1.0, 1.0]])


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(path=[[0.0, np.nan], [1.0, 1.0]]), "NaN"),
        (dict(path=[[0.0, np.inf], [1.0, 1.0]]), "NaN or inf"),
        (dict(path=[0.0, 1.0]), "shape"),
        (dict(path=np.zeros((0, 2))), "shape"),
        (dict(max_velocity=[1.0, 1.0, 1.0]), "max_velocity has shape"),
        (dict(max_velocity=[1.0, 0.0]), "max_velocity must be positive"),
        (dict(max_velocity=-1.0), "max_velocity must be positive"),
        (dict(max_velocity=[1.0, np.nan]), "max_velocity contains NaN"),
        (dict(max_velocity=np.inf), "max_velocity must be finite"),
        (dict(max_acceleration=0.0), "max_acceleration must be positive"),
        (dict(max_acceleration=[[1.0, 1.0]]), "max_acceleration has shape"),
        (dict(max_jerk=[1.0, -2.0]), "max_jerk must be positive"),
        (dict(velocity_scaling=0.0), r"velocity_scaling must be in \(0, 1\]"),
        (dict(velocity_scaling=1.5), r"velocity_scaling must be in \(0, 1\]"),
        (dict(acceleration_scaling=-0.1), r"acceleration_scaling must be in \(0, 1\]"),
        (dict(acceleration_scaling=np.nan), r"acceleration_scaling must be in \(0, 1\]"),
        (dict(joint_names=["a"]), "joint_names has 1 entries"),
        (dict(joint_names=["a", "a"]), "duplicates"),
        (dict(sample_period=0.0), "sample_period"),
        (dict(path_tolerance=-1.0), "path_tolerance"),
        (dict(path_tolerance=0.01, max_jerk=10.0), "only supported without max_jerk"),
    ],
)
def test_bad_inputs_raise(kwargs, match):
    args = dict(path=GOOD, max_velocity=1.0, max_acceleration=1.0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match) as info:
        time_parameterize(**args)
    assert isinstance(info.value, TimeParameterizationError)


def test_bad_timed_trajectory_raises():
    with pytest.raises(TimeParameterizationError, match="strictly increasing"):
        TimedTrajectory(["a"], [0.0, 0.0], [[0.0], [1.0]], [[0.0], [0.0]], [[0.0], [0.0]])
    with pytest.raises(TimeParameterizationError, match="positions has shape"):
        TimedTrajectory(["a", "b"], [0.0, 1.0], [[0.0], [1.0]], [[0.0], [0.0]], [[0.0], [0.0]])
    traj = time_parameterize(GOOD, 1.0, 1.0)
    with pytest.raises(TimeParameterizationError, match="dt"):
        traj.resample(0.0)


def test_input_not_modified():
    path = random_path(n=5, seed=12)
    before = path.copy()
    traj = time_parameterize(path, VMAX, AMAX)
    np.testing.assert_array_equal(path, before)
    traj.path[0, 0] = 99.0
    np.testing.assert_array_equal(path, before)
