"""move_group's plan capability (MoveIt: MoveGroupPlanService, /plan_kinematic_path): a core
MotionPlanRequest, completed with the defaults and checked against the request budgets, planned
on a free planning context; a success becomes the last plan that execute() runs. With the
trajectory cache enabled (capabilities/trajectory_cache.py) a stored trajectory that passes the
validator in the current scene answers instead, and what is planned is offered to the cache."""
from __future__ import annotations

import time
import traceback
from dataclasses import dataclass
from typing import Any, Sequence

from interfaces_py.msgs import JointTrajectory, MoveItErrorCode, RobotState as RobotStateMsg

from ..core.planning_interface.planning_interface import MotionPlanRequest, PoseGoal
from ..core.planning_scene.planning_scene import PlanningScene
from ..core.robot_trajectory.robot_trajectory import timed_to_joint_trajectory
from . import trajectory_cache
from .move_group_context import SOURCE, MoveGroupContext, RequestError, check_goal, check_number

__all__ = ["MAX_PLANNING_ATTEMPTS", "MAX_PLANNING_TIME", "PlanResult", "complete_request", "plan", "plan_any"]

# Request budgets: a request beyond them is refused with the bound, so no client can occupy the
# planner for hours (move_group has no such bounds; one careless request there blocks everyone).
#: s: the longest allowed_planning_time a plan request may ask for.
MAX_PLANNING_TIME = 300.0
#: num_planning_attempts at most (each attempt shares the planning time).
MAX_PLANNING_ATTEMPTS = 1000


@dataclass
class PlanResult:
    """The plan capability's answer: MoveIt's error code, and on success the trajectory as the
    controllers get it (sampled at the server's trajectory_sample_period) and the start state."""

    error_code: MoveItErrorCode
    trajectory: JointTrajectory | None = None
    planning_time: float = 0.0
    group: str = ""
    planner_id: str = ""
    start_state: Any = None  # core RobotState the plan starts from
    #: "hit" (answered by the trajectory cache), "miss" (planned; the cache is enabled), "" (disabled)
    trajectory_cache: str = ""
    #: s: a hit's lookup (key, SQLite, decoding) and validation (stitching, validator) times
    cache_lookup_time: float = 0.0
    cache_validate_time: float = 0.0


def complete_request(ctx: MoveGroupContext, request: MotionPlanRequest, start_state: RobotStateMsg | None = None,
                     goal_frame: str = "world", path_constraints: Any = None, scene_diff: Any = None) -> PlanningScene:
    """Fill what ``request`` leaves out (0, "", None) with the defaults, check it against the
    request budgets, and resolve its start state (merged onto the current one), goal frame and
    path constraints: the scene to plan in (its current state is the start state; with
    ``scene_diff``, a PlanningScene message, applied to it only). Raises RequestError with
    MoveIt's code."""
    bad = MoveItErrorCode.INVALID_MOTION_PLAN
    model = ctx.model
    if not model.has_group(request.group):
        raise RequestError(MoveItErrorCode.INVALID_GROUP_NAME,
                           f"unknown planning group {request.group!r}; known: {', '.join(model.group_names)}")
    check_goal(model, request.goal)
    d = ctx.defaults
    request.pipeline_id = request.pipeline_id or d.pipeline_id
    if not request.planner_id and request.pipeline_id == d.pipeline_id:  # another pipeline: its own default
        request.planner_id = d.planner_id
    for key, default in (("allowed_planning_time", d.planning_time),
                         ("max_velocity_scaling_factor", d.max_velocity_scaling_factor),
                         ("max_acceleration_scaling_factor", d.max_acceleration_scaling_factor)):
        value = getattr(request, key)
        setattr(request, key, default if not value else check_number(value, key))
    if not 0 < request.allowed_planning_time <= MAX_PLANNING_TIME:
        raise RequestError(bad, f"allowed_planning_time must be in (0, {MAX_PLANNING_TIME:g}] s, "
                                f"got {request.allowed_planning_time:g}")
    for key in ("max_velocity_scaling_factor", "max_acceleration_scaling_factor"):
        if not 0 < getattr(request, key) <= 1:
            raise RequestError(bad, f"{key} must be in (0, 1], got {getattr(request, key):g}")
    if request.num_planning_attempts == 0:
        request.num_planning_attempts = d.num_planning_attempts  # MoveIt reads 0 as "the default"
    if not 1 <= request.num_planning_attempts <= MAX_PLANNING_ATTEMPTS:
        raise RequestError(bad, f"num_planning_attempts must be in [1, {MAX_PLANNING_ATTEMPTS}], "
                                f"got {request.num_planning_attempts}")
    scene = ctx.start_scene(start_state, model.group(request.group).joint_names, scene_diff)
    if isinstance(request.goal, PoseGoal):
        request.goal.pose = ctx.in_world([request.goal.pose], goal_frame, scene)[0]
    request.start_state = scene.current_state.copy()
    request.path_constraints = ctx.resolve_path_constraints(path_constraints, scene)
    return scene


def plan(ctx: MoveGroupContext, request: MotionPlanRequest, start_state: RobotStateMsg | None = None,
         goal_frame: str = "world", path_constraints: Any = None, display: bool = True,
         scene_diff: Any = None) -> PlanResult:
    """Plan ``request`` (as complete_request reads it); never raises for bad input."""
    started = time.perf_counter()
    try:
        scene = complete_request(ctx, request, start_state, goal_frame, path_constraints, scene_diff)
    except RequestError as exc:
        ctx.last_plan, ctx.last_plan_problem = None, f"the last planning request failed: {exc.message}"
        ctx.log("warning", f"plan request refused: {exc.message}")
        return PlanResult(MoveItErrorCode(exc.moveit_code, exc.message, SOURCE))
    lookup = trajectory_cache.fetch_plan(ctx, scene, request)
    if lookup.hit is not None:
        return _cached(ctx, request, lookup.hit, started, display)
    cache = "miss" if trajectory_cache.enabled(ctx) else ""
    try:
        response = ctx.plan_in_context(scene, request)
    except Exception as exc:  # planners promise not to raise; if one does, answer anyway
        response = None
        ctx.log("error", f"planner raised {type(exc).__name__}: {exc}\n{traceback.format_exc()}")
        message = "the planner failed on this request with an internal error (the planning_server's log has the details)"
    if response is None or not response.success or response.trajectory is None:
        code = response.error_code if response is not None else MoveItErrorCode(MoveItErrorCode.FAILURE, message)
        ctx.last_plan, ctx.last_plan_problem = None, f"the last planning request failed: {code}"
        ctx.log("warning", f"planning for '{request.group}' failed: {code}")
        return PlanResult(MoveItErrorCode(code.val, code.message, code.source or request.pipeline_id),
                          planning_time=time.perf_counter() - started, group=request.group, trajectory_cache=cache)
    if cache:
        trajectory_cache.insert_plan(ctx, request, response, lookup.refused)
    trajectory = timed_to_joint_trajectory(response.trajectory, ctx.defaults.sample_period or None)
    ctx.last_plan, ctx.last_plan_problem = (trajectory, request.group), ""
    if display:
        ctx.display(trajectory)
    ctx.log("info", f"planned '{request.group}' with {request.pipeline_id}/{response.planner_id or 'default'}: "
                    f"{trajectory.duration:.3f} s trajectory in {response.planning_time:.3f} s")
    return PlanResult(MoveItErrorCode(MoveItErrorCode.SUCCESS, response.error_code.message, request.pipeline_id),
                      trajectory, response.planning_time, request.group, response.planner_id, request.start_state,
                      cache)


def _cached(ctx: MoveGroupContext, request: MotionPlanRequest, hit: trajectory_cache.CacheHit, started: float,
            display: bool) -> PlanResult:
    """The plan result of a trajectory cache hit (validated in the request's scene already)."""
    trajectory = timed_to_joint_trajectory(hit.trajectory, ctx.defaults.sample_period or None)
    ctx.last_plan, ctx.last_plan_problem = (trajectory, request.group), ""
    if display:
        ctx.display(trajectory)
    elapsed = time.perf_counter() - started
    message = (f"trajectory cache hit: entry {hit.entry.id} ({hit.entry.planner_id or 'planner unknown'}), "
               f"validated in the current scene")
    ctx.log("info", f"'{request.group}' answered from the trajectory cache (entry {hit.entry.id}): "
                    f"{trajectory.duration:.3f} s trajectory; lookup {1e3 * hit.lookup_time:.2f} ms, validation "
                    f"{1e3 * hit.validate_time:.2f} ms")
    return PlanResult(MoveItErrorCode(MoveItErrorCode.SUCCESS, message, "trajectory_cache"), trajectory, elapsed,
                      request.group, hit.entry.planner_id, request.start_state, "hit", hit.lookup_time,
                      hit.validate_time)


def plan_any(ctx: MoveGroupContext, requests: Sequence[tuple[MotionPlanRequest, str]],
             start_state: RobotStateMsg | None = None, path_constraints: Any = None,
             display: bool = True, scene_diff: Any = None) -> PlanResult:
    """Plan (request, goal frame) pairs in turn until one succeeds, as MoveIt reads several
    goal_constraints ("any of them"); the last failure when none does. ``scene_diff``: see
    complete_request."""
    result = PlanResult(MoveItErrorCode(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "the request has no goal", SOURCE))
    for request, frame in requests:
        result = plan(ctx, request, start_state, frame, path_constraints, display, scene_diff)
        if result.error_code.val == MoveItErrorCode.SUCCESS:
            break
    return result
