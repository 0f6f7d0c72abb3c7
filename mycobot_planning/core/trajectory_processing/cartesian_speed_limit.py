"""A cap on how fast one link may move in Cartesian space (MoveIt's limitMaxCartesianLinkSpeed),
used by MTC's CartesianPath ``max_cartesian_speed``.

The trajectory is slowed down uniformly (time x k: velocities / k, accelerations / k**2), which
keeps its path and its joint limits (they only get further away). MoveIt stretches each segment
on its own instead; a uniform factor is simpler and never faster than that.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import TimeParameterizationError
from ..robot_state.robot_state import RobotState
from ..robot_trajectory.robot_trajectory import TimedTrajectory

#: Seconds between the states at which the link speed is measured.
SPEED_SAMPLE_PERIOD = 0.005


def max_link_speed(trajectory: TimedTrajectory, state: RobotState, link: str) -> float:
    """Largest speed (m/s) of ``link``'s origin along the trajectory, from positions sampled every
    SPEED_SAMPLE_PERIOD (``state`` gives the joints the trajectory does not move)."""
    if len(trajectory) < 2 or trajectory.duration <= 0.0:
        return 0.0
    times = np.union1d(trajectory.times, np.arange(trajectory.times[0], trajectory.times[-1], SPEED_SAMPLE_PERIOD))
    positions, _, _ = trajectory.sample(times)
    probe = state.copy()
    points = np.empty((times.shape[0], 3))
    for k, q in enumerate(positions):
        probe.set_joint_positions(dict(zip(trajectory.joint_names, q)))
        points[k] = probe.frame_pose(link)[:3, 3]
    speeds = np.linalg.norm(np.diff(points, axis=0), axis=1) / np.diff(times)
    return float(speeds.max(initial=0.0))


def limit_cartesian_link_speed(trajectory: TimedTrajectory, state: RobotState, link: str,
                               max_speed: float) -> TimedTrajectory:
    """``trajectory`` slowed down just enough that ``link`` moves at most ``max_speed`` m/s."""
    if not (isinstance(max_speed, (int, float)) and math.isfinite(max_speed) and max_speed > 0.0):
        raise TimeParameterizationError(f"max_cartesian_speed must be > 0 m/s, got {max_speed!r}")
    fastest = max_link_speed(trajectory, state, link)
    if fastest <= max_speed:
        return trajectory
    k = fastest / max_speed * (1.0 + 1e-9)
    t0 = trajectory.times[0]
    return TimedTrajectory(trajectory.joint_names, t0 + (trajectory.times - t0) * k, trajectory.positions,
                           trajectory.velocities / k, trajectory.accelerations / (k * k),
                           interpolation=trajectory.interpolation, path=trajectory.path,
                           waypoint_times=None if trajectory.waypoint_times is None
                           else t0 + (trajectory.waypoint_times - t0) * k)
