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

__all__ = [
    "DEFAULT_SAMPLE_PERIOD",
    "TimeParameterizationError",
    "TimedTrajectory",
    "joint_trajectory_to_timed",
    "timed_to_joint_trajectory",
]

DEFAULT_SAMPLE_PERIOD = 0.01
"""Controller period (s) used by :meth:`TimedTrajectory.resample` when none is given."""

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
    t0 = float(trajectory.times[0])
    points = [
        JointTrajectoryPoint(
            positions=trajectory.positions[k].tolist(),
            velocities=trajectory.velocities[k].tolist(),
            accelerations=trajectory.accelerations[k].tolist() if with_accelerations else [],
            time_from_start=max(0.0, float(trajectory.times[k]) - t0),
        )
        for k in range(len(trajectory))
    ]
    return JointTrajectory(joint_names=list(trajectory.joint_names), points=points)


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
