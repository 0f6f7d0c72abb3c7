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
from ..trajectory_processing.trajectory_validator import DEFAULT_RESOLUTION, dense_samples

__all__ = ["PathAhead", "PathCollision", "StopPlan", "stopping_trajectory", "stop_command"]

#: s between the points of a stop command (a controller's period)
STOP_SAMPLE_PERIOD = 0.01


@dataclass(frozen=True)
class PathCollision:
    """The first colliding state ahead: its time on the trajectory, the last free time checked
    before it (None when the arm is already in collision), and the contacts."""

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
                 resolution: float = DEFAULT_RESOLUTION) -> None:
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
        state = np.array(scene.current_state.positions, dtype=float)
        state[self.indices] = rows[k]
        report = scene.check_collision(RobotState(self.model, state), max_contacts=3)
        contacts = tuple(str(c) for c in report.contacts)
        free = float(self.times[first + k - 1]) if k > 0 else None
        return PathCollision(float(self.times[first + k]), free, float(t_from), self.duration, contacts)


@dataclass(frozen=True)
class StopPlan:
    """A stop along the path: ``trajectory`` (times from 0, the state at trajectory time
    ``start`` first), at rest at trajectory time ``rest_at`` after ``duration`` seconds."""

    trajectory: TimedTrajectory
    start: float
    rest_at: float
    duration: float


def _slowest(qd: np.ndarray, curv: np.ndarray, limits: np.ndarray) -> float:
    """The largest lower bound on the path speed's rate s' that -a <= qdd s^2 + qd s' <= a puts."""
    return float(np.max(np.where(qd > 0, -limits - curv, limits - curv) / qd))


def stopping_trajectory(trajectory: TimedTrajectory, t0: float, acceleration_limits: np.ndarray,
                        stop_before: float | None = None, period: float = STOP_SAMPLE_PERIOD,
                        margin: float = 0.9, step: float = 0.002) -> StopPlan | None:
    """The quickest stop along ``trajectory`` from its time ``t0`` (s from its first point)
    with every joint's acceleration within ``margin`` x ``acceleration_limits`` (per joint of the
    trajectory; inf: unlimited; the margin absorbs what a controller's spline between the points
    adds where the path's own acceleration steps). With ``stop_before`` the arm must be at rest by that trajectory
    time; None when it cannot be (the caller then halts at once).

    The path speed s (1: as planned, 0: at rest) falls as fast as the limits allow: a joint's
    acceleration along the path is q''(tau) s^2 + q'(tau) s', so each joint bounds s' from below
    and the stop takes the largest bound, integrated every ``step`` seconds (1-D time-optimal
    path parameterisation, braking only). Velocities never exceed the trajectory's own. Where the
    path brakes hard itself, the stop may just follow it; where a hand-made path asks for more
    than the limits itself, the path speed still falls (by 1/s).
    The result has a point every ``period`` seconds and ends at rest."""
    t0 = float(min(max(t0, 0.0), trajectory.duration))
    first = float(trajectory.times[0])
    end = first + trajectory.duration
    full = np.asarray(acceleration_limits, dtype=float)
    full = np.where(np.isfinite(full) & (full > 0), full, np.inf)
    limits = full * margin
    tau, speed = first + t0, 1.0
    taus, speeds, slowings, stamps = [], [], [], []
    now = 0.0
    for _ in range(int(60.0 / step)):
        q, qd, qdd = trajectory.sample(tau)
        moving = np.abs(qd) > 1e-9
        if tau >= end or not np.any(moving) or speed <= 0.0:
            taus.append(min(tau, end))
            stamps.append(now)
            speeds.append(0.0)
            slowings.append(0.0)
            break
        # -a <= qdd s^2 + qd s' <= a  =>  s' >= (-a - qdd s^2) / qd  (qd > 0), (a - qdd s^2) / qd (qd < 0)
        curv = qdd[moving] * speed * speed
        slowing = _slowest(qd[moving], curv, limits[moving])
        if slowing > 0.0:  # the path brakes at its limits itself here: follow it (full limits)
            slowing = min(_slowest(qd[moving], curv, full[moving]), 0.0)
            if slowing >= 0.0 and _slowest(qd[moving], curv, full[moving]) > 0.0:
                slowing = -1.0  # a hand-made path asking for more than the limits: brake anyway
        taus.append(tau)
        stamps.append(now)
        speeds.append(speed)
        slowings.append(slowing)
        new_speed = speed + slowing * step
        if new_speed <= 0.0 and slowing < 0.0:  # at rest within this step
            dt = speed / -slowing
            tau += 0.5 * speed * dt
            taus.append(min(tau, end))
            stamps.append(now + dt)
            speeds.append(0.0)
            slowings.append(slowing)
            break
        advance = 0.5 * (speed + new_speed) * step
        if tau + advance >= end:  # the path itself ends (at rest) within this step
            taus.append(end)
            stamps.append(now + (end - tau) / max(0.5 * (speed + new_speed), 1e-9))
            speeds.append(0.0)
            slowings.append(slowing)
            break
        tau += advance
        speed = new_speed
        now += step
    else:
        return None
    tau_arr = np.array(taus)
    rest_at = float(tau_arr[-1] - first)
    if stop_before is not None and rest_at > stop_before:
        return None
    times = np.array(stamps)
    keep = np.unique(np.append(np.arange(0, len(times), max(1, round(period / step))), len(times) - 1))
    if len(keep) > 1 and times[keep[-1]] - times[keep[-2]] < 0.01 * period:
        keep = np.delete(keep, -2)
    q, qd, qdd = trajectory.sample(tau_arr[keep])
    s_k, ds_k = np.array(speeds)[keep, None], np.array(slowings)[keep, None]
    velocities = qd * s_k
    accelerations = qdd * s_k ** 2 + qd * ds_k
    velocities[-1] = 0.0
    # the braking acceleration holds until the very end (as the samples before it): an interpolating
    # controller told "0" there would brake harder in the last interval to meet it
    accelerations[-1] = accelerations[-2] if len(keep) > 1 else 0.0
    stop = TimedTrajectory(trajectory.joint_names, times[keep], q, velocities, accelerations, interpolation="quintic")
    return StopPlan(stop, t0, rest_at, float(times[-1]))


def stop_command(plan: StopPlan, lead: float, goal_id: str) -> JointTrajectory:
    """The stop as a JointTrajectory for the controllers: its first point ``lead`` seconds after
    receipt (the controller interpolates from where the joints are to it, as JTC does when a new
    goal preempts a running one)."""
    traj = plan.trajectory
    points = [JointTrajectoryPoint(positions=[float(v) for v in traj.positions[k]],
                                   velocities=[float(v) for v in traj.velocities[k]],
                                   accelerations=[float(v) for v in traj.accelerations[k]],
                                   time_from_start=float(lead + traj.times[k]))
              for k in range(len(traj))]
    return JointTrajectory(joint_names=list(traj.joint_names), points=points, frame_id=goal_id)

