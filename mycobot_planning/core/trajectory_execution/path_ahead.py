"""The path still ahead of a moving arm (MoveIt's plan_execution: isRemainingPathValid) and how to
stop short of it along the path itself, within the joint acceleration limits.

A trajectory being executed is sampled once, at the validator's resolution, when it starts; each
scene change then checks only the samples still ahead of the arm, in time order, and names the
first contact. A stop is a re-timing of the same path: the path parameter slows down on a smooth
(cubic) velocity profile, so the arm never leaves the path that was checked and comes to rest
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

#: largest number of re-timings tried before a stop is declared impossible within the limits
_MAX_STOP_ROUNDS = 60
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


def _profile(trajectory: TimedTrajectory, t0: float, span: float, period: float) -> tuple[np.ndarray, ...]:
    """(t, tau, q, qd, qdd, path_qdd, braking) of the path re-timed from ``t0`` with the path
    speed falling from 1 to 0 over ``span`` seconds as 1 - 3 s^2 + 2 s^3 (s = t / span): smooth
    at both ends, so the acceleration neither jumps when the stop begins nor when it ends; the
    path advances span/2. ``path_qdd`` is the path's own |acceleration| at tau, ``braking`` the
    |acceleration| the slowing down adds."""
    t = np.arange(0.0, span, period)
    t = np.append(t[span - t > 0.01 * period], span)
    s = t / span
    tau = t0 + span * (s - s ** 3 + 0.5 * s ** 4)
    speed = 1.0 - 3.0 * s ** 2 + 2.0 * s ** 3
    slowing = (6.0 * s ** 2 - 6.0 * s) / span
    q, qd, qdd = trajectory.sample(tau)
    braking = qd * slowing[:, None]
    return (t, tau, q, qd * speed[:, None], qdd * (speed ** 2)[:, None] + braking, np.abs(qdd),
            np.abs(braking))


def stopping_trajectory(trajectory: TimedTrajectory, t0: float, acceleration_limits: np.ndarray,
                        stop_before: float | None = None, period: float = STOP_SAMPLE_PERIOD,
                        margin: float = 0.95) -> StopPlan | None:
    """The quickest stop along ``trajectory`` from its time ``t0`` (s from its first point)
    whose joint accelerations stay within ``margin`` x ``acceleration_limits`` (per joint of the
    trajectory; inf: unlimited), or within what the path itself asks where a hand-made path
    already asks for more. Velocities never exceed the trajectory's own. With
    ``stop_before`` the arm must be at rest by that trajectory time; None when it cannot be
    (the caller then halts at once)."""
    t0 = float(min(max(t0, 0.0), trajectory.duration))
    start = trajectory.times[0] + t0
    limits = np.asarray(acceleration_limits, dtype=float) * margin
    limits = np.where(np.isfinite(limits) & (limits > 0), limits, np.inf)
    _, qd0, _ = trajectory.sample(start)
    with np.errstate(divide="ignore", invalid="ignore"):
        need = np.where(np.isfinite(limits), np.abs(qd0) / limits, 0.0)
    span = max(1.5 * float(np.max(need, initial=0.0)), 2 * period)
    for _ in range(_MAX_STOP_ROUNDS):
        rest_at = t0 + 0.5 * span
        if stop_before is not None and rest_at > stop_before:
            return None
        t, tau, q, qd, qdd, path_qdd, braking = _profile(trajectory, start, span, period)
        # within the limits; where the path itself asks for more, the braking within them
        fine = (np.abs(qdd) <= limits + 1e-9) | ((path_qdd > limits) & (braking <= limits + 1e-9))
        if np.all(fine):
            qdd[-1] = 0.0
            qd[-1] = 0.0
            stop = TimedTrajectory(trajectory.joint_names, t, q, qd, qdd, interpolation="quintic")
            return StopPlan(stop, t0, float(tau[-1] - trajectory.times[0]), float(span))
        span *= 1.15
    return None


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

