"""Motion plan requests and responses, and the checks every planner shares.

MoveIt's planners all answer the same question (a group, a start state, a goal, limits) with the
same kind of answer (a timed trajectory and a MoveItErrorCode). Keeping that contract here lets the
OMPL, industrial (PTP/LIN/CIRC), Cartesian and joint-interpolation planners differ only in how they
find the path, and gives users MoveIt's error codes whichever planner they pick.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence, Union

import numpy as np

from interfaces_py.msgs import MoveItErrorCode

from ..errors import PlanningError, TimeParameterizationError
from ..kinematic_constraints.kinematic_constraints import CONSTRAINT_CHECK_STEP, dense_violation
from ..kinematics.ik_solver import thread_ik_solver
from ..planning_scene.planning_scene import PlanningScene
from ..robot_model.robot_model import JointModelGroup, RobotModel
from ..robot_state.robot_state import RobotState
from ..robot_trajectory.robot_trajectory import TimedTrajectory
from ..trajectory_processing import DEFAULT_MAX_DEVIATION, time_parameterize
from ..trajectory_processing.trajectory_validator import DEFAULT_RESOLUTION, halving_order, validate_trajectory
from ..transforms import check_pose
from ..moveit_error_code import ErrorCodeResult


@dataclass
class JointGoal:
    """Joint values: a mapping by joint name, or a vector in the group's joint order."""

    values: Mapping[str, float] | Sequence[float] | np.ndarray
    tolerance: float = 1e-4


@dataclass
class NamedGoal:
    """An SRDF named state of the group ("home", "ready")."""

    name: str
    tolerance: float = 1e-4


@dataclass
class PoseGoal:
    """A pose (4x4, world frame) for a link, or for an ik_frame rigidly offset from it."""

    pose: np.ndarray
    link: str | None = None  # default: the group's tip link
    ik_frame_offset: np.ndarray | None = None  # pose of the ik_frame in the link frame
    position_tolerance: float = 1e-4
    orientation_tolerance: float = 1e-3


Goal = Union[JointGoal, NamedGoal, PoseGoal]


@dataclass
class MotionPlanRequest:
    """What to plan (MoveIt's MotionPlanRequest, flattened to what our planners use)."""

    group: str
    goal: Goal
    start_state: RobotState | None = None  # default: the scene's current state
    pipeline_id: str = "ompl"  # "ompl", "pilz_industrial_motion_planner", "joint_interpolation", "stomp", "chomp"
    planner_id: str = ""  # "RRTConnectkConfigDefault", "arm[RRTConnectkConfigDefault]", "PTP", "LIN", "CIRC"
    allowed_planning_time: float = 5.0
    num_planning_attempts: int = 1
    #: the number of this request's first attempt: a planner whose attempts are independent
    #: (``PlannerManager.independent_attempts``) seeds attempt k as attempt first_attempt + k of
    #: the whole request, so attempts split between processes plan as they would in one
    first_attempt: int = 0
    max_velocity_scaling_factor: float | None = None  # None: joint_limits.yaml's default
    max_acceleration_scaling_factor: float | None = None
    seed: int | None = None  # makes sampling planners and IK reproducible
    # Industrial CIRC: exactly one of these auxiliary points, in the world frame.
    circ_center: Sequence[float] | None = None
    circ_interim: Sequence[float] | None = None
    num_ik_goals: int = 8  # IK-sampled goal states for pose goals (sampling planners)
    #: kinematic_constraints.PathConstraints every state of the path must satisfy (None: none)
    path_constraints: Any = None
    #: Anything with ``is_set()`` (a threading.Event): set from another thread, it ends a running
    #: sampling planner early with PREEMPTED (the planning server's stop / an action's cancel).
    cancel: Any = field(default=None, repr=False, compare=False)


@dataclass
class MotionPlanResponse(ErrorCodeResult):
    """The result: a trajectory on success, a MoveItErrorCode (with a message) always."""

    error_code: MoveItErrorCode
    trajectory: TimedTrajectory | None = None
    planning_time: float = 0.0
    group_name: str = ""
    planner_id: str = ""
    start_state: RobotState | None = None
    path: np.ndarray | None = field(default=None, repr=False)  # geometric waypoints before timing
    #: The pipeline already ran the trajectory validator on this trajectory (start state, limits,
    #: collisions at its resolution, by the scene's checker) and it passed: callers need not
    #: check it again (a judge of the planner still can, with the validator's plain check).
    validated: bool = False


class PlanningFailure(PlanningError):
    """Raised inside planners to end planning with a MoveIt error code and a message."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.message = message

    def to_response(self, started: float, request: MotionPlanRequest) -> MotionPlanResponse:
        return MotionPlanResponse(
            error_code=MoveItErrorCode(self.code, self.message),
            planning_time=time.perf_counter() - started,
            group_name=request.group,
            planner_id=request.planner_id,
        )


def failure(code: int, message: str) -> PlanningFailure:
    return PlanningFailure(code, message)


# ---------------------------------------------------------------------------- request checks
def check_group(model: RobotModel, group: str) -> JointModelGroup:
    if not isinstance(group, str) or not model.has_group(group):
        known = ", ".join(model.group_names)
        raise failure(MoveItErrorCode.INVALID_GROUP_NAME, f"unknown planning group '{group}'; known: {known}")
    jmg = model.group(group)
    if not jmg.joint_names:
        raise failure(MoveItErrorCode.INVALID_GROUP_NAME, f"group '{group}' has no active joints to plan for")
    return jmg


def check_scaling(model: RobotModel, request: MotionPlanRequest) -> tuple[float, float]:
    """Scaling factors in (0, 1], defaulting to joint_limits.yaml's defaults."""
    values = []
    for name, value, default in (
        ("max_velocity_scaling_factor", request.max_velocity_scaling_factor, model.default_velocity_scaling_factor),
        ("max_acceleration_scaling_factor", request.max_acceleration_scaling_factor, model.default_acceleration_scaling_factor),
    ):
        value = default if value is None else value
        if not isinstance(value, (int, float)) or not math.isfinite(value) or not 0.0 < value <= 1.0:
            raise failure(MoveItErrorCode.INVALID_MOTION_PLAN, f"{name} must be in (0, 1], got {value}")
        values.append(float(value))
    return values[0], values[1]


def check_request_numbers(request: MotionPlanRequest) -> None:
    t = request.allowed_planning_time
    if not isinstance(t, (int, float)) or not math.isfinite(t) or t <= 0:
        raise failure(MoveItErrorCode.INVALID_MOTION_PLAN, f"allowed_planning_time must be > 0, got {t}")
    if not isinstance(request.num_planning_attempts, int) or request.num_planning_attempts < 1:
        raise failure(
            MoveItErrorCode.INVALID_MOTION_PLAN,
            f"num_planning_attempts must be an integer >= 1, got {request.num_planning_attempts}",
        )
    if not isinstance(request.first_attempt, int) or request.first_attempt < 0:
        raise failure(MoveItErrorCode.INVALID_MOTION_PLAN,
                      f"first_attempt must be an integer >= 0, got {request.first_attempt}")


def check_path_constraints_at_ends(request: MotionPlanRequest, start: RobotState,
                                   goals: list[RobotState]) -> list[RobotState]:
    """MoveIt's checks before planning under path constraints: the start must satisfy them
    (START_STATE_VIOLATES_PATH_CONSTRAINTS); goals that do not are dropped, and with none left the
    request fails with GOAL_VIOLATES_PATH_CONSTRAINTS."""
    constraints = request.path_constraints
    if not constraints:
        return goals
    problem = constraints.violation(start)
    if problem:
        raise failure(MoveItErrorCode.START_STATE_VIOLATES_PATH_CONSTRAINTS,
                      f"the start state violates the path constraints: {problem}")
    kept = [g for g in goals if constraints.satisfied(g)]
    if not kept:
        raise failure(MoveItErrorCode.GOAL_VIOLATES_PATH_CONSTRAINTS,
                      f"every goal state violates the path constraints, e.g. {constraints.violation(goals[0])}")
    return kept


def start_state_of(scene: PlanningScene, request: MotionPlanRequest) -> RobotState:
    """The request's start state (or the scene's current one), checked for bounds and collisions."""
    start = request.start_state if request.start_state is not None else scene.current_state
    if not isinstance(start, RobotState) or start.model is not scene.robot_model:
        raise failure(MoveItErrorCode.INVALID_ROBOT_STATE, "start state is not a RobotState of this robot")
    if not np.all(np.isfinite(start.positions)):
        raise failure(MoveItErrorCode.INVALID_ROBOT_STATE, "start state contains NaN or infinite values")
    check_start_state(scene, start)
    return start.copy()


def check_start_state(scene: PlanningScene, start: RobotState, check_collisions: bool = True) -> None:
    """Raise START_STATE_INVALID for a start outside the joint limits and, when
    ``check_collisions``, START_STATE_IN_COLLISION for one in collision in ``scene``."""
    violated = start.violated_bounds(margin=1e-6)
    if violated:
        raise failure(MoveItErrorCode.START_STATE_INVALID, "start state outside joint limits: " + "; ".join(violated))
    if check_collisions:
        report = scene.check_collision(start, max_contacts=3)
        if report.collision:
            raise failure(
                MoveItErrorCode.START_STATE_IN_COLLISION,
                "start state in collision: " + "; ".join(str(c) for c in report.contacts),
            )


def joint_goal_vector(model: RobotModel, jmg: JointModelGroup, goal: JointGoal | NamedGoal) -> np.ndarray:
    """A joint or named goal as the group's vector, checked against names, NaN and limits."""
    if isinstance(goal, NamedGoal):
        try:
            values: Mapping[str, float] | Sequence[float] = model.named_state(goal.name, jmg.name)
        except ValueError as exc:
            raise failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, str(exc)) from None
    else:
        values = goal.values
    if isinstance(values, Mapping):
        unknown = [name for name in values if name not in jmg.joint_names]
        if unknown:
            raise failure(
                MoveItErrorCode.INVALID_GOAL_CONSTRAINTS,
                f"goal names joints not in group '{jmg.name}': {unknown}; group joints: {list(jmg.joint_names)}",
            )
        missing = [name for name in jmg.joint_names if name not in values]
        if missing:
            raise failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, f"goal lacks values for joints {missing}")
        vector = np.array([float(values[name]) for name in jmg.joint_names])
    else:
        try:
            vector = np.array(values, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "joint goal is not a vector of numbers") from None
        if vector.size != jmg.variable_count:
            raise failure(
                MoveItErrorCode.INVALID_GOAL_CONSTRAINTS,
                f"joint goal has {vector.size} values; group '{jmg.name}' has {jmg.variable_count} joints",
            )
    if not np.all(np.isfinite(vector)):
        raise failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "joint goal contains NaN or infinite values")
    low = model.lower_limits[jmg.variable_indices]
    high = model.upper_limits[jmg.variable_indices]
    outside = [
        f"{name}={v:.4f} outside [{lo:.4f}, {hi:.4f}]"
        for name, v, lo, hi in zip(jmg.joint_names, vector, low, high)
        if v < lo - 1e-9 or v > hi + 1e-9
    ]
    if outside:
        raise failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "joint goal outside limits: " + "; ".join(outside))
    return vector


def check_pose_goal(model: RobotModel, jmg: JointModelGroup, goal: PoseGoal) -> tuple[str, np.ndarray]:
    """The goal's link (default: the group tip) and its pose, checked; raises PlanningFailure."""
    link = goal.link or jmg.tip_link
    if not model.has_link(link):
        try:
            model.frame_id(link)
        except ValueError:
            raise failure(MoveItErrorCode.INVALID_LINK_NAME, f"unknown link '{link}' in pose goal") from None
    try:
        pose = check_pose(goal.pose, "pose goal")
        if goal.ik_frame_offset is not None:
            check_pose(goal.ik_frame_offset, "ik_frame offset")
    except ValueError as exc:
        raise failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, str(exc)) from None
    return link, pose


def goal_state_in_scene(scene: PlanningScene, state: RobotState) -> None:
    """GOAL_IN_COLLISION with the contacts when a goal state collides."""
    report = scene.check_collision(state, max_contacts=3)
    if report.collision:
        raise failure(
            MoveItErrorCode.GOAL_IN_COLLISION, "goal state in collision: " + "; ".join(str(c) for c in report.contacts)
        )


def goal_states(
    scene: PlanningScene,
    jmg: JointModelGroup,
    start: RobotState,
    goal: Goal,
    max_states: int,
    timeout: float,
    rng: np.random.Generator,
) -> list[RobotState]:
    """Goal states for a request: one for joint/named goals, up to max_states valid IK solutions for
    pose goals (nearest to the start first). Raises PlanningFailure with MoveIt's code."""
    model = scene.robot_model
    if isinstance(goal, (JointGoal, NamedGoal)):
        state = start.copy()
        state.set_group_positions(jmg.name, joint_goal_vector(model, jmg, goal))
        goal_state_in_scene(scene, state)
        return [state]
    if not isinstance(goal, PoseGoal):
        raise failure(MoveItErrorCode.UNRECOGNIZED_GOAL_TYPE, f"unrecognised goal type {type(goal).__name__}")
    link, pose = check_pose_goal(model, jmg, goal)
    solver = thread_ik_solver(model, jmg.name, link, goal.ik_frame_offset)
    # Bounded descents as well as time: a pose with fewer IK branches than max_states must not
    # spend the whole budget looking for branches that do not exist.
    attempts = solver.options.seed_neighbours + 4 * max_states + 8
    solutions = solver.solve(
        pose, seed=start, timeout=timeout, max_solutions=max_states, min_solution_distance=0.1, rng=rng, attempts=attempts
    )
    if not solutions:
        raise failure(MoveItErrorCode.NO_IK_SOLUTION, f"no IK solution for the pose goal of '{link}' (group '{jmg.name}')")
    valid = [s for s in solutions if scene.is_state_valid(s)]
    if not valid:
        report = scene.check_collision(solutions[0], max_contacts=3)
        raise failure(
            MoveItErrorCode.GOAL_IN_COLLISION,
            f"all {len(solutions)} IK solutions for the pose goal collide, e.g. "
            + "; ".join(str(c) for c in report.contacts),
        )
    start_group = start.group_positions(jmg.name)
    valid.sort(key=lambda s: float(np.sum(np.abs(s.group_positions(jmg.name) - start_group))))
    return valid


def time_group_path(
    model: RobotModel,
    jmg: JointModelGroup,
    path: np.ndarray,
    velocity_scaling: float,
    acceleration_scaling: float,
    sample_period: float | None = None,
    max_deviation: float = DEFAULT_MAX_DEVIATION,
) -> TimedTrajectory:
    """Time a group path under joint_limits.yaml scaled by the request's factors.

    ``method="auto"``: a densely sampled curve (a Cartesian path, a B-spline-smoothed OMPL
    path) gets near time-optimal path speeds along a smooth curve through every waypoint
    within ``max_deviation`` (joint-space norm) of the polyline; anything else (straight
    runs and real corners, or jerk limits configured) one Ruckig profile per straight segment,
    exactly on the polyline, resting at each corner. See time_parameterization's module
    docstring."""
    idx = jmg.variable_indices
    jerk = None if model.jerk_limits is None else model.jerk_limits[idx]
    return time_parameterize(
        path,
        model.velocity_limits[idx],
        model.acceleration_limits[idx],
        max_jerk=jerk,
        velocity_scaling=velocity_scaling,
        acceleration_scaling=acceleration_scaling,
        joint_names=list(jmg.joint_names),
        sample_period=sample_period,
        method="auto",
        max_deviation=max_deviation,
    )


def polyline_problem(scene: PlanningScene, group: str, start: RobotState, path: np.ndarray,
                     constraints: Any = None) -> str | None:
    """Why the joint-space polyline ``path`` (the group's variables, one row per waypoint) is not
    valid when checked every DEFAULT_RESOLUTION (max-norm) for collisions and every
    CONSTRAINT_CHECK_STEP for the path constraints, or None. Trajectory optimisers (STOMP,
    CHOMP) ask this of a candidate before they time it."""
    rows = [path[:1]]
    for a, b in zip(path[:-1], path[1:]):
        steps = max(1, int(math.ceil(float(np.max(np.abs(b - a))) / DEFAULT_RESOLUTION)))
        rows.append(a + (b - a) * (np.arange(1, steps + 1) / steps)[:, None])
    states = np.vstack(rows)
    hit = scene.colliding_rows(group, start, states, order=halving_order(len(states)), stop_at_first=True)
    if hit.any():
        return "the path collides between its waypoints"
    if constraints:
        joint_names = list(scene.robot_model.group(group).joint_names)
        found = dense_violation(constraints, start, joint_names, path, CONSTRAINT_CHECK_STEP)
        if found is not None:
            return f"the path leaves the path constraints between its waypoints: {found[2]}"
    return None


def timed_and_validated(scene: PlanningScene, jmg: JointModelGroup, start: RobotState, path: np.ndarray,
                        constraints: Any, velocity_scaling: float, acceleration_scaling: float
                        ) -> tuple[TimedTrajectory | None, str | None]:
    """(the timed trajectory of ``path``, None) when the trajectory validator (the scene's
    checker, every DEFAULT_RESOLUTION) and the path constraints pass it, else (None, why not).
    The timing follows a smooth curve near the polyline (max_deviation), so it is checked
    again, and timed closer to the (densely checked) polyline when the curve touches something.
    What trajectory optimisers (STOMP, CHOMP) call before they count a path as found."""
    model = scene.robot_model
    report_problem = "not timed"
    for deviation in (DEFAULT_MAX_DEVIATION, DEFAULT_MAX_DEVIATION / 10.0):
        try:
            candidate = time_group_path(model, jmg, path, velocity_scaling, acceleration_scaling,
                                        max_deviation=deviation)
        except TimeParameterizationError as exc:
            report_problem = f"the path cannot be timed: {exc}"
            continue
        report = validate_trajectory(scene, candidate, jmg.name, start, all_pairs=False)
        if not report.valid:
            report_problem = "; ".join(report.problems[:2])
            continue
        if constraints:
            found = dense_violation(constraints, start, list(jmg.joint_names), candidate.positions,
                                    CONSTRAINT_CHECK_STEP)
            if found is not None:
                report_problem = f"the timed trajectory leaves the path constraints: {found[2]}"
                continue
        return candidate, None
    return None, report_problem


def success(
    trajectory: TimedTrajectory,
    started: float,
    request: MotionPlanRequest,
    start: RobotState,
    path: np.ndarray | None = None,
    message: str = "",
    validated: bool = False,
) -> MotionPlanResponse:
    return MotionPlanResponse(
        error_code=MoveItErrorCode(MoveItErrorCode.SUCCESS, message),
        trajectory=trajectory,
        planning_time=time.perf_counter() - started,
        group_name=request.group,
        planner_id=request.planner_id,
        start_state=start,
        path=path,
        validated=validated,
    )
