"""move_group's move action capability (MoveIt: MoveGroupMoveAction, /move_action): plan, then
execute the plan when planning succeeded and the request is not plan-only; with replanning
(planning_options.replan), a path invalidated by a scene change while it runs is planned again
from where the arm stopped, in the changed scene, as MoveIt's plan_execution does."""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Any, Callable, Sequence

from interfaces_py.msgs import CollisionObject, MoveItErrorCode, PlanningScene as PlanningSceneMsg
from interfaces_py.msgs import PlanningSceneWorld, RobotState as RobotStateMsg, SolidPrimitive

from ..core.planning_interface.planning_interface import MotionPlanRequest
from ..core.trajectory_execution import ExecutionResult
from .execute_trajectory import execute_trajectory
from .move_group_context import SOURCE, MoveGroupContext, RequestError
from .plan import PlanResult, plan_any

__all__ = ["MAX_REPLAN_ATTEMPTS", "MAX_REPLAN_DELAY", "Replanning", "plan_and_execute"]

#: replan_attempts above this are capped (a goal that keeps being invalidated must end)
MAX_REPLAN_ATTEMPTS = 100
#: s: the longest replan_delay accepted
MAX_REPLAN_DELAY = 60.0


@dataclass(frozen=True)
class Replanning:
    """MoveIt's PlanningOptions replan, replan_attempts, replan_delay, checked: attempts >= 0
    (capped at MAX_REPLAN_ATTEMPTS), delay a finite number of seconds in [0, MAX_REPLAN_DELAY]."""

    replan: bool = False
    attempts: int = 0
    delay: float = 0.0

    @classmethod
    def checked(cls, replan: Any, attempts: Any, delay: Any,
                log: Callable[[str, str], None] | None = None) -> "Replanning":
        if isinstance(attempts, bool) or not isinstance(attempts, int):
            raise RequestError(MoveItErrorCode.INVALID_MOTION_PLAN,
                               f"planning_options.replan_attempts must be an integer, got {attempts!r}")
        if attempts < 0:
            raise RequestError(MoveItErrorCode.INVALID_MOTION_PLAN,
                               f"planning_options.replan_attempts must be >= 0, got {attempts}")
        if isinstance(delay, bool) or not isinstance(delay, (int, float)) or not math.isfinite(delay) \
                or not 0.0 <= delay <= MAX_REPLAN_DELAY:
            raise RequestError(MoveItErrorCode.INVALID_MOTION_PLAN,
                               f"planning_options.replan_delay must be a number of seconds in [0, "
                               f"{MAX_REPLAN_DELAY:g}], got {delay!r}")
        if attempts > MAX_REPLAN_ATTEMPTS and replan and log is not None:
            log("warning", f"replan_attempts {attempts} capped at {MAX_REPLAN_ATTEMPTS}")
        return cls(bool(replan), min(attempts, MAX_REPLAN_ATTEMPTS), float(delay))


def plan_and_execute(ctx: MoveGroupContext, requests: Sequence[tuple[MotionPlanRequest, str]],
                     start_state: RobotStateMsg | None = None, path_constraints: Any = None, display: bool = True,
                     plan_only: bool = False, before_execution: Callable[[PlanResult], bool] | None = None,
                     replanning: Replanning | None = None, cancelled: Callable[[], bool] | None = None,
                     on_replan: Callable[[int], None] | None = None,
                     on_replanned: Callable[[PlanResult], None] | None = None,
                     scene_diff: Any = None,
                     ) -> tuple[PlanResult | None, ExecutionResult | None]:
    """(plan, execution) of (request, goal frame) pairs as plan_any reads them. The plan is None
    when the request is refused because another execution runs (the execution result says so);
    the execution is None when planning failed, ``plan_only``, or ``before_execution`` (told
    the plan) returned False.

    With ``replanning.replan``, an execution stopped by MOTION_PLAN_INVALIDATED_BY_ENVIRONMENT_CHANGE
    is followed, after ``replanning.delay`` s, by a new plan from the current state (the
    request's start state no longer holds) and its execution, up to ``replanning.attempts``
    times; ``on_replan(n)`` is told of the n-th before it plans, ``on_replanned(plan)`` of its
    plan before it executes. ``cancelled()`` ends the loop (PREEMPTED).

    ``scene_diff`` (MoveIt's planning_options.planning_scene_diff, a PlanningScene message) is
    planned with (every plan and replan of this goal) and never applied to the monitored scene:
    a goal changes nothing in it, whether it fails or succeeds, as in move_group. It is checked
    before anything else (RequestError)."""
    if scene_diff is not None:
        ctx.scene_with_diff(scene_diff)  # refused before planning or execution starts
    if not plan_only and ctx.executor.executing_after_stop():
        status = ctx.executor.status()
        return None, ExecutionResult(MoveItErrorCode(
            MoveItErrorCode.FAILURE, f"refused: another execution ({status['description']}) is in progress; stop it "
                                     "first or wait for it to finish", SOURCE))
    planned = plan_any(ctx, requests, start_state, path_constraints, display, scene_diff)
    if planned.trajectory is None or plan_only or (before_execution is not None and not before_execution(planned)):
        return planned, None
    executed = execute_trajectory(ctx, planned.trajectory, None, f"plan of '{planned.group}'")
    replanning = replanning or Replanning()
    attempt = 0
    is_cancelled = cancelled or (lambda: False)
    while (replanning.replan and attempt < replanning.attempts
           and executed.error_code.val == MoveItErrorCode.MOTION_PLAN_INVALIDATED_BY_ENVIRONMENT_CHANGE):
        attempt += 1
        ctx.log("info", f"replanning (attempt {attempt} of {replanning.attempts}) after: {executed.message}")
        if _wait(replanning.delay, is_cancelled) or is_cancelled():
            return planned, ExecutionResult(MoveItErrorCode(MoveItErrorCode.PREEMPTED,
                                                            "canceled while waiting to replan", SOURCE))
        if on_replan is not None:
            on_replan(attempt)
        group = requests[0][0].group if requests else ""
        joints = list(ctx.model.group(group).joint_names) if group and ctx.model.has_group(group) else []
        if joints and not ctx.wait_for_rest(joints):
            ctx.log("warning", "replanning: the arm did not come to rest within 2 s; planning from where it is")
        replanned = _replan(ctx, requests, path_constraints, display, scene_diff)
        if replanned.trajectory is None:
            code = replanned.error_code
            return replanned, ExecutionResult(MoveItErrorCode(
                code.val, f"replanning (attempt {attempt}) failed after the path was invalidated "
                          f"({executed.message}): {code.message}", code.source or SOURCE))
        if is_cancelled():
            return replanned, ExecutionResult(MoveItErrorCode(MoveItErrorCode.PREEMPTED, "canceled after replanning",
                                                              SOURCE))
        planned = replanned
        if on_replanned is not None:
            on_replanned(planned)
        executed = execute_trajectory(ctx, planned.trajectory, None,
                                      f"plan of '{planned.group}' (replanned, attempt {attempt})")
    if attempt and executed.error_code.val == MoveItErrorCode.SUCCESS:
        executed.error_code = MoveItErrorCode(MoveItErrorCode.SUCCESS, f"{executed.message} after {attempt} "
                                              f"replan{'s' if attempt > 1 else ''}", executed.error_code.source)
    return planned, executed


def _wait(delay: float, cancelled: Callable[[], bool]) -> bool:
    """Sleep ``delay`` s; True when cancelled meanwhile."""
    event = threading.Event()
    end = 0.0
    while end < delay:
        step = min(0.05, delay - end)
        event.wait(step)
        end += step
        if cancelled():
            return True
    return False


#: m: world primitives are grown by this much for a replan, so the new path keeps clear of what
#: invalidated the old one (OMPL's paths, checked at the validator's resolution with no padding,
#: may graze an object, and an executed state then touched it once in a test run); less than the
#: stop's own clearance (core.trajectory_execution.path_ahead.STOP_CLEARANCE), so the arm where it
#: stopped is still clear of the grown objects
REPLAN_CLEARANCE = 0.005


def _replan(ctx: MoveGroupContext, requests: Sequence[tuple[MotionPlanRequest, str]], path_constraints: Any,
            display: bool, scene_diff: Any) -> PlanResult:
    """A replan from the current state: first in the scene with its world primitives grown by
    REPLAN_CLEARANCE (not when the goal brings its own planning_scene_diff), then, if that finds
    nothing, in the scene as it is."""
    grown = None if scene_diff is not None else _grown_world(ctx, REPLAN_CLEARANCE)
    if grown is not None:
        result = plan_any(ctx, requests, None, path_constraints, display, grown)
        if result.trajectory is not None:
            return result
        ctx.log("info", f"replanning {REPLAN_CLEARANCE * 1e3:.0f} mm clear of the world's objects found nothing "
                        f"({result.error_code.message}); planning in the scene as it is")
    return plan_any(ctx, requests, None, path_constraints, display, scene_diff)


def _grown_world(ctx: MoveGroupContext, margin: float) -> PlanningSceneMsg | None:
    """A scene diff replacing each world object made only of boxes, spheres and cylinders by
    the same object grown by ``margin`` on every side (None when there is none)."""
    grown = []
    for obj in ctx.scene_copy().world_objects():
        if obj.meshes or not obj.primitives:
            continue
        shapes = []
        for primitive in obj.primitives:
            d = list(primitive.dimensions)
            if primitive.type == SolidPrimitive.BOX and len(d) == 3:
                d = [v + 2 * margin for v in d]
            elif primitive.type == SolidPrimitive.SPHERE and len(d) == 1:
                d = [d[0] + margin]
            elif primitive.type == SolidPrimitive.CYLINDER and len(d) == 2:
                d = [d[0] + 2 * margin, d[1] + margin]
            else:
                break
            shapes.append(SolidPrimitive(type=primitive.type, dimensions=d))
        else:
            grown.append(CollisionObject(id=obj.id, frame_id=obj.frame_id, pose=obj.pose, primitives=shapes,
                                         primitive_poses=list(obj.primitive_poses), operation=CollisionObject.ADD))
    if not grown:
        return None
    return PlanningSceneMsg(is_diff=True, robot_state=RobotStateMsg(is_diff=True),
                            world=PlanningSceneWorld(collision_objects=grown))
