"""Time parameterisation of dense curved paths (method "smooth" / "auto").

A Cartesian path is a curve sampled densely in joint space. Timing it segment by segment (the
exact "segments" method) rests at every waypoint; these tests pin down that the smooth method
instead gets close to the limits, stays within the limits as the validator samples them, stays
close to the polyline and passes through every waypoint, and that "auto" keeps the exact
method for sparse paths.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.planners.cartesian.cartesian_path import compute_cartesian_path
from mycobot_planning.core.kinematics.ik_solver import IKSolver
from mycobot_planning.core.planning_interface.planning_interface import time_group_path
from mycobot_planning.core.trajectory_processing import DEFAULT_MAX_DEVIATION, TimedTrajectory, TimeParameterizationError, path_deviation, retime, time_parameterize
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory
from mycobot_planning.core.transforms import make_pose

REL = 1e-6  # the validator's relative limit tolerance
PANDA_READY = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]


# ---------------------------------------------------------------------------- helpers
def interval_samples(traj: TimedTrajectory, per: int = 12):
    """The trajectory's own interpolation, ``per`` samples inside every stored interval (the
    validator samples only where the motion exceeds its resolution: this is stricter)."""
    t = traj.times
    frac = np.linspace(0.0, 1.0, per, endpoint=False)
    ts = np.append((t[:-1, None] + np.diff(t)[:, None] * frac[None, :]).ravel(), t[-1])
    q, qd, qdd = traj.sample(ts)
    return ts, q, qd, qdd


def assert_within_limits(traj: TimedTrajectory, vmax, amax) -> None:
    ts, q, qd, qdd = interval_samples(traj)
    assert np.all(np.abs(qd) <= np.asarray(vmax) * (1 + REL)), np.max(np.abs(qd) / vmax)
    assert np.all(np.abs(qdd) <= np.asarray(amax) * (1 + REL)), np.max(np.abs(qdd) / amax)
    # The reported velocities are the real ones: the velocity from position differences
    # obeys the limit as well.
    assert np.all(np.abs(np.diff(q, axis=0)) <= np.asarray(vmax) * np.diff(ts)[:, None] * (1 + 1e-4))


def chord_distance(traj: TimedTrajectory, per: int = 12) -> float:
    """Largest sampled distance of the trajectory from the chord of the waypoint interval it
    is in (an upper bound on the distance from the polyline)."""
    ts, q, _, _ = interval_samples(traj, per)
    path, wt = traj.path, traj.waypoint_times
    k = np.clip(np.searchsorted(wt, ts, side="right") - 1, 0, len(path) - 2)
    a, b = path[k], path[k + 1]
    ab = b - a
    u = np.clip(np.einsum("ij,ij->i", q - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
    return float(np.max(np.linalg.norm(q - a - u[:, None] * ab, axis=1)))


def velocity_lower_bound(path: np.ndarray, vmax: np.ndarray) -> float:
    """No trajectory through the waypoints is faster than each step at the limiting joint's
    top speed."""
    return float(np.sum(np.max(np.abs(np.diff(path, axis=0)) / vmax, axis=1)))


def smooth_curve(center, amplitude, n: int, seed: int) -> np.ndarray:
    """A random smooth joint-space curve around ``center``, sampled at n points."""
    rng = np.random.default_rng(seed)
    d = len(center)
    s = np.linspace(0.0, 1.0, n)[:, None]
    freq = rng.uniform(0.5, 1.5, size=(3, d))
    phase = rng.uniform(0.0, 2 * math.pi, size=(3, d))
    weight = rng.uniform(-1.0, 1.0, size=(3, d))
    wave = sum(weight[i] * (np.sin(2 * math.pi * freq[i] * s + phase[i]) - np.sin(phase[i]))
               for i in range(3))
    return np.asarray(center, dtype=float) + amplitude * wave / 3.0


def polyline_is_free(scene: PlanningScene, start: RobotState, group: str, path: np.ndarray) -> bool:
    model = scene.robot_model
    idx = model.group(group).variable_indices
    full = start.positions.copy()
    for a, b in zip(path[:-1], path[1:]):
        for f in (0.0, 0.5):
            full[idx] = a + f * (b - a)
            if not scene.is_valid_positions(full):
                return False
    full[idx] = path[-1]
    return scene.is_valid_positions(full)


# ---------------------------------------------------------------------------- Cartesian line
@pytest.fixture(scope="module")
def cartesian_line(mycobot: RobotModel):
    """The flange pointing down at (0.18, -0.15, 0.20), and the 0.3 m line to (0.18, 0.15,
    0.20) across the front of the robot, on the IK branch that completes it."""
    start_pose = make_pose((0.18, -0.15, 0.20), rpy=(math.pi, 0.0, 0.0))
    end_pose = make_pose((0.18, 0.15, 0.20), rpy=(math.pi, 0.0, 0.0))
    seed = RobotState(mycobot)
    seed.set_named("ready")
    solutions = IKSolver(mycobot, "arm").solve(start_pose, seed=seed, rng=0, timeout=0.5,
                                               max_solutions=6, min_solution_distance=0.5)
    scene = PlanningScene(mycobot)
    for state in solutions:
        if compute_cartesian_path(scene, "arm", state, [end_pose], eef_step=0.01).fraction == 1.0:
            return PlanningScene(mycobot, state), state, end_pose
    pytest.fail("no IK branch completes the Cartesian line")


def test_dense_cartesian_line_is_fast_valid_and_on_the_path(mycobot, cartesian_line):
    scene, start, end_pose = cartesian_line
    result = compute_cartesian_path(scene, "arm", start, [end_pose], eef_step=0.00025)
    assert result.fraction == 1.0
    path, traj = result.path, result.trajectory
    assert path.shape == (1201, 6)
    idx = mycobot.group("arm").variable_indices
    vmax, amax = mycobot.velocity_limits[idx], mycobot.acceleration_limits[idx]

    bound = velocity_lower_bound(path, vmax)
    assert traj.duration <= 3.0 * bound, (traj.duration, bound)
    # Resting at every waypoint (the exact segment method) takes more than 20 times as long.
    exact = time_parameterize(path, vmax, amax, method="segments")
    assert exact.duration > 20 * traj.duration

    report = validate_trajectory(scene, traj, "arm", start)
    assert report.valid, report.problems
    assert_within_limits(traj, vmax, amax)
    # Through every waypoint, and within a few micro-radians of the polyline in between.
    np.testing.assert_allclose(traj.sample(traj.waypoint_times)[0], path, atol=1e-12)
    assert path_deviation(traj) <= 1e-4
    assert chord_distance(traj) <= path_deviation(traj) * (1 + 1e-9) + 1e-15
    # Not stopping on the way: every interior waypoint is passed at speed.
    speeds = np.max(np.abs(traj.sample(traj.waypoint_times[1:-1])[1]), axis=1)
    assert np.min(speeds) > 0.05 * np.max(vmax)


def test_dense_cartesian_line_scaled(mycobot, cartesian_line):
    scene, start, end_pose = cartesian_line
    full = compute_cartesian_path(scene, "arm", start, [end_pose], eef_step=0.00025)
    half = compute_cartesian_path(scene, "arm", start, [end_pose], eef_step=0.00025,
                                  velocity_scaling=0.5, acceleration_scaling=0.5)
    assert half.trajectory.duration > 1.2 * full.trajectory.duration
    report = validate_trajectory(scene, half.trajectory, "arm", start,
                                 velocity_scaling=0.5, acceleration_scaling=0.5)
    assert report.valid, report.problems
    idx = mycobot.group("arm").variable_indices
    assert_within_limits(half.trajectory, 0.5 * mycobot.velocity_limits[idx],
                         0.5 * mycobot.acceleration_limits[idx])


@pytest.mark.parametrize("eef_step", [0.005, 0.01])
def test_coarser_cartesian_line_stays_within_max_deviation(mycobot, cartesian_line, eef_step):
    """At eef_step 0.01 a spline through the waypoints bulges ~1.8e-3 rad from the chords:
    knots inserted on the chords keep it within the default 1e-3."""
    scene, start, end_pose = cartesian_line
    result = compute_cartesian_path(scene, "arm", start, [end_pose], eef_step=eef_step)
    traj = result.trajectory
    report = validate_trajectory(scene, traj, "arm", start)
    assert report.valid, report.problems
    assert path_deviation(traj) <= DEFAULT_MAX_DEVIATION
    assert chord_distance(traj) <= DEFAULT_MAX_DEVIATION
    np.testing.assert_allclose(traj.sample(traj.waypoint_times)[0], result.path, atol=1e-12)
    idx = mycobot.group("arm").variable_indices
    exact = time_parameterize(result.path, mycobot.velocity_limits[idx],
                              mycobot.acceleration_limits[idx])
    assert traj.duration < 0.5 * exact.duration
    # A looser bound lets the curve bend less tightly: never slower.
    loose = time_group_path(mycobot, mycobot.group("arm"), result.path, 1.0, 1.0,
                            max_deviation=5e-3)
    assert loose.duration <= traj.duration * (1 + 1e-9)
    assert path_deviation(loose) <= 5e-3


# ---------------------------------------------------------------------------- random curves
@pytest.mark.parametrize("seed", [0, 2, 3])  # collision-free curves (asserted below)
@pytest.mark.parametrize("n", [150, 800])
def test_random_dense_curves_on_mycobot_pass_the_validator(mycobot, seed, n):
    start = RobotState(mycobot)
    start.set_named("ready")
    scene = PlanningScene(mycobot, start)
    path = smooth_curve(start.group_positions("arm"), 0.6, n, seed)
    assert polyline_is_free(scene, start, "arm", path)
    jmg = mycobot.group("arm")
    vmax, amax = mycobot.velocity_limits[jmg.variable_indices], mycobot.acceleration_limits[jmg.variable_indices]
    for vs, acc in ((1.0, 1.0), (0.4, 0.7)):
        traj = time_group_path(mycobot, jmg, path, vs, acc)
        report = validate_trajectory(scene, traj, "arm", start, velocity_scaling=vs, acceleration_scaling=acc)
        assert report.valid, report.problems
        assert_within_limits(traj, vs * vmax, acc * amax)
        assert path_deviation(traj) <= DEFAULT_MAX_DEVIATION
        np.testing.assert_allclose(traj.sample(traj.waypoint_times)[0], path, atol=1e-12)
        exact = time_parameterize(path, vmax, amax, velocity_scaling=vs, acceleration_scaling=acc)
        assert traj.duration < 0.5 * exact.duration


@pytest.mark.parametrize("seed", [3, 4])
def test_random_dense_curves_on_panda_pass_the_validator(panda, seed):
    start = RobotState(panda)
    start.set_group_positions("arm", PANDA_READY)
    scene = PlanningScene(panda, start)
    path = smooth_curve(PANDA_READY, 0.5, 500, seed)
    assert polyline_is_free(scene, start, "arm", path)
    jmg = panda.group("arm")
    vmax, amax = panda.velocity_limits[jmg.variable_indices], panda.acceleration_limits[jmg.variable_indices]
    for vs, acc in ((1.0, 1.0), (0.5, 0.25)):
        traj = time_group_path(panda, jmg, path, vs, acc, sample_period=0.01 if vs < 1 else None)
        report = validate_trajectory(scene, traj, "arm", start, velocity_scaling=vs, acceleration_scaling=acc)
        assert report.valid, report.problems
        assert_within_limits(traj, vs * vmax, acc * amax)
        assert chord_distance(traj) <= DEFAULT_MAX_DEVIATION
        exact = time_parameterize(path, vmax, amax, velocity_scaling=vs, acceleration_scaling=acc)
        assert traj.duration < 0.5 * exact.duration


def test_scaling_slows_the_smooth_method_down():
    path = smooth_curve(np.zeros(6), 1.0, 400, 7)
    vmax, amax = np.full(6, 2.0), np.full(6, 4.0)
    full = time_parameterize(path, vmax, amax, method="smooth")
    assert time_parameterize(path, vmax, amax, method="smooth", velocity_scaling=0.5).duration > full.duration
    assert time_parameterize(path, vmax, amax, method="smooth", acceleration_scaling=0.5).duration > full.duration
    half = time_parameterize(path, vmax, amax, method="smooth", velocity_scaling=0.5, acceleration_scaling=0.25)
    # Halving speeds and quartering accelerations is exactly twice as slow for the same path.
    assert half.duration == pytest.approx(2.0 * full.duration, rel=1e-6)
    assert_within_limits(half, 0.5 * vmax, 0.25 * amax)


def test_sample_period_output_is_exact():
    path = smooth_curve(np.zeros(4), 0.8, 300, 11)
    traj = time_parameterize(path, 1.5, 3.0, method="smooth")
    dense = time_parameterize(path, 1.5, 3.0, method="smooth", sample_period=0.01)
    assert dense.duration == pytest.approx(traj.duration, rel=1e-12)
    ts = np.linspace(0.0, traj.duration, 5001)
    np.testing.assert_allclose(dense.sample(ts)[0], traj.sample(ts)[0], atol=1e-12)
    np.testing.assert_allclose(dense.sample(ts)[1], traj.sample(ts)[1], atol=1e-9)


# ---------------------------------------------------------------------------- method choice
def test_auto_keeps_the_exact_method_for_sparse_paths():
    rng = np.random.default_rng(5)
    corners = np.cumsum(rng.uniform(-1.0, 1.0, size=(8, 6)), axis=0)  # sharp corners only
    dense = np.concatenate([np.linspace(a, b, 9, endpoint=False)
                            for a, b in zip(corners[:-1], corners[1:])] + [corners[-1:]])
    vmax, amax = np.full(6, 2.0), np.full(6, 4.0)
    for path in (corners, dense, corners[:2]):
        auto = time_parameterize(path, vmax, amax, method="auto")
        exact = time_parameterize(path, vmax, amax, method="segments")
        np.testing.assert_array_equal(auto.times, exact.times)
        np.testing.assert_array_equal(auto.positions, exact.positions)
        assert path_deviation(auto) <= 1e-12


def test_auto_keeps_the_exact_method_with_jerk_limits():
    path = smooth_curve(np.zeros(6), 1.0, 100, 3)
    auto = time_parameterize(path, 2.0, 4.0, max_jerk=40.0, method="auto")
    exact = time_parameterize(path, 2.0, 4.0, max_jerk=40.0)
    np.testing.assert_array_equal(auto.times, exact.times)
    with pytest.raises(TimeParameterizationError, match="max_jerk"):
        time_parameterize(path, 2.0, 4.0, max_jerk=40.0, method="smooth")


def test_auto_picks_smooth_for_dense_curves():
    path = smooth_curve(np.zeros(3), 1.0, 200, 9)
    auto = time_parameterize(path, 1.0, 2.0, method="auto")
    smooth = time_parameterize(path, 1.0, 2.0, method="smooth")
    np.testing.assert_array_equal(auto.times, smooth.times)


# ---------------------------------------------------------------------------- smooth method
def test_straight_path_matches_the_trapezoid():
    path = np.array([[0.0, 0.0], [1.0, 0.5]])
    exact = time_parameterize(path, 1.0, 2.0)
    smooth = time_parameterize(path, 1.0, 2.0, method="smooth")
    assert smooth.duration == pytest.approx(exact.duration, rel=1e-3)
    assert smooth.duration >= exact.duration * (1 - 1e-9)  # the exact one is optimal
    assert path_deviation(smooth) <= 1e-12
    assert_within_limits(smooth, np.ones(2), 2.0 * np.ones(2))


def test_sharp_corner_is_a_rest_exactly_on_the_waypoint():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    traj = time_parameterize(path, 1.0, 2.0, method="smooth")
    q, qd, _ = traj.sample(traj.waypoint_times[1])
    np.testing.assert_allclose(q, [1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(qd, 0.0, atol=1e-12)
    assert path_deviation(traj) <= 1e-12
    assert traj.duration == pytest.approx(time_parameterize(path, 1.0, 2.0).duration, rel=1e-3)


def test_gentle_bend_is_passed_within_max_deviation():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.2]])  # turns by 0.2 rad
    stop = time_parameterize(path, 1.0, 2.0)
    durations = []
    for tol in (1e-4, 1e-3, 1e-2):
        traj = time_parameterize(path, 1.0, 2.0, method="smooth", max_deviation=tol)
        assert path_deviation(traj) <= tol
        assert chord_distance(traj, per=40) <= tol
        _, qd, _ = traj.sample(traj.waypoint_times[1])
        assert np.linalg.norm(qd) > 0.1  # no rest at the bend
        np.testing.assert_allclose(traj.sample(traj.waypoint_times)[0], path, atol=1e-12)
        assert_within_limits(traj, np.ones(2), 2.0 * np.ones(2))
        durations.append(traj.duration)
    assert durations[0] < stop.duration
    assert durations[0] >= durations[1] >= durations[2]


def test_single_waypoint_and_duplicates():
    one = time_parameterize([[0.1, 0.2]] * 3, 1.0, 1.0, method="smooth")
    assert len(one) == 1 and one.duration == 0.0
    path = smooth_curve(np.zeros(3), 1.0, 60, 2)
    a = time_parameterize(path, 1.0, 2.0, method="smooth")
    b = time_parameterize(np.repeat(path, 2, axis=0), 1.0, 2.0, method="smooth")
    assert b.duration == pytest.approx(a.duration, rel=1e-12)
    np.testing.assert_array_equal(b.path, path)


def test_retime_passes_the_method_on():
    path = smooth_curve(np.zeros(6), 1.0, 300, 4)
    traj = time_parameterize(path, 2.0, 4.0, method="smooth")
    slower = retime(traj, 2.0, 4.0, velocity_scaling=0.5, method="smooth")
    np.testing.assert_array_equal(slower.path, path)
    assert slower.duration > traj.duration
    assert slower.duration < 0.5 * retime(traj, 2.0, 4.0, velocity_scaling=0.5).duration


def test_path_deviation_of_exact_and_unknown_paths():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    assert path_deviation(time_parameterize(path, 1.0, 2.0)) <= 1e-12
    bare = TimedTrajectory(["a"], [0.0, 1.0], [[0.0], [1.0]], [[0.0], [0.0]], [[0.0], [0.0]])
    assert math.isnan(path_deviation(bare))


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(method="fast"), "unknown method"),
        (dict(method="smooth", max_deviation=0.0), "max_deviation"),
        (dict(method="smooth", max_deviation=float("nan")), "max_deviation"),
        (dict(method="smooth", max_deviation="x"), "max_deviation"),
        (dict(method="smooth", path_tolerance=0.01), "path_tolerance"),
    ],
)
def test_bad_inputs_raise(kwargs, match):
    with pytest.raises(TimeParameterizationError, match=match):
        time_parameterize([[0.0, 0.0], [1.0, 0.1], [2.0, 0.3]], 1.0, 1.0, **kwargs)


# ---------------------------------------------------------------- the compiled TOPP against NumPy's
# The vectorised TOPP dense_path_topp ran before its kernel (rows that never bind pruned in NumPy,
# the two passes as Python loops): the reference _topp_kernel is held to.
def _reference_pareto(w0: np.ndarray, w1: np.ndarray) -> np.ndarray:
    """Per row, the lines (values w0 at x = 0 and w1 at the row's largest x; smaller is
    tighter) that may bind somewhere in between: a line is dropped when another is at least as
    tight at both ends, hence everywhere between. Vectorised: sorted by w0, a line survives
    only if it is strictly tighter at the far end than every line before it. Infinite lines
    never survive."""
    order = np.argsort(w0, axis=1, kind="stable")
    w1s = np.take_along_axis(w1, order, axis=1)
    before = np.minimum.accumulate(w1s, axis=1)
    survive = np.empty_like(w1s, dtype=bool)
    survive[:, 0] = True
    survive[:, 1:] = w1s[:, 1:] < before[:, :-1]
    survive &= np.isfinite(w1s) & np.isfinite(np.take_along_axis(w0, order, axis=1))
    keep = np.zeros_like(survive)
    np.put_along_axis(keep, order, survive, axis=1)
    return keep


def _reference_topp(ds: np.ndarray, t0: np.ndarray, k0: np.ndarray, t1: np.ndarray, k1: np.ndarray,
                    amax: np.ndarray, xcap: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """dense_path_topp._topp as NumPy computed it (its docstring says what): the rows that never
    bind pruned first (vectorised), then the two passes as plain loops."""
    m = ds.shape[0]
    two_ds = 2.0 * ds
    tau = np.concatenate((t0, t1 + two_ds[:, None] * k1), axis=1)  # (m, 2d)
    kap = np.concatenate((k0, k1), axis=1)
    lim = np.concatenate((amax, amax))[None, :] * scale[:, None]
    at = np.abs(tau)
    tiny = at < 1e-12
    safe = np.where(tiny, 1.0, at)
    finite = ~tiny
    a = np.where(tiny, np.inf, lim / safe)
    b = np.where(tiny, 0.0, -np.sign(tau) * kap / safe)
    with np.errstate(divide="ignore", invalid="ignore"):
        # A joint the path does not move here: only its curvature term, a cap on x.
        x_tiny = np.min(np.where(tiny & (kap != 0.0), lim / np.abs(kap), np.inf), axis=1)
        # Some u must fit: -a_k + b_k x <= a_l + b_l x, i.e. x (b_k - b_l) / (a_k + a_l) <= 1,
        # for every pair of rows (k, l); rows of unmoved joints (a = inf) give 0.
        worst = np.max((b[:, :, None] - b[:, None, :]) / (a[:, :, None] + a[:, None, :]),
                       axis=(1, 2))
        x_pair = np.where(worst > 0.0, 1.0 / worst, np.inf)
    a = np.where(finite, a, 0.0)
    cap = xcap.copy()
    cap[:-1] = np.minimum(cap[:-1], np.minimum(x_tiny, x_pair))
    xh = np.minimum(cap[:-1], 1e300)[:, None]  # finite, so 0 * xh is 0
    inf = np.where(finite, 0.0, np.inf)
    up_keep = _reference_pareto(a + inf, a + b * xh + inf)
    lo_keep = _reference_pareto(a + inf, a - b * xh + inf)
    # Backward: x + 2 ds (-a_k + b_k x) <= cap[i+1]  <=>  x (1 + 2 ds b_k) <= cap[i+1] + 2 ds a_k;
    # rows with 1 + 2 ds b_k <= 0 never bind for x >= 0.
    q_back = 1.0 + two_ds[:, None] * b
    rows, cols = np.nonzero(lo_keep & (q_back > 0.0))
    bp = two_ds[rows] * a[rows, cols]
    bq = q_back[rows, cols]
    b_bnd = np.searchsorted(rows, np.arange(m + 1))
    # Forward: x[i+1] = x[i] + 2 ds min_k(a_k + b_k x[i]), within the controllable set.
    rows, cols = np.nonzero(up_keep)
    fp = two_ds[rows] * a[rows, cols]
    fq = 1.0 + two_ds[rows] * b[rows, cols]
    f_bnd = np.searchsorted(rows, np.arange(m + 1))
    caps = np.array(cap, dtype=float)
    x = np.zeros(m + 1)
    _reference_passes(caps, b_bnd, bp, bq, f_bnd, fp, fq, x)
    return x


def _reference_passes(caps, b_bnd, bp, bq, f_bnd, fp, fq, x):
    """The two passes over the grid as plain Python: backward, the largest x[i] from which the
    rest can be reached (into ``caps``); forward, the path speeds squared (into ``x``)."""
    m = caps.shape[0] - 1
    for i in reversed(range(m)):  # min keeps the first of equal values, as a strict-less loop
        caps[i] = min([caps[i]] + [(caps[i + 1] + bp[j]) / bq[j] for j in range(b_bnd[i], b_bnd[i + 1])])
    for i in range(m):
        xn = min([caps[i + 1]] + [fp[j] + fq[j] * x[i] for j in range(f_bnd[i], f_bnd[i + 1])])
        x[i + 1] = xn if xn >= 0.0 else 0.0


def _topp_calls(monkeypatch) -> list:
    """Every _topp call (arguments copied when called: the caller changes xcap and scale
    afterwards) of smooth timings of random curves and random polylines with a stop."""
    from mycobot_planning.core.trajectory_processing import dense_path_topp

    calls = []
    topp = dense_path_topp._topp

    def spy(*args):
        saved = [np.array(a, copy=True) for a in args]
        x = topp(*args)
        calls.append((saved, x))
        return x

    monkeypatch.setattr(dense_path_topp, "_topp", spy)
    rng = np.random.default_rng(5)
    t = np.linspace(0.0, 1.0, 300)[:, None]
    for _ in range(8):
        path = np.hstack([0.5 * (1.0 + 0.3 * rng.normal()) * np.sin(3.0 * t + i) for i in range(6)])
        time_parameterize(path, 1.5, 3.0, method="smooth")
    for _ in range(8):
        path = np.cumsum(rng.normal(size=(20, 7)) * 0.1, axis=0)
        path[5] = path[4]  # a repeated waypoint: a stop
        time_parameterize(path, rng.uniform(0.5, 2.0, 7), rng.uniform(1.0, 5.0, 7), method="smooth")
    return calls


def test_compiled_topp_gives_the_numpy_topps_speeds(monkeypatch):
    """dense_path_topp._topp (one compiled kernel, every row in the passes) against the NumPy
    version it replaced (rows that never bind pruned first): the same squared path speeds on
    every call of 16 timings (measured before writing this: bit for bit on all 24 calls)."""
    calls = _topp_calls(monkeypatch)
    assert len(calls) >= 16
    for args, x in calls:
        reference = _reference_topp(*[np.array(a, copy=True) for a in args])
        np.testing.assert_allclose(x, reference, rtol=1e-12, atol=0.0)


def test_compiled_topp_gives_the_python_loops_results(monkeypatch):
    """The kernel compiled and the same code run as plain Python (numba's py_func) give the same
    trajectories bit for bit."""
    from mycobot_planning.core.jit import numba_available
    from mycobot_planning.core.trajectory_processing import dense_path_topp

    if not numba_available():
        pytest.skip("numba is not installed (scripts/requirements.txt): nothing compiled to compare")
    rng = np.random.default_rng(5)
    t = np.linspace(0.0, 1.0, 300)[:, None]
    for _ in range(8):
        path = np.hstack([0.5 * (1.0 + 0.3 * rng.normal()) * np.sin(3.0 * t + i) for i in range(6)])
        compiled = time_parameterize(path, 1.5, 3.0, method="smooth")
        with monkeypatch.context() as patch:
            patch.setattr(dense_path_topp, "_topp_kernel", dense_path_topp._topp_kernel.py_func)
            plain = time_parameterize(path, 1.5, 3.0, method="smooth")
        for name in ("times", "positions", "velocities", "accelerations"):
            assert np.array_equal(getattr(compiled, name), getattr(plain, name)), name


def test_compiled_bezier_deviation_is_numpys():
    """The compiled deviation bound gives the NumPy version's values (within rounding: the sums
    run in another order) on random curves of 1 to 7 joints, degenerate segments and NaN."""
    from mycobot_planning.core.jit import numba_available
    from mycobot_planning.core.trajectory_processing import dense_path_topp

    if not numba_available():
        pytest.skip("numba is not installed (scripts/requirements.txt): only the NumPy version runs")
    rng = np.random.default_rng(8)
    for _ in range(200):
        n, d = int(rng.integers(1, 50)), int(rng.integers(1, 8))
        p0, c1, c2, p3 = (rng.normal(size=(n, d)) for _ in range(4))
        a, b = p0 + 0.1 * rng.normal(size=(n, d)), p3 + 0.1 * rng.normal(size=(n, d))
        b[0] = a[0]  # a segment of zero length
        if rng.random() < 0.2:
            c1[rng.integers(n), rng.integers(d)] = np.nan
        ours = dense_path_topp.bezier_deviation(p0, c1, c2, p3, a, b)
        reference = dense_path_topp._bezier_deviation_numpy(p0, c1, c2, p3, a, b)
        assert np.allclose(ours, reference, rtol=1e-12, atol=1e-14, equal_nan=True)
