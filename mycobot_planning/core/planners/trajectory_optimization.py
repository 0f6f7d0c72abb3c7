"""What MoveIt's trajectory-optimisation planners (CHOMP, STOMP) share around their algorithms.

Both take a flat set of typed parameters (strings from ROS parameters, checked all or nothing),
check the request and resolve its goal to joint states (IK for a pose goal, within a share of
allowed_planning_time) before optimising a joint-space path, and answer with the timed, validated
path or MoveIt's failure codes (PREEMPTED, TIMED_OUT, PLANNING_FAILED). One implementation of
that plumbing here; each planner's module keeps only its optimisation.
"""
from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, fields, replace
from typing import Any, Callable, ClassVar, Generic, Mapping, Sequence, TypeVar

import numpy as np

from interfaces_py.msgs import MoveItErrorCode

from ..errors import PlanningError
from ..planning_interface.planning_interface import (
    JointGoal,
    MotionPlanRequest,
    MotionPlanResponse,
    NamedGoal,
    PlanningFailure,
    PoseGoal,
    check_group,
    check_path_constraints_at_ends,
    check_request_numbers,
    check_scaling,
    failure,
    goal_states,
    start_state_of,
    success,
)
from ..planning_scene.planning_scene import PlanningScene
from ..robot_state.robot_state import RobotState

__all__ = ["IK_TIME_SHARE", "OptimizationProblem", "OptimizerParams", "TrajectoryOptimizationPlanner",
           "optimized_response", "parse_params", "planned", "prepare_problem"]

#: share of allowed_planning_time IK may use for a pose goal before the optimisation starts
IK_TIME_SHARE = 0.25


@dataclass(frozen=True)
class OptimizerParams:
    """Base of a planner's frozen parameter dataclass: typed fields, checked by ``problem``."""

    #: the planner's name in messages ("CHOMP")
    PLANNER: ClassVar[str] = ""

    def range_problem(self) -> str | None:
        """Why the (well-typed) values are out of range (None: they are not)."""
        return None

    def problem(self) -> str | None:
        """Why these values cannot be used (None: they can)."""
        for f in fields(self):
            value = getattr(self, f.name)
            if f.type == "bool" and not isinstance(value, bool):
                return f"{self.PLANNER} parameter {f.name} must be true or false, got {value!r}"
            if f.type == "int" and (isinstance(value, bool) or not isinstance(value, int)):
                return f"{self.PLANNER} parameter {f.name} must be an integer, got {value!r}"
            if f.type == "float" and (isinstance(value, bool) or not isinstance(value, (int, float))
                                      or not math.isfinite(value)):
                return f"{self.PLANNER} parameter {f.name} must be a finite number, got {value!r}"
        return self.range_problem()

    def as_strings(self) -> dict[str, str]:
        return {k: (str(v).lower() if isinstance(v, bool) else str(v)) for k, v in asdict(self).items()}


P = TypeVar("P", bound=OptimizerParams)


def _parse_value(planner: str, key: str, kind: str, text: Any) -> Any:
    if kind == "str":
        return str(text)
    if kind == "bool":
        if isinstance(text, bool):
            return text
        lowered = str(text).strip().lower()
        if lowered in ("true", "1"):
            return True
        if lowered in ("false", "0"):
            return False
        raise ValueError(f"{planner} parameter {key} must be true or false, got {text!r}")
    try:
        number = float(text)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{planner} parameter {key} must be a number, got {text!r}") from None
    if kind == "int":
        if not number.is_integer():
            raise ValueError(f"{planner} parameter {key} must be an integer, got {text!r}")
        return int(number)
    return number


def parse_params(defaults: P, base: P, params: Mapping[str, Any], replace_all: bool = False) -> P | str:
    """``base`` (or ``defaults`` with ``replace_all``) with ``params`` (strings, numbers or booleans)
    applied, checked; a message when refused."""
    types = {f.name: f.type for f in fields(defaults)}
    known = list(types)
    unknown = sorted(set(params) - set(known))
    if unknown:
        return f"unknown {defaults.PLANNER} parameters {unknown}; known: {known}"
    values: dict[str, Any] = {}
    for key, text in params.items():
        try:
            values[key] = _parse_value(defaults.PLANNER, key, str(types[key]), text)
        except ValueError as exc:
            return str(exc)
    result = replace(defaults if replace_all else base, **values)
    problem = result.problem()
    return problem if problem is not None else result


@dataclass
class OptimizationProblem:
    """A checked request: the group, its start state, the goal states (nearest first) and the budget."""

    jmg: Any
    start: RobotState
    goals: list[RobotState]
    rng: np.random.Generator
    budget: float
    velocity_scaling: float
    acceleration_scaling: float

    @property
    def lower(self) -> np.ndarray:
        return self.start.model.lower_limits[self.jmg.variable_indices]

    @property
    def upper(self) -> np.ndarray:
        return self.start.model.upper_limits[self.jmg.variable_indices]


def prepare_problem(scene: PlanningScene, request: MotionPlanRequest, params: OptimizerParams
                    ) -> OptimizationProblem:
    """Check the request and the parameters and resolve the goal; raises PlanningFailure."""
    if not isinstance(request, MotionPlanRequest):
        raise failure(MoveItErrorCode.INVALID_MOTION_PLAN,
                      f"expected a MotionPlanRequest, got {type(request).__name__}")
    problem = params.problem()
    if problem is not None:
        raise failure(MoveItErrorCode.INVALID_MOTION_PLAN, problem)
    model = scene.robot_model
    check_request_numbers(request)
    jmg = check_group(model, request.group)
    velocity_scaling, acceleration_scaling = check_scaling(model, request)
    start = start_state_of(scene, request)
    constraints = request.path_constraints
    if constraints:
        violation = constraints.violation(start)
        if violation:
            raise failure(MoveItErrorCode.START_STATE_VIOLATES_PATH_CONSTRAINTS,
                          f"the start state violates the path constraints: {violation}")
    rng = np.random.default_rng(request.seed)
    budget = float(request.allowed_planning_time)
    goal = request.goal
    if isinstance(goal, PoseGoal):
        goals = goal_states(scene, jmg, start, goal, max(1, int(request.num_ik_goals)),
                            max(budget * IK_TIME_SHARE, 1e-3), rng)
    elif isinstance(goal, (JointGoal, NamedGoal)):
        goals = goal_states(scene, jmg, start, goal, 1, 1e-3, rng)
    else:
        raise failure(MoveItErrorCode.UNRECOGNIZED_GOAL_TYPE, f"unrecognised goal type {type(goal).__name__}")
    goals = check_path_constraints_at_ends(request, start, goals)
    return OptimizationProblem(jmg, start, list(goals), rng, budget, velocity_scaling, acceleration_scaling)


def optimized_response(result: Any, problem: OptimizationProblem, planner: str, pipeline_id: str,
                       started: float, request: MotionPlanRequest, tried: str = "") -> MotionPlanResponse:
    """The response for an optimiser's ``result`` (status, message, path, accepted: the timed
    trajectory); raises PlanningFailure when it found no valid path. MoveIt's optimising planners
    answer with their pipeline id as planner_id."""
    group = problem.jmg.name
    if result.status == "PREEMPTED":
        raise failure(MoveItErrorCode.PREEMPTED, f"planning for group '{group}' was cancelled (stop requested)")
    if result.path is None:
        code = MoveItErrorCode.TIMED_OUT if result.status == "TIMEOUT" else MoveItErrorCode.PLANNING_FAILED
        raise failure(code, f"{planner} found no valid path for group '{group}' in {problem.budget:.3g} s{tried}: "
                            f"{result.status} ({result.message})")
    response = success(
        result.accepted, started, request, problem.start, path=result.path,
        message=(f"{planner}: {result.message}; {len(result.path)} waypoints, "
                 f"duration {result.accepted.duration:.3f} s"),
        validated=True,
    )
    response.planner_id = pipeline_id
    return response


def planned(planner: str, plan: Callable[[PlanningScene, MotionPlanRequest, P, float], MotionPlanResponse],
            scene: PlanningScene, request: MotionPlanRequest, params: P) -> MotionPlanResponse:
    """``plan`` run with its start time; a failure becomes the response's MoveItErrorCode, never a raise."""
    started = time.perf_counter()
    try:
        return plan(scene, request, params, started)
    except PlanningFailure as exc:
        return exc.to_response(started, request)
    except PlanningError as exc:
        return failure(MoveItErrorCode.FAILURE, f"{planner} failed: {exc}").to_response(started, request)


class TrajectoryOptimizationPlanner(Generic[P]):
    """A trajectory-optimisation pipeline as a PlannerManager (core.planning_interface.planner_manager):
    one planner id, its parameters read and set all or nothing."""

    pipeline_id: ClassVar[str]
    description: ClassVar[str]
    enforces_path_constraints: ClassVar[bool]
    #: the planner id MoveIt's plugin lists; also accepted: "" and the pipeline id
    planner_id: ClassVar[str]
    default_params: ClassVar[Any]

    def __init__(self, params: P | Mapping[str, Any] | None = None) -> None:
        if params is None:
            params = self.default_params
        elif not isinstance(params, type(self.default_params)):
            parsed = parse_params(self.default_params, self.default_params, params)
            if isinstance(parsed, str):
                raise ValueError(parsed)
            params = parsed
        problem = params.problem()
        if problem is not None:
            raise ValueError(problem)
        self.params: P = params

    def _accepts(self, planner_id: str) -> bool:
        return planner_id in ("", self.planner_id, self.pipeline_id)

    def planner_ids(self, group: str = "") -> list[str]:
        return [self.planner_id]

    def planner_id_problem(self, planner_id: str, groups: Sequence[str] = ()) -> str | None:
        if self._accepts(planner_id):
            return None
        return f"'{planner_id}' is not the {self.description} planner ('{self.planner_id}')"

    def can_service_request(self, request: MotionPlanRequest) -> bool:
        return isinstance(request.goal, (JointGoal, NamedGoal, PoseGoal)) and self._accepts(request.planner_id)

    def plan(self, scene: PlanningScene, request: MotionPlanRequest) -> MotionPlanResponse:
        raise NotImplementedError

    def planner_params(self, planner_id: str, group: str = "") -> dict[str, str]:
        return self.params.as_strings() if self._accepts(planner_id) else {}

    def set_planner_params(self, planner_id: str, params: Mapping[str, str], replace: bool = False) -> str | None:
        """All or nothing: every key a parameter of this planner, every value of its type and in its range."""
        if not self._accepts(planner_id):
            return f"unknown planner configuration {planner_id!r}; {self.description} has '{self.planner_id}'"
        parsed = parse_params(self.default_params, self.params, params, replace)
        if isinstance(parsed, str):
            return parsed
        self.params = parsed
        return None
