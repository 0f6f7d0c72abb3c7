"""A timed joint trajectory (MoveIt's robot_trajectory) and its JointTrajectory message form.

Every planner, the time parameterisation, the validator, execution and the task solutions
share this one type; docs/time_parameterization.md explains the interpolation it assumes.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from interfaces_py.msgs import JointTrajectory, JointTrajectoryPoint

from ..errors import TimeParameterizationError
from ..jit import compiled, numba_available

__all__ = [
    "DEFAULT_MAX_WAYPOINT_DISTANCE",
    "DEFAULT_SAMPLE_PERIOD",
    "TimeParameterizationError",
    "TimedTrajectory",
    "densify_joint_trajectory",
    "joint_trajectory_to_timed",
    "limit_waypoint_distance",
    "max_steps",
    "timed_to_joint_trajectory",
]

DEFAULT_SAMPLE_PERIOD = 0.01
"""Controller period (s) used by :meth:`TimedTrajectory.resample` when none is given."""

DEFAULT_MAX_WAYPOINT_DISTANCE = 0.1
"""Largest motion of any joint (rad, or m) between consecutive waypoints of a planned or executed
trajectory: MTC's JointInterpolationPlanner ``max_step`` (see :func:`limit_waypoint_distance`)."""

# Sampled outputs drop a grid sample closer than this fraction of the period to a breakpoint,
# waypoint instant or the end: intervals much shorter than the period make position-based
# splines (a controller's cubic/quintic) numerically ill-conditioned.
_MIN_SAMPLE_FRACTION = 0.01


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
        if _EVALUATE_COMPILED and len(self) > 1:
            # clipping, the intervals, the polynomials and the stored points in one compiled call
            # (the validator samples several times a plan: each NumPy step cost microseconds)
            q, qd, qdd = self._sampled(np.atleast_1d(np.asarray(t, dtype=float)), True)
        else:
            ts = np.clip(np.atleast_1d(np.asarray(t, dtype=float)), self.times[0], self.times[-1])
            if np.any(np.isnan(ts)):
                raise TimeParameterizationError("sample time is NaN")
            q, qd, qdd = self._interpolate(ts)
        if scalar:
            return q[0], qd[0], qdd[0]
        return q, qd, qdd

    def _sampled(self, ts: np.ndarray, clip: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """_interpolate (after sample's clipping, with ``clip``) by _sample_kernel: at least two
        stored points and numba."""
        m, d = ts.shape[0], self.positions.shape[1]
        q, qd, qdd = np.empty((m, d)), np.empty((m, d)), np.empty((m, d))
        if not _sample_kernel(np.ascontiguousarray(self.times, dtype=float),
                              np.ascontiguousarray(self.positions, dtype=float),
                              np.ascontiguousarray(self.velocities, dtype=float),
                              np.ascontiguousarray(self.accelerations, dtype=float),
                              self.interpolation == "cubic", np.ascontiguousarray(ts, dtype=float), clip, q, qd, qdd):
            raise TimeParameterizationError("sample time is NaN")
        return q, qd, qdd

    def _interpolate(self, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if _EVALUATE_COMPILED and len(self) > 1 and not np.isnan(ts).any():
            return self._sampled(ts, False)
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
        return self._evaluate_numpy(ts, k)

    def _evaluate_numpy(self, ts: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """_evaluate in NumPy: without numba, and the reference the compiled kernel is held to."""
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
        dt = positive_float(dt, "dt")
        if keep_breakpoints and self.interpolation == "cubic":
            return _densify(self, dt)
        return self._sampled_at(uniform_grid(self.times[0], self.times[-1], dt))

    def _sampled_at(self, ts: np.ndarray) -> "TimedTrajectory":
        q, qd, qdd = self._interpolate(ts)
        return TimedTrajectory(self.joint_names, ts, q, qd, qdd, interpolation="quintic",
                               path=self.path, waypoint_times=self.waypoint_times)



def positive_float(value: float, what: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TimeParameterizationError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(v) or v <= 0.0:
        raise TimeParameterizationError(f"{what} must be a finite positive number, got {value!r}")
    return v


def uniform_grid(t0: float, t1: float, dt: float) -> np.ndarray:
    n = int(math.floor((t1 - t0) / dt + 1e-9))
    ts = t0 + dt * np.arange(n + 1)
    ts = ts[ts < t1 - _MIN_SAMPLE_FRACTION * dt]
    return np.append(ts, t1)


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
    grid = uniform_grid(traj.times[0], traj.times[-1], period)
    pos = np.clip(np.searchsorted(anchors, grid), 1, anchors.shape[0] - 1)
    near = np.minimum(np.abs(anchors[pos] - grid), np.abs(anchors[pos - 1] - grid))
    ts = np.union1d(anchors, grid[near > _MIN_SAMPLE_FRACTION * period])
    q, qd, qdd = traj._interpolate(ts)
    return TimedTrajectory(traj.joint_names, ts, q, qd, qdd, interpolation="cubic",
                           path=traj.path, waypoint_times=traj.waypoint_times)



def timed_to_joint_trajectory(trajectory: TimedTrajectory | None, sample_period: float | None = None) -> JointTrajectory:
    """A core TimedTrajectory as the JointTrajectory message (times from 0) that a controller
    reproduces exactly.

    A joint trajectory controller interpolates cubic Hermite splines when points carry positions
    and velocities, quintic ones when they also carry accelerations. Planned trajectories
    (interpolation "cubic": piecewise constant jerk, breakpoints included) are exactly the cubic
    Hermite spline through their points, so they are sent *without* accelerations: with them the
    controller would fit quintics whose acceleration overshoots the limits at every acceleration
    step. "quintic" trajectories keep their accelerations. With ``sample_period`` the trajectory is
    first resampled on that grid (breakpoints kept), which keeps the spline exact and gives
    displays and controllers evenly spaced points.
    """
    if trajectory is None:  # a stage without motion
        return JointTrajectory(joint_names=[], points=[])
    if sample_period and len(trajectory) > 1:
        trajectory = trajectory.resample(sample_period)
    with_accelerations = trajectory.interpolation == "quintic"
    times = np.asarray(trajectory.times, dtype=float)
    return JointTrajectory.from_arrays(list(trajectory.joint_names), np.maximum(0.0, times - times[0]),
                                       trajectory.positions, trajectory.velocities,
                                       trajectory.accelerations if with_accelerations else None)


def joint_trajectory_to_timed(trajectory: JointTrajectory) -> TimedTrajectory:
    """The inverse of timed_to_joint_trajectory: the TimedTrajectory a controller would follow.

    Points without accelerations define a cubic Hermite spline (what a joint trajectory
    controller interpolates); the accelerations stored at each point are that spline's, taken
    just after the point (zero after a final point at rest), as TimedTrajectory keeps them.
    """
    points = trajectory.points
    times = np.array([p.time_from_start for p in points], dtype=float)
    positions = np.array([p.positions for p in points], dtype=float)
    d = len(trajectory.joint_names)
    velocities = np.array([p.velocities if p.velocities else [0.0] * d for p in points], dtype=float)
    if all(len(p.accelerations) == d for p in points):
        accelerations = np.array([p.accelerations for p in points], dtype=float)
        return TimedTrajectory(list(trajectory.joint_names), times, positions, velocities, accelerations, interpolation="quintic")
    accelerations = np.zeros_like(positions)
    if len(points) > 1:
        dt = np.diff(times)[:, None]
        dp = np.diff(positions, axis=0)
        v0, v1 = velocities[:-1], velocities[1:]
        accelerations[:-1] = 6.0 * dp / dt**2 - (4.0 * v0 + 2.0 * v1) / dt
        if np.any(velocities[-1] != 0.0):  # still moving at the end: the spline's last value
            accelerations[-1] = -6.0 * dp[-1] / dt[-1] ** 2 + (2.0 * v0[-1] + 4.0 * v1[-1]) / dt[-1]
    return TimedTrajectory(list(trajectory.joint_names), times, positions, velocities, accelerations, interpolation="cubic")


def limit_waypoint_distance(trajectory: TimedTrajectory, max_distance: float = DEFAULT_MAX_WAYPOINT_DISTANCE
                            ) -> TimedTrajectory:
    """The same motion with exact samples inserted so that no joint moves more than
    ``max_distance`` between consecutive points.

    The samples come from the trajectory's own interpolation (a piece of a constant-jerk or
    quintic polynomial split at an inner instant is the same polynomial on both halves), so
    positions, velocities and accelerations at every instant are unchanged: what a display, a
    controller's spline and the validator see between two points is the motion that was timed.
    Returns ``trajectory`` itself when it is dense enough already.
    """
    max_distance = positive_float(max_distance, "max_distance")
    if len(trajectory) < 2:
        return trajectory
    times = trajectory.times
    positions = trajectory.positions
    steps = np.abs(np.diff(positions, axis=0))
    if steps.max() <= max_distance:
        return trajectory
    first = True
    for _ in range(64):  # each round splits every too-long interval; a few rounds suffice
        gaps = steps.max(axis=1)
        bad = np.nonzero(gaps > max_distance)[0]
        if bad.size == 0:
            break
        travel = gaps[bad]
        if first and trajectory.interpolation == "cubic":
            travel = np.maximum(travel, _cubic_travel_bound(trajectory, bad))
        first = False
        # >= 2 each; the factor keeps a travel of exactly k steps from ending a rounding error above
        pieces = np.ceil(travel / max_distance * (1.0 + 1e-9)).astype(int)
        inner = pieces - 1
        interval = np.repeat(bad, inner)
        rank = np.arange(int(inner.sum())) - np.repeat(np.cumsum(inner) - inner, inner) + 1
        fraction = rank / np.repeat(pieces, inner)
        added = times[interval] + fraction * (times[interval + 1] - times[interval])
        times = np.union1d(times, added)
        positions, velocities, accelerations = trajectory._interpolate(times)
        steps = np.abs(np.diff(positions, axis=0))
    return TimedTrajectory(trajectory.joint_names, times, positions, velocities, accelerations,
                           interpolation=trajectory.interpolation, path=trajectory.path,
                           waypoint_times=trajectory.waypoint_times)


def _cubic_travel_bound(trajectory: TimedTrajectory, intervals: np.ndarray) -> np.ndarray:
    """Per interval, the largest distance any joint can travel on it: its peak speed (at an end,
    or where the constant-jerk piece's velocity parabola turns) times the interval's length.
    Splitting an interval into ceil(bound / max_distance) equal times then keeps every part
    within max_distance in one pass, also where the speed changes along the interval."""
    t = trajectory.times
    h = (t[intervals + 1] - t[intervals])[:, None]
    v0, v1 = trajectory.velocities[intervals], trajectory.velocities[intervals + 1]
    a0 = trajectory.accelerations[intervals]
    jerk = 2.0 * (v1 - v0 - a0 * h) / (h * h)
    with np.errstate(divide="ignore", invalid="ignore"):
        turn = np.where(jerk != 0.0, -a0 / jerk, -1.0)
    inside = (turn > 0.0) & (turn < h)
    turn = np.where(inside, turn, 0.0)
    peak = np.maximum(np.abs(v0), np.abs(v1))
    peak = np.where(inside, np.maximum(peak, np.abs(v0 + turn * (a0 + 0.5 * jerk * turn))), peak)
    return (peak * h).max(axis=1)


def densify_joint_trajectory(trajectory: JointTrajectory, max_distance: float = DEFAULT_MAX_WAYPOINT_DISTANCE
                             ) -> JointTrajectory:
    """A JointTrajectory message with points inserted where a joint would move more than
    ``max_distance`` between two points, sampled from the spline a JointTrajectoryController
    follows through them (linear for positions only, cubic with velocities, quintic with
    velocities and accelerations): the controller's motion is unchanged, only described densely.

    Times keep their offsets (a first point later than 0 stays where it is); a message whose
    points do not all carry the same fields is returned unchanged (controllers refuse it anyway).
    """
    max_distance = positive_float(max_distance, "max_distance")
    points = trajectory.points
    d = len(trajectory.joint_names)
    if len(points) < 2 or d == 0:
        return trajectory
    has_velocities = {len(p.velocities) == d for p in points}
    has_accelerations = {len(p.accelerations) == d for p in points}
    if len(has_velocities) != 1 or len(has_accelerations) != 1:
        return trajectory
    times = np.array([p.time_from_start for p in points], dtype=float)
    positions = np.array([p.positions for p in points], dtype=float)
    if np.all(np.max(np.abs(np.diff(positions, axis=0)), axis=1) <= max_distance):
        return trajectory
    if not has_velocities.pop():
        # positions only: a controller interpolates linearly, so the inserted points are on the lines
        gaps = np.max(np.abs(np.diff(positions, axis=0)), axis=1)
        rows, stamps = [positions[:1]], [times[:1]]
        for k, gap in enumerate(gaps):
            pieces = max(1, int(math.ceil(gap / max_distance - 1e-12)))
            fraction = (np.arange(1, pieces + 1) / pieces)[:, None]
            segment = positions[k] + fraction * (positions[k + 1] - positions[k])
            segment[-1] = positions[k + 1]
            rows.append(segment)
            stamps.append(times[k] + fraction[:, 0] * (times[k + 1] - times[k]))
        stamps_all = np.concatenate(stamps)
        stamps_all[np.cumsum([len(s) for s in stamps]) - 1] = times  # the given points exactly
        dense = np.vstack(rows)
        return JointTrajectory(joint_names=list(trajectory.joint_names), frame_id=trajectory.frame_id, points=[
            JointTrajectoryPoint(positions=dense[k].tolist(), time_from_start=float(stamps_all[k]))
            for k in range(len(dense))])
    timed = limit_waypoint_distance(joint_trajectory_to_timed(trajectory), max_distance)
    with_accelerations = timed.interpolation == "quintic"
    return JointTrajectory(joint_names=list(trajectory.joint_names), frame_id=trajectory.frame_id, points=[
        JointTrajectoryPoint(
            positions=timed.positions[k].tolist(),
            velocities=timed.velocities[k].tolist(),
            accelerations=timed.accelerations[k].tolist() if with_accelerations else [],
            time_from_start=float(timed.times[k]),
        )
        for k in range(len(timed))
    ])


#: TimedTrajectory.sample evaluates with the compiled kernel (the validator samples every plan
#: hundreds of times over: NumPy's per-operation cost dominated); tests switch it off to compare.
#: Without it (or with one stored point) sample runs the NumPy steps.
_EVALUATE_COMPILED = numba_available()


def max_steps(positions: np.ndarray) -> np.ndarray:
    """Each step's largest joint change, ``max(|diff(positions)|, axis=1)``, NaN where a row
    holds one: compiled, since NumPy's reduction over a row of a few joints costs ~40 µs for
    the 700 states of a validated motion."""
    positions = np.ascontiguousarray(positions, dtype=float)
    if not _EVALUATE_COMPILED or positions.ndim != 2 or positions.shape[0] < 2 or positions.shape[1] == 0:
        return np.max(np.abs(np.diff(positions, axis=0)), axis=1)
    out = np.empty(positions.shape[0] - 1)
    _max_steps_kernel(positions, out)
    return out


@compiled
def _max_steps_kernel(positions, out):  # pragma: no cover - compiled
    for m in range(out.shape[0]):
        largest = 0.0
        nan = False
        for j in range(positions.shape[1]):
            d = abs(positions[m + 1, j] - positions[m, j])
            if d != d:
                nan = True
            elif d > largest:
                largest = d
        out[m] = math.nan if nan else largest


@compiled
def _sample_kernel(times, positions, velocities, accelerations, cubic, ts, clip, q, qd, qdd):  # pragma: no cover
    """TimedTrajectory.sample (``clip``: times clamped to the stored span) or _interpolate, per
    time: its interval (searchsorted 'right' minus one, within 0..n-2), the interval's polynomial
    with _evaluate_numpy's operations in the same order (so the same roundings), and at a stored
    time the stored point verbatim. False when a time is NaN (nothing else is then reliable)."""
    n = times.shape[0]
    for m in range(ts.shape[0]):
        t = ts[m]
        if t != t:
            return False
        if clip:
            t = min(max(t, times[0]), times[n - 1])
        i = min(max(np.searchsorted(times, t, side="right") - 1, 0), n - 2)
        stored = min(np.searchsorted(times, t), n - 1)
        if times[stored] == t:
            for j in range(positions.shape[1]):
                q[m, j] = positions[stored, j]
                qd[m, j] = velocities[stored, j]
                qdd[m, j] = accelerations[stored, j]
            continue
        h = times[i + 1] - times[i]
        x = (t - times[i]) / h
        for j in range(positions.shape[1]):
            p0 = positions[i, j]
            if cubic:
                tau = x * h
                a0 = accelerations[i, j]
                vel0 = velocities[i, j]
                jerk = 2.0 * (velocities[i + 1, j] - vel0 - a0 * h) / (h * h)
                q[m, j] = p0 + tau * (vel0 + tau * (0.5 * a0 + tau * jerk / 6.0))
                qd[m, j] = vel0 + tau * (a0 + 0.5 * tau * jerk)
                qdd[m, j] = a0 + tau * jerk
                continue
            p1 = positions[i + 1, j]
            v0 = velocities[i, j] * h
            v1 = velocities[i + 1, j] * h
            a0 = accelerations[i, j] * h * h
            a1 = accelerations[i + 1, j] * h * h
            c0, c1, c2 = p0, v0, 0.5 * a0
            dp = p1 - p0
            c3 = 10 * dp - 6 * v0 - 4 * v1 - 1.5 * a0 + 0.5 * a1
            c4 = -15 * dp + 8 * v0 + 7 * v1 + 1.5 * a0 - a1
            c5 = 6 * dp - 3 * v0 - 3 * v1 - 0.5 * a0 + 0.5 * a1
            q[m, j] = c0 + x * (c1 + x * (c2 + x * (c3 + x * (c4 + x * c5))))
            qd[m, j] = (c1 + x * (2 * c2 + x * (3 * c3 + x * (4 * c4 + x * 5 * c5)))) / h
            qdd[m, j] = (2 * c2 + x * (6 * c3 + x * (12 * c4 + x * 20 * c5))) / (h * h)
    return True
