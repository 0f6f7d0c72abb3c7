"""The path still ahead of a moving arm (MoveIt's plan_execution: isRemainingPathValid) and how to
stop short of it along the path itself, within the joint acceleration limits.

A trajectory being executed is sampled once, at the validator's resolution, when it starts; each
scene change then checks only the samples still ahead of the arm, in time order, and names the
first contact. A stop is a re-timing of the same path: the path speed falls as fast as the joint
acceleration limits allow, so the arm never leaves the path that was checked and comes to rest
where the path was still free. docs/trajectory_execution.md, "Reacting to scene changes".
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from interfaces_py.msgs import JointTrajectory, JointTrajectoryPoint

from ..planning_scene.planning_scene import PlanningScene
from ..robot_model.robot_model import RobotModel
from ..robot_state.robot_state import RobotState
from ..robot_trajectory.robot_trajectory import TimedTrajectory, joint_trajectory_to_timed
from ..trajectory_processing.trajectory_limits import DEFAULT_LIMIT_TOLERANCE
from ..trajectory_processing.trajectory_validator import DEFAULT_RESOLUTION, dense_samples

__all__ = ["PathAhead", "PathCollision", "StopPlan", "stopping_trajectory", "stop_command"]

#: m: a stop along the path ends where the robot is still this far from the first contact
STOP_CLEARANCE = 0.01
#: s between the points of a stop command (a controller's period)
STOP_SAMPLE_PERIOD = 0.01


@dataclass(frozen=True)
class PathCollision:
    """The first colliding state ahead: its time on the trajectory, the last time before it
    where the robot is still the path's clearance away from any contact (None when there is
    none: the arm is already in or next to the contact), and the contacts."""

    time: float
    free_until: float | None
    checked_from: float
    duration: float
    contacts: tuple[str, ...]

    def message(self) -> str:
        what = "; ".join(self.contacts) or "contact not reported by the scene"
        return f"the path ahead collides: {what} at {self.time:.2f} s of {self.duration:.2f} s"


class PathAhead:
    """A trajectory under execution, sampled once at ``resolution`` (max joint step, rad or m)."""

    def __init__(self, model: RobotModel, trajectory: JointTrajectory | TimedTrajectory,
                 resolution: float = DEFAULT_RESOLUTION, clearance: float = STOP_CLEARANCE) -> None:
        timed = trajectory if isinstance(trajectory, TimedTrajectory) else joint_trajectory_to_timed(trajectory)
        self.model = model
        self.trajectory = timed
        mimic = set(model.mimic_joint_names)
        keep = [i for i, n in enumerate(timed.joint_names) if n not in mimic]
        self.joint_names = [timed.joint_names[i] for i in keep]
        self.indices = np.array([model.variable_index(n) for n in self.joint_names], dtype=int)
        ts, q, _, _, _ = dense_samples(timed, resolution)
        self.times = ts - timed.times[0]
        self.positions = q[:, keep]
        self.duration = timed.duration
        self.clearance = clearance

    def first_collision(self, scene: PlanningScene, t_from: float) -> PathCollision | None:
        """The first state at or after ``t_from`` (s from the start; the sample just before it is
        checked too) that collides in ``scene`` (whose current state gives the joints the
        trajectory does not move), or None when the rest of the path is free."""
        first = max(int(np.searchsorted(self.times, t_from, side="right")) - 1, 0)
        rows = self.positions[first:]
        if not rows.shape[0]:
            return None
        order = np.arange(rows.shape[0])
        hits = scene.colliding_rows(self.indices, None, rows, order=order, stop_at_first=True)
        if not np.any(hits):
            return None
        k = int(np.argmax(hits))
        base = np.array(scene.current_state.positions, dtype=float)

        def state(row: np.ndarray) -> RobotState:
            values = base.copy()
            values[self.indices] = row
            return RobotState(self.model, values)

        report = scene.check_collision(state(rows[k]), max_contacts=3)
        contacts = tuple(str(c) for c in report.contacts)
        world = any("Object" in (c.kind_a, c.kind_b) for c in report.contacts)
        # clearance from the world's objects; a self-contact (an attached object) is kept apart
        # at the path's resolution only
        free = self._clear_before(scene, rows, k, state) if world else (k - 1 if k > 0 else None)
        return PathCollision(float(self.times[first + k]), None if free is None else float(self.times[first + free]),
                             float(t_from), self.duration, contacts)

    def _clear_before(self, scene: PlanningScene, rows: np.ndarray, k: int, state) -> int | None:
        """The last row before ``k`` at least ``clearance`` m from every world object, or None
        when there is none: backwards in doubling steps, then halving between the last row found
        too close and the first found clear (a handful of distance queries)."""
        def clear(j: int) -> bool:
            return scene.distance(state(rows[j]), include_self=False).min_distance >= self.clearance

        near, step = k, 1
        j = k - 1
        while j >= 0 and not clear(j):
            near, j, step = j, j - step, step * 2
        if j < 0:
            if k > 0 and near > 0 and clear(0):
                j = 0
            else:
                return None
        while near - j > 1:  # j clear, near too close
            mid = (j + near) // 2
            if clear(mid):
                j = mid
            else:
                near = mid
        return j

    def locate(self, positions: np.ndarray, around: float, window: float = 0.3, ahead: float | None = None) -> float:
        """The time on the path (within ``window`` s before and ``ahead`` s, by default a sixth
        of the window, after ``around``) whose state is nearest ``positions`` (the trajectory's
        joints, max-norm): where a controller that started late or runs behind really is."""
        lo = np.searchsorted(self.times, around - window)
        hi = np.searchsorted(self.times, around + (window / 6.0 if ahead is None else ahead), side="right")
        if hi <= lo:
            return float(min(max(around, 0.0), self.duration))
        error = np.max(np.abs(self.positions[lo:hi] - np.asarray(positions, dtype=float)), axis=1)
        return float(self.times[lo + int(np.argmin(error))])


@dataclass(frozen=True)
class StopPlan:
    """A stop along the path: ``trajectory`` (times from 0, the state at trajectory time
    ``start`` first), at rest at trajectory time ``rest_at`` after ``duration`` seconds."""

    trajectory: TimedTrajectory
    start: float
    rest_at: float
    duration: float


def stopping_trajectory(trajectory: TimedTrajectory, t0: float, acceleration_limits: np.ndarray,
                        stop_before: float | None = None, period: float = STOP_SAMPLE_PERIOD,
                        margin: float = 0.9, step: float = 0.001, horizon: float = 3.0) -> StopPlan | None:
    """The quickest stop along ``trajectory`` from its time ``t0`` (s from its first point)
    with every joint's acceleration within ``margin`` x ``acceleration_limits`` (per joint of the
    trajectory; inf: unlimited; the margin absorbs what a controller's spline between the points
    adds where the path's own acceleration steps). With ``stop_before`` the arm must be at rest
    by that trajectory time; None when it cannot be (the caller then halts at once).

    The path speed s (1: as planned, 0: at rest) falls as fast as the limits allow. A joint's
    acceleration along the path is q''(tau) s^2 + q'(tau) s'; with x = s^2, dx/dtau = 2 s', and
    each joint bounds s' from below by a bound linear in x. So x is integrated over the path
    parameter tau on a grid of ``step`` seconds of path time, sampled in one vectorised call
    (1-D time-optimal path parameterisation, braking only), then turned into time. Velocities
    never exceed the trajectory's own. Where the path brakes at its limits itself the stop
    follows it; where a hand-made path asks for more than the limits itself, the path speed
    still falls (s' = -1/s). The result has a point every ``period`` seconds and ends at rest."""
    t0 = float(min(max(t0, 0.0), trajectory.duration))
    first = float(trajectory.times[0])
    end = first + trajectory.duration
    full = np.asarray(acceleration_limits, dtype=float)
    full = np.where(np.isfinite(full) & (full > 0), full, np.inf)
    limits = full * margin
    grid = np.arange(first + t0, min(end, first + t0 + horizon), step)
    grid = np.append(grid, min(end, first + t0 + horizon)) if grid.size == 0 or grid[-1] < end else grid
    _, qd, qdd = trajectory.sample(grid)
    moving = np.abs(qd) > 1e-9
    safe_qd = np.where(moving, qd, 1.0)
    # s' >= (c - qdd x) / qd with c = -a (qd > 0) or +a (qd < 0): lower bounds linear in x
    c_margin = np.where(qd > 0, -limits, limits) / safe_qd
    # the full limits with the controllers' tolerance: a planned path may touch them within it
    c_full = np.where(qd > 0, -full, full) * (1.0 + DEFAULT_LIMIT_TOLERANCE) / safe_qd
    slope = qdd / safe_qd
    x = 1.0
    xs, rates, taus = [1.0], [], [float(grid[0])]
    rest = None
    for i in range(grid.size - 1):
        m = moving[i]
        if not m.any():  # the path itself is at rest here
            rest = float(grid[i])
            break
        # both ends of the step bound it: the path's own acceleration may step in between
        ends = (i, i + 1) if moving[i + 1].any() else (i,)

        def bound(c: np.ndarray) -> float:
            return max(float(np.max(c[k, moving[k]] - slope[k, moving[k]] * x)) for k in ends)

        rate = bound(c_margin)
        if rate > 0.0:  # the path brakes at its limits itself: follow it within the full limits
            full_rate = bound(c_full)
            rate = min(full_rate, 0.0)
            if full_rate > 0.0:
                rate = -1.0  # a hand-made path asking for more than the limits: brake anyway
        rates.append(rate)
        h = float(grid[i + 1] - grid[i])
        x_next = x + 2.0 * rate * h
        if x_next <= 0.0:
            rest = float(grid[i]) + (x / (-2.0 * rate) if rate < 0 else h)
            taus.append(rest)
            xs.append(0.0)
            break
        x = x_next
        xs.append(x)
        taus.append(float(grid[i + 1]))
    else:
        if grid[-1] < end - 1e-12:
            return None  # not at rest within the horizon
        rest = float(grid[-1])
    if rest is None:
        return None
    # the rate at the rest point: the braking that got there (0 where the path itself rests)
    rates.append(rates[-1] if rates and len(taus) > len(rates) and xs[-1] == 0.0 else 0.0)
    while len(rates) < len(taus):
        rates.append(0.0)
    tau_arr = np.array(taus)
    rest_at = float(rest - first)
    if stop_before is not None and rest_at > stop_before:
        return None
    speed = np.sqrt(np.maximum(np.array(xs), 0.0))
    # time to cover each tau step at the mean of its end speeds (exact for s linear in time)
    dtau = np.diff(tau_arr)
    mean = 0.5 * (speed[:-1] + speed[1:])
    times = np.concatenate(([0.0], np.cumsum(np.where(mean > 0, dtau / np.maximum(mean, 1e-12), 0.0))))
    rate_arr = np.array(rates[:len(taus)])
    ts = np.arange(0.0, times[-1], period)
    ts = np.append(ts[times[-1] - ts > 0.01 * period], times[-1])
    # within step i the speed is linear in time with slope rates[i]: tau is exact there
    i = np.clip(np.searchsorted(times, ts, side="right") - 1, 0, len(times) - 1)
    dt = ts - times[i]
    tau_k = np.minimum(tau_arr[i] + speed[i] * dt + 0.5 * rate_arr[i] * dt * dt, tau_arr[-1])
    s_k = np.maximum(speed[i] + rate_arr[i] * dt, 0.0)[:, None]
    ds_k = rate_arr[i][:, None]
    q, qd_k, qdd_k = trajectory.sample(tau_k)
    velocities = qd_k * s_k
    accelerations = qdd_k * s_k ** 2 + qd_k * ds_k
    velocities[-1] = 0.0
    # the braking acceleration holds until the very end (as at the samples before it): a
    # controller told "0" there would brake harder in the last interval to meet it
    accelerations[-1] = accelerations[-2] if len(ts) > 1 else 0.0
    stop = TimedTrajectory(trajectory.joint_names, ts, q, velocities, accelerations, interpolation="quintic")
    return StopPlan(stop, t0, rest_at, float(ts[-1]))


def stop_command(plan: StopPlan, lead: float, goal_id: str, elapsed: float = 0.0,
                 min_lead: float = 0.008) -> JointTrajectory:
    """The stop as a JointTrajectory for the controllers: the plan began ``lead`` s after the arm's
    place it was computed from, ``elapsed`` s ago; each point is timed from now (the receipt), and
    points that would come sooner than ``min_lead`` are dropped (the arm is already past them; the
    controller interpolates from where the joints are to the first point kept, as JTC does when a
    new goal preempts a running one). The last point is always kept."""
    traj = plan.trajectory
    shift = lead - elapsed
    keep = [k for k in range(len(traj)) if traj.times[k] + shift >= min_lead] or [len(traj) - 1]
    points = [JointTrajectoryPoint(positions=[float(v) for v in traj.positions[k]],
                                   velocities=[float(v) for v in traj.velocities[k]],
                                   accelerations=[float(v) for v in traj.accelerations[k]],
                                   time_from_start=float(max(traj.times[k] + shift, min_lead)))
              for k in keep]
    return JointTrajectory(joint_names=list(traj.joint_names), points=points, frame_id=goal_id)
