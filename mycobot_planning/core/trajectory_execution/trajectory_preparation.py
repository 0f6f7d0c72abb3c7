"""A trajectory made ready for controllers: parsed, checked against the model and limits, mimic
joints dropped, and its start compared with the current state."""
from __future__ import annotations

import math
import json
from typing import Any, Mapping, Sequence

import numpy as np

from interfaces_py.msgs import JointTrajectory, JointTrajectoryPoint, MessageError, MoveItErrorCode, RobotTrajectory

from ..robot_model.robot_model import RobotModel
from ..robot_trajectory.robot_trajectory import DEFAULT_MAX_WAYPOINT_DISTANCE, densify_joint_trajectory
from ..trajectory_processing.trajectory_limits import DEFAULT_LIMIT_TOLERANCE, motion_limit_problem
from .settings import ExecutionError

def parse_trajectory(value: Any, what: str = "trajectory") -> tuple[JointTrajectory, str]:
    """(JointTrajectory, group name) from a RobotTrajectory or JointTrajectory message / dict / JSON.

    Raises ExecutionError(INVALID_MOTION_PLAN) naming the problem.
    """
    try:
        if isinstance(value, RobotTrajectory):
            return value.joint_trajectory, value.group_name
        if isinstance(value, JointTrajectory):
            return value, ""
        if isinstance(value, (str, bytes, bytearray)):
            try:
                value = json.loads(value)
            except ValueError as exc:
                raise ExecutionError(MoveItErrorCode.INVALID_MOTION_PLAN, f"{what}: malformed JSON: {exc}") from None
        if not isinstance(value, Mapping):
            raise ExecutionError(MoveItErrorCode.INVALID_MOTION_PLAN,
                                 f"{what} must be a RobotTrajectory or JointTrajectory object, got {type(value).__name__}")
        if "joint_trajectory" in value:
            robot_trajectory = RobotTrajectory.from_dict(value)
            return robot_trajectory.joint_trajectory, robot_trajectory.group_name
        return JointTrajectory.from_dict(value), ""
    except MessageError as exc:
        raise ExecutionError(MoveItErrorCode.INVALID_MOTION_PLAN, f"invalid {what}: {exc}") from None


def prepare_trajectory(model: RobotModel, trajectory: JointTrajectory, position_tolerance: float = 1e-4,
                       limit_tolerance: float = DEFAULT_LIMIT_TOLERANCE,
                       max_waypoint_distance: float = DEFAULT_MAX_WAYPOINT_DISTANCE) -> JointTrajectory:
    """The trajectory as controllers get it: active joints only, checked, dense.

    Dense: where a joint would move more than ``max_waypoint_distance`` between two points,
    points sampled from the spline the controller follows are inserted (0 keeps the points as
    given); the motion is the same.

    Mimic joints are dropped when their source joint is in the trajectory (the controller drives
    the source); a mimic joint alone is refused. Refuses (ExecutionError INVALID_MOTION_PLAN): no
    points, unknown joints, non-finite values (also caught by the message class), positions outside
    the joint limits, times not strictly increasing, accelerations without velocities, velocities or
    accelerations beyond the joint limits by more than ``limit_tolerance`` (relative; see
    trajectory_limits.py).
    """
    bad = MoveItErrorCode.INVALID_MOTION_PLAN
    if not trajectory.joint_names:
        raise ExecutionError(bad, "trajectory names no joints")
    if not trajectory.points:
        raise ExecutionError(bad, "trajectory has no points")
    mimic = set(model.mimic_joint_names)
    names = list(trajectory.joint_names)
    unknown = [n for n in names if n not in model.variable_names and n not in mimic]
    if unknown:
        raise ExecutionError(
            bad, f"trajectory names joints {unknown} that robot '{model.name}' does not have; "
            f"its joints are {model.variable_names}"
        )
    keep = [i for i, n in enumerate(names) if n not in mimic]
    dropped = [n for n in names if n in mimic]
    if dropped:
        sources = {model.joint(n).mimic.joint for n in dropped if model.joint(n).mimic is not None}
        missing = sorted(s for s in sources if s not in names)
        if missing:
            raise ExecutionError(bad, f"trajectory moves mimic joints {dropped} without their source joints {missing}; "
                                      "command the source joint instead")
    indices = np.array([model.variable_index(names[i]) for i in keep], dtype=int)
    low, high = model.lower_limits[indices], model.upper_limits[indices]
    previous = -math.inf
    for k, point in enumerate(trajectory.points):
        values = np.array([point.positions[i] for i in keep], dtype=float)
        if not np.all(np.isfinite(values)):
            raise ExecutionError(bad, f"trajectory point {k} contains NaN or infinite positions")
        outside = [
            f"{names[keep[j]]}={values[j]:.4f} outside [{low[j]:.4f}, {high[j]:.4f}]"
            for j in range(len(keep))
            if values[j] < low[j] - position_tolerance or values[j] > high[j] + position_tolerance
        ]
        if outside:
            raise ExecutionError(bad, f"trajectory point {k} is outside the joint limits: " + "; ".join(outside))
        t = point.time_from_start
        if not math.isfinite(t) or t < 0:
            raise ExecutionError(bad, f"trajectory point {k} has an invalid time_from_start {t}")
        if t <= previous:
            raise ExecutionError(bad, f"trajectory point {k}: time_from_start {t} is not after the previous point's {previous}")
        previous = t
        if len(point.accelerations) and not len(point.velocities):  # JTC refuses it: say so before anything moves
            raise ExecutionError(bad, f"trajectory point {k} has accelerations but no velocities (a controller "
                                      "interpolates accelerations only with velocities)")
    problem = motion_limit_problem(
        [names[i] for i in keep],
        np.array([p.time_from_start for p in trajectory.points], dtype=float),
        np.array([[p.positions[i] for i in keep] for p in trajectory.points], dtype=float),
        _given(trajectory, "velocities", keep), _given(trajectory, "accelerations", keep),
        model.velocity_limits[indices], model.acceleration_limits[indices], limit_tolerance)
    if problem is not None:
        raise ExecutionError(bad, problem)
    if dropped:
        trajectory = JointTrajectory(
            joint_names=[names[i] for i in keep],
            points=[_select_point(p, keep) for p in trajectory.points],
            frame_id=trajectory.frame_id,
        )
    if max_waypoint_distance > 0:
        trajectory = densify_joint_trajectory(trajectory, max_waypoint_distance)
    return trajectory


def _given(trajectory: JointTrajectory, field: str, keep: Sequence[int]) -> np.ndarray | None:
    """The points' velocities or accelerations of the kept joints, or None unless every point has them."""
    rows = [getattr(p, field) for p in trajectory.points]
    if not all(len(r) == len(trajectory.joint_names) for r in rows):
        return None
    return np.array([[r[i] for i in keep] for r in rows], dtype=float)


def _select_point(point: JointTrajectoryPoint, keep: Sequence[int]) -> JointTrajectoryPoint:
    return JointTrajectoryPoint(
        positions=[point.positions[i] for i in keep],
        velocities=[point.velocities[i] for i in keep] if point.velocities else [],
        accelerations=[point.accelerations[i] for i in keep] if point.accelerations else [],
        time_from_start=point.time_from_start,
    )


def trajectory_duration(trajectory: JointTrajectory) -> float:
    return trajectory.points[-1].time_from_start if trajectory.points else 0.0


def check_start_state(trajectory: JointTrajectory, current: Mapping[str, float], tolerance: float) -> None:
    """Refuse a trajectory whose first point is farther than ``tolerance`` from the robot.

    MoveIt's allowed_start_tolerance: a controller would otherwise jump to the first point.
    Raises ExecutionError(START_STATE_INVALID) naming the joint; tolerance 0 disables the check.
    """
    if tolerance <= 0 or not trajectory.points:
        return
    first = trajectory.points[0].positions
    worst_name, worst = "", 0.0
    for name, value in zip(trajectory.joint_names, first):
        if name not in current:
            raise ExecutionError(MoveItErrorCode.ROBOT_STATE_STALE, f"no current joint state for '{name}'")
        deviation = abs(float(value) - float(current[name]))
        if deviation > worst:
            worst_name, worst = name, deviation
    if worst > tolerance:
        raise ExecutionError(
            MoveItErrorCode.START_STATE_INVALID,
            f"execution refused: the trajectory starts {worst:.4f} away from the current state at joint "
            f"'{worst_name}' (trajectory {dict(zip(trajectory.joint_names, first))[worst_name]:.4f}, "
            f"robot {current[worst_name]:.4f}); allowed_start_tolerance is {tolerance}",
        )

