"""The joint trajectory follower of the mock controllers, with the joints measured instead of
simulated: the trajectory gives the desired state, the arm's readback the actual one.

JointTrajectoryFollower (mock_control) keeps the one implementation of everything JTC does with
a goal (validation, limits, start tolerance, preemption, interpolation, goal tolerance, state
reports); this subclass only changes where the actual positions come from, and adds what a real
arm needs on top: a path tolerance checked against the readback, a time limit to reach the goal
after the trajectory ends, and aborting a goal when the arm is lost or reports an error.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from ..mock_control.joint_trajectory_follower import (
    ControllerStatus,
    JointTrajectoryFollower,
    SubmitResult,
    TrajectoryCommand,
)


def _fmt(value: float) -> str:
    return f"{value:.4g}"


class MeasuredTrajectoryFollower(JointTrajectoryFollower):
    """``path_tolerance`` (rad per joint, inf: unchecked): while a goal runs, a readback farther
    than that from the desired position aborts it (status failed). ``goal_time`` (s): how long
    after the trajectory's end the joints may take to come within goal tolerance before the goal
    fails. ``unavailable``: while set (a sentence: why), new goals are refused with it."""

    #: rad a readback must move to count as motion, s without motion to count as stalled
    STALL_EPSILON = 0.005
    STALL_TIME = 0.3

    def __init__(self, *args, path_tolerance: Sequence[float] | float = math.inf, goal_time: float = 1.0,
                 allow_stalling: bool = False, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.path_tolerance = np.broadcast_to(np.asarray(path_tolerance, dtype=float), (self.dof,)).copy()
        self.goal_time = float(goal_time)
        #: a gripper closing on an object stops short of its goal: after the trajectory's end, a
        #: readback that stops moving counts as success (GripperActionController's allow_stalling)
        self.allow_stalling = bool(allow_stalling)
        self._still_since: float | None = None
        self._still_at: np.ndarray | None = None
        self.unavailable = ""
        self.measured = False  # a readback has arrived since start-up / the last reconnect
        self.measured_at: float | None = None

    # ------------------------------------------------------------------ readback
    def measure(self, positions: Sequence[float], velocities: Sequence[float] | None, now: float) -> None:
        """The arm's readback at time `now` (controller joint order)."""
        q = np.asarray(positions, dtype=float).reshape(self.dof)
        if self._still_at is None or np.max(np.abs(q - self._still_at)) > self.STALL_EPSILON:
            self._still_at, self._still_since = q.copy(), float(now)
        self._actual_pos[:] = q
        self._actual_vel[:] = 0.0 if velocities is None else np.asarray(velocities, dtype=float)
        self._actual_acc[:] = 0.0
        if self._spline is None:
            self._desired_pos[:] = q
        self.measured = True
        self.measured_at = float(now)

    def desired_at(self, t: float) -> np.ndarray | None:
        """The trajectory's position at time t (None without a goal): what to command ahead."""
        if self._spline is None:
            return None
        return self._spline.sample(t)[0]

    def desired_state_at(self, t: float) -> tuple[np.ndarray, np.ndarray] | None:
        """The trajectory's position and velocity at time t (None without a goal)."""
        if self._spline is None:
            return None
        q, qd, _ = self._spline.sample(t)
        return q, qd

    @property
    def final_positions(self) -> np.ndarray | None:
        return None if self._spline is None else self._spline.final.copy()

    # ------------------------------------------------------------------ JTC behaviour over a real arm
    def _track(self, t: float) -> None:
        q, qd, qdd = self._spline.sample(t)
        self._desired_pos[:] = q
        self._desired_vel[:] = qd
        self._desired_acc[:] = qdd

    def submit(self, command: TrajectoryCommand, now: float) -> SubmitResult:
        if self.unavailable and not command.is_stop:
            self._goal_counter += 1
            goal_id = command.goal_id or f"{self.name}#{self._goal_counter}"
            event = self._snapshot(ControllerStatus.ABORTED, goal_id, f"rejected: {self.unavailable}", self.active,
                                   of_current_goal=False)
            return SubmitResult(False, goal_id, self.unavailable, [event])
        return super().submit(command, now)

    def update(self, now: float):
        before = self._status
        super().update(now)
        if self._spline is not None and self._status in (ControllerStatus.EXECUTING, ControllerStatus.STALLED):
            # the readback against where the trajectory was when it was read, not now: between two
            # readbacks the desired state moves on while the measured one stands still
            at = self.measured_at if self.measured_at is not None else now
            error = np.abs(self._spline.sample(min(at, now))[0] - self._actual_pos)
            over = np.nonzero(error > self.path_tolerance)[0]
            if over.size:
                j = int(over[0])
                self._finish(ControllerStatus.FAILED, (
                    f"goal {self._goal_id} aborted: path tolerance violated: the arm's readback of joint "
                    f"{self.joint_names[j]} is {_fmt(error[j])} rad from the desired position (tolerance "
                    f"{_fmt(self.path_tolerance[j])})"))
            elif self._status == ControllerStatus.STALLED:
                late = now - self._spline.end
                err = float(np.max(np.abs(self._actual_pos - self._spline.final)))
                still = (self._still_since is not None
                         and now - max(self._still_since, self._spline.end) >= self.STALL_TIME)
                if self.allow_stalling and still:
                    self._finish(ControllerStatus.SUCCEEDED, (
                        f"goal {self._goal_id} succeeded: stalled at {_fmt(float(self._actual_pos[0]))}, "
                        f"{_fmt(err)} short of the goal (holding an object; allow_stalling)"))
                elif late > self.goal_time:
                    self._finish(ControllerStatus.FAILED, (
                        f"goal {self._goal_id} aborted: the arm did not reach the goal within goal_time "
                        f"{_fmt(self.goal_time)} s after the trajectory's end ({_fmt(err)} rad away, goal "
                        f"tolerance {_fmt(self.goal_tolerance)})"))
                else:
                    self._message = (f"goal {self._goal_id}: trajectory ended, waiting for the arm to settle "
                                     f"({_fmt(err)} rad from the goal)")
        return self.state() if self._status != before else None

    def abort(self, now: float, reason: str) -> list:
        """End the running goal as failed with `reason` (lost port, servo error). Returns its
        report (empty without a goal)."""
        if self._spline is None:
            return []
        self._last_update = max(now, self._last_update or now)
        self._finish(ControllerStatus.FAILED, f"goal {self._goal_id} aborted: {reason}")
        return [self.state()]
