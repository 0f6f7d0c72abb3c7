"""Time parameterisation of collision-checked joint-space paths (MoveIt's TOTG / Ruckig role).

A planner hands us a geometric path: N joint-space waypoints whose piecewise-linear
interpolation was collision-checked. We must give it timing (velocities, accelerations,
time stamps) that is as fast as the joint limits allow **without leaving that polyline**,
because any deviation is motion nobody has checked.

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

from .errors import PlanningError

__all__ = [
    "DEFAULT_SAMPLE_PERIOD",
    "TimeParameterizationError",
    "TimedTrajectory",
    "time_parameterize",
    "retime",
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
) -> TimedTrajectory:
    """Time-optimal-per-segment timing of a joint-space path that never leaves the path.

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
            at every non-collinear waypoint. Only allowed without a jerk limit.

    Returns:
        A trajectory that starts and ends at rest, passes through every waypoint (or within
        ``path_tolerance`` of corner waypoints) and respects the scaled limits.

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

    pts = _drop_duplicates(pts)
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
                             sample_period=sample_period, path_tolerance=path_tolerance)
