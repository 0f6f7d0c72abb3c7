"""OmplPlanner, MoveIt's OMPL planner manager: ompl_interface on our scene, IK and Ruckig timing.

solve.py knows OMPL and nothing of robots; this module turns a MotionPlanRequest into
its inputs (the group's joint box, the scene's validity checker, IK-sampled goal states for pose
goals) and its result back into a timed trajectory with MoveIt's error codes. As in MoveIt, the
planner stops at its first exact solution, the path is simplified (shortcutting, smoothing) and
interpolated to the validity-checking resolution, then timed. Before OMPL runs, the straight
motion to the nearest goals is timed and given to the trajectory validator (``_straight_motion``):
when it is valid it is the plan, the shortest there is, checked in full as every plan is.
"""
from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from interfaces_py.msgs import MoveItErrorCode

from mycobot_planning.paths import config_file
from .config import (
    CONTEXT_KEYS,
    SETTABLE_CONTEXT_KEYS,
    GroupConfig,
    OmplConfig,
    ResolvedPlanner,
    check_context,
    load_ompl_config,
    parse_projection_evaluator,
    resolve_planner_id,
)
from .planners import OmplConfigError, canonical_planner_type, validate_params
from .solve import OmplResult, plan_joint_space
from ...kinematic_constraints.constraint_manifold import ConstraintManifold
from ...kinematic_constraints.kinematic_constraints import CONSTRAINT_CHECK_STEP, dense_violation
from ...robot_state.robot_state import RobotState
from ...planning_interface.planning_interface import (
    MotionPlanRequest,
    MotionPlanResponse,
    PlanningFailure,
    JointGoal,
    NamedGoal,
    PoseGoal,
    check_group,
    check_path_constraints_at_ends,
    check_pose_goal,
    check_request_numbers,
    check_scaling,
    failure,
    goal_states,
    start_state_of,
    success,
    time_group_path,
)
from ...errors import TimeParameterizationError
from ...kinematics.ik_solver import thread_ik_solver
from ...planning_scene.planning_scene import PlanningScene
from ...robot_model.robot_model import JointModelGroup
from ...trajectory_processing.trajectory_validator import DEFAULT_RESOLUTION, halving_order, validate_trajectory

_STATUS_CODES = {
    "INVALID_START": MoveItErrorCode.START_STATE_IN_COLLISION,
    "INVALID_GOAL": MoveItErrorCode.GOAL_IN_COLLISION,
    "TIMEOUT": MoveItErrorCode.TIMED_OUT,
    "ABORT": MoveItErrorCode.PREEMPTED,
    "INFEASIBLE": MoveItErrorCode.PLANNING_FAILED,
    "CRASH": MoveItErrorCode.CRASH,
    "INVALID_PATH": MoveItErrorCode.INVALID_MOTION_PLAN,
}

#: Share of the planning time that IK for pose goals may use before OMPL starts.
IK_TIME_SHARE = 0.25

#: Re-plans (each with a 4x finer edge resolution) when the timed path collides between OMPL's
#: checks. OMPL checks edges at longest_valid_segment_fraction x the joint box diagonal (0.07 rad
#: for the myCobot at MoveIt's 0.005), which lets a gripper sweep through a 5 mm wall between two
#: checks; MoveIt has the same gap and closes it with its ValidateSolution adapter. Here the
#: trajectory validator does that job on the timed trajectory (what is executed), every
#: 0.005 rad, once: the response says so (``validated``), so callers need not check again.
MAX_REPLANS = 3


#: the request's pipeline_id of OMPL (MoveIt's)
OMPL_PIPELINE_ID = "ompl"


class OmplPlanner:
    """Plans with OMPL under a MoveIt-format ompl_planning.yaml (config/ompl_planning.yaml by
    default); MoveIt's OMPL PlannerManager (core.planning_interface.planner_manager)."""

    pipeline_id = OMPL_PIPELINE_ID
    description = "OMPL"
    enforces_path_constraints = True
    #: attempts are independent (attempt k seeded from the request's seed and first_attempt + k,
    #: the shortest path wins, ties to the earlier attempt): PlanningWorkers may split them
    independent_attempts = True

    def __init__(self, config: OmplConfig | str | Path | Mapping | None = None) -> None:
        if config is None:
            config = config_file("ompl_planning.yaml")
        self.config: OmplConfig = config if isinstance(config, OmplConfig) else load_ompl_config(config)

    # ------------------------------------------------------------------ PlannerManager
    def planner_ids(self, group: str = "") -> list[str]:
        """The group's planner configurations (every configuration for a group the YAML does not
        list, or for "")."""
        if group and group in self.config.groups:
            return list(self.config.groups[group].planner_configs)
        return sorted(self.config.planner_configs)

    def planner_id_problem(self, planner_id: str, groups: Sequence[str] = ()) -> str | None:
        if not planner_id:
            return None
        problems = []
        for group in list(groups) or list(self.config.groups) or ["arm"]:
            try:
                self.resolve(group, planner_id)
                return None
            except PlanningFailure as exc:
                problems.append(exc.message)
        if len(groups) == 1:
            return problems[0]
        known = sorted(self.config.planner_configs)
        return (f"'{planner_id}' is no OMPL planner configuration ({', '.join(known[:4])}"
                f"{', ...' if len(known) > 4 else ''})")

    def can_service_request(self, request: MotionPlanRequest) -> bool:
        if not isinstance(request.goal, (JointGoal, NamedGoal, PoseGoal)):
            return False
        return self.planner_id_problem(request.planner_id, [request.group]) is None

    def planner_params(self, planner_id: str, group: str = "") -> dict[str, str]:
        config = self.config.planner_configs.get(planner_id)
        if config is None:
            return {}
        params = {k: str(v) for k, v in config.params.items()}
        params["type"] = config.type
        return params

    def set_planner_params(self, planner_id: str, params: Mapping[str, str], replace: bool = False) -> str | None:
        """All or nothing: every key must be a parameter the configuration's planner type declares
        (planners.PLANNERS) or one of the context keys checked here (longest_valid_segment_fraction,
        projection_evaluator), every value of its type and range and finite; "type" may only
        repeat the configuration's type. None when applied, else why not (nothing changed)."""
        current = self.config
        config = current.planner_configs.get(planner_id)
        if config is None:
            return (f"unknown planner configuration {planner_id!r}; known: "
                    f"{', '.join(sorted(current.planner_configs))}")
        where = f"planner configuration {planner_id!r}"
        plain: dict[str, Any] = {}
        context: dict[str, Any] = {}
        for key, text in params.items():
            if key == "type":
                try:
                    same = canonical_planner_type(str(text)) == config.type
                except OmplConfigError:
                    same = False
                if not same:
                    return f"{where}: its type is {config.type}; 'type' cannot change it (got {text!r})"
            elif key in SETTABLE_CONTEXT_KEYS:
                context[key] = text
            elif key in CONTEXT_KEYS:
                return (f"{where}: {key!r} is a planning context setting that set_planner_params cannot change "
                        f"(settable: the planner's parameters, {', '.join(sorted(SETTABLE_CONTEXT_KEYS))})")
            else:
                plain[key] = text
        try:
            values = validate_params(config.type, plain, where)
            settings = check_context(where, context)
        except (OmplConfigError, ValueError) as exc:
            return str(exc)
        infinite = [k for k, v in values.items() if isinstance(v, float) and not math.isfinite(v)]
        if infinite:
            return f"{where}: parameter {infinite[0]!r} must be a finite number, got {params[infinite[0]]!r}"
        new = dataclasses.replace(config, params=values if replace else {**config.params, **values},
                                  context=settings if replace else {**config.context, **settings})
        self.config = dataclasses.replace(current, planner_configs={**current.planner_configs, planner_id: new})
        return None

    def resolve(self, group: str, planner_id: str) -> ResolvedPlanner:
        """The planner for a group; groups the YAML does not list (any URDF + SRDF robot) get every
        configured planner with RRTConnect as the default, as MoveIt's setup assistant would write."""
        config = self.config
        if group not in config.groups:
            names = tuple(config.planner_configs)
            default = "RRTConnectkConfigDefault" if "RRTConnectkConfigDefault" in names else None
            groups = dict(config.groups)
            groups[group] = GroupConfig(
                name=group,
                planner_configs=names,
                default_planner_config=default,
                longest_valid_segment_fraction=0.005,
                projection_evaluator=None,
            )
            config = OmplConfig(planner_configs=config.planner_configs, groups=groups, pipeline=config.pipeline)
        try:
            return resolve_planner_id(config, group, planner_id)
        except OmplConfigError as exc:
            raise failure(MoveItErrorCode.INVALID_MOTION_PLAN, str(exc)) from None

    @staticmethod
    def _projection_dims(jmg: JointModelGroup, resolved: ResolvedPlanner) -> list[int] | None:
        if not resolved.projection_evaluator:
            return None
        kind, names = parse_projection_evaluator(resolved.projection_evaluator)
        if kind != "joints":
            return None
        dims = [jmg.joint_names.index(n) for n in names if n in jmg.joint_names]
        return dims or None

    def plan(self, scene: PlanningScene, request: MotionPlanRequest) -> MotionPlanResponse:
        """Plan the request; never raises for bad input (the error code says what was wrong)."""
        started = time.perf_counter()
        try:
            return self._plan(scene, request, started)
        except PlanningFailure as exc:
            return exc.to_response(started, request)

    def _plan(self, scene: PlanningScene, request: MotionPlanRequest, started: float) -> MotionPlanResponse:
        model = scene.robot_model
        check_request_numbers(request)
        jmg = check_group(model, request.group)
        velocity_scaling, acceleration_scaling = check_scaling(model, request)
        resolved = self.resolve(jmg.name, request.planner_id)
        start = start_state_of(scene, request)
        rng = np.random.default_rng(request.seed)
        budget = float(request.allowed_planning_time)
        ik_time = budget * IK_TIME_SHARE if isinstance(request.goal, PoseGoal) else 0.0
        if request.path_constraints:  # the start first, before sampling goals (as check_path_constraints_at_ends)
            problem = request.path_constraints.violation(start)
            if problem:
                raise failure(MoveItErrorCode.START_STATE_VIOLATES_PATH_CONSTRAINTS,
                              f"the start state violates the path constraints: {problem}")
        if request.path_constraints and isinstance(request.goal, PoseGoal):
            goals = _constrained_pose_goals(scene, jmg, start, request.goal, max(1, request.num_ik_goals),
                                            max(ik_time, 1e-3), rng, request.path_constraints)
        else:
            goals = goal_states(scene, jmg, start, request.goal, max(1, request.num_ik_goals), max(ik_time, 1e-3), rng)
        goals = check_path_constraints_at_ends(request, start, goals)
        start_vector = start.group_positions(jmg.name)
        goal_vectors = [g.group_positions(jmg.name) for g in goals]
        lower = model.lower_limits[jmg.variable_indices]
        upper = model.upper_limits[jmg.variable_indices]
        lower = np.where(np.isfinite(lower), lower, -math.pi)
        upper = np.where(np.isfinite(upper), upper, math.pi)
        constraints = request.path_constraints
        manifold = None
        if constraints:
            manifold = ConstraintManifold(constraints, start, jmg.name, [start, *goals])
            if not manifold or manifold.codim >= jmg.variable_count:
                manifold = None  # nothing to project onto (or no freedom left): rejection only
        # OMPL samples and interpolates inside its bounds; projecting onto a constraint manifold
        # does not, so constrained states are checked against the joint limits too
        # the batch sphere test judges collisions only: not with path constraints (or bounds) to keep
        batch_free = None if manifold is not None or constraints else scene.batch_free_checker(jmg.name, start)
        # with it, the states checked one by one are mostly those it left undecided: no one-state
        # sphere test before the exact check (measured: 7.8 ms a myCobot plan_ompl plan with it
        # off, 8.0 ms on; 12.3 ms without any batch test; CPU time, docs/core.md)
        validity = scene.validity_checker(jmg.name, start, check_bounds=manifold is not None,
                                          sphere_pretest=batch_free is None)
        if constraints:
            validity = _constrained(validity, constraints.for_planning([start, *goals]), start, jmg)

        best = None
        last = None
        attempts = request.num_planning_attempts
        fraction = resolved.longest_valid_segment_fraction
        replans = 0
        attempt = 0
        straight_free = not constraints  # the straight motion may be the answer; tried per attempt
        while attempt < attempts:
            remaining = budget - (time.perf_counter() - started)
            if remaining <= 0 or (request.cancel is not None and request.cancel.is_set()):
                break
            seed = None if request.seed is None else \
                int(request.seed) + 1 + request.first_attempt + attempt + 1000 * replans
            if straight_free:
                straight = _straight_motion(scene, jmg, start, start_vector, goal_vectors, lower, upper, fraction,
                                            velocity_scaling, acceleration_scaling, resolved.type)
                if straight is None:
                    straight_free = False  # blocked, as it will be on every attempt
                else:
                    result, trajectory, _ = straight  # validated already
                    last = result
                    if best is None or _length(result.path) < _length(best[0].path):
                        best = (result, trajectory)
                    attempt += 1
                    continue
            result = plan_joint_space(
                lower,
                upper,
                validity,
                start_vector,
                goal_vectors,
                planner_type=resolved.type,
                planner_params=resolved.params,
                timeout=remaining / (attempts - attempt),
                longest_valid_segment_fraction=fraction,
                simplify=True,
                interpolate_states=0,
                seed=seed,
                projection_dims=self._projection_dims(jmg, resolved),
                stop_on_first_solution=True,
                cancel=request.cancel,
                manifold=manifold,
                manifold_delta=_manifold_delta(lower, upper, fraction) if manifold is not None else None,
                try_direct=bool(constraints),  # without constraints _straight_motion has tried (finer)
                batch_free=batch_free,
            )
            last = result
            if result.status == "ABORT":
                break
            trajectory = None
            if result.success and manifold is not None:
                try:  # a path walked along a manifold can have corners the timing cannot take
                    trajectory = time_group_path(model, jmg, result.path, velocity_scaling, acceleration_scaling)
                except TimeParameterizationError as exc:
                    result.success, result.status = False, "INVALID_PATH"
                    result.message = f"the path found cannot be timed: {exc}"
                    if replans < MAX_REPLANS:
                        replans += 1
                        continue
            if result.success:
                if trajectory is None:
                    # A straight motion is timed from its ends: the same motion as through its
                    # interpolated states (collinear, so no corner), a sixth of the timing work.
                    timed = result.path[[0, -1]] if result.direct else result.path
                    trajectory = time_group_path(model, jmg, timed, velocity_scaling, acceleration_scaling)
                # The plan's own check at the validator's resolution, on the scene's checker
                # (proved equal to the plain check; the plain one costs ~10x: docs/ompl.md).
                report = validate_trajectory(scene, trajectory, jmg.name, start, all_pairs=False)
                broken = None
                if constraints and report.valid:  # the path, and the timed trajectory that follows it
                    broken = _path_violation(constraints, start, jmg, result.path) or \
                        _path_violation(constraints, start, jmg, trajectory.positions)
                if broken is not None:
                    result.success, result.status = False, "INVALID_PATH"
                    result.message = f"every path found left the path constraints between checks: {broken}"
                    if replans < MAX_REPLANS:  # a segment leaves the constraints between checks: finer
                        replans += 1
                        fraction /= 4.0
                        continue
                elif not report.valid:
                    result.success, result.status = False, "INVALID_PATH"
                    result.message = ("every path found crossed an obstacle between collision checks"
                                      if report.contacts else "; ".join(report.problems[:2]))
                    if report.contacts and replans < MAX_REPLANS:
                        # An edge passes through an obstacle between OMPL's checks: plan again, finer.
                        replans += 1
                        fraction /= 4.0
                        continue
            if result.success and (best is None or _length(result.path) < _length(best[0].path)):
                best = (result, trajectory)
            attempt += 1
        if request.cancel is not None and request.cancel.is_set():  # preempted: no partial answers
            raise failure(MoveItErrorCode.PREEMPTED, f"planning for group '{jmg.name}' was cancelled (stop requested)")
        if best is None:
            status = last.status if last is not None else "TIMEOUT"
            code = _STATUS_CODES.get(status, MoveItErrorCode.PLANNING_FAILED)
            detail = f" ({last.message})" if last is not None and last.message else ""
            raise failure(
                code,
                f"{resolved.config_name} found no path for group '{jmg.name}' in "
                f"{budget:.3g} s: {status}{detail}",
            )
        best_result, trajectory = best
        response = success(
            trajectory,
            started,
            request,
            start,
            path=best_result.path,
            message=f"{resolved.config_name}: {len(best_result.path)} waypoints, {trajectory.duration:.3f} s",
            validated=True,
        )
        response.planner_id = f"{jmg.name}[{resolved.config_name}]"
        return response


#: Goals (nearest first) whose straight motion from the start is tried before OMPL.
STRAIGHT_GOALS = 3
#: States of the straight line (at the validator's resolution, coarse to fine) checked before
#: the motion is timed and validated: most blocked lines are caught here for a few checks
#: instead of the timing and the validator's sampling (about 0.9 ms on the myCobot).
STRAIGHT_SCREEN = 16


def _straight_motion(scene: PlanningScene, jmg: JointModelGroup, start: RobotState, start_vector: np.ndarray,
                     goal_vectors: list[np.ndarray], lower: np.ndarray, upper: np.ndarray, fraction: float,
                     velocity_scaling: float, acceleration_scaling: float, planner_type: str):
    """(result, trajectory, report) for the straight motion from the start to one of the nearest
    goals when it is valid, else None.

    The candidate is timed from its two ends (one profile from rest to rest) and checked by the
    trajectory validator itself, coarse to fine, stopping at the first collision: a blocked
    motion is rejected after a few states, and a free one has had the same full check every
    plan gets (every 0.005 rad of the timed trajectory), so nothing is checked twice and no
    tree, simplification or second check is needed. The path reported is the line interpolated
    at OMPL's checking resolution, as an OMPL path would be."""
    started = time.perf_counter()
    model = scene.robot_model
    resolution = fraction * float(np.linalg.norm(upper - lower))
    nearest = sorted(range(len(goal_vectors)), key=lambda i: float(np.linalg.norm(goal_vectors[i] - start_vector)))
    for i in nearest[:STRAIGHT_GOALS]:
        goal = np.asarray(goal_vectors[i], dtype=float)
        travel = float(np.max(np.abs(goal - start_vector)))
        if travel <= 1e-12:
            continue  # nothing to move: plan_joint_space answers that
        count = int(math.ceil(travel / DEFAULT_RESOLUTION)) + 1
        screen = halving_order(count)[:STRAIGHT_SCREEN] / (count - 1)
        if scene.colliding_rows(jmg.name, start, start_vector + screen[:, None] * (goal - start_vector),
                                stop_at_first=True).any():
            continue
        try:
            trajectory = time_group_path(model, jmg, np.array([start_vector, goal]), velocity_scaling,
                                         acceleration_scaling)
        except TimeParameterizationError:
            continue
        report = validate_trajectory(scene, trajectory, jmg.name, start, first_collision=True, all_pairs=False)
        if not report.valid:
            continue
        segments = max(1, int(math.ceil(float(np.linalg.norm(goal - start_vector)) / resolution)))
        path = start_vector + np.linspace(0.0, 1.0, segments + 1)[:, None] * (goal - start_vector)
        path[-1] = goal
        result = OmplResult(success=True, status="EXACT_SOLUTION", path=path,
                            planning_time=time.perf_counter() - started, simplify_time=0.0, planner=planner_type,
                            goal_index=i, validity_checks=report.checked_states,
                            message="the straight motion to the goal is valid", direct=True)
        return result, trajectory, report
    return None


def _constrained_pose_goals(scene: PlanningScene, jmg: JointModelGroup, start: RobotState, goal: PoseGoal,
                           max_states: int, timeout: float, rng: np.random.Generator, constraints: Any
                           ) -> list[RobotState]:
    """IK goal states for a pose goal that also satisfy the path constraints (MoveIt's goal
    sampler rejects the IK solutions its path-constrained validity check refuses, and samples
    again), nearest to the start first."""
    model = scene.robot_model
    link, pose = check_pose_goal(model, jmg, goal)
    solver = thread_ik_solver(model, jmg.name, link, goal.ik_frame_offset)
    attempts = solver.options.seed_neighbours + 8 * max_states + 16
    solutions = solver.solve(pose, seed=start, timeout=timeout, max_solutions=max_states, min_solution_distance=0.1,
                             rng=rng, attempts=attempts,
                             validity=lambda state: scene.is_state_valid(state) and constraints.satisfied(state))
    if not solutions:
        # say why: no IK at all, only colliding ones, or only ones breaking the constraints
        goal_states(scene, jmg, start, goal, max_states, timeout, rng)  # raises NO_IK_SOLUTION / GOAL_IN_COLLISION
        raise failure(MoveItErrorCode.GOAL_VIOLATES_PATH_CONSTRAINTS,
                      f"no IK solution for the pose goal of '{link}' satisfies the path constraints "
                      f"({constraints.describe()})")
    start_group = start.group_positions(jmg.name)
    solutions.sort(key=lambda s: float(np.sum(np.abs(s.group_positions(jmg.name) - start_group))))
    return solutions


#: rad: OMPL's ProjectedStateSpace default step along the constraint manifold (its delta)
MANIFOLD_DELTA = 0.05


def _manifold_delta(lower: np.ndarray, upper: np.ndarray, fraction: float) -> float:
    """The step along the constraint manifold: OMPL's default, or finer when the edge
    resolution (longest_valid_segment_fraction x the box diagonal) is, as after a re-plan."""
    return min(MANIFOLD_DELTA, fraction * float(np.linalg.norm(upper - lower)))


def _constrained(validity: Any, constraints: Any, start: RobotState, jmg: Any) -> Any:
    """The scene's validity check plus the path constraints (MoveIt's OMPL interface rejects
    states that break them the same way)."""
    state = start.copy()
    index = np.asarray(jmg.variable_indices)
    q = state.positions.copy()

    def check(values: np.ndarray) -> bool:
        if not validity(values):
            return False
        q[index] = values
        state.set_positions(q)
        return constraints.satisfied(state)

    return check


def _path_violation(constraints: Any, start: RobotState, jmg: Any, path: np.ndarray) -> str | None:
    """Why the straight segments of ``path`` leave the constraints somewhere (checked every
    CONSTRAINT_CHECK_STEP), or None."""
    found = dense_violation(constraints, start, jmg.joint_names, path, CONSTRAINT_CHECK_STEP)
    return None if found is None else found[2]


def _length(path: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1))) if len(path) > 1 else 0.0
