"""Time parameterisation of collision-checked joint-space paths (MoveIt's TOTG / Ruckig role).

A planner hands us a geometric path: N joint-space waypoints whose piecewise-linear
interpolation was collision-checked. We must give it timing (velocities, accelerations,
time stamps) that is as fast as the joint limits allow **without leaving that polyline**,
because any deviation is motion nobody has checked.

Two methods (``time_parameterize(method=...)``):

* ``"segments"`` (default): one Ruckig profile per straight run, exactly on the polyline,
  resting at every real corner. Exact and optimal for sparse paths (OMPL's corners, PTP).
* ``"smooth"``: a near time-optimal path-speed profile (discrete TOPP) along a smooth curve
  through every waypoint that stays within ``max_deviation`` (default 1e-3) of the polyline.
  For densely sampled curves (Cartesian paths: hundreds of waypoints, each turning a little),
  where resting at every waypoint takes 10-30 times longer than needed.

``"auto"`` (what planning_interface.time_group_path uses) picks ``"smooth"`` when the path has
at least one gentle bend and no jerk limit is set, else ``"segments"``.

Why this is segment-wise and not one Ruckig call with waypoints
-----------------------------------------------------------------
Ruckig's ``InputParameter.intermediate_positions`` is a Ruckig *Pro* feature. In the
community build shipped as the ``ruckig`` 0.19 PyPI wheel, setting it makes ``calculate``
print ``[ruckig] calculate trajectory via cloud API`` and try to reach a remote server (and
fail offline with ``RuckigError``). We never use it. Ruckig also plans the path and the timing
*jointly* there, i.e. it would cut corners, which we must not do anyway.

So each straight segment gets its own Ruckig profile. Moving exactly along the segment
direction ``u`` is a one-dimensional problem in the arc length ``s``: ``q(t) = w + s(t) u``.
The per-joint limits become limits on ``s``: ``v_s <= min_j vmax_j / |u_j|`` (same for
acceleration and jerk). This is precisely what Ruckig's ``Synchronization.Phase`` does for a
multi-DoF move whose start/target velocities are parallel to the displacement (the limiting
joint fixes the profile, the others are scaled copies) when it works, but Phase falls back to
Time synchronisation when the scaled profile would break another joint's limit (documented in
Ruckig's input_parameter.hpp). That fallback is not rare: for random rest-to-rest 6-DoF
segments under unequal limits it happened in ~1.5 % of cases, leaving the line by up to 0.09
rad. A 1-DoF profile in ``s`` cannot fall back, so the result stays on the line by
construction. Where Phase does succeed, both give the same duration (to 1e-15).

Runs of collinear waypoints are timed as one segment, and the waypoints inside are stamped
where the profile passes them (``Trajectory.get_first_time_at_position``), so densely
interpolated paths are not slowed down by zero-acceleration targets at every waypoint.

Corners
-------
A trajectory that stays on a polyline *and* has continuous velocity must stop at every
corner: the velocity at the corner would have to be parallel to both segments. Waypoints on a
straight line (e.g. a densely interpolated OMPL path) are passed at speed; at real corners the
robot stops, unless the caller grants a ``path_tolerance`` > 0: the corner is then replaced by
a constant-acceleration parabolic blend (the LSPB/TOTG idea) whose distance from the corner
waypoint is at most ``path_tolerance`` (joint-space Euclidean norm, radians/metres), and whose
per-joint acceleration respects the limits. That blend needs an acceleration step, so it is
only offered for the acceleration-limited (``max_jerk=None``) case. Pass-through speeds are
found with the classic forward/backward pass over the segments, using the exact minimum
distance a jerk-limited (or acceleration-limited) velocity change needs, so every per-segment
Ruckig profile is feasible without overshooting the segment end.

Output representation
---------------------
``sample_period=None`` stores every point where the motion changes polynomial piece (segment
ends, Ruckig phase boundaries, blend ends; phases shorter than 1 ns merged). Each piece is a
polynomial of degree <= 3, which a cubic Hermite spline on (position, velocity) reproduces
*exactly*, so ``TimedTrajectory.sample`` is exact; the stored accelerations are those at the
start of the following piece (accelerations jump between pieces in the acceleration-limited
case). If you send such a trajectory to ros2_control's JointTrajectoryController, drop the
accelerations so that it, too, interpolates cubically. This form is compact (about 3-8 points
per segment) and is the right input for re-timing, checking, or sampling at any rate.

``sample_period=dt`` additionally stores exact samples every ``dt`` seconds (grid samples
within 1 % of ``dt`` of a breakpoint or waypoint instant are dropped, so no interval is
pathologically short). Keeping the breakpoints keeps it exact under the same cubic
interpolation; a spline through uniform samples alone would smear the acceleration steps of an
acceleration-limited profile into overshoots of ~50 % of the acceleration limit.

Accelerations: with ``max_jerk`` they are continuous and safe to send to a controller (its
quintic spline then reproduces the cubic pieces exactly). Without ``max_jerk`` they step at
breakpoints and the stored value is the one *after* the instant; send position+velocity only
so the controller interpolates cubically, which is exact.

Dense curved paths (method "smooth")
------------------------------------
A curve sampled densely in joint space (a 0.3 m Cartesian line at eef_step 0.25 mm: 1201
waypoints, each turning by ~0.002 rad) cannot be followed exactly with continuous velocity
without stopping at every waypoint. MoveIt answers with TOTG (Kunz & Stilman: circular blends,
then numerical integration of the path-speed phase plane). We do the same in spirit, shaped
by what the validator and a controller check:

1. Geometry. A C2 cubic spline in the chord-length parameter s passes through the waypoints
   (one spline per piece between rests: the ends, and waypoints turning by more than
   0.35 rad, where the robot stops exactly on the corner). Its distance from the polyline is
   bounded per interval from its Bezier control points; where it exceeds ``max_deviation``
   the chord midpoint is added as a knot (it lies on the polyline, so the curve is pulled
   back onto it, at the price of a tighter bend), a few rounds at most.
2. Speeds. TOPP on a grid (the knots, plus spline points so each piece has >= 64 intervals
   of <= 0.05 rad): x = s_dot**2, s_ddot constant per interval, joint accelerations
   q'(s) s_ddot + q''(s) x bounded at both ends of every interval, velocities at the grid
   points. That is TOPP-RA's discretisation; a backward pass (controllable sets) and a
   greedy forward pass give the time-optimal x for it (the same 1.5572 s as the ``toppra``
   package on the 1201-waypoint line, which is not used: it pulls in matplotlib at import and
   takes 35 ms on that grid).
3. Output. Points at the grid with positions (waypoints exactly), velocities q'(s) s_dot and
   times from the trapezoidal rule; ``interpolation="cubic"``, i.e. the cubic Hermite spline
   on (q, qd), which is what ros2_control does with position+velocity points. Its
   acceleration is linear on each interval, so the stored value (the one after the instant)
   and the value at the interval's end bound it exactly; velocities are checked at their
   interior extremum too. The Hermite spline differs from the ideal motion by a few per cent
   where the grid is coarse: those intervals get tighter limits and TOPP runs again (at most
   3 times), and any excess left (< 0.1 % on dense paths) is removed by slowing the whole
   trajectory down uniformly (time x k: velocities / k, accelerations / k**2). Its distance
   from the polyline (:func:`path_deviation`, from the Bezier control points) is checked
   too; grid intervals that stray beyond ``max_deviation`` are subdivided and the timing
   redone.

The result starts and ends at rest, passes through every waypoint (``waypoint_times``) and
stays within the limits as sampled by the validator. Accelerations step slightly at the grid
points, as in the acceleration-limited Ruckig case: send position+velocity to a controller.
There is no jerk limit in this method (as in MoveIt's TOTG); with jerk limits "auto" keeps
"segments". On the 1201-waypoint line it takes ~7 ms (the scalar passes are pure Python
over pruned constraint rows).

Scaling follows MoveIt: velocity limits are multiplied by ``velocity_scaling``, acceleration
limits by ``acceleration_scaling``; jerk limits are not scaled (as in MoveIt's
RuckigSmoothing).

This module has no ROS dependency.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal, Sequence

import numpy as np
import ruckig
from scipy.interpolate import CubicSpline

from .errors import PlanningError

__all__ = [
    "DEFAULT_MAX_DEVIATION",
    "DEFAULT_SAMPLE_PERIOD",
    "TimeParameterizationError",
    "TimedTrajectory",
    "time_parameterize",
    "retime",
    "path_deviation",
]

DEFAULT_SAMPLE_PERIOD = 0.01
"""Controller period (s) used by :meth:`TimedTrajectory.resample` when none is given."""

# Two consecutive waypoints closer than this (max-norm) are the same waypoint: a zero-length
# segment has no direction and would make the per-segment problem ill-posed.
_DUPLICATE_TOL = 1e-10
# Segments whose unit direction differs from the first one of their run by at most this
# (max-norm) are one straight line: timing them as one implies a velocity jump below
# 1e-9 * speed at the waypoints inside, i.e. numerical noise.
_COLLINEAR_TOL = 1e-9
# A blend may use at most this fraction of each adjacent segment, so blends never overlap.
_BLEND_SEGMENT_FRACTION = 0.5
# Breakpoints closer than this (s) are merged: see _parameterize. The merged phase changes the
# acceleration by at most jerk * 1e-9, far below any tolerance that matters.
_MIN_INTERVAL = 1e-9
# Sampled outputs drop a grid sample closer than this fraction of the period to a breakpoint,
# waypoint instant or the end: intervals much shorter than the period make position-based
# splines (a controller's cubic/quintic) numerically ill-conditioned.
_MIN_SAMPLE_FRACTION = 0.01

DEFAULT_MAX_DEVIATION = 1e-3
"""Default bound (joint-space Euclidean norm, rad/m) on how far the ``"smooth"`` method's
trajectory may stray from the polyline through the waypoints."""
# The smooth method rests at waypoints where the path turns by more than this (rad): such a
# bend cannot be taken fast within a small deviation anyway, and "auto" only picks the smooth
# method for paths with at least one bend gentler than this (a densely sampled curve).
_SMOOTH_MAX_TURN = 0.35
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


class TimeParameterizationError(PlanningError, ValueError):
    """Bad input to time parameterisation (NaN, wrong shape, non-positive limits, bad scaling),
    or a profile Ruckig could not compute."""


@dataclass
class TimedTrajectory:
    """A joint trajectory: positions/velocities/accelerations at increasing time stamps.

    ``interpolation`` says how :meth:`sample` fills the gaps between stored points:

    * ``"cubic"``: the points include every breakpoint of a piecewise constant-jerk motion
      (what :func:`time_parameterize` returns, with or without ``sample_period``). Each stored
      acceleration is the one *after* that instant (acceleration-limited profiles step there);
      on each interval the cubic starts from the stored (q, qd, qdd) and reaches the next
      stored qd. For such data this equals the cubic Hermite spline on (q, qd), i.e. what
      ros2_control's JointTrajectoryController does with position+velocity points.
    * ``"quintic"`` (default for hand-made trajectories and :meth:`resample` output): Hermite
      on position/velocity/acceleration, as the JointTrajectoryController interpolates
      position+velocity+acceleration points.

    ``path`` and ``waypoint_times`` are set by :func:`time_parameterize`: the geometric
    waypoints (duplicates removed) and the time at which each is reached (for a blended corner,
    the blend midpoint). :func:`retime` uses ``path`` so re-timing does not treat sampled
    points as new corners.
    """

    joint_names: list[str]
    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray
    interpolation: Literal["cubic", "quintic"] = "quintic"
    path: np.ndarray | None = field(default=None, repr=False)
    waypoint_times: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        self.joint_names = list(self.joint_names)
        self.times = np.asarray(self.times, dtype=float).reshape(-1)
        n = self.times.shape[0]
        d = len(self.joint_names)
        if n == 0:
            raise TimeParameterizationError("a TimedTrajectory needs at least one point")
        for name in ("positions", "velocities", "accelerations"):
            arr = np.asarray(getattr(self, name), dtype=float)
            if arr.ndim == 1 and d == 1:
                arr = arr.reshape(-1, 1)
            if arr.shape != (n, d):
                raise TimeParameterizationError(
                    f"TimedTrajectory.{name} has shape {arr.shape}, expected ({n}, {d}) "
                    f"for {n} time stamps and joints {self.joint_names}")
            if not np.all(np.isfinite(arr)):
                raise TimeParameterizationError(f"TimedTrajectory.{name} contains NaN or inf")
            setattr(self, name, arr)
        if not np.all(np.isfinite(self.times)):
            raise TimeParameterizationError("TimedTrajectory.times contains NaN or inf")
        if n > 1 and np.any(np.diff(self.times) <= 0.0):
            raise TimeParameterizationError("TimedTrajectory.times must be strictly increasing")
        if self.interpolation not in ("cubic", "quintic"):
            raise TimeParameterizationError(
                f"unknown interpolation {self.interpolation!r}; expected 'cubic' or 'quintic'")

    # ------------------------------------------------------------------ queries
    @property
    def duration(self) -> float:
        """Time from the first to the last point (s)."""
        return float(self.times[-1] - self.times[0])

    @property
    def dof(self) -> int:
        return len(self.joint_names)

    def __len__(self) -> int:
        return int(self.times.shape[0])

    def sample(self, t: float | np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """State at time(s) ``t``: ``(q, qd, qdd)``.

        A scalar ``t`` gives vectors of length ``dof``; an array of M times gives (M, dof)
        arrays. Times outside ``[times[0], times[-1]]`` are clamped: before the start and after
        the end the robot holds the first/last stored position (velocity and acceleration
        reported as stored there, which is zero for anything :func:`time_parameterize` made).
        """
        scalar = np.ndim(t) == 0
        ts = np.clip(np.atleast_1d(np.asarray(t, dtype=float)), self.times[0], self.times[-1])
        if np.any(np.isnan(ts)):
            raise TimeParameterizationError("sample time is NaN")
        q, qd, qdd = self._interpolate(ts)
        if scalar:
            return q[0], qd[0], qdd[0]
        return q, qd, qdd

    def _interpolate(self, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q, qd, qdd = self._evaluate(ts)
        # Stored points are returned verbatim (no rounding from evaluating a polynomial).
        idx = np.minimum(np.searchsorted(self.times, ts), len(self) - 1)
        hit = self.times[idx] == ts
        if np.any(hit):
            q[hit], qd[hit], qdd[hit] = (self.positions[idx[hit]], self.velocities[idx[hit]],
                                         self.accelerations[idx[hit]])
        return q, qd, qdd

    def _evaluate(self, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = len(self)
        if n == 1:
            m = ts.shape[0]
            return (np.repeat(self.positions, m, axis=0), np.repeat(self.velocities, m, axis=0),
                    np.repeat(self.accelerations, m, axis=0))
        # Interval k covers [times[k], times[k+1]]; stored points are reproduced exactly.
        k = np.clip(np.searchsorted(self.times, ts, side="right") - 1, 0, n - 2)
        h = (self.times[k + 1] - self.times[k])[:, None]
        x = ((ts - self.times[k])[:, None]) / h
        p0, p1 = self.positions[k], self.positions[k + 1]
        v0, v1 = self.velocities[k] * h, self.velocities[k + 1] * h
        if self.interpolation == "cubic":
            # Constant jerk on the interval, starting from the stored state at its left end and
            # reaching the stored velocity at its right end; the position then lands on the
            # stored one for consistent data. Built from velocities and accelerations rather
            # than position differences, because position differences over the very short
            # phases Ruckig can produce lose every significant digit once divided by h**2.
            tau = x * h
            a0 = self.accelerations[k]
            vel0 = self.velocities[k]
            jerk = 2.0 * (self.velocities[k + 1] - vel0 - a0 * h) / (h * h)
            q = p0 + tau * (vel0 + tau * (0.5 * a0 + tau * jerk / 6.0))
            qd = vel0 + tau * (a0 + 0.5 * tau * jerk)
            qdd = a0 + tau * jerk
            return q, qd, qdd
        a0, a1 = self.accelerations[k] * h * h, self.accelerations[k + 1] * h * h
        # Quintic through (p, v, a) at both ends, in monomial form c0..c5 on the unit interval.
        c0, c1, c2 = p0, v0, 0.5 * a0
        dp = p1 - p0
        c3 = 10 * dp - 6 * v0 - 4 * v1 - 1.5 * a0 + 0.5 * a1
        c4 = -15 * dp + 8 * v0 + 7 * v1 + 1.5 * a0 - a1
        c5 = 6 * dp - 3 * v0 - 3 * v1 - 0.5 * a0 + 0.5 * a1
        q = c0 + x * (c1 + x * (c2 + x * (c3 + x * (c4 + x * c5))))
        qd = (c1 + x * (2 * c2 + x * (3 * c3 + x * (4 * c4 + x * 5 * c5)))) / h
        qdd = (2 * c2 + x * (6 * c3 + x * (12 * c4 + x * 20 * c5))) / (h * h)
        return q, qd, qdd

    def resample(self, dt: float = DEFAULT_SAMPLE_PERIOD,
                 keep_breakpoints: bool = True) -> "TimedTrajectory":
        """Exact samples every ``dt`` seconds from the start, plus the final point.

        For a ``"cubic"`` trajectory (what :func:`time_parameterize` returns) the breakpoints
        and waypoint instants are kept as well unless ``keep_breakpoints`` is False, so the
        result stays exact under cubic interpolation (see :func:`time_parameterize`,
        ``sample_period``). Otherwise the result is the uniform grid only, interpolated
        quintically; between samples that straddle an acceleration step that is only an
        approximation (the same one a controller would make).

        Grid samples within 1 % of ``dt`` of a kept instant or of the end are dropped, so the
        last interval can be up to 1.01 ``dt`` long.
        """
        dt = _positive_float(dt, "dt")
        if keep_breakpoints and self.interpolation == "cubic":
            return _densify(self, dt)
        return self._sampled_at(_uniform_grid(self.times[0], self.times[-1], dt))

    def _sampled_at(self, ts: np.ndarray) -> "TimedTrajectory":
        q, qd, qdd = self._interpolate(ts)
        return TimedTrajectory(self.joint_names, ts, q, qd, qdd, interpolation="quintic",
                               path=self.path, waypoint_times=self.waypoint_times)


# ---------------------------------------------------------------------------- validation
def _positive_float(value: float, what: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TimeParameterizationError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(v) or v <= 0.0:
        raise TimeParameterizationError(f"{what} must be a finite positive number, got {value!r}")
    return v


def _limit_vector(value, d: int, what: str, allow_inf: bool = False) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise TimeParameterizationError(f"{what} must be numeric, got {value!r}") from None
    if arr.ndim == 0:
        arr = np.full(d, float(arr))
    if arr.shape != (d,):
        raise TimeParameterizationError(
            f"{what} has shape {arr.shape}, expected a scalar or ({d},) to match the path's "
            f"{d} joints")
    if np.any(np.isnan(arr)):
        raise TimeParameterizationError(f"{what} contains NaN: {arr.tolist()}")
    if not allow_inf and not np.all(np.isfinite(arr)):
        raise TimeParameterizationError(f"{what} must be finite: {arr.tolist()}")
    if np.any(arr <= 0.0):
        raise TimeParameterizationError(f"{what} must be positive for every joint: {arr.tolist()}")
    return arr


def _scaling(value: float, what: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TimeParameterizationError(f"{what} must be a number, got {value!r}") from None
    if not (0.0 < v <= 1.0):  # also rejects NaN
        raise TimeParameterizationError(f"{what} must be in (0, 1], got {value!r}")
    return v


def _validate_path(path) -> np.ndarray:
    try:
        arr = np.array(path, dtype=float)  # copy: we never alias the caller's array
    except (TypeError, ValueError):
        raise TimeParameterizationError("path must be a numeric (N, d) array of waypoints") \
            from None
    if arr.ndim != 2 or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise TimeParameterizationError(
            f"path must have shape (N, d) with N >= 1 waypoints and d >= 1 joints, "
            f"got shape {arr.shape}")
    bad = ~np.all(np.isfinite(arr), axis=1)
    if np.any(bad):
        raise TimeParameterizationError(
            f"path waypoint(s) {np.flatnonzero(bad).tolist()} contain NaN or inf")
    return arr


def _drop_duplicates(path: np.ndarray) -> np.ndarray:
    if path.shape[0] < 2 or np.all(np.max(np.abs(np.diff(path, axis=0)), axis=1) > _DUPLICATE_TOL):
        return path  # the usual case, without a Python loop over thousands of waypoints
    keep = [0]
    for i in range(1, path.shape[0]):
        if np.max(np.abs(path[i] - path[keep[-1]])) > _DUPLICATE_TOL:
            keep.append(i)
    return path[keep]


def _uniform_grid(t0: float, t1: float, dt: float) -> np.ndarray:
    n = int(math.floor((t1 - t0) / dt + 1e-9))
    ts = t0 + dt * np.arange(n + 1)
    ts = ts[ts < t1 - _MIN_SAMPLE_FRACTION * dt]
    return np.append(ts, t1)


# ---------------------------------------------------------------------------- 1-D kinematics
def _max_reachable_speed(v_other: float, length: float, a: float, j: float) -> float:
    """Largest speed v >= v_other that can be changed into v_other (or reached from it) within
    ``length`` of path, with zero acceleration at both ends, under acceleration bound ``a``
    and jerk bound ``j`` (``inf`` allowed).

    The fastest velocity change is point-symmetric about its midpoint, so it covers
    (v + v_other) / 2 * T, with T = dv/a + a/j if it reaches ``a`` (dv >= a^2/j), else
    T = 2 sqrt(dv/j), and T = dv/a without a jerk limit. Solving that for dv in closed form
    keeps the forward/backward passes exact, so each segment's Ruckig profile is feasible
    without overshooting the segment end."""
    if length <= 0.0:
        return v_other
    if math.isinf(j):
        return math.sqrt(v_other * v_other + 2.0 * a * length)
    # Without reaching a: x = sqrt(dv) solves f(x) = x^3 + 2 v_other x - length sqrt(j) = 0,
    # monotone in x with one real root: Cardano, polished by Newton (Cardano cancels badly
    # when v_other dominates).
    p, q = 2.0 * v_other, -length * math.sqrt(j)
    disc = math.sqrt(q * q / 4.0 + p ** 3 / 27.0)
    x = float(np.cbrt(-q / 2.0 + disc) + np.cbrt(-q / 2.0 - disc))
    for _ in range(3):
        x -= (x * x * x + p * x + q) / (3.0 * x * x + p)
    dv = x * x
    if dv * j >= a * a:
        # Reaches a: (v_other + dv/2)(dv/a + a/j) = length, i.e. qa dv^2 + qb dv + qc = 0 with
        # qc <= 0 here; the cancellation-free form of the positive root.
        qa, qb, qc = 0.5 / a, v_other / a + 0.5 * a / j, v_other * a / j - length
        dv = -2.0 * qc / (qb + math.sqrt(qb * qb - 4.0 * qa * qc))
    dv = max(dv, 0.0)
    v = v_other + dv
    if v - v_other > dv:  # rounded up: never hand Ruckig a change it cannot make in `length`
        v = float(np.nextafter(v, 0.0))
    return v


# ---------------------------------------------------------------------------- main algorithm
def time_parameterize(
    path: np.ndarray | Sequence[Sequence[float]],
    max_velocity: float | Sequence[float] | np.ndarray,
    max_acceleration: float | Sequence[float] | np.ndarray,
    max_jerk: float | Sequence[float] | np.ndarray | None = None,
    velocity_scaling: float = 1.0,
    acceleration_scaling: float = 1.0,
    joint_names: Sequence[str] | None = None,
    sample_period: float | None = None,
    path_tolerance: float = 0.0,
    method: Literal["segments", "smooth", "auto"] = "segments",
    max_deviation: float = DEFAULT_MAX_DEVIATION,
) -> TimedTrajectory:
    """Time a joint-space path: per straight segment, exactly on the polyline (``"segments"``,
    default), or near time-optimal along a smooth curve through the waypoints (``"smooth"``).

    Args:
        path: (N, d) waypoints; consecutive duplicates are dropped.
        max_velocity, max_acceleration: per-joint limits (scalar or (d,)), > 0, finite.
        max_jerk: per-joint jerk limits, or None for acceleration-limited (infinite-jerk)
            trapezoidal profiles. ``inf`` entries mean the same as None.
        velocity_scaling, acceleration_scaling: MoveIt-style factors in (0, 1].
        joint_names: d names; default ``joint_0 .. joint_{d-1}``.
        sample_period: None keeps only the polynomial breakpoints and waypoint instants
            (exact, compact); a period (e.g. :data:`DEFAULT_SAMPLE_PERIOD`) adds exact samples
            at that period (see :meth:`TimedTrajectory.resample`). Both use cubic
            interpolation and are exact.
        path_tolerance: how far (joint-space Euclidean norm) the trajectory may round a corner
            waypoint to avoid stopping there. 0 (default) follows the polyline exactly and stops
            at every non-collinear waypoint. Only allowed without a jerk limit. Applies to
            ``method="segments"``.
        method: ``"segments"`` (default) times each straight run with its own Ruckig profile
            and stays exactly on the polyline, resting at every real corner (see the module
            docstring). ``"smooth"`` passes through every waypoint along a C2 spline that stays
            within ``max_deviation`` of the polyline, with near time-optimal path speeds
            (discrete TOPP, see "Dense curved paths" in the module docstring); it rests only at
            the ends and at bends sharper than 0.35 rad, and needs ``max_jerk=None`` and
            ``path_tolerance=0``. ``"auto"`` picks ``"smooth"`` for paths with at least one
            gentle bend (densely sampled curves such as Cartesian paths) when those conditions
            hold, else ``"segments"``.
        max_deviation: largest distance (joint-space Euclidean norm) the ``"smooth"``
            trajectory may keep from the polyline.

    Returns:
        A trajectory that starts and ends at rest, passes through every waypoint (or within
        ``path_tolerance`` of corner waypoints) and respects the scaled limits. With
        ``"smooth"`` it stays within ``max_deviation`` of the polyline between waypoints
        (:func:`path_deviation`).

    Raises:
        TimeParameterizationError (a ValueError) on bad input, naming the problem.
    """
    pts = _validate_path(path)
    d = pts.shape[1]
    vmax = _limit_vector(max_velocity, d, "max_velocity")
    amax = _limit_vector(max_acceleration, d, "max_acceleration")
    jmax = (np.full(d, math.inf) if max_jerk is None
            else _limit_vector(max_jerk, d, "max_jerk", allow_inf=True))
    vmax = vmax * _scaling(velocity_scaling, "velocity_scaling")
    amax = amax * _scaling(acceleration_scaling, "acceleration_scaling")
    if joint_names is None:
        names = [f"joint_{i}" for i in range(d)]
    else:
        names = [str(n) for n in joint_names]
        if len(names) != d:
            raise TimeParameterizationError(
                f"joint_names has {len(names)} entries but the path has {d} joints")
        if len(set(names)) != d:
            raise TimeParameterizationError(f"joint_names contains duplicates: {names}")
    if sample_period is not None:
        sample_period = _positive_float(sample_period, "sample_period")
    try:
        tol = float(path_tolerance)
    except (TypeError, ValueError):
        raise TimeParameterizationError(
            f"path_tolerance must be a number, got {path_tolerance!r}") from None
    if not math.isfinite(tol) or tol < 0.0:
        raise TimeParameterizationError(
            f"path_tolerance must be finite and >= 0, got {path_tolerance!r}")
    if tol > 0.0 and np.any(np.isfinite(jmax)):
        raise TimeParameterizationError(
            "path_tolerance > 0 (corner blending) needs an acceleration step at the blend and is "
            "only supported without max_jerk; use path_tolerance=0 with jerk limits")

    if method not in ("segments", "smooth", "auto"):
        raise TimeParameterizationError(
            f"unknown method {method!r}; expected 'segments', 'smooth' or 'auto'")
    try:
        max_dev = float(max_deviation)
    except (TypeError, ValueError):
        raise TimeParameterizationError(
            f"max_deviation must be a number, got {max_deviation!r}") from None
    if not math.isfinite(max_dev) or max_dev <= 0.0:
        raise TimeParameterizationError(
            f"max_deviation must be finite and > 0, got {max_deviation!r}")
    if method == "smooth" and np.any(np.isfinite(jmax)):
        raise TimeParameterizationError(
            "method 'smooth' is acceleration-limited and does not support max_jerk; use "
            "method='segments' (or 'auto') with jerk limits")
    if method == "smooth" and tol > 0.0:
        raise TimeParameterizationError(
            "path_tolerance applies to method 'segments'; method 'smooth' is bounded by "
            "max_deviation")

    pts = _drop_duplicates(pts)
    if method == "auto":
        method = _choose_method(pts, jmax, tol)
    if method == "smooth":
        traj = _smooth_parameterize(pts, vmax, amax, names, max_dev)
    else:
        traj = _parameterize(pts, vmax, amax, jmax, tol, names)
    if sample_period is not None:
        traj = traj.resample(sample_period)
    return traj


def _densify(traj: TimedTrajectory, period: float) -> TimedTrajectory:
    """Exact samples every ``period`` plus every breakpoint and waypoint instant.

    Keeping the breakpoints means no interval straddles a change of polynomial piece, so the
    result is still exact under cubic interpolation (an acceleration-limited profile has
    acceleration steps there, which a spline through uniform samples would smear into a large
    overshoot). Grid samples within 1 % of the period of a kept instant are dropped."""
    if len(traj) == 1:
        return traj
    anchors = (traj.times if traj.waypoint_times is None
               else np.union1d(traj.times, traj.waypoint_times))
    grid = _uniform_grid(traj.times[0], traj.times[-1], period)
    pos = np.clip(np.searchsorted(anchors, grid), 1, anchors.shape[0] - 1)
    near = np.minimum(np.abs(anchors[pos] - grid), np.abs(anchors[pos - 1] - grid))
    ts = np.union1d(anchors, grid[near > _MIN_SAMPLE_FRACTION * period])
    q, qd, qdd = traj._interpolate(ts)
    return TimedTrajectory(traj.joint_names, ts, q, qd, qdd, interpolation="cubic",
                           path=traj.path, waypoint_times=traj.waypoint_times)


def _parameterize(pts: np.ndarray, vmax: np.ndarray, amax: np.ndarray, jmax: np.ndarray,
                  tol: float, names: list[str]) -> TimedTrajectory:
    n, d = pts.shape
    zeros = np.zeros(d)
    if n == 1:
        z = np.zeros((1, d))
        return TimedTrajectory(names, np.zeros(1), pts.copy(), z, z.copy(), interpolation="cubic",
                               path=pts.copy(), waypoint_times=np.zeros(1))

    sub_len = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    sub_dir = np.diff(pts, axis=0) / sub_len[:, None]

    # Timing vertices: the ends and every real corner. Runs of collinear waypoints (e.g. an
    # interpolated OMPL path) form one straight segment, timed by one Ruckig profile; the
    # waypoints inside are stamped where the profile passes them. Timing them separately
    # would force zero acceleration at each (Ruckig's target state), which with a jerk limit
    # means needless slowdowns. Collinearity is checked against the run's first direction so
    # tiny bends cannot accumulate.
    verts = [0]
    run_dir = sub_dir[0]
    for i in range(1, n - 1):
        if np.max(np.abs(sub_dir[i] - run_dir)) > _COLLINEAR_TOL:
            verts.append(i)
            run_dir = sub_dir[i]
    verts.append(n - 1)
    vidx = np.array(verts)
    nv = vidx.shape[0]
    nseg = nv - 1
    deltas = pts[vidx[1:]] - pts[vidx[:-1]]
    lengths = np.linalg.norm(deltas, axis=1)
    dirs = deltas / lengths[:, None]
    absu = np.abs(dirs)
    with np.errstate(divide="ignore"):
        seg_v = np.min(np.where(absu > 0, vmax / absu, np.inf), axis=1)
        seg_a = np.min(np.where(absu > 0, amax / absu, np.inf), axis=1)
        seg_j = np.min(np.where(absu > 0, jmax / absu, np.inf), axis=1)

    # Per-vertex speed caps (vertex m joins segments m-1 and m) and blend geometry.
    cap = np.zeros(nv)            # 0 at the ends: start and end at rest; 0 at unblended corners
    blend_k = np.zeros(nv)        # blend duration tau = speed * k
    blend_du = np.zeros((nv, d))  # u_out - u_in
    if tol > 0.0:
        for m in range(1, nv - 1):
            du = dirs[m] - dirs[m - 1]
            k = float(np.max(np.abs(du) / amax))
            # A blend may take at most a fraction of the sub-segments touching the corner, so
            # it never overlaps another blend nor swallows a collinear waypoint.
            room = min(sub_len[vidx[m] - 1], sub_len[vidx[m]])
            cap[m] = min(seg_v[m - 1], seg_v[m],
                         math.sqrt(8.0 * tol / (k * float(np.linalg.norm(du)))),
                         math.sqrt(2.0 * _BLEND_SEGMENT_FRACTION * room / k))
            blend_k[m] = k
            blend_du[m] = du

    # Blend lengths along each adjacent segment at the cap speed: an upper bound, so the
    # straight remainder used in the passes is a lower bound and the passes stay feasible.
    bmax = 0.5 * cap * cap * blend_k
    straight_min = np.maximum(lengths - bmax[:-1] - bmax[1:], 0.0)

    speed = cap.copy()
    for m in range(nseg):  # forward: reachable from the previous vertex
        speed[m + 1] = min(speed[m + 1],
                           _max_reachable_speed(speed[m], straight_min[m], seg_a[m], seg_j[m]))
    for m in range(nseg - 1, -1, -1):  # backward: able to slow down for the next vertex
        speed[m] = min(speed[m],
                       _max_reachable_speed(speed[m + 1], straight_min[m], seg_a[m], seg_j[m]))

    tau = speed * blend_k
    blen = 0.5 * speed * tau  # arc length a blend takes from each adjacent segment

    otg = ruckig.Ruckig(1)  # no waypoint capacity: never the cloud path
    inp = ruckig.InputParameter(1)
    out = ruckig.Trajectory(1)

    # Candidate points: (time, q, qd, qdd from here on, is_waypoint_or_end). Times accumulate
    # exactly; near-coincident points are thinned afterwards.
    cands: list[tuple[float, np.ndarray, np.ndarray, np.ndarray, bool]] = [
        (0.0, pts[0].copy(), zeros.copy(), zeros.copy(), True)]
    wp_times = np.zeros(n)
    t = 0.0
    for m in range(nseg):
        u = dirs[m]
        w = pts[vidx[m]]
        s0 = blen[m]
        straight = lengths[m] - blen[m] - blen[m + 1]
        v0, v1 = min(speed[m], seg_v[m]), min(speed[m + 1], seg_v[m])
        if straight > 1e-12 or abs(v1 - v0) > 1e-12:
            a_start, boundaries = _segment_profile(otg, inp, out, max(straight, 0.0), v0, v1,
                                                   seg_v[m], seg_a[m], seg_j[m], m)
            tq, q, v, _, prot = cands[-1]
            cands[-1] = (tq, q, v, a_start * u, prot)  # acceleration from here on
            seg_cands = []
            t_rel = 0.0
            for dt, p, v, a in boundaries:
                t_rel += dt
                seg_cands.append((t_rel, w + (s0 + p) * u, v * u, a * u, False))
            for i in range(vidx[m] + 1, vidx[m + 1]):  # collinear waypoints inside
                s_i = float((pts[i] - w) @ u) - s0
                t_i = _time_at_arc_length(out, min(max(s_i, 0.0), straight))
                _, v, a = out.at_time(t_i)  # right-hand limits at phase boundaries
                seg_cands.append((t_i, pts[i].copy(), v[0] * u, a[0] * u, True))
                wp_times[i] = t + t_i
            seg_cands.sort(key=lambda c: c[0])
            cands.extend((t + c[0],) + c[1:] for c in seg_cands)
            t += t_rel
        if m + 1 < nv - 1 and tau[m + 1] > 0.0:
            # Parabolic blend around vertex m+1: starts where the straight part ended.
            s, t_b, du = speed[m + 1], tau[m + 1], blend_du[m + 1]
            tq, q, v, _, prot = cands[-1]
            cands[-1] = (tq, q, v, s * du / t_b, prot)
            wp_times[vidx[m + 1]] = t + 0.5 * t_b
            t += t_b
            cands.append((t, pts[vidx[m + 1]] + blen[m + 1] * dirs[m + 1], s * dirs[m + 1],
                          zeros.copy(), False))
        else:
            tq, _, v, a, _ = cands[-1]
            cands[-1] = (tq, pts[vidx[m + 1]].copy(), v, a, True)  # exact waypoint
            wp_times[vidx[m + 1]] = t
    tq, q, _, _, _ = cands[-1]
    cands[-1] = (tq, q, zeros.copy(), zeros.copy(), True)

    # Ruckig profiles can contain phases of 1e-12 s (a limit touched by a hair). Such short
    # intervals make any interpolation ill-conditioned and carry no motion, so drop phase /
    # blend boundaries closer than _MIN_INTERVAL to their predecessor; waypoints are kept.
    # Two waypoints passed within _MIN_INTERVAL of each other (nearly coincident waypoints on
    # a fast segment) keep only the first as a stored point (the last one if it is the end);
    # the other is still passed, within max speed * 1e-9 s, at its waypoint_times entry.
    kept = [cands[0]]
    last = len(cands) - 1
    for idx, c in enumerate(cands[1:], start=1):
        if c[0] - kept[-1][0] < _MIN_INTERVAL and not (idx == last and len(kept) == 1):
            if not kept[-1][4] or idx == last:
                kept[-1] = c
            else:
                # Keep the earlier point, but what follows the dropped one is c's acceleration.
                kept[-1] = kept[-1][:3] + (c[3], True)
            continue
        kept.append(c)
    return TimedTrajectory(names, np.array([c[0] for c in kept]), np.array([c[1] for c in kept]),
                           np.array([c[2] for c in kept]), np.array([c[3] for c in kept]),
                           interpolation="cubic", path=pts.copy(), waypoint_times=wp_times)


def _time_at_arc_length(out: ruckig.Trajectory, s: float) -> float:
    """First time the (monotone, non-decreasing) 1-DoF profile reaches position ``s``.

    Ruckig's root finder can miss a position that sits on a phase boundary by a rounding
    error (returns None); bisection on the monotone profile is the fallback."""
    t = out.get_first_time_at_position(0, s)
    if t is not None:
        return float(t)
    lo, hi = 0.0, float(out.duration)
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if out.at_time(mid)[0][0] < s:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-15 * max(1.0, hi):
            break
    return hi


def _segment_profile(otg: ruckig.Ruckig, inp: ruckig.InputParameter, out: ruckig.Trajectory,
                     length: float, v0: float, v1: float, vmax: float, amax: float, jmax: float,
                     index: int):
    """Ruckig 1-DoF profile from (0, v0, 0) to (length, v1, 0).

    Returns (s_ddot right after the start, [(phase duration, s, s_dot, s_ddot right after the
    boundary) for each phase boundary after the start])."""
    inp.current_position = [0.0]
    inp.current_velocity = [v0]
    inp.current_acceleration = [0.0]
    inp.target_position = [length]
    inp.target_velocity = [v1]
    inp.target_acceleration = [0.0]
    inp.max_velocity = [vmax]
    inp.max_acceleration = [amax]
    inp.max_jerk = [jmax]
    last_err = ""
    # The passes make (v0, v1, length) feasible, sometimes exactly at the boundary; floating
    # point can tip Ruckig over it, so retry with speeds shaved by a relative 1e-9, then 1e-6.
    for shave in (0.0, 1e-9, 1e-6):
        inp.current_velocity = [v0 * (1.0 - shave)]
        inp.target_velocity = [v1 * (1.0 - shave)]
        try:
            result = otg.calculate(inp, out)
        except ruckig.RuckigError as exc:
            last_err = str(exc)
            continue
        if result not in (ruckig.Result.Working, ruckig.Result.Finished):
            last_err = str(result)
            continue
        ext = out.position_extrema[0]
        if ext.min < -1e-9 * max(1.0, length) or ext.max > length + 1e-9 * max(1.0, length):
            last_err = f"profile overshoots the segment (s in [{ext.min}, {ext.max}])"
            continue
        prof = out.profiles[0][0]
        if prof.brake.duration > 0.0:
            last_err = "profile needs a pre-trajectory brake"
            continue
        # prof.p/v/a[k] is the state at the start of phase k. Without a jerk limit, a[k] is
        # phase k's constant acceleration and zero-length phases carry unrelated values, so the
        # acceleration after a boundary is that of the next phase that has a duration.
        durations = list(prof.t)

        def accel_from(k: int) -> float:
            m = next((m for m in range(k, len(durations)) if durations[m] > 0.0), len(durations))
            return prof.a[m]

        boundaries = [(dt, prof.p[k + 1], prof.v[k + 1], accel_from(k + 1))
                      for k, dt in enumerate(durations) if dt > 0.0]
        return accel_from(0), boundaries
    raise TimeParameterizationError(
        f"Ruckig could not time segment {index} (length {length:g}, speeds {v0:g} -> {v1:g}): "
        f"{last_err}")


# ---------------------------------------------------------------------------- smooth method
def _turning(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Turning angle (rad) at each interior waypoint, and whether the waypoint is a real bend
    (not collinear by the same test the segment method uses)."""
    delta = np.diff(pts, axis=0)
    dirs = delta / np.linalg.norm(delta, axis=1)[:, None]
    cosang = np.clip(np.einsum("ij,ij->i", dirs[:-1], dirs[1:]), -1.0, 1.0)
    bend = np.max(np.abs(dirs[1:] - dirs[:-1]), axis=1) > _COLLINEAR_TOL
    return np.arccos(cosang), bend


def _choose_method(pts: np.ndarray, jmax: np.ndarray, tol: float) -> str:
    """'smooth' for paths with at least one gentle bend (dense curves: Cartesian paths, B-spline
    smoothed OMPL paths), else 'segments' (straight runs and real corners: exact and optimal)."""
    if pts.shape[0] < 3 or tol > 0.0 or np.any(np.isfinite(jmax)):
        return "segments"
    angle, bend = _turning(pts)
    return "smooth" if np.any(bend & (angle <= _SMOOTH_MAX_TURN)) else "segments"


def _bezier_deviation(p0: np.ndarray, c1: np.ndarray, c2: np.ndarray, p3: np.ndarray,
                      a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Upper bound on the distance of each cubic Bezier (p0, c1, c2, p3) from the segment a-b.

    The curve lies in the convex hull of its control points, and the distance to a segment is
    convex, so the largest control-point distance bounds it. Splitting the curve at its middle
    first (de Casteljau) makes the bound tight for the gentle arcs met here (exact for a
    symmetric one), where the unsplit hull overestimates by a third."""
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
    turning more than _SMOOTH_MAX_TURN, and the ends, are stops: the robot comes to rest
    exactly on them, as the segment method does at every corner."""
    n = pts.shape[0]
    knots = pts
    is_wp = np.ones(n, dtype=bool)
    stop = np.zeros(n, dtype=bool)
    stop[[0, -1]] = True
    if n > 2:
        angle, _ = _turning(pts)
        stop[1:-1] = angle > _SMOOTH_MAX_TURN
    rounds = 0
    while True:  # ends: every round refines (at most _SMOOTH_REFINE_ROUNDS times) or adds stops
        seg = np.linalg.norm(np.diff(knots, axis=0), axis=1)
        s = np.concatenate(([0.0], np.cumsum(seg)))
        pieces, t_start, t_end = _piece_splines(knots, s, stop)
        c1 = knots[:-1] + t_start * (seg / 3.0)[:, None]
        c2 = knots[1:] - t_end * (seg / 3.0)[:, None]
        dev = _bezier_deviation(knots[:-1], c1, c2, knots[1:], knots[:-1], knots[1:])
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


def _pareto(w0: np.ndarray, w1: np.ndarray) -> np.ndarray:
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
    The passes are scalar loops over the grid, so rows that never bind are pruned first
    (vectorised)."""
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
    up_keep = _pareto(a + inf, a + b * xh + inf)
    lo_keep = _pareto(a + inf, a - b * xh + inf)
    # Backward: x + 2 ds (-a_k + b_k x) <= cap[i+1]  <=>  x (1 + 2 ds b_k) <= cap[i+1] + 2 ds a_k;
    # rows with 1 + 2 ds b_k <= 0 never bind for x >= 0.
    q_back = 1.0 + two_ds[:, None] * b
    rows, cols = np.nonzero(lo_keep & (q_back > 0.0))
    bp = (two_ds[rows] * a[rows, cols]).tolist()
    bq = q_back[rows, cols].tolist()
    bnd = np.searchsorted(rows, np.arange(m + 1)).tolist()
    caps = cap.tolist()
    c = caps[m]
    for i in range(m - 1, -1, -1):
        best = caps[i]
        for j in range(bnd[i], bnd[i + 1]):
            v = (c + bp[j]) / bq[j]
            if v < best:
                best = v
        c = best
        caps[i] = c
    # Forward: x[i+1] = x[i] + 2 ds min_k(a_k + b_k x[i]), within the controllable set.
    rows, cols = np.nonzero(up_keep)
    fp = (two_ds[rows] * a[rows, cols]).tolist()
    fq = (1.0 + two_ds[rows] * b[rows, cols]).tolist()
    bnd = np.searchsorted(rows, np.arange(m + 1)).tolist()
    x = [0.0] * (m + 1)
    xi = 0.0
    for i in range(m):
        xn = caps[i + 1]
        for j in range(bnd[i], bnd[i + 1]):
            v = fp[j] + fq[j] * xi
            if v < xn:
                xn = v
        if xn < 0.0:
            xn = 0.0
        x[i + 1] = xn
        xi = xn
    return np.array(x)


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


def _smooth_parameterize(pts: np.ndarray, vmax: np.ndarray, amax: np.ndarray, names: list[str],
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
        dev = _bezier_deviation(q[:-1], q[:-1] + vel[:-1] * h / 3.0, q[1:] - vel[1:] * h / 3.0,
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
    dev = _bezier_deviation(q[:-1], q[:-1] + v[:-1] * h / 3.0, q[1:] - v[1:] * h / 3.0, q[1:],
                            path[seg], path[seg + 1])
    return float(np.max(dev))


def retime(
    trajectory_or_path: TimedTrajectory | np.ndarray | Sequence[Sequence[float]],
    max_velocity: float | Sequence[float] | np.ndarray,
    max_acceleration: float | Sequence[float] | np.ndarray,
    max_jerk: float | Sequence[float] | np.ndarray | None = None,
    velocity_scaling: float = 1.0,
    acceleration_scaling: float = 1.0,
    joint_names: Sequence[str] | None = None,
    sample_period: float | None = None,
    path_tolerance: float = 0.0,
    method: Literal["segments", "smooth", "auto"] = "segments",
    max_deviation: float = DEFAULT_MAX_DEVIATION,
) -> TimedTrajectory:
    """Re-time an existing trajectory (or a bare path) under new limits/scaling factors.

    For a :class:`TimedTrajectory` its geometric ``path`` is re-timed when known (so sampled
    points and blend arcs are not mistaken for waypoints), else its stored positions are the
    path; its joint names are kept unless ``joint_names`` is given.
    """
    if isinstance(trajectory_or_path, TimedTrajectory):
        src = trajectory_or_path
        path = src.path if src.path is not None else src.positions
        names = src.joint_names if joint_names is None else joint_names
    else:
        path, names = trajectory_or_path, joint_names
    return time_parameterize(path, max_velocity, max_acceleration, max_jerk=max_jerk,
                             velocity_scaling=velocity_scaling,
                             acceleration_scaling=acceleration_scaling, joint_names=names,
                             sample_period=sample_period, path_tolerance=path_tolerance,
                             method=method, max_deviation=max_deviation)
