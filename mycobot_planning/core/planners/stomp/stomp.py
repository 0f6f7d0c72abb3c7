"""MoveIt's STOMP planner (stomp_moveit/StompPlanner) as a core planner: pipeline_id "stomp".

Stochastic Trajectory Optimization for Motion Planning: start from the straight joint-space
line of ``num_timesteps`` waypoints, and in every iteration perturb it ``num_rollouts`` times
with smooth noise (drawn from the inverse of the finite-difference acceleration matrix), cost
every waypoint of every rollout (collisions from the scene's batch check, path constraints,
control cost), weight the noise per timestep by its exponentiated cost and move the path by the
weighted noise, smoothed by the same matrix and clipped to the joint limits. It stops when the
path is valid and ``num_iterations_after_valid`` more iterations are done, after
``num_iterations``, or when ``allowed_planning_time`` runs out (TIMED_OUT, as MoveIt).

The full story: docs/core.md, section mycobot_planning.core.planners.stomp.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable, ClassVar, Mapping, Sequence

import numpy as np

from ...kinematic_constraints.constraint_manifold import ConstraintManifold
from ...kinematic_constraints.kinematic_constraints import NEARLY_FREE, XYZ_EULER_ANGLES
from ...planning_interface.planning_interface import (
    MotionPlanRequest,
    MotionPlanResponse,
    polyline_problem,
    timed_and_validated,
)
from ...planning_scene.planning_scene import PlanningScene
from ...robot_state.robot_state import RobotState
from .. import trajectory_optimization as optimization

__all__ = ["DEFAULT_PARAMS", "PLANNER_ID", "STOMP_PIPELINE_ID", "StompParams", "StompPlanner", "plan_stomp"]

#: the request's pipeline_id of STOMP (MoveIt's stomp_planning.yaml)
STOMP_PIPELINE_ID = "stomp"
#: the planner id MoveIt's plugin lists (its algorithm list is {"STOMP"}); "stomp" is accepted too
PLANNER_ID = "STOMP"

#: rad: MoveIt's stomp_moveit noise, normal with this standard deviation for every joint (hard-coded there)
NOISE_STDDEV = 0.1
#: rad (L2): spacing of the states checked between waypoints for the collision cost (MoveIt's 0.05)
COLLISION_CHECK_STEP = 0.05
#: at most this many checked states per waypoint segment for the cost (the final path is checked densely)
MAX_SUBSTEPS = 12
#: the cost of a colliding waypoint and of one breaking the path constraints (MoveIt's penalty 1.0)
COLLISION_PENALTY = 1.0
CONSTRAINT_PENALTY = 1.0


@dataclass(frozen=True)
class StompParams(optimization.OptimizerParams):
    """MoveIt's ``stomp_moveit`` parameters (res/stomp_moveit.yaml defaults)."""

    num_timesteps: int = 40
    num_iterations: int = 1000
    num_iterations_after_valid: int = 0
    num_rollouts: int = 15
    max_rollouts: int = 25
    exponentiated_cost_sensitivity: float = 0.5
    control_cost_weight: float = 0.1
    delta_t: float = 0.1

    PLANNER: ClassVar[str] = "STOMP"

    def range_problem(self) -> str | None:
        """Why these values are out of range (None: they are not)."""
        if self.num_timesteps < 3:
            return f"STOMP parameter num_timesteps must be >= 3, got {self.num_timesteps}"
        if self.num_iterations < 1:
            return f"STOMP parameter num_iterations must be >= 1, got {self.num_iterations}"
        if self.num_iterations_after_valid < 0:
            return f"STOMP parameter num_iterations_after_valid must be >= 0, got {self.num_iterations_after_valid}"
        if self.num_rollouts < 1:
            return f"STOMP parameter num_rollouts must be >= 1, got {self.num_rollouts}"
        if self.max_rollouts < self.num_rollouts:
            return (f"STOMP parameter max_rollouts must be >= num_rollouts ({self.num_rollouts}), "
                    f"got {self.max_rollouts}")
        if self.exponentiated_cost_sensitivity < 0:
            return (f"STOMP parameter exponentiated_cost_sensitivity must be >= 0, "
                    f"got {self.exponentiated_cost_sensitivity:g}")
        if self.control_cost_weight < 0:
            return f"STOMP parameter control_cost_weight must be >= 0, got {self.control_cost_weight:g}"
        if self.delta_t <= 0:
            return f"STOMP parameter delta_t must be > 0, got {self.delta_t:g}"
        return None


DEFAULT_PARAMS = StompParams()


def parse_params(base: StompParams, params: Mapping[str, Any], replace_all: bool = False) -> StompParams | str:
    """``base`` with ``params`` (strings or numbers) applied, checked; a message when refused."""
    return optimization.parse_params(DEFAULT_PARAMS, base, params, replace_all)


# ---------------------------------------------------------------------------- the matrices
def _finite_difference_matrices(free: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For the ``free`` interior waypoints: R = AᵀA of the acceleration matrix A (tridiagonal
    1, -2, 1), normalised to max 1; the Cholesky factor of R⁻¹ normalised to max 1 (the noise
    covariance); and STOMP's smoothing matrix M (R⁻¹ with each column scaled to max 1/free)."""
    a = -2.0 * np.eye(free) + np.eye(free, k=1) + np.eye(free, k=-1)
    r = a.T @ a
    r_inv = np.linalg.inv(r)
    covariance = r_inv / np.max(r_inv)
    chol = np.linalg.cholesky(covariance + 1e-12 * np.eye(free))
    smoothing = r_inv / (np.max(r_inv, axis=0, keepdims=True) * free)
    return r / np.max(r), chol, smoothing


def _gaussian_windows(invalid: np.ndarray) -> np.ndarray:
    """Binary per-waypoint costs (rows: rollouts) with each run of invalid waypoints spread by a
    Gaussian of sigma max(1, run length / 2) around its centre (MoveIt's stomp_moveit cost
    smoothing): a rollout that collides in fewer waypoints near the obstacle costs less."""
    out = invalid.astype(float)
    count = invalid.shape[1]
    t = np.arange(count, dtype=float)
    for k in np.flatnonzero(invalid.any(axis=1)):
        row = invalid[k].astype(np.int8)
        edges = np.diff(np.concatenate(([0], row, [0])))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        for s, e in zip(starts, ends):
            centre, sigma = (s + e - 1) / 2.0, max(1.0, (e - s) / 2.0)
            out[k] = np.maximum(out[k], np.exp(-0.5 * ((t - centre) / sigma) ** 2))
    return out


def _manifold_covers(constraints: Any) -> bool:
    """Whether ConstraintManifold holds every one of ``constraints`` (single-region positions,
    orientation axes either bounded on the manifold or free over every error there is)."""
    if any(len(c.regions) != 1 for c in constraints.positions):
        return False
    for c in constraints.orientations:
        euler = c.parameterization == XYZ_EULER_ANGLES
        largest = np.array([math.pi, math.pi / 2 if euler else math.pi, math.pi])
        for tolerance, top in zip(c.tolerances, largest):
            if top - NEARLY_FREE <= tolerance < top:
                return False  # a band near the wrap-around the manifold leaves to the exact check
    return True


class _Costs:
    """Per-waypoint state costs of many paths at once (collision + path constraints)."""

    def __init__(self, scene: PlanningScene, group: str, start: RobotState, constraints: Any,
                 references: Sequence[RobotState]) -> None:
        self.scene = scene
        self.group = group
        self.start = start
        self.constraints = constraints if constraints else None
        self.manifold = None
        if self.constraints is not None:
            manifold = ConstraintManifold(self.constraints.for_planning(references), start, group, references)
            self.manifold = manifold if manifold else None
        #: the manifold holds every constraint (its bounds are inside the constraints' own): a
        #: state with no excess over them satisfies the constraints, and needs no exact check
        self.covered = self.manifold is not None and _manifold_covers(self.constraints)
        self.indices = np.asarray(scene.robot_model.group(group).variable_indices)
        self._state = start.copy()
        self._q = start.positions.copy()

    def collisions(self, paths: np.ndarray) -> np.ndarray:
        """(B, N) bool: waypoint t of path b is, or touches a segment that is, in collision
        (states checked every COLLISION_CHECK_STEP along the segments, at most MAX_SUBSTEPS each)."""
        count, steps, dim = paths.shape
        segments = paths[:, 1:] - paths[:, :-1]
        longest = float(np.max(np.linalg.norm(segments, axis=2))) if steps > 1 else 0.0
        sub = int(min(MAX_SUBSTEPS, max(1, math.ceil(longest / COLLISION_CHECK_STEP))))
        fractions = np.arange(1, sub + 1) / sub
        states = paths[:, :-1, None, :] + fractions[None, None, :, None] * segments[:, :, None, :]
        hit = self.scene.colliding_rows(self.group, self.start, states.reshape(-1, dim))
        segment_hit = hit.reshape(count, steps - 1, sub).any(axis=2)
        out = np.zeros((count, steps), dtype=bool)
        out[:, 1:] |= segment_hit
        out[:, :-1] |= segment_hit
        return out

    def constraint_costs(self, paths: np.ndarray, exact: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """(cost, violated) per waypoint: 1 per state that breaks the path constraints plus how
        far it is outside them (the constraint manifold's excess: radians and metres). Not
        ``exact`` (rollouts' costs) and with a manifold holding every constraint, a state with
        an excess over the manifold's bounds (a little inside the constraints') counts as
        breaking them, without the exact check."""
        count, steps, dim = paths.shape
        violated = np.zeros((count, steps), dtype=bool)
        if self.constraints is None:
            return np.zeros((count, steps)), violated
        excess = np.zeros((count, steps))
        if self.manifold is not None:
            excess = np.abs(self.manifold.values_many(paths.reshape(-1, dim))).sum(axis=1).reshape(count, steps)
        if self.covered and not exact:
            violated = excess > 0.0
            return excess + CONSTRAINT_PENALTY * violated, violated
        state, q = self._state, self._q
        for b, t in zip(*np.nonzero((excess > 0.0) | (not self.covered))):
            q[self.indices] = paths[b, t]
            state.set_positions(q)
            violated[b, t] = not self.constraints.satisfied(state)
        return excess + CONSTRAINT_PENALTY * violated, violated

    def state_costs(self, paths: np.ndarray, exact: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """(costs, invalid) per waypoint of each path (``exact``: see constraint_costs)."""
        colliding = self.collisions(paths)
        cost, violated = self.constraint_costs(paths, exact)
        return COLLISION_PENALTY * _gaussian_windows(colliding) + cost, colliding | violated

    def dense_problem(self, path: np.ndarray) -> str | None:
        """Why the polyline ``path`` is not valid, checked densely (planning_interface.polyline_problem)."""
        return polyline_problem(self.scene, self.group, self.start, path, self.constraints)


# ---------------------------------------------------------------------------- the optimisation
@dataclass
class StompResult:
    path: np.ndarray | None
    iterations: int
    status: str  # "VALID", "TIMEOUT", "MAX_ITERATIONS", "PREEMPTED"
    message: str = ""
    accepted: Any = None  # what ``accept`` returned for ``path``


def optimize(costs: _Costs, start: np.ndarray, goal: np.ndarray, lower: np.ndarray, upper: np.ndarray,
             params: StompParams, rng: np.random.Generator, deadline: float, cancel: Any = None,
             accept: Callable[[np.ndarray], tuple[Any, str | None]] | None = None) -> StompResult:
    """STOMP from the straight line ``start`` -> ``goal``; the last valid path found (densely
    checked, and accepted by ``accept``: (what to keep, None) or (None, why not), e.g. the timed
    trajectory and its validation) or None with why not."""
    n_steps = params.num_timesteps
    free = n_steps - 2
    dim = start.size
    fractions = np.linspace(0.0, 1.0, n_steps)
    theta = start + fractions[:, None] * (goal - start)  # (N, d), ends fixed
    theta[-1] = goal
    _, chol, smoothing = _finite_difference_matrices(free)
    acc_scale = params.control_cost_weight * 0.5 / params.delta_t
    h = params.exponentiated_cost_sensitivity
    reuse = params.max_rollouts - params.num_rollouts
    kept_paths = np.empty((0, n_steps, dim))
    kept_costs = np.empty((0, free))
    best_valid: np.ndarray | None = None
    kept: Any = None
    rejected = ""
    valid_iterations = 0
    iteration = 0

    def control_costs(paths: np.ndarray) -> np.ndarray:
        acc = paths[:, :-2] - 2.0 * paths[:, 1:-1] + paths[:, 2:]  # (B, free, d)
        return acc_scale * np.sum(acc * acc, axis=2) / 6.0  # 6: max of AᵀA (R normalised to max 1)

    def check(path: np.ndarray) -> bool:
        nonlocal kept, rejected
        _, invalid = costs.state_costs(path[None])
        if invalid.any() or costs.dense_problem(path) is not None:
            return False
        if accept is None:
            return True
        result, problem = accept(path)
        if result is None:
            rejected = f"; the last path valid at its waypoints was refused: {problem}"
            return False
        kept = result
        return True

    if check(theta):
        best_valid = theta.copy()
        if params.num_iterations_after_valid == 0:
            return StompResult(best_valid, 0, "VALID", "the straight line is valid", kept)
    while iteration < params.num_iterations:
        if cancel is not None and cancel.is_set():
            return StompResult(None, iteration, "PREEMPTED", "cancelled")
        if time.perf_counter() > deadline:
            if best_valid is not None:
                return StompResult(best_valid, iteration, "VALID", "time ran out after a valid path", kept)
            return StompResult(None, iteration, "TIMEOUT", f"no valid path after {iteration} iterations{rejected}")
        iteration += 1
        # new rollouts: smooth noise around the interior of the path, within the joint limits
        z = rng.standard_normal((params.num_rollouts, free, dim))
        noise = NOISE_STDDEV * np.einsum("ij,kjd->kid", chol, z)
        paths = np.repeat(theta[None], params.num_rollouts, axis=0)
        paths[:, 1:-1] = np.clip(theta[1:-1] + noise, lower, upper)
        state_cost, _ = costs.state_costs(paths, exact=False)
        total = state_cost[:, 1:-1] + control_costs(paths)
        # the best rollouts of the last iteration are used again (their costs do not change)
        all_paths = np.concatenate([paths, kept_paths]) if len(kept_paths) else paths
        all_costs = np.concatenate([total, kept_costs]) if len(kept_costs) else total
        all_noise = all_paths[:, 1:-1] - theta[1:-1]
        # exponentiated cost per timestep, normalised over rollouts
        low = all_costs.min(axis=0)
        span = all_costs.max(axis=0) - low
        scaled = np.where(span > 1e-12, (all_costs - low) / np.where(span > 1e-12, span, 1.0), 0.0)
        weights = np.exp(-h * scaled)
        weights /= weights.sum(axis=0, keepdims=True)
        update = smoothing @ np.einsum("kt,ktd->td", weights, all_noise)
        theta[1:-1] = np.clip(theta[1:-1] + update, lower, upper)
        if reuse > 0:
            order = np.argsort(all_costs.sum(axis=1), kind="stable")[:reuse]
            kept_paths, kept_costs = all_paths[order], all_costs[order]
        if check(theta):
            best_valid = theta.copy()
            if valid_iterations >= params.num_iterations_after_valid:
                return StompResult(best_valid, iteration, "VALID", f"valid after {iteration} iterations", kept)
            valid_iterations += 1
        elif best_valid is not None:
            valid_iterations += 1
            if valid_iterations > params.num_iterations_after_valid:
                return StompResult(best_valid, iteration, "VALID", f"valid after {iteration} iterations", kept)
    if best_valid is not None:
        return StompResult(best_valid, iteration, "VALID", f"valid after {iteration} iterations", kept)
    return StompResult(None, iteration, "MAX_ITERATIONS",
                       f"no valid path in num_iterations = {iteration}{rejected}")


# ---------------------------------------------------------------------------- the planner
def plan_stomp(scene: PlanningScene, request: MotionPlanRequest, params: StompParams = DEFAULT_PARAMS
               ) -> MotionPlanResponse:
    """Plan ``request`` with STOMP. Never raises for bad input: the response's MoveItErrorCode says
    what was wrong (MoveIt's codes; TIMED_OUT when allowed_planning_time ran out, PLANNING_FAILED
    after num_iterations, INVALID_MOTION_PLAN when the timed path fails validation)."""
    return optimization.planned(PLANNER_ID, _plan, scene, request, params)


def _plan(scene: PlanningScene, request: MotionPlanRequest, params: StompParams, started: float
          ) -> MotionPlanResponse:
    problem = optimization.prepare_problem(scene, request, params)
    jmg, start, constraints = problem.jmg, problem.start, request.path_constraints
    goal_state = problem.goals[0]  # the nearest valid goal state (IK solutions sorted by distance)
    start_vector = start.group_positions(jmg.name)
    goal_vector = goal_state.group_positions(jmg.name)
    costs = _Costs(scene, jmg.name, start, constraints, [start, goal_state])

    def timed(path: np.ndarray) -> tuple[Any, str | None]:
        return timed_and_validated(scene, jmg, start, path, constraints, problem.velocity_scaling,
                                   problem.acceleration_scaling)

    result = optimize(costs, start_vector, goal_vector, problem.lower, problem.upper, params, problem.rng,
                      started + problem.budget, request.cancel, accept=timed)
    # MoveIt's STOMP answers with planner_id "stomp"
    return optimization.optimized_response(result, problem, PLANNER_ID, STOMP_PIPELINE_ID, started, request)


class StompPlanner(optimization.TrajectoryOptimizationPlanner[StompParams]):
    """The ``stomp`` pipeline as a PlannerManager (core.planning_interface.planner_manager)."""

    pipeline_id = STOMP_PIPELINE_ID
    description = "STOMP"
    #: path constraints are a cost, and the final path is checked against them densely
    enforces_path_constraints = True
    planner_id = PLANNER_ID
    default_params = DEFAULT_PARAMS

    def plan(self, scene: PlanningScene, request: MotionPlanRequest) -> MotionPlanResponse:
        return plan_stomp(scene, request, self.params)
