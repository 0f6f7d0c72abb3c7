"""The local planner's loop, ROS-free: MoveIt's SimpleSampler (trajectory operator) and
ForwardTrajectory (local constraint solver) on a global trajectory.

Each iteration (``ForwardTrajectory.step``, at the local planning frequency) takes the arm's
current joint positions and answers what to send to the arm's controller and what feedback to
give:

* the reference (SimpleSampler) advances along the global trajectory while the arm is within
  ``WAYPOINT_RADIAN_TOLERANCE`` (L1 over the joints) of it; the reference is forwarded as a
  one-point JointTrajectory a short ``lead`` ahead (longer when the joints could not get there
  that fast within their velocity limits), so the arm is meant to follow ``lead`` seconds
  behind it: the distance is measured to where the reference was ``lead`` ago;
* with ``stop_before_collision``, the path still ahead of the arm is checked in the current
  scene whenever the scene (or the trajectory) changed
  (core.trajectory_execution.path_ahead.PathAhead): on a collision the arm is brought to rest
  along its path before it (``stopping_trajectory``, within the acceleration limits; at once
  when that is impossible), held, and the feedback "Collision ahead" is given once; a later
  scene in which the path is free again resumes the motion;
* stuck: ``STUCK_ITERATIONS_THRESHOLD`` iterations with fresh joint states in which the arm moved
  less than ``STUCK_THRESHOLD_RAD`` while it is neither at the goal nor held -> feedback "Local
  planner is stuck" (counting starts once the arm has moved, or ``STARTUP_GRACE`` after the
  start, so the first instants of a motion from rest do not count);
* the goal is reached when the reference is at the trajectory's end and every joint is within
  ``goal_tolerance`` of its last point.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from interfaces_py.msgs import JointTrajectory, JointTrajectoryPoint

from ..planning_scene.planning_scene import PlanningScene
from ..robot_model.robot_model import RobotModel
from ..robot_trajectory.robot_trajectory import TimedTrajectory, joint_trajectory_to_timed
from ..trajectory_execution.path_ahead import PathAhead, PathCollision, stop_command, stopping_trajectory
from .planner_logic import LocalFeedback

__all__ = ["STARTUP_GRACE", "STUCK_ITERATIONS_THRESHOLD", "STUCK_THRESHOLD_RAD", "WAYPOINT_RADIAN_TOLERANCE",
           "ForwardTrajectory", "LocalCommand", "SimpleSampler", "StuckDetector"]

#: rad, L1 over the group's joints: the arm this close to the reference lets it advance (MoveIt's value)
WAYPOINT_RADIAN_TOLERANCE = 0.2
#: iterations without motion that make the local planner stuck (MoveIt: 5)
STUCK_ITERATIONS_THRESHOLD = 5
#: rad (largest joint change between two iterations) below which the arm counts as not moving (MoveIt: 1e-4)
STUCK_THRESHOLD_RAD = 1e-4
#: s after a trajectory starts before a resting arm counts towards "stuck" (it may not have started yet)
STARTUP_GRACE = 1.0
#: rad/s: an arm slower than this on every joint is at rest (a stop is then a halt where it is)
AT_REST_VELOCITY = 1e-3
#: fraction of a joint's velocity limit a command's lead-in may ask for
LEAD_IN_VELOCITY_FRACTION = 0.9


class SimpleSampler:
    """The reference on a global trajectory: a time on it that advances by the elapsed time while
    the arm is within ``tolerance`` (L1) of the reference state (MoveIt's SimpleSampler steps one
    waypoint per iteration; on a trajectory sampled at the local planning period that is the same)."""

    def __init__(self, trajectory: TimedTrajectory, tolerance: float = WAYPOINT_RADIAN_TOLERANCE) -> None:
        self.trajectory = trajectory
        self.tolerance = tolerance
        self.time = 0.0  # s from the trajectory's first point

    def reference(self) -> tuple[np.ndarray, np.ndarray]:
        q, qd, _ = self.trajectory.sample(self.trajectory.times[0] + self.time)
        return q, qd

    @property
    def at_end(self) -> bool:
        return self.time >= self.trajectory.duration

    def advance(self, q: np.ndarray, elapsed: float, lag: float = 0.0) -> bool:
        """Advance by ``elapsed`` s when ``q`` is close enough to the reference (to where the
        reference was ``lag`` s of trajectory time ago, when the arm is meant to follow it that
        far behind); whether it moved."""
        if self.at_end or elapsed <= 0:
            return False
        reference, _, _ = self.trajectory.sample(self.trajectory.times[0] + max(self.time - lag, 0.0))
        if float(np.sum(np.abs(np.asarray(q, dtype=float) - reference))) > self.tolerance:
            return False
        self.time = min(self.time + elapsed, self.trajectory.duration)
        return True


class StuckDetector:
    """Counts consecutive iterations without motion; True once ``iterations`` are reached (then
    counts afresh)."""

    def __init__(self, iterations: int = STUCK_ITERATIONS_THRESHOLD, threshold: float = STUCK_THRESHOLD_RAD) -> None:
        self.iterations = iterations
        self.threshold = threshold
        self.count = 0

    def reset(self) -> None:
        self.count = 0

    def update(self, moved: float) -> bool:
        if moved >= self.threshold:
            self.count = 0
            return False
        self.count += 1
        if self.count >= self.iterations:
            self.count = 0
            return True
        return False


@dataclass
class LocalCommand:
    """One iteration's outcome: a command for the controller (None: nothing new to send; no
    points: stop where you are), a feedback string, whether the goal is reached."""

    trajectory: JointTrajectory | None = None
    feedback: str | None = None
    done: bool = False


class ForwardTrajectory:
    """Follows one global trajectory (see the module docstring). ``period``: s between iterations;
    ``lead``: s ahead of receipt at which the controller is to reach a forwarded reference."""

    def __init__(self, model: RobotModel, trajectory: JointTrajectory | TimedTrajectory, period: float,
                 stop_before_collision: bool = True, goal_tolerance: float = 0.01, lead: float = 0.05,
                 goal_id: str = "hybrid_planning") -> None:
        self.timed = trajectory if isinstance(trajectory, TimedTrajectory) else joint_trajectory_to_timed(trajectory)
        self.path = PathAhead(model, self.timed)
        self.joint_names = list(self.timed.joint_names)
        missing = [n for n in self.path.joint_names if n not in self.joint_names]
        if missing or len(self.path.joint_names) != len(self.joint_names):
            raise ValueError("the global trajectory moves mimic joints; give the group's active joints only")
        index = [model.variable_index(n) for n in self.joint_names]
        self.velocity_limits = np.asarray(model.velocity_limits, dtype=float)[index]
        self.acceleration_limits = np.asarray(model.acceleration_limits, dtype=float)[index]
        self.period = float(period)
        self.lead = float(lead)
        self.stop_before_collision = bool(stop_before_collision)
        self.goal_tolerance = float(goal_tolerance)
        self.goal_id = goal_id
        self.sampler = SimpleSampler(self.timed)
        self.stuck = StuckDetector()
        self.holding = False
        self.collision: PathCollision | None = None
        self._collision_reported = False
        self._check_pending = self.stop_before_collision
        self._arm_index = 0
        self._last_q: np.ndarray | None = None
        self._last_now: float | None = None
        self._started: float | None = None
        self._moved = False
        self._sent_time: float | None = None

    # ------------------------------------------------------------------ inputs
    def positions(self, joints: Mapping[str, float]) -> np.ndarray:
        """The trajectory's joints from a {name: position} map (KeyError names a missing one)."""
        return np.array([float(joints[n]) for n in self.joint_names])

    def scene_changed(self) -> None:
        """The next step re-checks the path ahead (when stop_before_collision is on)."""
        self._check_pending = self.stop_before_collision

    @property
    def final_positions(self) -> np.ndarray:
        return self.timed.positions[-1]

    def arm_time(self, q: np.ndarray) -> float:
        """Where on the trajectory the arm is (s from its start): the nearest path sample between
        the last one found and the reference (the arm only moves forward along the path)."""
        times, rows = self.path.times, self.path.positions
        end = int(np.searchsorted(times, self.sampler.time, side="right"))
        end = min(max(end, self._arm_index + 1), len(times))
        window = rows[self._arm_index:end]
        if window.shape[0]:
            k = int(np.argmin(np.sum(np.abs(window - q), axis=1)))
            self._arm_index += k
        return float(times[self._arm_index])

    # ------------------------------------------------------------------ commands
    def _point_command(self, q_now: np.ndarray, q: np.ndarray, qd: np.ndarray) -> JointTrajectory:
        with np.errstate(divide="ignore", invalid="ignore"):
            need = np.where(self.velocity_limits > 0, np.abs(q - q_now) / (self.velocity_limits * LEAD_IN_VELOCITY_FRACTION),
                            0.0)
        lead = max(self.lead, float(np.max(need, initial=0.0)))
        point = JointTrajectoryPoint(positions=[float(v) for v in q], velocities=[float(v) for v in qd],
                                     time_from_start=lead)
        return JointTrajectory(joint_names=list(self.joint_names), points=[point], frame_id=self.goal_id)

    def halt(self) -> JointTrajectory:
        """An empty trajectory: a JointTrajectoryController stops and holds where the joints are."""
        return JointTrajectory(joint_names=list(self.joint_names), points=[], frame_id=self.goal_id)

    def _stop_along_path(self, t_arm: float, stop_before: float | None) -> JointTrajectory:
        plan = stopping_trajectory(self.timed, t_arm + self.lead, self.acceleration_limits, stop_before)
        return self.halt() if plan is None else stop_command(plan, self.lead, self.goal_id)

    def stop(self, joints: Mapping[str, float], velocities: Mapping[str, float] | None = None) -> JointTrajectory | None:
        """The command that brings the arm to rest (a cancel): along its path within the
        acceleration limits, at once when it is already (nearly) at rest; None when held already."""
        if self.holding:
            return None
        self.holding = True
        if velocities is not None and self._at_rest(velocities):
            return self.halt()
        return self._stop_along_path(self.arm_time(self.positions(joints)), None)

    def _at_rest(self, velocities: Mapping[str, float]) -> bool:
        values = [abs(float(velocities.get(n, 0.0))) for n in self.joint_names]
        return max(values, default=0.0) < AT_REST_VELOCITY

    # ------------------------------------------------------------------ the loop
    def step(self, joints: Mapping[str, float], now: float, scene: PlanningScene | None = None,
             fresh: bool = True, velocities: Mapping[str, float] | None = None) -> LocalCommand:
        """One iteration at time ``now`` (s) with the arm at ``joints`` (``fresh``: a joint state
        received since the last iteration; ``velocities`` when known); ``scene``: the current
        scene for the check of the path ahead (used when it changed, see scene_changed)."""
        q = self.positions(joints)
        if self._started is None:
            self._started = now
        elapsed = 0.0 if self._last_now is None else min(max(now - self._last_now, 0.0), 3 * self.period)
        self._last_now = now
        t_arm = self.arm_time(q)
        out = LocalCommand()
        if self._check_pending and scene is not None:
            self._check_pending = False
            self._check_path(scene, t_arm, q, velocities, out)
        if self.holding:
            self._remember(q, fresh)
            return out
        if self.sampler.at_end and float(np.max(np.abs(q - self.final_positions), initial=0.0)) <= self.goal_tolerance:
            out.done = True
            return out
        self.sampler.advance(q, elapsed, lag=self.lead)
        if self._sent_time != self.sampler.time:
            self._sent_time = self.sampler.time
            out.trajectory = self._point_command(q, *self.sampler.reference())
        if fresh and self._last_q is not None:
            moved = float(np.max(np.abs(q - self._last_q), initial=0.0))
            self._moved = self._moved or moved >= self.stuck.threshold
            if (self._moved or now - self._started >= STARTUP_GRACE) and self.stuck.update(moved):
                out.feedback = LocalFeedback.LOCAL_PLANNER_STUCK
        self._remember(q, fresh)
        return out

    def _remember(self, q: np.ndarray, fresh: bool) -> None:
        if fresh or self._last_q is None:
            self._last_q = q

    def _check_path(self, scene: PlanningScene, t_arm: float, q: np.ndarray,
                    velocities: Mapping[str, float] | None, out: LocalCommand) -> None:
        hit = self.path.first_collision(scene, t_arm)
        self.collision = hit
        if hit is None:
            if self.holding:  # the path is free again: go on from where the arm is
                self.holding = False
                self._collision_reported = False
                self.sampler.time = min(self.sampler.time, t_arm)
                self._sent_time = None
                self.stuck.reset()
            return
        if not self.holding:
            self.holding = True
            at_rest = velocities is not None and self._at_rest(velocities)
            if at_rest or hit.free_until is None:  # at rest, or already touching: stay where it is
                out.trajectory = self.halt()
            else:
                out.trajectory = self._stop_along_path(t_arm, hit.free_until)
        if not self._collision_reported:
            self._collision_reported = True
            out.feedback = LocalFeedback.COLLISION_AHEAD
