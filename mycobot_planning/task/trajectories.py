"""Trajectory helpers for stages: reversal (backward propagation), merging (Merger, Connect)
and joint-space path checks.

Why exact reversal: a stage that propagates backward plans from its end state and must return
a trajectory that *ends* there. Re-timing the reversed path would change the motion and cost a
Ruckig run; reversing the timed trajectory itself is exact and free. For the constant-jerk
("cubic") trajectories of the core's time parameterisation, each stored acceleration is the one
*after* its instant, so the reversed trajectory needs the acceleration *before* each original
instant, which follows from the interval's constant jerk.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from ..core.planning_interface.planning_interface import time_group_path
from ..core.planning_scene.planning_scene import PlanningScene
from ..core.robot_model.robot_model import JointModelGroup, RobotModel
from ..core.robot_state.robot_state import RobotState
from ..core.robot_trajectory.robot_trajectory import TimedTrajectory

#: Joint-space resolution (rad, max-norm) of the collision checks between merged waypoints;
#: the trajectory validator's default, so both look equally closely.
CHECK_RESOLUTION = 0.005


def single_point(joint_names: Sequence[str], positions: np.ndarray) -> TimedTrajectory:
    """A trajectory holding one state (a motion of zero length)."""
    row = np.asarray(positions, dtype=float).reshape(1, -1)
    zeros = np.zeros_like(row)
    return TimedTrajectory(list(joint_names), np.zeros(1), row, zeros, zeros.copy(), interpolation="cubic", path=row.copy(),
                           waypoint_times=np.zeros(1))


def reverse_trajectory(traj: TimedTrajectory) -> TimedTrajectory:
    """The same motion played backwards (exact for both interpolation kinds)."""
    times = np.asarray(traj.times, dtype=float)
    end = times[-1]
    new_times = (end - times)[::-1].copy()
    new_times -= new_times[0]
    positions = traj.positions[::-1].copy()
    velocities = -traj.velocities[::-1]
    if traj.interpolation == "cubic" and len(traj) > 1:
        a = traj.accelerations
        h = np.diff(times)[:, None]
        jerk = 2.0 * (traj.velocities[1:] - traj.velocities[:-1] - a[:-1] * h) / (h * h)
        before = a[:-1] + jerk * h  # acceleration just before points 1..n-1
        accelerations = np.vstack([before[::-1], a[:1]])
    else:
        accelerations = traj.accelerations[::-1].copy()
    path = None if traj.path is None else traj.path[::-1].copy()
    waypoint_times = None
    if traj.waypoint_times is not None:
        waypoint_times = (end - np.asarray(traj.waypoint_times, dtype=float))[::-1].copy()
    return TimedTrajectory(list(traj.joint_names), new_times, positions, velocities + 0.0, accelerations,
                           interpolation=traj.interpolation, path=path, waypoint_times=waypoint_times)


def geometric_path(traj: TimedTrajectory) -> np.ndarray:
    """The waypoints the trajectory was timed from (its stored points when unknown)."""
    return np.asarray(traj.path if traj.path is not None else traj.positions, dtype=float)


def time_path(model: RobotModel, jmg: JointModelGroup, path: np.ndarray, velocity_scaling: float = 1.0,
              acceleration_scaling: float = 1.0) -> TimedTrajectory:
    """Time a group path with the core's Ruckig timing (a single point stays a single point)."""
    path = np.asarray(path, dtype=float)
    if len(path) < 2 or np.all(np.abs(path - path[0]) <= 1e-12):
        return single_point(jmg.joint_names, path[0])
    return time_group_path(model, jmg, path, velocity_scaling, acceleration_scaling)


def full_state(start: RobotState, indices: np.ndarray, values: np.ndarray) -> RobotState:
    """``start`` with the given variables replaced."""
    positions = np.array(start.positions, dtype=float)
    positions[indices] = values
    return RobotState(start.model, positions)


def check_path(scene: PlanningScene, start: RobotState, indices: np.ndarray, path: np.ndarray,
               resolution: float = CHECK_RESOLUTION) -> tuple[bool, str]:
    """Every state on the straight joint-space lines between consecutive waypoints valid?"""
    full = np.array(start.positions, dtype=float)
    is_valid = scene.is_valid_positions
    for k in range(len(path)):
        a = path[max(k - 1, 0)]
        b = path[k]
        steps = max(1, int(math.ceil(float(np.max(np.abs(b - a))) / resolution))) if k else 1
        for j in range(1, steps + 1):
            # the waypoint itself exactly (a + 1.0 * (b - a) can round past a bound it sits on)
            full[indices] = b if j == steps else a + (j / steps) * (b - a)
            if not is_valid(full):
                state = RobotState(start.model, full)
                report = scene.check_collision(state, max_contacts=1)
                what = "; ".join(str(c) for c in report.contacts) or "joint limits"
                return False, f"merged path invalid at waypoint {k}: {what}"
    return True, ""


def _stationary(traj: TimedTrajectory) -> bool:
    return bool(np.all(np.abs(traj.positions - traj.positions[0]) <= 1e-12))


def _at_start(model: RobotModel, start: RobotState, traj: TimedTrajectory) -> bool:
    indices = [model.variable_index(n) for n in traj.joint_names]
    return bool(np.all(np.abs(traj.positions[0] - start.positions[indices]) <= 1e-12))


def _extend(model: RobotModel, jmg: JointModelGroup, start: RobotState, traj: TimedTrajectory) -> TimedTrajectory:
    """``traj`` over all of ``jmg``'s joints, the joints it lacks held at ``start``'s values."""
    n = len(traj.times)
    own = {name: k for k, name in enumerate(traj.joint_names)}
    positions = np.empty((n, len(jmg.joint_names)))
    velocities = np.zeros_like(positions)
    accelerations = np.zeros_like(positions)
    path = None if traj.path is None else np.empty((len(traj.path), len(jmg.joint_names)))
    for j, name in enumerate(jmg.joint_names):
        k = own.get(name)
        if k is None:
            value = start.positions[model.variable_index(name)]
            positions[:, j] = value
            if path is not None:
                path[:, j] = value
        else:
            positions[:, j] = traj.positions[:, k]
            velocities[:, j] = traj.velocities[:, k]
            accelerations[:, j] = traj.accelerations[:, k]
            if path is not None:
                path[:, j] = traj.path[:, k]
    waypoint_times = None if traj.waypoint_times is None else np.array(traj.waypoint_times, dtype=float)
    return TimedTrajectory(list(jmg.joint_names), np.array(traj.times, dtype=float), positions, velocities,
                           accelerations, interpolation=traj.interpolation, path=path, waypoint_times=waypoint_times)


def find_group(model: RobotModel, joint_names: set[str]) -> str | None:
    """A planning group whose active joints are exactly ``joint_names`` (for merged motions)."""
    for name in model.group_names:
        if set(model.group(name).joint_names) == joint_names:
            return name
    return None


def merge_trajectories(scene: PlanningScene, start: RobotState, parts: Sequence[tuple[str, TimedTrajectory]],
                       velocity_scaling: float = 1.0, acceleration_scaling: float = 1.0,
                       ) -> tuple[TimedTrajectory | None, str, str]:
    """Merge trajectories of disjoint groups into one simultaneous motion (MTC's merge()).

    Waypoints are paired by index (shorter paths hold their last waypoint), the merged path is
    checked against ``scene`` and timed for the merged group. When only one part moves and the
    others hold ``start``'s values (Connect's usual case: the gripper does not move), that part's
    trajectory is kept as it is, extended by the held joints: no new states, so no re-check
    (planners return trajectories checked in the scene they planned in) and no re-timing.
    Returns ``(trajectory, group, message)``; the trajectory is None (and the message says why)
    when the groups overlap, no planning group covers the union of their joints, or the merged
    path collides.
    """
    model = scene.robot_model
    names: list[str] = []
    for group, traj in parts:
        for name in traj.joint_names:
            if name in names:
                return None, "", f"cannot merge: joint '{name}' is moved by more than one group"
            names.append(name)
    merged_group = find_group(model, set(names))
    if merged_group is None:
        return None, "", (f"cannot merge: no planning group has exactly the joints {sorted(names)} "
                          "(add one to the SRDF, e.g. 'arm_with_gripper')")
    jmg = model.group(merged_group)
    moving = [traj for _, traj in parts if not _stationary(traj)]
    if len(moving) <= 1 and all(_at_start(model, start, traj) for _, traj in parts if _stationary(traj)):
        # One motion and the rest holding the start state: the merged motion is that motion,
        # state for state, and its planner checked those states in this scene already.
        return _extend(model, jmg, start, moving[0] if moving else parts[0][1]), merged_group, ""
    paths = [geometric_path(traj) for _, traj in parts]
    length = max(len(p) for p in paths)
    columns = {}
    for (_, traj), path in zip(parts, paths):
        padded = np.vstack([path, np.repeat(path[-1:], length - len(path), axis=0)]) if len(path) < length else path
        for j, name in enumerate(traj.joint_names):
            columns[name] = padded[:, j]
    merged = np.column_stack([columns[name] for name in jmg.joint_names])
    ok, message = check_path(scene, start, jmg.variable_indices, merged)
    if not ok:
        return None, merged_group, message
    return time_path(model, jmg, merged, velocity_scaling, acceleration_scaling), merged_group, ""
