"""The pilz_industrial_motion_planner pipeline: checks the request and hands it to PTP, LIN or CIRC."""
from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Mapping

from interfaces_py.msgs import MoveItErrorCode

from ...planning_interface.planning_interface import (
    MotionPlanRequest,
    MotionPlanResponse,
    PlanningFailure,
    check_group,
    check_request_numbers,
    check_scaling,
    failure,
    start_state_of,
    success,
)
from ...planning_scene.planning_scene import PlanningScene
from .common import (
    DEFAULT_COLLISION_CHECK_RESOLUTION,
    DEFAULT_SAMPLE_TIME,
    KNOWN_PLANNER_IDS,
    PILZ_PIPELINE_ID,
    PTP,
    PilzContext,
)
from .limits import CartesianLimits, CartesianLimitsError, default_cartesian_limits, load_cartesian_limits
from .lin_circ import plan_lin_circ
from .ptp import plan_ptp


# ---------------------------------------------------------------------------- planner
class IndustrialMotionPlanner:
    """The ``pilz_industrial_motion_planner`` pipeline: ``plan(scene, request)`` for planner ids
    PTP, LIN and CIRC, with Cartesian limits loaded once."""

    def __init__(self, cartesian_limits: str | Path | Mapping | CartesianLimits | None = None,
                 sample_time: float = DEFAULT_SAMPLE_TIME,
                 collision_check_resolution: float | None = DEFAULT_COLLISION_CHECK_RESOLUTION) -> None:
        self.cartesian_limits = (default_cartesian_limits() if cartesian_limits is None
                                 else load_cartesian_limits(cartesian_limits))
        self.sample_time = sample_time
        self.collision_check_resolution = collision_check_resolution

    def plan(self, scene: PlanningScene, request: MotionPlanRequest) -> MotionPlanResponse:
        return plan_industrial(scene, request, self.cartesian_limits, self.sample_time,
                               collision_check_resolution=self.collision_check_resolution)


def plan_industrial(
    scene: PlanningScene,
    request: MotionPlanRequest,
    cartesian_limits: str | Path | Mapping | CartesianLimits | None = None,
    sample_time: float = DEFAULT_SAMPLE_TIME,
    *,
    collision_check_resolution: float | None = DEFAULT_COLLISION_CHECK_RESOLUTION,
) -> MotionPlanResponse:
    """Plan ``request`` with the industrial generator named by ``request.planner_id``.

    Never raises for bad input: the response's error code says what was wrong (MoveIt's codes).
    ``collision_check_resolution`` (joint units) also checks the motion between samples; None
    checks the samples only, as MoveIt does.
    """
    started = time.perf_counter()
    try:
        if request.planner_id not in KNOWN_PLANNER_IDS:
            raise failure(
                MoveItErrorCode.INVALID_MOTION_PLAN,
                f"unknown planner_id '{request.planner_id}' for {PILZ_PIPELINE_ID}; "
                f"known: {', '.join(KNOWN_PLANNER_IDS)}",
            )
        if isinstance(sample_time, bool) or not isinstance(sample_time, (int, float)) \
                or not math.isfinite(sample_time) or sample_time <= 0.0:
            raise failure(MoveItErrorCode.INVALID_MOTION_PLAN, f"sample_time must be > 0 s, got {sample_time!r}")
        if collision_check_resolution is not None and not (
            isinstance(collision_check_resolution, (int, float)) and math.isfinite(collision_check_resolution)
            and collision_check_resolution > 0.0
        ):
            raise failure(
                MoveItErrorCode.INVALID_MOTION_PLAN,
                f"collision_check_resolution must be > 0 or None, got {collision_check_resolution!r}",
            )
        limits = None
        if request.planner_id != PTP:
            try:
                limits = (default_cartesian_limits() if cartesian_limits is None
                          else load_cartesian_limits(cartesian_limits))
            except CartesianLimitsError as exc:
                raise failure(MoveItErrorCode.INVALID_MOTION_PLAN, str(exc)) from None
        model = scene.robot_model
        check_request_numbers(request)
        jmg = check_group(model, request.group)
        vel_scale, acc_scale = check_scaling(model, request)
        start = start_state_of(scene, request)
        context = PilzContext(scene, model, jmg, start, float(sample_time), collision_check_resolution)
        if request.planner_id == PTP:
            trajectory, message = plan_ptp(context, request, vel_scale, acc_scale)
        else:
            trajectory, message = plan_lin_circ(context, request, limits, vel_scale, acc_scale)
        return success(trajectory, started, request, start, path=trajectory.positions, message=message)
    except PlanningFailure as exc:
        return exc.to_response(started, request)

