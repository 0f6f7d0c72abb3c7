"""MTC-style relative motion: a direction or twist in any frame, turned into Cartesian waypoints
and planned with compute_cartesian_path (min/max distance as MoveRelative has them)."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
import pinocchio as pin

from interfaces_py.msgs import MoveItErrorCode

from .cartesian_path import (
    STOP_INVALID_REQUEST,
    CartesianPathResult,
    check_link_name,
    check_offset,
    compute_cartesian_path,
    failed_result,
    finite_number,
    pose_of_frame,
)
from ...moveit_error_code import ErrorCodeResult
from ...planning_interface.planning_interface import PlanningFailure, check_group, failure
from ...planning_scene.planning_scene import PlanningScene
from ...robot_state.robot_state import RobotState
from ...robot_trajectory.robot_trajectory import TimedTrajectory


@dataclass
class RelativeTarget:
    """Where a relative motion sends the ik frame (all world frame).

    ``linear`` is the translation (m) and ``angular`` the rotation vector (axis * angle, rad),
    rotation about the ik frame's origin. ``measure`` says how achieved distance is measured:
    'translation' (m) or 'rotation' (rad, when the motion has no translation), as in MTC.
    """

    pose: np.ndarray
    start_pose: np.ndarray
    linear: np.ndarray
    angular: np.ndarray
    measure: str
    distance: float

    @property
    def waypoints(self) -> list[np.ndarray]:
        return [self.pose]

    def achieved(self, reached_pose: np.ndarray) -> float:
        """Distance covered when the ik frame is at reached_pose (in this target's measure)."""
        if self.measure == "rotation":
            delta = reached_pose[:3, :3] @ self.start_pose[:3, :3].T
            return float(np.linalg.norm(pin.log3(delta)))
        return float(np.linalg.norm(reached_pose[:3, 3] - self.start_pose[:3, 3]))


@dataclass
class RelativeMotionResult(ErrorCodeResult):
    """Outcome of :func:`plan_relative_motion` (MTC's MoveRelative).

    ``error_code`` is SUCCESS only when MTC would accept the motion (see min_distance); a
    failed motion still carries the partial ``trajectory`` and ``achieved_distance`` so the
    caller can inspect it, as MTC keeps failed solutions for introspection.
    """

    error_code: MoveItErrorCode
    trajectory: TimedTrajectory | None = None
    path: np.ndarray | None = field(default=None, repr=False)
    achieved_distance: float = 0.0
    fraction: float = 0.0
    target: RelativeTarget | None = field(default=None, repr=False)
    cartesian: CartesianPathResult | None = field(default=None, repr=False)

    @property
    def stop_reason(self) -> str:
        return self.cartesian.stop_reason if self.cartesian is not None else STOP_INVALID_REQUEST


# ---------------------------------------------------------------------------- relative motion
def _vector(value: object, size: int, name: str) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, f"{name} is not a vector of numbers") from None
    if arr.size != size:
        raise failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, f"{name} must have {size} values, got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, f"{name} contains NaN or infinite values")
    return arr


def relative_target_poses(
    scene: PlanningScene,
    start_state: RobotState | None,
    link: str | None,
    ik_frame_offset: np.ndarray | None = None,
    direction: Sequence[float] | np.ndarray | None = None,
    twist: Sequence[float] | np.ndarray | None = None,
    frame: str = "world",
    distance: float | None = None,
    group: str | None = None,
) -> RelativeTarget:
    """The goal of an MTC MoveRelative from start_state (world frame).

    Exactly one of:
      * ``direction`` (3-vector, in ``frame``'s axes): translate the ik frame by the vector, or,
        when ``distance`` > 0, by ``distance`` along its normalised direction.
      * ``twist`` (6-vector: linear xyz, angular xyz, in ``frame``'s axes): translate by the
        linear part and rotate by |angular| rad about the angular axis through the ik frame's
        origin. With ``distance`` > 0 both parts are scaled so that the linear part has length
        ``distance`` (or, for a pure rotation, the angle is ``distance`` rad).

    ``frame`` is 'world', a link, or a collision object id; only its orientation matters. The
    link defaults to the group's tip link when ``group`` is given.

    Raises PlanningFailure (a PlanningError carrying the MoveIt error code) on bad input.
    """
    if not isinstance(scene, PlanningScene):
        raise failure(MoveItErrorCode.INVALID_MOTION_PLAN, f"scene must be a PlanningScene, got {type(scene).__name__}")
    model = scene.robot_model
    if link is None:
        if group is None:
            raise failure(MoveItErrorCode.INVALID_LINK_NAME, "give the link to move (or the group, for its tip link)")
        link = check_group(model, group).tip_link
    link = check_link_name(model, link)
    offset = check_offset(ik_frame_offset)
    state = scene.current_state if start_state is None else start_state
    if not isinstance(state, RobotState) or state.model is not model:
        raise failure(MoveItErrorCode.INVALID_ROBOT_STATE, "start state is not a RobotState of the scene's robot")
    if (direction is None) == (twist is None):
        raise failure(
            MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "give exactly one of direction (3-vector) or twist (6-vector)"
        )
    if distance is not None:
        distance = finite_number(distance, "distance")
        if distance == 0.0:
            distance = None  # MTC: max_distance 0 means "use the vector as given"
    if not isinstance(frame, str) or not frame:
        raise failure(MoveItErrorCode.FRAME_TRANSFORM_FAILURE, f"invalid frame {frame!r}")
    axes = pose_of_frame(scene, frame, state)[:3, :3]
    start_pose = state.frame_pose(link)
    if offset is not None:
        start_pose = start_pose @ offset

    if direction is not None:
        linear = _vector(direction, 3, "direction")
        norm = float(np.linalg.norm(linear))
        if norm < 1e-12:
            raise failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "direction is the zero vector")
        if distance is not None:
            linear = linear / norm * distance
        linear = axes @ linear
        angular = np.zeros(3)
        measure = "translation"
    else:
        values = _vector(twist, 6, "twist")
        linear, angular = values[:3], values[3:]
        lin_norm, ang_norm = float(np.linalg.norm(linear)), float(np.linalg.norm(angular))
        if lin_norm < 1e-12 and ang_norm < 1e-12:
            raise failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "twist is zero: nothing to move")
        measure = "rotation" if lin_norm < 1e-12 else "translation"
        if distance is not None:
            scale = distance / (lin_norm if measure == "translation" else ang_norm)
            linear, angular = linear * scale, angular * scale
        linear, angular = axes @ linear, axes @ angular

    pose = start_pose.copy()
    pose[:3, :3] = pin.exp3(angular) @ start_pose[:3, :3]  # rotation about the ik frame's origin
    pose[:3, 3] = start_pose[:3, 3] + linear
    nominal = float(np.linalg.norm(linear)) if measure == "translation" else float(np.linalg.norm(angular))
    return RelativeTarget(pose=pose, start_pose=start_pose, linear=linear, angular=angular, measure=measure,
                          distance=nominal)


def plan_relative_motion(
    scene: PlanningScene,
    group: str,
    start_state: RobotState | None = None,
    link: str | None = None,
    ik_frame_offset: np.ndarray | None = None,
    direction: Sequence[float] | np.ndarray | None = None,
    twist: Sequence[float] | np.ndarray | None = None,
    frame: str = "world",
    min_distance: float = -1.0,
    max_distance: float = 0.0,
    eef_step: float = 0.01,
    jump_threshold: float = 0.0,
    avoid_collisions: bool = True,
    velocity_scaling: float | None = None,
    acceleration_scaling: float | None = None,
    min_fraction: float = 1.0,
    **cartesian_options,
) -> RelativeMotionResult:
    """MTC's MoveRelative with its CartesianPath solver.

    The motion is given by ``direction`` or ``twist`` in ``frame`` (see
    :func:`relative_target_poses`); ``max_distance`` > 0 says how far to go along it (0: the
    vector's own length). Success follows MTC:

      * ``min_distance`` > 0: success iff the ik frame moved at least min_distance (m, or rad for
        a pure rotation), even if the full distance was not reached;
      * ``min_distance`` == 0: success whatever distance was achieved;
      * ``min_distance`` < 0 (default -1): success only if the Cartesian path reached
        ``min_fraction`` (default 1.0, i.e. the whole motion).

    Extra keyword arguments go to :func:`compute_cartesian_path` (revolute_jump_threshold, ...).
    """
    started = time.perf_counter()
    try:
        min_distance = finite_number(min_distance, "min_distance", minimum=-math.inf)
        max_distance = finite_number(max_distance, "max_distance", minimum=-math.inf)
        max_distance = abs(max_distance)
        min_fraction = finite_number(min_fraction, "min_fraction")
        if min_fraction > 1.0:
            raise failure(MoveItErrorCode.INVALID_MOTION_PLAN, f"min_fraction must be in [0, 1], got {min_fraction}")
        if max_distance > 0 and min_distance > max_distance:
            raise failure(
                MoveItErrorCode.INVALID_MOTION_PLAN,
                f"min_distance {min_distance:g} exceeds max_distance {max_distance:g}: the motion can never succeed",
            )
        model = scene.robot_model if isinstance(scene, PlanningScene) else None
        jmg = check_group(model, group) if model is not None else None
        if jmg is None:
            raise failure(
                MoveItErrorCode.INVALID_MOTION_PLAN, f"scene must be a PlanningScene, got {type(scene).__name__}"
            )
        target = relative_target_poses(
            scene, start_state, link if link is not None else jmg.tip_link, ik_frame_offset, direction, twist, frame,
            max_distance if max_distance > 0 else None,
        )
    except PlanningFailure as exc:
        return RelativeMotionResult(
            error_code=MoveItErrorCode(exc.code, exc.message),
            cartesian=failed_result(exc.code, exc.message, group if isinstance(group, str) else "", started),
        )
    result = compute_cartesian_path(
        scene, group, start_state, target.waypoints, link=link, ik_frame_offset=ik_frame_offset, eef_step=eef_step,
        jump_threshold=jump_threshold, avoid_collisions=avoid_collisions, velocity_scaling=velocity_scaling,
        acceleration_scaling=acceleration_scaling, **cartesian_options,
    )
    if not result:
        return RelativeMotionResult(error_code=result.error_code, target=target, cartesian=result)
    last = result.states()[-1]
    reached = last.frame_pose(result.link)
    if ik_frame_offset is not None:
        reached = reached @ np.asarray(ik_frame_offset, dtype=float)
    achieved = target.achieved(reached)
    unit = "rad" if target.measure == "rotation" else "m"
    if min_distance > 0:
        ok = achieved >= min_distance
        why = (f"moved {achieved:.4g} {unit} >= min_distance {min_distance:g}" if ok
               else f"min_distance not reached ({achieved:.4g} < {min_distance:g} {unit}): {result.message}")
    elif min_distance == 0:
        ok, why = True, f"moved {achieved:.4g} {unit} (min_distance 0: any distance succeeds)"
    else:
        ok = result.fraction >= min_fraction - 1e-12
        why = (f"moved the full {achieved:.4g} {unit}" if ok
               else f"failed to move full distance ({achieved:.4g} of {target.distance:.4g} {unit}): {result.message}")
    code = MoveItErrorCode.SUCCESS if ok else MoveItErrorCode.PLANNING_FAILED
    return RelativeMotionResult(
        error_code=MoveItErrorCode(code, why),
        trajectory=result.trajectory,
        path=result.path,
        achieved_distance=achieved,
        fraction=result.fraction,
        target=target,
        cartesian=result,
    )

