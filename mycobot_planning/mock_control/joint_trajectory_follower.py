"""Following a joint trajectory in time, as ros2_control's JointTrajectoryController (JTC) does.

The full story: docs/mock_control.md, section mycobot_planning.mock_control.joint_trajectory_follower.
"""
from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from ..core.errors import StateError
from ..core.robot_trajectory.robot_trajectory import TimedTrajectory
from ..core.trajectory_execution.path_ahead import stopping_trajectory
from ..core.trajectory_processing.trajectory_limits import DEFAULT_LIMIT_TOLERANCE, motion_limit_problem


class ControllerStatus:
    """Values of the ``status`` field of ``/<controller>/state`` (see contract: issue 4)."""

    IDLE = "idle"  # no goal yet; holding the initial (or reset) position
    EXECUTING = "executing"  # following a goal
    SUCCEEDED = "succeeded"  # reached the last point within goal tolerance
    ABORTED = "aborted"  # the command was rejected (message says "rejected: <reason>")
    FAILED = "failed"  # fault injected with fail_after: stopped mid-goal
    STALLED = "stalled"  # fault injected with stall_after: end time passed, goal not reached
    PREEMPTED = "preempted"  # replaced by a newer goal
    STOPPED = "stopped"  # stop service, or an empty trajectory

    ALL = (IDLE, EXECUTING, SUCCEEDED, ABORTED, FAILED, STALLED, PREEMPTED, STOPPED)
    #: A goal in one of these states is over and will not change any more.
    TERMINAL = (SUCCEEDED, ABORTED, FAILED, PREEMPTED, STOPPED)


# --------------------------------------------------------------------------------- commands


@dataclass
class TrajectoryCommand:
    """A trajectory as it arrived (trajectory_msgs/JointTrajectory, unvalidated).

    ``velocities``/``accelerations`` hold one list per point, each empty or with one value per
    joint (as in the ROS message); an empty outer sequence means "none given". ``start_time``
    is the header stamp in the follower's clock, or None ("start on receipt", stamp 0 in ROS).
    ``goal_id`` names the goal in state reports; empty means the follower makes one up.
    """

    joint_names: Sequence[str]
    times: Sequence[float]
    positions: Sequence[Sequence[float]]
    velocities: Sequence[Sequence[float]] = ()
    accelerations: Sequence[Sequence[float]] = ()
    start_time: float | None = None
    goal_id: str = ""

    @classmethod
    def from_arrays(
        cls,
        joint_names: Sequence[str],
        times: Sequence[float],
        positions: Any,
        velocities: Any = None,
        accelerations: Any = None,
        goal_id: str = "",
        start_time: float | None = None,
    ) -> "TrajectoryCommand":
        """From (N,) times and (N, d) arrays, e.g. a TimedTrajectory's fields."""
        def rows(values: Any) -> list[list[float]]:
            return [] if values is None else [list(map(float, row)) for row in np.asarray(values, dtype=float)]

        return cls(list(joint_names), [float(t) for t in times], rows(positions), rows(velocities),
                   rows(accelerations), start_time, goal_id)

    @property
    def is_stop(self) -> bool:
        """An empty trajectory: JTC's way of saying "stop and hold"."""
        return len(self.times) == 0 and len(self.positions) == 0


@dataclass
class _Plan:
    """A validated command in controller joint order (times relative to the start)."""

    times: np.ndarray  # (N,)
    positions: np.ndarray  # (N, d)
    velocities: np.ndarray | None
    accelerations: np.ndarray | None

    @property
    def kind(self) -> str:
        if self.accelerations is not None:
            return "quintic"
        if self.velocities is not None:
            return "cubic"
        return "linear"


#: s between the samples of the path a smooth stop slows down along, and how far ahead they reach
_STOP_SAMPLE = 0.005
_STOP_HORIZON = 3.0


def _fmt(value: float) -> str:
    return f"{value:.6g}"


class _Spline:
    """Piecewise polynomial through knots at absolute times; coefficients precomputed so one
    update costs a bisect and a Horner evaluation on d-vectors."""

    def __init__(self, times: np.ndarray, pos: np.ndarray, vel: np.ndarray, acc: np.ndarray, kind: str):
        self.times = times
        self._times_list = times.tolist()
        self.final = pos[-1].copy()
        self.dof = pos.shape[1]
        n = times.shape[0]
        self.coeffs = np.zeros((max(n - 1, 0), 6, self.dof))  # on x in [0, 1] per segment
        self.h = np.diff(times)
        for k in range(n - 1):
            h = self.h[k]
            p0, p1 = pos[k], pos[k + 1]
            dp = p1 - p0
            c = self.coeffs[k]
            c[0] = p0
            if kind == "linear":
                c[1] = dp
            elif kind == "cubic":
                v0, v1 = vel[k] * h, vel[k + 1] * h
                c[1] = v0
                c[2] = 3 * dp - 2 * v0 - v1
                c[3] = -2 * dp + v0 + v1
            else:
                v0, v1 = vel[k] * h, vel[k + 1] * h
                a0, a1 = acc[k] * h * h, acc[k + 1] * h * h
                c[1] = v0
                c[2] = 0.5 * a0
                c[3] = 10 * dp - 6 * v0 - 4 * v1 - 1.5 * a0 + 0.5 * a1
                c[4] = -15 * dp + 8 * v0 + 7 * v1 + 1.5 * a0 - a1
                c[5] = 6 * dp - 3 * v0 - 3 * v1 - 0.5 * a0 + 0.5 * a1
        self.start = float(times[0])
        self.end = float(times[-1])
        self._pos0 = pos[0].copy()
        self._vel0 = vel[0].copy()
        self._acc0 = acc[0].copy()

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q, qd, qdd) at absolute time t; before the start the first knot, after the end the
        last position held at rest."""
        if t >= self.end:
            return self.final.copy(), np.zeros(self.dof), np.zeros(self.dof)
        if t <= self.start:
            return self._pos0.copy(), self._vel0.copy(), self._acc0.copy()
        k = bisect_right(self._times_list, t) - 1
        h = self.h[k]
        x = (t - self._times_list[k]) / h
        c = self.coeffs[k]
        q = c[0] + x * (c[1] + x * (c[2] + x * (c[3] + x * (c[4] + x * c[5]))))
        qd = (c[1] + x * (2 * c[2] + x * (3 * c[3] + x * (4 * c[4] + x * 5 * c[5])))) / h
        qdd = (2 * c[2] + x * (6 * c[3] + x * (12 * c[4] + x * 20 * c[5]))) / (h * h)
        return q, qd, qdd


# --------------------------------------------------------------------------------- state


@dataclass
class FollowerState:
    """One ``/<controller>/state`` report. ``to_dict`` is the JSON form (contract, issue 4):
    desired/actual/error are trajectory_msgs/JointTrajectoryPoint-shaped dicts (the schema of
    ``interfaces_py.msgs.JointTrajectoryPoint``), ``time_from_start`` = time since the goal
    started (0 when there is no goal)."""

    joint_names: list[str]
    status: str
    active: bool
    goal_id: str
    message: str
    time_from_start: float
    desired_positions: np.ndarray
    desired_velocities: np.ndarray
    desired_accelerations: np.ndarray
    actual_positions: np.ndarray
    actual_velocities: np.ndarray
    actual_accelerations: np.ndarray

    def _point(self, p: np.ndarray, v: np.ndarray, a: np.ndarray) -> dict[str, Any]:
        return {"positions": p.tolist(), "velocities": v.tolist(), "accelerations": a.tolist(),
                "time_from_start": self.time_from_start}

    def to_dict(self) -> dict[str, Any]:
        return {
            "joint_names": list(self.joint_names),
            "desired": self._point(self.desired_positions, self.desired_velocities, self.desired_accelerations),
            "actual": self._point(self.actual_positions, self.actual_velocities, self.actual_accelerations),
            "error": self._point(self.desired_positions - self.actual_positions,
                                 self.desired_velocities - self.actual_velocities,
                                 self.desired_accelerations - self.actual_accelerations),
            "active": self.active,
            "status": self.status,
            "message": self.message,
            "goal_id": self.goal_id,
        }


@dataclass
class SubmitResult:
    """What happened to a command: accepted or not (with the reason), and the state reports the
    node must publish right away (preempted old goal, rejection, new goal executing, stop)."""

    accepted: bool
    goal_id: str
    reason: str = ""
    events: list[FollowerState] = field(default_factory=list)


# --------------------------------------------------------------------------------- follower


class JointTrajectoryFollower:
    """A joint trajectory controller without hardware: the commanded state *is* the measured
    state, except while a stall is injected.

    Not thread-safe: the node serialises calls.
    """

    def __init__(
        self,
        joint_names: Sequence[str],
        lower_limits: Sequence[float],
        upper_limits: Sequence[float],
        initial_positions: Sequence[float] | None = None,
        *,
        goal_tolerance: float = 0.01,
        start_tolerance: float = 0.05,
        name: str = "controller",
        limit_margin: float = 1e-6,
        velocity_limits: Sequence[float] | None = None,
        acceleration_limits: Sequence[float] | None = None,
        limit_tolerance: float = DEFAULT_LIMIT_TOLERANCE,
    ) -> None:
        """``velocity_limits`` / ``acceleration_limits`` (per joint; None: unlimited): a trajectory
        that exceeds them by more than ``limit_tolerance`` (relative) is refused before it moves
        anything, the controller's last line of defence (see trajectory_limits.py)."""
        self.name = name
        self.joint_names = list(joint_names)
        if not self.joint_names:
            raise StateError(f"{name}: a controller needs at least one joint")
        if len(set(self.joint_names)) != len(self.joint_names):
            raise StateError(f"{name}: duplicate joint names in {self.joint_names}")
        d = len(self.joint_names)
        self.lower = np.asarray(lower_limits, dtype=float).reshape(-1)
        self.upper = np.asarray(upper_limits, dtype=float).reshape(-1)
        if self.lower.shape != (d,) or self.upper.shape != (d,):
            raise StateError(f"{name}: expected {d} lower and upper limits for joints {self.joint_names}")
        if np.any(np.isnan(self.lower)) or np.any(np.isnan(self.upper)) or np.any(self.lower > self.upper):
            raise StateError(f"{name}: limits must be numbers with lower <= upper")
        for what, value in (("goal_tolerance", goal_tolerance), ("start_tolerance", start_tolerance)):
            if not (math.isfinite(value) and value >= 0):
                raise StateError(f"{name}: {what} must be a finite number >= 0, got {value}")
        self.goal_tolerance = float(goal_tolerance)
        self.start_tolerance = float(start_tolerance)
        self.limit_margin = float(limit_margin)
        unlimited = np.full(d, np.inf)
        self.velocity_limits = unlimited if velocity_limits is None else np.asarray(velocity_limits, dtype=float)
        self.acceleration_limits = (unlimited if acceleration_limits is None
                                    else np.asarray(acceleration_limits, dtype=float))
        if self.velocity_limits.shape != (d,) or self.acceleration_limits.shape != (d,):
            raise StateError(f"{name}: expected {d} velocity and acceleration limits for joints {self.joint_names}")
        if not (math.isfinite(limit_tolerance) and limit_tolerance >= 0):
            raise StateError(f"{name}: limit_tolerance must be a finite number >= 0, got {limit_tolerance}")
        self.limit_tolerance = float(limit_tolerance)
        self._index = {n: i for i, n in enumerate(self.joint_names)}
        self.fail_after = -1.0
        self.stall_after = -1.0
        self._goal_counter = 0
        start = np.clip(np.zeros(d), self.lower, self.upper) if initial_positions is None else None
        if start is None:
            start = self._checked_positions(initial_positions, "initial positions")
        self._zero = np.zeros(d)
        self._actual_pos = start.copy()
        self._actual_vel = np.zeros(d)
        self._actual_acc = np.zeros(d)
        self._desired_pos = start.copy()
        self._desired_vel = np.zeros(d)
        self._desired_acc = np.zeros(d)
        self._status = ControllerStatus.IDLE
        self._message = f"{name} idle"
        self._goal_id = ""
        self._spline: _Spline | None = None
        self._stopping: str | None = None  # the reason of a smooth stop under way
        self._goal_start = 0.0
        self._stall_time: float | None = None
        self._last_update: float | None = None

    # ------------------------------------------------------------------ queries
    @property
    def dof(self) -> int:
        return len(self.joint_names)

    @property
    def status(self) -> str:
        return self._status

    @property
    def goal_id(self) -> str:
        return self._goal_id

    @property
    def active(self) -> bool:
        """A goal is being followed (executing or stalled): the joints may move."""
        return self._spline is not None

    @property
    def positions(self) -> np.ndarray:
        """Measured (actual) joint positions, controller joint order. A view: do not modify."""
        return self._actual_pos

    @property
    def velocities(self) -> np.ndarray:
        return self._actual_vel

    def state(self) -> FollowerState:
        """The current report (as of the last update)."""
        return self._snapshot(self._status, self._goal_id, self._message, self.active)

    def _snapshot(self, status: str, goal_id: str, message: str, active: bool,
                  of_current_goal: bool = True) -> FollowerState:
        elapsed = 0.0
        if of_current_goal and self._spline is not None and self._last_update is not None:
            elapsed = max(0.0, self._last_update - self._goal_start)
        return FollowerState(
            self.joint_names, status, active, goal_id, message, elapsed,
            self._desired_pos.copy(), self._desired_vel.copy(), self._desired_acc.copy(),
            self._actual_pos.copy(), self._actual_vel.copy(), self._actual_acc.copy(),
        )

    # ------------------------------------------------------------------ validation
    def _checked_positions(self, values: Sequence[float], what: str) -> np.ndarray:
        arr = np.asarray(values, dtype=float).reshape(-1)
        if arr.shape != (self.dof,):
            raise StateError(f"{self.name}: {what} need {self.dof} values for {self.joint_names}, got {arr.size}")
        if not np.all(np.isfinite(arr)):
            raise StateError(f"{self.name}: {what} must be finite numbers, got {arr.tolist()}")
        bad = np.flatnonzero((arr < self.lower - self.limit_margin) | (arr > self.upper + self.limit_margin))
        if bad.size:
            i = int(bad[0])
            raise StateError(f"{self.name}: {what}: {self.joint_names[i]} = {_fmt(arr[i])} is outside its "
                             f"limits [{_fmt(self.lower[i])}, {_fmt(self.upper[i])}]")
        return arr

    def validate(self, command: TrajectoryCommand) -> str | None:
        """Why `command` would be refused (one sentence naming the problem), or None.

        Checks joint names, per-point sizes, finite numbers, strictly increasing non-negative
        times and position limits. The start-tolerance check needs the current state and is
        made on submit.
        """
        result = self._prepare(command)
        return result if isinstance(result, str) else None

    def _prepare(self, command: TrajectoryCommand) -> _Plan | str:
        names = list(command.joint_names)
        d = self.dof
        if not names:
            return "joint_names is empty"
        seen: set[str] = set()
        for n in names:
            if n in seen:
                return f"joint '{n}' appears twice in joint_names"
            seen.add(n)
        unknown = [n for n in names if n not in self._index]
        if unknown:
            return (f"unknown joint{'s' if len(unknown) > 1 else ''} {unknown}: {self.name} controls "
                    f"{self.joint_names}")
        missing = [n for n in self.joint_names if n not in seen]
        if missing:
            return f"missing joint{'s' if len(missing) > 1 else ''} {missing}: {self.name} needs every one of {self.joint_names}"
        n_points = len(command.positions)
        if n_points == 0:
            return "the trajectory has no points"
        if len(command.times) != n_points:
            return f"{len(command.times)} time stamps for {n_points} points"
        rows: dict[str, np.ndarray | None] = {}
        for what, values, optional in (("positions", command.positions, False),
                                       ("velocities", command.velocities, True),
                                       ("accelerations", command.accelerations, True)):
            values = list(values)
            if optional and (not values or all(len(v) == 0 for v in values)):
                rows[what] = None
                continue
            if len(values) != n_points:
                return f"{what} given for {len(values)} of {n_points} points"
            for i, row in enumerate(values):
                if len(row) != d:
                    extra = " (give them for every point or for none)" if optional else ""
                    return (f"points[{i}].{what} has {len(row)} values, expected {d} "
                            f"(one per joint name){extra}")
            try:
                arr = np.asarray(values, dtype=float).reshape(n_points, d)
            except (TypeError, ValueError):
                return f"{what} are not all numbers"
            bad = np.argwhere(~np.isfinite(arr))
            if bad.size:
                i, j = (int(v) for v in bad[0])
                return f"points[{i}].{what}[{j}] ({names[j]}) is {arr[i, j]}: values must be finite"
            rows[what] = arr
        if rows["accelerations"] is not None and rows["velocities"] is None:
            return "accelerations are given without velocities"
        try:
            times = np.asarray(list(command.times), dtype=float).reshape(-1)
        except (TypeError, ValueError):
            return "time_from_start values are not all numbers"
        if not np.all(np.isfinite(times)):
            i = int(np.flatnonzero(~np.isfinite(times))[0])
            return f"points[{i}].time_from_start is {times[i]}: it must be finite"
        if times[0] < 0:
            return f"points[0].time_from_start is negative ({_fmt(times[0])} s)"
        steps = np.diff(times)
        if np.any(steps <= 0):
            i = int(np.flatnonzero(steps <= 0)[0]) + 1
            return (f"points[{i}].time_from_start ({_fmt(times[i])} s) is not after points[{i - 1}]'s "
                    f"({_fmt(times[i - 1])} s): times must strictly increase")
        if command.start_time is not None and not math.isfinite(command.start_time):
            return "the start time (header.stamp) is not finite"
        # Reorder columns into the controller's joint order.
        order = [names.index(n) for n in self.joint_names]
        pos = rows["positions"][:, order]
        low = pos < self.lower - self.limit_margin
        high = pos > self.upper + self.limit_margin
        if np.any(low | high):
            i, j = (int(v) for v in np.argwhere(low | high)[0])
            return (f"points[{i}] puts {self.joint_names[j]} at {_fmt(pos[i, j])}, outside its limits "
                    f"[{_fmt(self.lower[j])}, {_fmt(self.upper[j])}]")
        vel = None if rows["velocities"] is None else rows["velocities"][:, order]
        acc = None if rows["accelerations"] is None else rows["accelerations"][:, order]
        problem = motion_limit_problem(self.joint_names, times, pos, vel, acc, self.velocity_limits,
                                       self.acceleration_limits, self.limit_tolerance)
        if problem is not None:
            return problem
        return _Plan(times, pos, vel, acc)

    # ------------------------------------------------------------------ commands
    def submit(self, command: TrajectoryCommand, now: float) -> SubmitResult:
        """Accept (and start following) or reject a command at time `now`.

        Rejection leaves any goal being executed untouched (as JTC does with an invalid goal)
        and reports the rejected goal with status ``aborted`` and message ``rejected: ...``.
        """
        self.update(now)
        if command.is_stop:
            events = self.stop(now, "empty trajectory received")
            return SubmitResult(True, command.goal_id or self._goal_id, "", events)
        self._goal_counter += 1
        goal_id = command.goal_id or f"{self.name}#{self._goal_counter}"
        prepared = self._prepare(command)
        if isinstance(prepared, _Plan):
            reason = self._start_reason(prepared, command.start_time, now)
        else:
            reason = prepared
        if reason is not None:
            event = self._snapshot(ControllerStatus.ABORTED, goal_id, f"rejected: {reason}", self.active,
                                   of_current_goal=False)
            return SubmitResult(False, goal_id, reason, [event])
        events: list[FollowerState] = []
        if self._spline is not None:
            events.append(self._snapshot(ControllerStatus.PREEMPTED, self._goal_id,
                                         f"goal {self._goal_id} preempted by goal {goal_id}", False))
        self._start(prepared, command.start_time, now, goal_id)
        events.append(self.state())
        return SubmitResult(True, goal_id, "", events)

    def _start_reason(self, plan: _Plan, start_time: float | None, now: float) -> str | None:
        begins = max(now, start_time if start_time is not None else now)
        lead = begins + plan.times[0] - now
        if lead > 0:  # the controller interpolates from where the joints are to the first point
            problem = motion_limit_problem(self.joint_names, np.array([0.0, lead]),
                                           np.vstack((self._actual_pos, plan.positions[0])), None, None,
                                           self.velocity_limits, self.acceleration_limits, self.limit_tolerance)
            return None if problem is None else problem.replace(
                "trajectory point 1:", "reaching the first point from where the joints are:", 1)
        if self.start_tolerance <= 0:
            return None
        deviation = np.abs(plan.positions[0] - self._actual_pos)
        j = int(np.argmax(deviation))
        if deviation[j] > self.start_tolerance:
            return (f"the first point (time_from_start 0) puts {self.joint_names[j]} at "
                    f"{_fmt(plan.positions[0, j])}, {_fmt(deviation[j])} from where it is "
                    f"({_fmt(self._actual_pos[j])}; start tolerance {_fmt(self.start_tolerance)}); "
                    "give the first point a time_from_start > 0 to move there")
        return None

    def _start(self, plan: _Plan, start_time: float | None, now: float, goal_id: str) -> None:
        # A stamp in the past means "as soon as possible": start on receipt, never mid-trajectory.
        begins = now if start_time is None else max(now, start_time)
        times = begins + plan.times
        d = self.dof
        vel = plan.velocities if plan.velocities is not None else np.zeros_like(plan.positions)
        acc = plan.accelerations if plan.accelerations is not None else np.zeros_like(plan.positions)
        if times[0] > now:
            # Interpolate from where the joints are now: no jump on preemption.
            times = np.concatenate(([now], times))
            pos = np.vstack((self._actual_pos, plan.positions))
            vel = np.vstack((self._actual_vel if plan.velocities is not None else np.zeros(d), vel))
            acc = np.vstack((self._actual_acc if plan.accelerations is not None else np.zeros(d), acc))
        else:
            pos = plan.positions
        self._spline = _Spline(times, pos, vel, acc, plan.kind)
        self._stopping = None
        self._goal_id = goal_id
        self._goal_start = now
        self._stall_time = None
        self._status = ControllerStatus.EXECUTING
        self._message = (f"executing goal {goal_id}: {len(plan.times)} points, "
                         f"{_fmt(self._spline.end - now)} s, {plan.kind} interpolation")
        self._last_update = now
        self._track(now)

    def stop(self, now: float, reason: str = "stop requested", smooth: bool = False) -> list[FollowerState]:
        """Stop the goal being followed and hold the current position. Returns the report of the
        stopped goal (empty when there was nothing to stop, or while a smooth stop runs).

        ``smooth``: decelerate along the goal's own path within the joint acceleration limits
        (core.trajectory_execution.path_ahead.stopping_trajectory) and report STOPPED once at
        rest, as a cancelled goal should end on hardware; without it, or with unlimited
        accelerations, or while stalled, the joints hold where they are at once."""
        self.update(now)
        if self._spline is None:
            return []
        if self._stopping is not None:  # already decelerating: a second stop changes nothing
            return []
        if smooth and self._stall_time is None and self._decelerate(now):
            self._stopping = reason
            self._message = f"goal {self._goal_id} stopping: {reason}"
            return []
        self._finish(ControllerStatus.STOPPED, f"goal {self._goal_id} stopped: {reason}")
        return [self.state()]

    def _decelerate(self, now: float) -> bool:
        """Replace the spline by a stop along it from ``now``; False when there is nothing to
        slow down (at rest, unlimited accelerations) or no stop within the path."""
        if not np.all(np.isfinite(self.acceleration_limits)) or not np.any(np.abs(self._actual_vel) > 1e-6):
            return False
        spline = self._spline
        end = min(spline.end, now + _STOP_HORIZON)
        ts = np.append(np.arange(now, end, _STOP_SAMPLE), end) if end > now else np.array([now])
        if ts.size < 2:
            return False
        samples = [spline.sample(float(t)) for t in ts]
        path = TimedTrajectory(self.joint_names, ts - now, np.array([q for q, _, _ in samples]),
                               np.array([v for _, v, _ in samples]), np.array([a for _, _, a in samples]))
        plan = stopping_trajectory(path, 0.0, self.acceleration_limits)
        if plan is None or len(plan.trajectory) < 2:
            return False
        stop = plan.trajectory
        self._spline = _Spline(now + stop.times, stop.positions, stop.velocities, stop.accelerations, "quintic")
        return True

    def reset_positions(self, positions: Sequence[float]) -> None:
        """Put the joints somewhere else at once (the simulator's "initial position"); only
        while no goal is being followed, since a jump mid-motion is not something hardware does."""
        if self._spline is not None:
            raise StateError(f"{self.name} is executing goal {self._goal_id}; stop it before moving the joints")
        values = self._checked_positions(positions, "positions")
        self._actual_pos[:] = values
        self._desired_pos[:] = values
        for arr in (self._actual_vel, self._actual_acc, self._desired_vel, self._desired_acc):
            arr[:] = 0.0

    # ------------------------------------------------------------------ time
    def update(self, now: float) -> FollowerState | None:
        """Advance to time `now` (earlier times are treated as the last one). Returns the report
        when the status changed in this update, else None."""
        if self._last_update is not None and now < self._last_update:
            now = self._last_update
        if self._spline is None:
            self._last_update = now
            return None
        before = self._status
        fail_at = self._goal_start + self.fail_after if self.fail_after >= 0 else math.inf
        if now >= fail_at:
            when = max(fail_at, self._last_update if self._last_update is not None else fail_at)
            if self._stall_time is None:
                self._track(when)
            self._last_update = now
            self._finish(ControllerStatus.FAILED,
                         f"goal {self._goal_id} failed {_fmt(when - self._goal_start)} s after it started "
                         f"(fault injected: {self.name}.fail_after = {_fmt(self.fail_after)})")
            return self.state()
        stall_at = self._goal_start + self.stall_after if self.stall_after >= 0 else math.inf
        if self._stall_time is None and now >= stall_at:
            when = max(stall_at, self._last_update if self._last_update is not None else stall_at)
            self._track(when)
            self._stall_time = when
            self._actual_vel[:] = 0.0
            self._actual_acc[:] = 0.0
        self._last_update = now
        self._track(now)
        if now >= self._spline.end and self._stopping is not None:
            self._finish(ControllerStatus.STOPPED, f"goal {self._goal_id} stopped: {self._stopping}")
            return self.state()
        if now >= self._spline.end:
            reached = bool(np.all(np.abs(self._actual_pos - self._spline.final) <= self.goal_tolerance))
            if reached:
                self._finish(ControllerStatus.SUCCEEDED, f"goal {self._goal_id} succeeded")
            elif self._status != ControllerStatus.STALLED:
                self._status = ControllerStatus.STALLED
                err = float(np.max(np.abs(self._actual_pos - self._spline.final)))
                self._message = (f"goal {self._goal_id} stalled: the trajectory ended but the joints stopped "
                                 f"{_fmt(err)} from its last point (fault injected: {self.name}.stall_after = "
                                 f"{_fmt(self.stall_after)})")
        return self.state() if self._status != before else None

    def _track(self, t: float) -> None:
        """Desired state from the spline at t; actual follows it unless stalled."""
        q, qd, qdd = self._spline.sample(t)
        self._desired_pos[:] = q
        self._desired_vel[:] = qd
        self._desired_acc[:] = qdd
        if self._stall_time is None:
            self._actual_pos[:] = q
            self._actual_vel[:] = qd
            self._actual_acc[:] = qdd

    def _finish(self, status: str, message: str) -> None:
        """End the goal: hold the actual position at rest."""
        self._spline = None
        self._stopping = None
        self._stall_time = None
        self._status = status
        self._message = message
        self._desired_pos[:] = self._actual_pos
        for arr in (self._actual_vel, self._actual_acc, self._desired_vel, self._desired_acc):
            arr[:] = 0.0
