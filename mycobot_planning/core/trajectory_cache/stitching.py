"""A cached trajectory started from where the robot really is.

A fuzzy hit starts within the start tolerance of the actual start state, not at it; a
controller refuses a trajectory whose first point is off the current state (the execution
manager's allowed_start_tolerance), and the validator does too. So the hit is stitched: a short
rest-to-rest motion from the actual start to the cached trajectory's first point (timed under
the request's scaling, like any plan), then the cached trajectory, shifted in time. Both pieces
start and end at rest, so the joint is as smooth and within limits as each piece.
"""
from __future__ import annotations

import numpy as np

from ..planning_interface.planning_interface import time_group_path
from ..robot_model.robot_model import RobotModel
from ..robot_state.robot_state import RobotState
from ..robot_trajectory.robot_trajectory import TimedTrajectory

__all__ = ["STITCH_TOLERANCE", "stitch_to_start"]

#: rad or m: a cached start this close to the actual one is used as it is (the validator's own
#: start tolerance)
STITCH_TOLERANCE = 1e-6
#: s between the samples of a stitch before a "quintic" cached trajectory
_QUINTIC_BRIDGE_PERIOD = 0.005


def stitch_to_start(model: RobotModel, group: str, trajectory: TimedTrajectory, start: RobotState,
                    velocity_scaling: float = 1.0, acceleration_scaling: float = 1.0) -> TimedTrajectory:
    """``trajectory`` (over ``group``'s joints) preceded by the motion from ``start`` to its
    first point; ``trajectory`` itself when it starts at ``start`` already. ValueError when it
    is not a trajectory of the group's joints."""
    jmg = model.group(group)
    if list(trajectory.joint_names) != list(jmg.joint_names):
        raise ValueError(f"the cached trajectory moves {list(trajectory.joint_names)}, group '{group}' has "
                         f"{list(jmg.joint_names)}")
    actual = start.group_positions(group)
    first = trajectory.positions[0]
    if float(np.max(np.abs(actual - first))) <= STITCH_TOLERANCE:
        return trajectory
    bridge = time_group_path(model, jmg, np.array([actual, first]), velocity_scaling, acceleration_scaling)
    if trajectory.interpolation != bridge.interpolation:
        bridge = bridge.resample(_QUINTIC_BRIDGE_PERIOD, keep_breakpoints=False)
    offset = bridge.times[-1]
    shifted = trajectory.times - trajectory.times[0] + offset
    # the junction keeps the cached trajectory's first point: for "cubic" data its acceleration is
    # the one after that instant, which the cached motion starts with
    path = None
    if trajectory.path is not None:
        path = np.vstack([actual[None, :], trajectory.path])
    waypoint_times = None
    if trajectory.waypoint_times is not None:
        waypoint_times = np.concatenate([[bridge.times[0]], trajectory.waypoint_times - trajectory.times[0] + offset])
    return TimedTrajectory(
        list(trajectory.joint_names),
        np.concatenate([bridge.times[:-1], shifted]),
        np.vstack([bridge.positions[:-1], trajectory.positions]),
        np.vstack([bridge.velocities[:-1], trajectory.velocities]),
        np.vstack([bridge.accelerations[:-1], trajectory.accelerations]),
        interpolation=trajectory.interpolation,
        path=path,
        waypoint_times=waypoint_times,
    )
