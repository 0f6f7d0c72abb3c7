"""MTC's JointInterpolationPlanner as a core planner: a straight line in joint space.

The full story: docs/core.md, section mycobot_planning.core.planners.joint_interpolation.
"""
from __future__ import annotations

import math
import time

import numpy as np

from interfaces_py.msgs import MoveItErrorCode

from ...errors import PlanningError, StateError
from ...planning_interface.planning_interface import (
    MotionPlanRequest,
    MotionPlanResponse,
    NamedGoal,
    JointGoal,
    PlanningFailure,
    PoseGoal,
    check_group,
    check_request_numbers,
    check_scaling,
    failure,
    goal_states,
    start_state_of,
    success,
    time_group_path,
)
from ...planning_scene.planning_scene import PlanningScene
from ...robot_state.robot_state import RobotState, as_vector

__all__ = [
    "DEFAULT_MAX_STEP",
    "PLANNER_ID",
    "interpolate_joint_path",
    "plan_joint_interpolation",
]

DEFAULT_MAX_STEP = 0.01
"""Largest joint motion (rad or m) between two checked states of the line (see docs/core.md (mycobot_planning.core.planners.joint_interpolation))."""

PLANNER_ID = "JointInterpolation"

# Share of allowed_planning_time that IK may use for a pose goal (the line itself takes ms).
_IK_TIME_SHARE = 0.5


def _describe_state(names: list[str], values: np.ndarray) -> str:
    return ", ".join(f"{n}={v:.4f}" for n, v in zip(names, values))


def interpolate_joint_path(
    scene: PlanningScene,
    group: str,
    start_state: RobotState,
    goal_vector: np.ndarray,
    max_step: float = DEFAULT_MAX_STEP,
) -> tuple[np.ndarray | None, str]:
    """The straight joint-space line from ``start_state`` to ``goal_vector`` (group joint order).

    Returns ``(path, message)``: ``path`` is an (N, d) array of equally spaced group states, start
    and goal included, no joint moving more than ``max_step`` between rows, every row checked
    valid (joint limits and collisions; joints outside the group stay at the start state's
    values). If a state is invalid, ``path`` is None and ``message`` says where along the line
    and why (the contacts, or the violated limits).

    Raises RobotModelError for an unknown group, StateError for a goal of the wrong length or with
    NaN, or a start state of another robot, ValueError for a bad ``max_step``: those are wrong
    calls, not planning outcomes.
    """
    model = scene.robot_model
    jmg = model.group(group)
    if not isinstance(start_state, RobotState) or start_state.model is not model:
        raise StateError("start_state must be a RobotState of the scene's robot model")
    goal = as_vector(goal_vector, jmg.variable_count, f"goal of group '{jmg.name}'")
    if isinstance(max_step, bool) or not isinstance(max_step, (int, float)) or not (
        math.isfinite(max_step) and max_step > 0.0
    ):
        raise ValueError(f"max_step must be a finite number > 0, got {max_step!r}")

    indices = jmg.variable_indices
    names = list(jmg.joint_names)
    start = np.array(start_state.group_positions(jmg.name), dtype=float)
    distance = float(np.max(np.abs(goal - start))) if goal.size else 0.0
    steps = max(1, int(math.ceil(distance / max_step - 1e-9)))
    fractions = np.arange(steps + 1) / steps
    path = start + fractions[:, None] * (goal - start)
    path[-1] = goal  # exactly, not start + 1.0 * (goal - start)

    full = np.tile(np.asarray(start_state.positions, dtype=float), (steps + 1, 1))
    full[:, indices] = path
    is_valid = scene.is_valid_positions
    for i in range(steps + 1):
        if is_valid(full[i]):
            continue
        state = RobotState(model, full[i])
        if i == 0:
            where = "start state"
        elif i == steps:
            where = "goal state"
        else:
            where = (
                f"joint-space line at {100.0 * i / steps:.0f}% of the way (step {i} of {steps}, "
                f"{_describe_state(names, path[i])})"
            )
        violated = state.violated_bounds(margin=0.0)
        if violated:
            return None, f"{where} outside joint limits: " + "; ".join(violated)
        report = scene.check_collision(state, max_contacts=3)
        contacts = "; ".join(str(c) for c in report.contacts) or "contact not reported by the scene"
        return None, f"{where} in collision: {contacts}"
    return path, (
        f"collision-free joint-space line: {steps} step{'s' if steps != 1 else ''} of at most "
        f"{max_step:g}, largest joint motion {distance:.4f}"
    )


def plan_joint_interpolation(
    scene: PlanningScene, request: MotionPlanRequest, max_step: float = DEFAULT_MAX_STEP
) -> MotionPlanResponse:
    """Plan ``request`` as a straight joint-space line (MTC's JointInterpolationPlanner).

    Never raises for bad input: the response's MoveItErrorCode says what was wrong
    (INVALID_GROUP_NAME, INVALID_MOTION_PLAN for bad scaling or times, START_STATE_IN_COLLISION,
    INVALID_GOAL_CONSTRAINTS, NO_IK_SOLUTION, GOAL_IN_COLLISION, PLANNING_FAILED when the line
    collides, with the first contact in the message).
    """
    started = time.perf_counter()
    try:
        return _plan(scene, request, started, max_step)
    except PlanningFailure as exc:
        return exc.to_response(started, request)
    except PlanningError as exc:  # e.g. a malformed goal the shared checks let through
        return failure(MoveItErrorCode.FAILURE, f"joint interpolation failed: {exc}").to_response(started, request)


def _plan(scene: PlanningScene, request: MotionPlanRequest, started: float, max_step: float) -> MotionPlanResponse:
    if not isinstance(request, MotionPlanRequest):
        raise failure(
            MoveItErrorCode.INVALID_MOTION_PLAN, f"expected a MotionPlanRequest, got {type(request).__name__}"
        )
    model = scene.robot_model
    check_request_numbers(request)
    jmg = check_group(model, request.group)
    velocity_scaling, acceleration_scaling = check_scaling(model, request)
    if isinstance(max_step, bool) or not isinstance(max_step, (int, float)) or not (
        math.isfinite(max_step) and max_step > 0.0
    ):
        raise failure(MoveItErrorCode.INVALID_MOTION_PLAN, f"max_step must be a finite number > 0, got {max_step!r}")
    start = start_state_of(scene, request)
    goal = request.goal
    if isinstance(goal, PoseGoal):
        goal_state = _pose_goal_state(scene, jmg, start, request)
    elif isinstance(goal, (JointGoal, NamedGoal)):
        goal_state = goal_states(scene, jmg, start, goal, 1, 1e-3, np.random.default_rng(request.seed))[0]
    else:
        raise failure(MoveItErrorCode.UNRECOGNIZED_GOAL_TYPE, f"unrecognised goal type {type(goal).__name__}")

    path, message = interpolate_joint_path(scene, jmg.name, start, goal_state.group_positions(jmg.name), max_step)
    if path is None:
        raise failure(MoveItErrorCode.PLANNING_FAILED, f"{PLANNER_ID} for group '{jmg.name}': {message}")
    trajectory = time_group_path(model, jmg, path, velocity_scaling, acceleration_scaling)
    response = success(
        trajectory,
        started,
        request,
        start,
        path=path,
        message=f"{PLANNER_ID}: {message}; duration {trajectory.duration:.3f} s",
    )
    response.planner_id = f"{jmg.name}[{PLANNER_ID}]"
    return response


def _pose_goal_state(scene, jmg, start: RobotState, request: MotionPlanRequest) -> RobotState:
    """IK for the pose goal, the valid solution nearest the start (sum of joint distances).

    MTC calls setFromIK seeded from the start state with a validity callback, which usually
    yields the nearest valid solution but not always (a seeded descent can land on the other
    elbow branch). Asking for up to num_ik_goals distinct solutions, the seeded one first, and
    taking the nearest makes "nearest the start" hold; goal_states sorts them that way and raises
    NO_IK_SOLUTION / GOAL_IN_COLLISION with MoveIt's codes."""
    rng = np.random.default_rng(request.seed)
    budget = max(float(request.allowed_planning_time) * _IK_TIME_SHARE, 1e-3)
    return goal_states(scene, jmg, start, request.goal, max(1, int(request.num_ik_goals)), budget, rng)[0]
