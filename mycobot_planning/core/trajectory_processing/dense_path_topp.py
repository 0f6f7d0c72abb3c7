"""Method "smooth": near time-optimal path speeds (discrete TOPP) along a C2 spline through
the waypoints that stays within max_deviation of the polyline; for dense curved paths.

The algorithm and why it is written here rather than taken from toppra: see
docs/time_parameterization.md.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import CubicSpline

from ..errors import TimeParameterizationError
from ..jit import compiled, numba_available
from ..robot_trajectory.robot_trajectory import TimedTrajectory
from .path_geometry import turning_angles

__all__ = ["DEFAULT_MAX_DEVIATION", "path_deviation", "time_smooth_path"]

DEFAULT_MAX_DEVIATION = 1e-3
"""Default bound (joint-space Euclidean norm, rad/m) on how far the ``"smooth"`` method's
trajectory may stray from the polyline through the waypoints."""
# The smooth method rests at waypoints where the path turns by more than this (rad): such a
# bend cannot be taken fast within a small deviation anyway, and "auto" only picks the smooth
# method for paths with at least one bend gentler than this (a densely sampled curve).
SMOOTH_MAX_TURN = 0.35
# TOPP grid of the smooth method: at least this many intervals per piece between rests, none
# longer than this (rad/m); the optimum is resolved to about 1/_SMOOTH_MIN_INTERVALS.
_SMOOTH_MIN_INTERVALS = 64
_SMOOTH_MAX_GRID_STEP = 0.05
# Rounds of chord-midpoint insertion to bring the smooth path within max_deviation; after
# that, offending intervals become rests.
_SMOOTH_REFINE_ROUNDS = 16
# The trajectory is a cubic Hermite spline through the grid points, checked exactly. Where its
# accelerations exceed the TOPP model's by more than this fraction, the model is tightened
# there and solved again (at most _SMOOTH_FIX_ROUNDS times); a smaller excess is removed by
# slowing the whole trajectory down by at most half of it.
_SMOOTH_FIX_THRESHOLD = 1e-3
_SMOOTH_FIX_ROUNDS = 3
# Grid refinements (doubling, where the Hermite spline strays more than max_deviation from the
# polyline) before giving up.
_SMOOTH_GRID_ROUNDS = 3


def bezier_deviation(p0: np.ndarray, c1: np.ndarray, c2: np.ndarray, p3: np.ndarray,
                      a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Upper bound on the distance of each cubic Bezier (p0, c1, c2, p3) from the segment a-b.

    The curve lies in the convex hull of its control points, and the distance to a segment is
    convex, so the largest control-point distance bounds it. Splitting the curve at its middle
    first (de Casteljau) makes the bound tight for the gentle arcs met here (exact for a
    symmetric one), where the unsplit hull overestimates by a third."""
    if not numba_available():
        return _bezier_deviation_numpy(p0, c1, c2, p3, a, b)
    out = np.empty(a.shape[0])
    _bezier_deviation_kernel(*(np.ascontiguousarray(x, dtype=float) for x in (p0, c1, c2, p3, a, b)), out)
    return out


@compiled
def _bezier_deviation_kernel(p0, c1, c2, p3, a, b, out):  # pragma: no cover - compiled
    """bezier_deviation row by row (NumPy's version took ~70 small NumPy calls a call): the
    seven control points of the curve split at its middle, each one's distance to the segment."""
    d = a.shape[1]
    points = np.empty((7, d))
    for i in range(a.shape[0]):
        den = 0.0
        for k in range(d):
            ab = b[i, k] - a[i, k]
            den += ab * ab
        den = max(den, 1e-300)
        for k in range(d):
            c01 = 0.5 * (p0[i, k] + c1[i, k])
            c12 = 0.5 * (c1[i, k] + c2[i, k])
            c23 = 0.5 * (c2[i, k] + p3[i, k])
            c012 = 0.5 * (c01 + c12)
            c123 = 0.5 * (c12 + c23)
            points[0, k] = p0[i, k]
            points[1, k] = c01
            points[2, k] = c012
            points[3, k] = 0.5 * (c012 + c123)
            points[4, k] = c123
            points[5, k] = c23
            points[6, k] = p3[i, k]
        worst = 0.0
        nan = False
        for m in range(7):
            dot = 0.0
            for k in range(d):
                dot += (points[m, k] - a[i, k]) * (b[i, k] - a[i, k])
            t = min(max(dot / den, 0.0), 1.0)
            dist = 0.0
            for k in range(d):
                e = points[m, k] - a[i, k] - t * (b[i, k] - a[i, k])
                dist += e * e
            if dist != dist:
                nan = True  # NaN anywhere: NaN, as np.maximum gives
            elif math.sqrt(dist) > worst:
                worst = math.sqrt(dist)
        out[i] = math.nan if nan else worst


def _bezier_deviation_numpy(p0: np.ndarray, c1: np.ndarray, c2: np.ndarray, p3: np.ndarray,
                            a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """bezier_deviation in NumPy: without numba, and the reference the kernel is held to."""
    c01, c12, c23 = 0.5 * (p0 + c1), 0.5 * (c1 + c2), 0.5 * (c2 + p3)
    c012, c123 = 0.5 * (c01 + c12), 0.5 * (c12 + c23)
    mid = 0.5 * (c012 + c123)
    ab = b - a
    den = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    worst = np.zeros(a.shape[0])
    for p in (p0, c01, c012, mid, c123, c23, p3):
        t = np.clip(np.einsum("ij,ij->i", p - a, ab) / den, 0.0, 1.0)
        worst = np.maximum(worst, np.linalg.norm(p - a - t[:, None] * ab, axis=1))
    return worst


def _piece_splines(knots: np.ndarray, s: np.ndarray, stop: np.ndarray):
    """One C2 cubic spline (chord-length parameter, not-a-knot ends) per piece between stops.

    Returns the pieces [(first knot, last knot, spline)] and each knot interval's tangents at its
    start and end (dq/ds). Pieces are separate so that a stop's two sides do not see each
    other: the robot is at rest there, the direction may change."""
    ends = np.flatnonzero(stop)
    pieces = []
    t_start = np.empty((knots.shape[0] - 1, knots.shape[1]))
    t_end = np.empty_like(t_start)
    for a, b in zip(ends[:-1], ends[1:]):
        spline = CubicSpline(s[a:b + 1], knots[a:b + 1], axis=0)
        d1 = spline(s[a:b + 1], 1)
        t_start[a:b] = d1[:-1]
        t_end[a:b] = d1[1:]
        pieces.append((int(a), int(b), spline))
    return pieces, t_start, t_end


def _smooth_geometry(pts: np.ndarray, max_dev: float):
    """Knots through which the smooth path passes, and its splines.

    The knots are the waypoints plus points inserted on the polyline (chord midpoints) where the
    spline would stray more than ``max_dev`` from it: a closer knot pulls the curve back to the
    chord, at the price of a tighter bend (and so a lower speed) at the waypoint. Waypoints
    turning more than SMOOTH_MAX_TURN, and the ends, are stops: the robot comes to rest
    exactly on them, as the segment method does at every corner."""
    n = pts.shape[0]
    knots = pts
    is_wp = np.ones(n, dtype=bool)
    stop = np.zeros(n, dtype=bool)
    stop[[0, -1]] = True
    if n > 2:
        angle, _ = turning_angles(pts)
        stop[1:-1] = angle > SMOOTH_MAX_TURN
    rounds = 0
    while True:  # ends: every round refines (at most _SMOOTH_REFINE_ROUNDS times) or adds stops
        seg = np.linalg.norm(np.diff(knots, axis=0), axis=1)
        s = np.concatenate(([0.0], np.cumsum(seg)))
        pieces, t_start, t_end = _piece_splines(knots, s, stop)
        c1 = knots[:-1] + t_start * (seg / 3.0)[:, None]
        c2 = knots[1:] - t_end * (seg / 3.0)[:, None]
        dev = bezier_deviation(knots[:-1], c1, c2, knots[1:], knots[:-1], knots[1:])
        bad = np.flatnonzero(dev > max_dev)
        if bad.size == 0:
            return knots, s, is_wp, stop, pieces
        # A bad interval is split at its chord midpoint while that is worth it; otherwise the
        # robot rests at both its ends, which makes it a straight piece of its own (a bad
        # interval always has an end that is not a stop yet, so this terminates).
        can_split = (seg[bad] > 2.0 * max_dev) & (rounds < _SMOOTH_REFINE_ROUNDS)
        rest = bad[~can_split]
        stop[rest] = True
        stop[rest + 1] = True
        split = bad[can_split]
        if split.size:
            rounds += 1
            mid = 0.5 * (knots[split] + knots[split + 1])
            knots = np.insert(knots, split + 1, mid, axis=0)
            is_wp = np.insert(is_wp, split + 1, False)
            stop = np.insert(stop, split + 1, False)


def _grid_counts(s: np.ndarray, pieces) -> np.ndarray:
    """Grid intervals per knot interval: every piece gets at least _SMOOTH_MIN_INTERVALS, and
    none is longer than _SMOOTH_MAX_GRID_STEP."""
    seg = np.diff(s)
    counts = np.ones(seg.size, dtype=int)
    for a, b, _ in pieces:
        step = min(_SMOOTH_MAX_GRID_STEP, (s[b] - s[a]) / _SMOOTH_MIN_INTERVALS)
        counts[a:b] = np.maximum(1, np.ceil(seg[a:b] / step - 1e-9)).astype(int)
    return counts


def _smooth_grid(knots: np.ndarray, s: np.ndarray, stop: np.ndarray, pieces, counts: np.ndarray):
    """TOPP grid: the knots, plus ``counts - 1`` points on the spline inside each knot interval.

    Returns grid positions, arc-length parameter, (dq/ds, d2q/ds2) at both ends of every grid
    interval, the grid index of every knot, and the rest flags on the grid."""
    seg = np.diff(s)
    knot_grid = np.concatenate(([0], np.cumsum(counts)))
    m = int(knot_grid[-1])
    interval_knot = np.repeat(np.arange(seg.size), counts)
    frac = (np.arange(m) - knot_grid[interval_knot]) / counts[interval_knot]
    sg = np.append(s[interval_knot] + seg[interval_knot] * frac, s[-1])
    sg[knot_grid] = s  # exact knot parameters
    d = knots.shape[1]
    q = np.empty((m + 1, d))
    t0 = np.empty((m, d)); t1 = np.empty((m, d)); k0 = np.empty((m, d)); k1 = np.empty((m, d))
    for a, b, spline in pieces:
        ga, gb = knot_grid[a], knot_grid[b]
        ss = sg[ga:gb + 1]
        q[ga:gb + 1] = spline(ss)
        d1 = spline(ss, 1)
        d2 = spline(ss, 2)
        t0[ga:gb], t1[ga:gb] = d1[:-1], d1[1:]
        k0[ga:gb], k1[ga:gb] = d2[:-1], d2[1:]
    q[knot_grid] = knots  # the knots exactly, not the spline's rounding of them
    gstop = np.zeros(m + 1, dtype=bool)
    gstop[knot_grid[stop]] = True
    return q, sg, t0, k0, t1, k1, knot_grid, gstop


def _topp(ds: np.ndarray, t0: np.ndarray, k0: np.ndarray, t1: np.ndarray, k1: np.ndarray,
          amax: np.ndarray, xcap: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Time-optimal squared path speeds x = s_dot**2 on a grid (TOPP-RA's discretisation).

    The path acceleration u = s_ddot is constant on each grid interval, so
    x[i+1] = x[i] + 2 ds[i] u[i]. Joint accelerations q' u + q'' x must respect ``amax`` at
    both ends of every interval; with x[i+1] substituted, both are linear in (x[i], u):
    ``|tau u + kappa x[i]| <= A``, i.e. u in [max_k(-a_k + b_k x), min_k(a_k + b_k x)] over
    the 2 d rows k (each joint, at both ends). A backward pass computes the largest x[i] from
    which the end (and every rest) can still be reached (the controllable set), a forward pass
    then accelerates as hard as allowed without leaving it. ``xcap`` (velocity limits, rests
    = 0) caps x pointwise; ``scale`` (per interval, <= 1) tightens the acceleration limits.
    One compiled call (_topp_kernel): the rows, the caps and both passes."""
    x = np.zeros(ds.shape[0] + 1)
    _topp_kernel(np.ascontiguousarray(ds, dtype=float), np.ascontiguousarray(t0, dtype=float),
                 np.ascontiguousarray(k0, dtype=float), np.ascontiguousarray(t1, dtype=float),
                 np.ascontiguousarray(k1, dtype=float), np.ascontiguousarray(amax, dtype=float),
                 np.array(xcap, dtype=float), np.ascontiguousarray(scale, dtype=float), x)
    return x


@compiled
def _topp_kernel(ds, t0, k0, t1, k1, amax, caps, scale, x):  # pragma: no cover - compiled
    """_topp's work, written into ``caps`` (then the controllable set) and ``x``. Per interval
    i and row k: tau (the joint's path tangent, at the far end plus 2 ds q''), kappa (q''),
    A = amax scale; a row whose |tau| < 1e-12 (the path does not move that joint there) only
    caps x at A / |kappa|. u fits at all only while x (b_k - b_l) <= a_k + a_l for every pair
    of rows (a = A / |tau|, b = -sign(tau) kappa / |tau|): a cap too. The passes then take, per
    interval, the tightest row (the rows NumPy's version pruned as never binding are taken too:
    they are looser wherever x can be, so the minima are the same up to rounding)."""
    m, d = t0.shape
    rows = 2 * d
    a = np.empty(rows)
    b = np.empty(rows)
    finite = np.empty(rows, dtype=np.bool_)
    ra = np.empty((m, rows))  # a, b per interval and row; only finite rows are used
    rb = np.empty((m, rows))
    rf = np.empty((m, rows), dtype=np.bool_)
    for i in range(m):
        two_ds = 2.0 * ds[i]
        x_tiny = np.inf
        for k in range(rows):
            j = k if k < d else k - d
            if k < d:
                tau = t0[i, j]
                kap = k0[i, j]
            else:
                tau = t1[i, j] + two_ds * k1[i, j]
                kap = k1[i, j]
            lim = amax[j] * scale[i]
            at = abs(tau)
            if at < 1e-12:
                finite[k] = False
                a[k] = np.inf
                b[k] = 0.0
                if kap != 0.0:
                    x_tiny = min(x_tiny, lim / abs(kap))
            else:
                finite[k] = True
                a[k] = lim / at
                b[k] = -(1.0 if tau > 0.0 else -1.0) * kap / at
        worst = 0.0  # the diagonal pairs give 0
        undefined = False
        for k in range(rows):
            for n in range(rows):
                v = (b[k] - b[n]) / (a[k] + a[n])
                if v != v:
                    undefined = True  # as NumPy's max: a NaN pair leaves no pair cap
                elif v > worst:
                    worst = v
        x_pair = 1.0 / worst if worst > 0.0 and not undefined else np.inf
        caps[i] = min(caps[i], min(x_tiny, x_pair))
        for k in range(rows):
            ra[i, k] = a[k]
            rb[i, k] = b[k]
            rf[i, k] = finite[k]
    # Backward: x + 2 ds (-a_k + b_k x) <= caps[i+1]  <=>  x (1 + 2 ds b_k) <= caps[i+1] + 2 ds a_k;
    # rows with 1 + 2 ds b_k <= 0 never bind for x >= 0.
    c = caps[m]
    for i in range(m - 1, -1, -1):
        two_ds = 2.0 * ds[i]
        best = caps[i]
        for k in range(rows):
            if rf[i, k]:
                q = 1.0 + two_ds * rb[i, k]
                if q > 0.0:
                    v = (c + two_ds * ra[i, k]) / q
                    if v < best:
                        best = v
        c = best
        caps[i] = c
    # Forward: x[i+1] = x[i] + 2 ds min_k(a_k + b_k x[i]), within the controllable set.
    xi = 0.0
    for i in range(m):
        two_ds = 2.0 * ds[i]
        xn = caps[i + 1]
        for k in range(rows):
            if rf[i, k]:
                v = two_ds * ra[i, k] + (1.0 + two_ds * rb[i, k]) * xi
                if v < xn:
                    xn = v
        if xn < 0.0:
            xn = 0.0
        x[i + 1] = xn
        xi = xn


def _hermite(times: np.ndarray, q: np.ndarray, v: np.ndarray):
    """Accelerations at both ends of every interval of the cubic Hermite spline on (q, v), and
    the largest |velocity| inside each interval (per joint). The acceleration is linear on an
    interval, so these bound it exactly."""
    h = np.diff(times)[:, None]
    dp = np.diff(q, axis=0)
    v0, v1 = v[:-1], v[1:]
    a0 = 6.0 * dp / (h * h) - (4.0 * v0 + 2.0 * v1) / h
    a1 = -6.0 * dp / (h * h) + (2.0 * v0 + 4.0 * v1) / h
    vpeak = np.maximum(np.abs(v0), np.abs(v1))
    cross = a0 * a1 < 0.0
    if np.any(cross):
        with np.errstate(divide="ignore", invalid="ignore"):
            inner = np.abs(v0 + 0.5 * a0 * (h * a0 / (a0 - a1)))
        vpeak = np.where(cross, np.maximum(vpeak, inner), vpeak)
    return a0, a1, vpeak


def time_smooth_path(pts: np.ndarray, vmax: np.ndarray, amax: np.ndarray, names: list[str],
                         max_dev: float) -> TimedTrajectory:
    n, d = pts.shape
    if n == 1:
        z = np.zeros((1, d))
        return TimedTrajectory(names, np.zeros(1), pts.copy(), z, z.copy(), interpolation="cubic",
                               path=pts.copy(), waypoint_times=np.zeros(1))
    knots, s_knots, is_wp, stop, pieces = _smooth_geometry(pts, max_dev)
    counts = _grid_counts(s_knots, pieces)
    # The waypoint interval each knot interval lies on (inserted knots are on the chords).
    wp_of_knot = np.cumsum(is_wp)[:-1] - 1
    for attempt in range(_SMOOTH_GRID_ROUNDS + 1):
        grid = _smooth_grid(knots, s_knots, stop, pieces, counts)
        q, knot_grid = grid[0], grid[6]
        times, vel, acc = _time_grid(*grid[:6], grid[7], vmax, amax)
        # The trajectory is the cubic Hermite spline through the grid points, not the spline
        # itself: where the path speed changes fast within a grid interval their shapes differ
        # a little. Check it against the polyline and refine the grid where it strays.
        h = np.diff(times)[:, None]
        seg_wp = np.repeat(wp_of_knot, counts)
        dev = bezier_deviation(q[:-1], q[:-1] + vel[:-1] * h / 3.0, q[1:] - vel[1:] * h / 3.0,
                                q[1:], pts[seg_wp], pts[seg_wp + 1])
        bad_knot = np.zeros(counts.size, dtype=bool)
        bad_knot[np.repeat(np.arange(counts.size), counts)[dev > max_dev]] = True
        if not np.any(bad_knot):
            break
        if attempt == _SMOOTH_GRID_ROUNDS:
            raise TimeParameterizationError(
                f"smooth time parameterisation could not keep the trajectory within "
                f"max_deviation={max_dev:g} of the path (reached {float(dev.max()):.3g}); "
                f"use method='segments'")
        counts = np.where(bad_knot, 2 * counts, counts)
    return TimedTrajectory(names, times, q, vel, acc, interpolation="cubic", path=pts.copy(),
                           waypoint_times=times[knot_grid[is_wp]])


def _time_grid(q: np.ndarray, sg: np.ndarray, t0: np.ndarray, k0: np.ndarray, t1: np.ndarray,
               k1: np.ndarray, gstop: np.ndarray, vmax: np.ndarray, amax: np.ndarray):
    """Times, velocities and (right-hand) accelerations at the grid points: TOPP path speeds,
    turned into a cubic Hermite spline whose limits are checked exactly."""
    m, d = t0.shape
    ds = np.diff(sg)
    # Velocity caps at the grid points, from the tangent on either side.
    with np.errstate(divide="ignore"):
        inv = np.full(m + 1, np.inf)
        inv[:-1] = np.min(np.where(t0 != 0.0, vmax / np.abs(t0), np.inf), axis=1)
        inv[1:] = np.minimum(inv[1:], np.min(np.where(t1 != 0.0, vmax / np.abs(t1), np.inf),
                                             axis=1))
    xcap = inv * inv
    xcap[gstop] = 0.0
    tangent = np.concatenate((t0, t1[-1:]), axis=0)  # right-hand tangents (C1 inside pieces)
    scale = np.ones(m)
    for fix in range(_SMOOTH_FIX_ROUNDS + 1):
        x = _topp(ds, t0, k0, t1, k1, amax, xcap, scale)
        sdot = np.sqrt(x)
        speed_sum = sdot[:-1] + sdot[1:]
        if not np.all(speed_sum > 0.0):
            raise TimeParameterizationError(
                "smooth time parameterisation found a grid interval it cannot move along "
                "(both ends at rest)")
        times = np.concatenate(([0.0], np.cumsum(2.0 * ds / speed_sum)))
        vel = tangent * sdot[:, None]
        vel[gstop] = 0.0
        # The TOPP model bounds the accelerations of the ideal motion along the spline at the
        # grid points; the trajectory is the cubic Hermite spline on (q, vel), whose
        # accelerations (linear on each interval, so checked exactly at its ends) differ by a
        # few per cent where the grid is coarse. Tighten the model where they exceed the limits
        # and solve again: an interval's Hermite accelerations scale with its speeds squared.
        a0, a1, vpeak = _hermite(times, q, vel)
        ratio_a = np.max(np.maximum(np.abs(a0), np.abs(a1)) / amax, axis=1)
        ratio_v = np.max(vpeak / vmax, axis=1)
        worst = max(float(ratio_a.max()), float(ratio_v.max()) ** 2)
        if worst <= 1.0 + _SMOOTH_FIX_THRESHOLD or fix == _SMOOTH_FIX_ROUNDS:
            break
        over = ratio_a > 1.0
        scale[over] /= ratio_a[over]
        over_v = np.flatnonzero(ratio_v > 1.0)
        for idx in (over_v, over_v + 1):
            xcap[idx] = np.minimum(xcap[idx], x[idx] / ratio_v[over_v] ** 2)
    # What is left is removed by slowing the whole trajectory down uniformly: scaling time by
    # k scales velocities by 1/k and accelerations by 1/k**2, keeping the geometry.
    k = max(1.0, math.sqrt(float(ratio_a.max())), float(ratio_v.max()))
    if k > 1.0:
        k *= 1.0 + 1e-12
        times, vel, a0 = times * k, vel / k, a0 / (k * k)
    acc = np.concatenate((a0, np.zeros((1, d))), axis=0)
    return times, vel, acc


def path_deviation(trajectory: TimedTrajectory) -> float:
    """How far (joint-space Euclidean norm) the trajectory strays from its polyline
    ``trajectory.path``: an upper bound, tight for gentle arcs, from the Bezier control points
    of each cubic Hermite piece against the chord of the waypoint interval it lies in (found
    with ``waypoint_times``). Meaningful for what :func:`time_parameterize` returns with
    ``path_tolerance=0`` (a blend spans two chords); ~1e-16 for the ``"segments"`` method,
    at most ``max_deviation`` for ``"smooth"``; ``nan`` when the trajectory carries no path."""
    if trajectory.path is None or trajectory.waypoint_times is None or len(trajectory) < 2:
        return float("nan")
    path, wt = trajectory.path, trajectory.waypoint_times
    times, q, v = trajectory.times, trajectory.positions, trajectory.velocities
    h = np.diff(times)[:, None]
    mid = 0.5 * (times[:-1] + times[1:])
    seg = np.clip(np.searchsorted(wt, mid, side="right") - 1, 0, path.shape[0] - 2)
    dev = bezier_deviation(q[:-1], q[:-1] + v[:-1] * h / 3.0, q[1:] - v[1:] * h / 3.0, q[1:],
                            path[seg], path[seg + 1])
    return float(np.max(dev))

