"""MoveIt's CHOMP planner (chomp_interface/CHOMPPlanner) as a core planner: pipeline_id "chomp".

Covariant Hamiltonian Optimization for Motion Planning: a path of 101 waypoints (MoveIt's 3 s at
0.03 s) from the start to the goal, initialised by a quintic (minimum-jerk) spline, is improved
by covariant gradient descent. The smoothness cost is the sum of squared finite differences
(velocity, acceleration, jerk rules of 7 points, MoveIt's weights) of each joint's path, a
quadratic form A; the obstacle cost is CHOMP's potential of each collision sphere of the moving
links (core.collision_distance_field) in the signed distance field of the world objects,
weighted by the sphere's workspace speed. Each iteration: forward kinematics of every
waypoint, the potential and its workspace gradient (projected orthogonal to the sphere's motion,
with the curvature term) pulled back through the sphere's Jacobian, the step A⁻¹(smoothness +
obstacle gradient) times the learning rate, limited per joint to joint_update_limit, and joint
limits restored along A⁻¹'s columns. All of it a few NumPy array operations.

A path counts as found only once the exact checks pass it: densely checked for collisions,
timed by the shared time parameterisation and passed by the trajectory validator
(planning_interface.timed_and_validated, as STOMP). The checks run when the obstacle cost falls
below collision_threshold or no sphere penetrates the world, and every 10 iterations (MoveIt's
mesh-to-mesh check); then max_iterations_after_collision_free more iterations run and the
valid path of lowest cost is returned. Without one after max_iterations (or planning_time_limit):
PLANNING_FAILED, after the recovery attempts MoveIt makes when enable_failure_recovery is set;
when allowed_planning_time runs out: TIMED_OUT.

The full story: docs/core.md, section mycobot_planning.core.planners.chomp.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Any, Callable, ClassVar, Mapping, Sequence

import numpy as np
import pinocchio as pin

from interfaces_py.msgs import MoveItErrorCode

from ...collision_distance_field.body_decomposition import (
    BodySpheres,
    group_spheres,
    moving_joints,
    spheres_of_bodies,
)
from ...collision_distance_field.distance_field import WorldDistanceField
from ...planning_interface.planning_interface import (
    MotionPlanRequest,
    MotionPlanResponse,
    failure,
    polyline_problem,
    timed_and_validated,
)
from ...planning_scene.planning_scene import PlanningScene
from ...robot_model.robot_model import RobotModel, group_configuration
from ...robot_state.robot_state import RobotState
from .. import trajectory_optimization as optimization

__all__ = ["CHOMP_PIPELINE_ID", "ChompParams", "ChompPlanner", "DEFAULT_PARAMS", "INITIALIZATION_METHODS",
           "PLANNER_ID", "plan_chomp"]

#: the request's pipeline_id of CHOMP (MoveIt's chomp_planning.yaml)
CHOMP_PIPELINE_ID = "chomp"
#: the planner id MoveIt's plugin lists (getPlanningAlgorithms: {"CHOMP"}); "chomp" is accepted too
PLANNER_ID = "CHOMP"
#: MoveIt's ChompParameters::VALID_INITIALIZATION_METHODS
INITIALIZATION_METHODS = ("quintic-spline", "linear", "cubic", "fillTrajectory")

#: MoveIt's ChompTrajectory(model, 3.0, 0.03, group): 101 waypoints 0.03 s apart
TRAJECTORY_DURATION = 3.0
DISCRETIZATION = 0.03
#: MoveIt's chomp_utils DIFF_RULES: velocity, acceleration and jerk over 7 points
DIFF_RULE_LENGTH = 7
DIFF_RULES = np.array([
    [0, 0, -2 / 6.0, -3 / 6.0, 6 / 6.0, -1 / 6.0, 0],
    [0, -1 / 12.0, 16 / 12.0, -30 / 12.0, 16 / 12.0, -1 / 12.0, 0],
    [0, 1 / 12.0, -17 / 12.0, 46 / 12.0, -46 / 12.0, 17 / 12.0, -1 / 12.0],
])
#: MoveIt's exact (mesh-to-mesh) check every this many iterations
EXACT_CHECK_EVERY = 10
#: and every this many iterations while no sphere penetrates the world (between waypoints it may)
CLEAR_CHECK_EVERY = 3
#: spheres whose potential is below this add nothing to the gradient (MoveIt's 0.0001)
MIN_POTENTIAL = 1e-4
#: what enable_failure_recovery adds per attempt (MoveIt's ChompPlanner::solve)
RECOVERY_LEARNING_RATE = 0.02
RECOVERY_RIDGE_FACTOR = 0.002
RECOVERY_TIME = 5.0
RECOVERY_ITERATIONS = 50


@dataclass(frozen=True)
class ChompParams(optimization.OptimizerParams):
    """MoveIt's CHOMP parameters, with CHOMPInterface::loadParams' defaults (those of moveit_resources'
    panda chomp_planning.yaml) but one: ``use_stochastic_descent`` is False here (MoveIt: True).
    MoveIt's stochastic descent takes the obstacle gradient of one random waypoint per iteration,
    saving the per-waypoint gradient work of its C++ loop; here the gradient of every waypoint is
    the same few array operations, and one waypoint per iteration rarely clears an obstacle
    within max_iterations on the myCobot's short links (measured: 0 of 5 seeds around the test
    box, against 5 of 5 in 0.3 s with the full gradient). moveit_configs_utils' default
    chomp_planning.yaml sets ridge_factor 0.01 and enable_failure_recovery true; the ridge pulls
    every waypoint towards zero, so it stays 0 here as in loadParams."""

    planning_time_limit: float = 10.0
    max_iterations: int = 200
    max_iterations_after_collision_free: int = 5
    smoothness_cost_weight: float = 0.1
    obstacle_cost_weight: float = 1.0
    learning_rate: float = 0.01
    smoothness_cost_velocity: float = 0.0
    smoothness_cost_acceleration: float = 1.0
    smoothness_cost_jerk: float = 0.0
    ridge_factor: float = 0.0
    use_pseudo_inverse: bool = False
    pseudo_inverse_ridge_factor: float = 1e-4
    joint_update_limit: float = 0.1
    collision_clearance: float = 0.2
    collision_threshold: float = 0.07
    use_stochastic_descent: bool = False
    trajectory_initialization_method: str = "quintic-spline"
    enable_failure_recovery: bool = False
    max_recovery_attempts: int = 5

    PLANNER: ClassVar[str] = "CHOMP"

    def range_problem(self) -> str | None:
        """Why these values are out of range (None: they are not)."""
        positive = ("planning_time_limit", "learning_rate", "joint_update_limit", "collision_clearance")
        for name in positive:
            if getattr(self, name) <= 0:
                return f"CHOMP parameter {name} must be > 0, got {getattr(self, name):g}"
        non_negative = ("smoothness_cost_weight", "obstacle_cost_weight", "smoothness_cost_velocity",
                        "smoothness_cost_acceleration", "smoothness_cost_jerk", "ridge_factor",
                        "pseudo_inverse_ridge_factor", "collision_threshold")
        for name in non_negative:
            if getattr(self, name) < 0:
                return f"CHOMP parameter {name} must be >= 0, got {getattr(self, name):g}"
        if self.max_iterations < 1:
            return f"CHOMP parameter max_iterations must be >= 1, got {self.max_iterations}"
        for name in ("max_iterations_after_collision_free", "max_recovery_attempts"):
            if getattr(self, name) < 0:
                return f"CHOMP parameter {name} must be >= 0, got {getattr(self, name)}"
        if (self.smoothness_cost_velocity + self.smoothness_cost_acceleration + self.smoothness_cost_jerk == 0
                and self.ridge_factor == 0):
            return ("CHOMP parameters smoothness_cost_velocity, smoothness_cost_acceleration, "
                    "smoothness_cost_jerk and ridge_factor are all 0: the smoothness metric has no inverse")
        if self.trajectory_initialization_method not in INITIALIZATION_METHODS:
            return (f"CHOMP parameter trajectory_initialization_method must be one of "
                    f"{list(INITIALIZATION_METHODS)}, got {self.trajectory_initialization_method!r}")
        return None


DEFAULT_PARAMS = ChompParams()


def parse_params(base: ChompParams, params: Mapping[str, Any], replace_all: bool = False) -> ChompParams | str:
    """``base`` with ``params`` (strings, numbers or booleans) applied, checked; a message when refused."""
    return optimization.parse_params(DEFAULT_PARAMS, base, params, replace_all)


# ---------------------------------------------------------------------------- the smoothness metric
def smoothness_matrices(points: int, params: ChompParams, dt: float = DISCRETIZATION
                        ) -> tuple[np.ndarray, np.ndarray]:
    """(A_full, A⁻¹) of MoveIt's ChompCost for a path of ``points`` waypoints: A_full over the
    path padded with DIFF_RULE_LENGTH - 1 copies of each end (P = points - 2 + 12 rows), the sum
    of each rule's DᵀD times its weight and dt^(order); A⁻¹ the inverse of A_full's block of the
    free waypoints, both scaled so that max(A⁻¹) = 1."""
    free = points - 2
    pad = DIFF_RULE_LENGTH - 1
    size = free + 2 * pad
    half = DIFF_RULE_LENGTH // 2
    weights = (params.smoothness_cost_velocity, params.smoothness_cost_acceleration, params.smoothness_cost_jerk)
    full = np.zeros((size, size))
    multiplier = 1.0
    for rule, weight in zip(DIFF_RULES, weights):
        multiplier *= dt
        diff = np.zeros((size, size))
        for offset in range(-half, half + 1):
            diff += rule[offset + half] * np.eye(size, k=offset)
        full += weight * multiplier * (diff.T @ diff)
    full += params.ridge_factor * np.eye(size)
    inverse = np.linalg.inv(full[pad:pad + free, pad:pad + free])
    scale = float(inverse.max())
    return full * scale, inverse / scale


def initial_path(start: np.ndarray, goal: np.ndarray, points: int, method: str) -> np.ndarray:
    """(points, d) from ``start`` to ``goal``: quintic-spline (minimum jerk, rest at both ends),
    cubic (rest at both ends) or linear."""
    t = np.linspace(0.0, 1.0, points)
    if method == "quintic-spline":
        s = 10 * t ** 3 - 15 * t ** 4 + 6 * t ** 5
    elif method == "cubic":
        s = 3 * t ** 2 - 2 * t ** 3
    else:
        s = t
    path = start + s[:, None] * (goal - start)
    path[0], path[-1] = start, goal
    return path


def potential(distance: np.ndarray, clearance: float) -> tuple[np.ndarray, np.ndarray]:
    """CHOMP's obstacle potential of a sphere whose surface is ``distance`` from the world, and
    its derivative: 0 beyond ``clearance``, (d - ε)²/2ε within it, ε/2 - d inside an object."""
    d = distance
    inside = d < 0.0
    near = (d >= 0.0) & (d < clearance)
    value = np.where(inside, -d + 0.5 * clearance, np.where(near, 0.5 * (d - clearance) ** 2 / clearance, 0.0))
    slope = np.where(inside, -1.0, np.where(near, (d - clearance) / clearance, 0.0))
    return value, slope


# ---------------------------------------------------------------------------- the kinematics
class _SphereKinematics:
    """World positions and Jacobians (over the group's variables) of the collision spheres."""

    def __init__(self, model: RobotModel, group: str, start: RobotState, spheres: BodySpheres) -> None:
        self.model = model
        self.pin_model = model.pin_model
        self.data = self.pin_model.createData()
        self.spheres = spheres
        self.indices = np.asarray(model.group(group).variable_indices, dtype=int)
        self.full = np.array(start.positions, dtype=float)
        self.slots = model.q_slots(self.indices)
        self.q = np.array(model.to_q(self.full), dtype=float)
        self.joints = np.unique(spheres.joints)
        self.joint_slot = {int(j): k for k, j in enumerate(self.joints)}
        self.sphere_joint_slot = np.array([self.joint_slot[int(j)] for j in spheres.joints], dtype=int)
        nv = self.pin_model.nv
        self.masks = np.zeros((len(spheres), nv))
        for s, joint in enumerate(spheres.joints):
            for support in self.pin_model.supports[int(joint)]:
                start_v, width = self.pin_model.idx_vs[support], self.pin_model.nvs[support]
                self.masks[s, start_v:start_v + width] = 1.0
        self.jacobian_map = model.jacobian_map(self.indices)

    def configuration(self, values: np.ndarray) -> np.ndarray:
        return group_configuration(self.model, values, self.slots, self.q, self.full, self.indices)

    def positions(self, path: np.ndarray) -> np.ndarray:
        """(N, S, 3) sphere centres in the world for each row of ``path`` (N, d)."""
        rotations = np.empty((len(path), len(self.joints), 3, 3))
        translations = np.empty((len(path), len(self.joints), 3))
        model, data = self.pin_model, self.data
        joints = self.joints.tolist()
        for i, values in enumerate(path):
            pin.forwardKinematics(model, data, self.configuration(values))
            for k, joint in enumerate(joints):
                placement = data.oMi[joint]
                rotations[i, k] = placement.rotation
                translations[i, k] = placement.translation
        r = rotations[:, self.sphere_joint_slot]  # (N, S, 3, 3)
        t = translations[:, self.sphere_joint_slot]
        return np.einsum("nsij,sj->nsi", r, self.spheres.centres) + t

    def jacobians(self, path: np.ndarray, rows: np.ndarray, points: np.ndarray, which: np.ndarray) -> np.ndarray:
        """(k, 3, d) linear Jacobians over the group's variables of spheres ``which`` (k,) at world
        ``points`` (k, 3), the robot at ``path[rows]`` (k rows, repeated as often as needed)."""
        unique, inverse = np.unique(rows, return_inverse=True)
        frames = np.empty((len(unique), 6, self.pin_model.nv))
        for k, row in enumerate(unique.tolist()):  # WORLD frame: spatial velocity at the origin
            frames[k] = pin.computeJointJacobians(self.pin_model, self.data, self.configuration(path[row]))
        j = frames[inverse]  # (k, 6, nv)
        v, w, p = j[:, :3], j[:, 3:], points[:, :, None]
        # a point p moving with the joint: v + ω × p
        linear = v + np.stack([w[:, 1] * p[:, 2] - w[:, 2] * p[:, 1],
                               w[:, 2] * p[:, 0] - w[:, 0] * p[:, 2],
                               w[:, 0] * p[:, 1] - w[:, 1] * p[:, 0]], axis=1)
        return (linear * self.masks[which][:, None, :]) @ self.jacobian_map


# ---------------------------------------------------------------------------- the optimisation
@dataclass
class ChompResult:
    path: np.ndarray | None
    iterations: int
    status: str  # "VALID", "TIMEOUT", "MAX_ITERATIONS", "TIME_LIMIT", "PREEMPTED"
    message: str = ""
    accepted: Any = None  # what ``accept`` returned for ``path``


class ChompOptimizer:
    """One CHOMP optimisation of a path (MoveIt's ChompOptimizer)."""

    def __init__(self, kinematics: _SphereKinematics, field: WorldDistanceField, path: np.ndarray,
                 lower: np.ndarray, upper: np.ndarray, params: ChompParams, rng: np.random.Generator) -> None:
        self.kin = kinematics
        self.field = field
        self.params = params
        self.rng = rng
        self.path = path.copy()
        self.lower, self.upper = lower, upper
        self.points = len(path)
        self.free = self.points - 2
        self.pad = DIFF_RULE_LENGTH - 1
        self.full_metric, self.inverse = smoothness_matrices(self.points, params)
        self.radii = kinematics.spheres.radii
        # the padded ends do not move: their sphere positions once
        ends = kinematics.positions(path[[0, -1]])
        self.start_spheres, self.goal_spheres = ends[0], ends[1]

    def padded(self) -> np.ndarray:
        pad = self.pad
        return np.vstack([np.repeat(self.path[:1], pad, axis=0), self.path[1:-1], np.repeat(self.path[-1:], pad, axis=0)])

    def smoothness_cost(self) -> float:
        theta = self.padded()
        return float(self.params.smoothness_cost_weight * np.sum(theta * (self.full_metric @ theta)))

    def evaluate(self) -> dict[str, np.ndarray | float]:
        """Forward kinematics of the free waypoints and the obstacle terms there."""
        p, pad, free = self.params, self.pad, self.free
        centres = self.kin.positions(self.path[1:-1])  # (free, S, 3)
        padded = np.concatenate([np.repeat(self.start_spheres[None], pad, axis=0), centres,
                                 np.repeat(self.goal_spheres[None], pad, axis=0)])
        half = DIFF_RULE_LENGTH // 2
        velocity = np.zeros_like(centres)
        acceleration = np.zeros_like(centres)
        for offset in range(-half, half + 1):
            rows = padded[pad + offset:pad + offset + free]
            velocity += DIFF_RULES[0][offset + half] * rows
            acceleration += DIFF_RULES[1][offset + half] * rows
        velocity /= DISCRETIZATION
        acceleration /= DISCRETIZATION ** 2
        distance, gradient = self.field.distance_and_gradient(centres.reshape(-1, 3))
        clearance = distance.reshape(free, -1) - self.radii
        value, slope = potential(clearance, p.collision_clearance)
        speed = np.linalg.norm(velocity, axis=2)
        return {
            "centres": centres, "velocity": velocity, "acceleration": acceleration, "speed": speed,
            "potential": value, "gradient": slope[..., None] * gradient.reshape(free, -1, 3),
            "penetrating": bool((clearance < 0.0).any()),
            "obstacle_cost": float(p.obstacle_cost_weight * np.sum(value * speed)),
        }

    def obstacle_increments(self, terms: Mapping[str, Any]) -> np.ndarray:
        """(free, d): minus the obstacle gradient (CHOMP's functional) at the chosen waypoints,
        every (waypoint, sphere) pair with a potential at once."""
        p = self.params
        out = np.zeros((self.free, self.path.shape[1]))
        chosen = np.zeros(self.free, dtype=bool)
        if p.use_stochastic_descent:
            chosen[int(self.rng.integers(0, self.free))] = True
        else:
            chosen[:] = True
        speed = terms["speed"]
        active = (terms["potential"] >= MIN_POTENTIAL) & (speed > 1e-9) & chosen[:, None]
        rows, which = np.nonzero(active)
        if not rows.size:
            return out
        v = terms["velocity"][rows, which]
        magnitude = speed[rows, which][:, None]
        unit = v / magnitude
        projector = np.eye(3)[None] - unit[:, :, None] * unit[:, None, :]  # (k, 3, 3)
        curvature = np.einsum("kij,kj->ki", projector, terms["acceleration"][rows, which]) / magnitude ** 2
        grad = np.einsum("kij,kj->ki", projector, terms["gradient"][rows, which])
        cartesian = magnitude * (grad - terms["potential"][rows, which][:, None] * curvature)
        jac = self.kin.jacobians(self.path, rows + 1, terms["centres"][rows, which], which)  # (k, 3, d)
        if p.use_pseudo_inverse:
            jjt = jac @ jac.transpose(0, 2, 1) + p.pseudo_inverse_ridge_factor * np.eye(3)[None]
            pseudo = jac.transpose(0, 2, 1) @ np.linalg.inv(jjt)  # (k, d, 3)
            contributions = np.einsum("kdi,ki->kd", pseudo, cartesian)
        else:
            contributions = np.einsum("kid,ki->kd", jac, cartesian)
        np.subtract.at(out, rows, contributions)
        return out

    def step(self, terms: Mapping[str, Any]) -> None:
        """One covariant gradient step, limited per joint, then the joint limits restored."""
        p = self.params
        theta = self.padded()
        smooth = -(self.full_metric @ (2.0 * theta))[self.pad:self.pad + self.free]
        increments = p.learning_rate * (self.inverse @ (p.smoothness_cost_weight * smooth
                                                         + p.obstacle_cost_weight * self.obstacle_increments(terms)))
        largest = np.maximum(np.abs(increments.max(axis=0)), np.abs(increments.min(axis=0)))
        scale = np.minimum(1.0, p.joint_update_limit / np.where(largest > 0.0, largest, np.inf))
        self.path[1:-1] += increments * scale
        self._restore_joint_limits()

    def _restore_joint_limits(self) -> None:
        """MoveIt's handleJointLimits: the worst violation of each joint is removed by moving the
        path along A⁻¹'s column there (a smooth bump), up to 10 times; then clipped."""
        inner = self.path[1:-1]
        for joint in range(inner.shape[1]):
            low, high = self.lower[joint], self.upper[joint]
            for _ in range(10):
                column = inner[:, joint]
                amount = np.where(column > high, high - column, np.where(column < low, low - column, 0.0))
                worst = int(np.argmax(np.abs(amount)))
                if abs(amount[worst]) <= 1e-6:
                    break
                inner[:, joint] += amount[worst] / self.inverse[worst, worst] * self.inverse[:, worst]
        np.clip(inner, self.lower, self.upper, out=inner)

    def optimize(self, deadline: float, time_limit: float, cancel: Any,
                 accept: Callable[[np.ndarray], tuple[Any, str | None]]) -> ChompResult:
        """Iterate until a valid path has had max_iterations_after_collision_free more iterations
        (the path they end with is checked too, and the one of lower cost kept), or
        max_iterations, the time limit or the deadline; the valid path accepted by ``accept``,
        or None with why not."""
        p = self.params
        best: tuple[float, np.ndarray, Any] | None = None
        rejected = ""
        after_valid = 0
        iteration = 0
        last_checked = -EXACT_CHECK_EVERY
        while True:
            if cancel is not None and cancel.is_set():
                return ChompResult(None, iteration, "PREEMPTED", "cancelled")
            now = time.perf_counter()
            out_of_time = now > deadline or now > time_limit
            if best is None and out_of_time:
                status = "TIMEOUT" if now > deadline else "TIME_LIMIT"
                return ChompResult(None, iteration, status, f"no valid path after {iteration} iterations{rejected}")
            terms = self.evaluate()
            cost = terms["obstacle_cost"] + self.smoothness_cost()
            last = iteration >= p.max_iterations or out_of_time or (
                best is not None and after_valid >= p.max_iterations_after_collision_free)
            if best is None:
                # a path whose spheres stay out of the world may still pass through a thin object
                # between waypoints: at most every CLEAR_CHECK_EVERY iterations on that ground
                clear = not terms["penetrating"] and iteration - last_checked >= CLEAR_CHECK_EVERY
                check = (terms["obstacle_cost"] < p.collision_threshold or clear
                         or iteration % EXACT_CHECK_EVERY == 0 or last)
            else:
                check = last and cost < best[0]
            if check:
                last_checked = iteration
                kept, problem = accept(self.path)
                if problem is None:
                    best = (cost, self.path.copy(), kept)
                else:
                    rejected = f"; the last checked path was refused: {problem}"
            if best is not None and (last or after_valid >= p.max_iterations_after_collision_free):
                return ChompResult(best[1], iteration, "VALID", f"valid after {iteration} iterations", best[2])
            if last:
                return ChompResult(None, iteration, "MAX_ITERATIONS",
                                   f"no valid path in max_iterations = {p.max_iterations}{rejected}")
            if best is not None:
                after_valid += 1
            self.step(terms)
            iteration += 1


# ---------------------------------------------------------------------------- the planner
def plan_chomp(scene: PlanningScene, request: MotionPlanRequest, params: ChompParams = DEFAULT_PARAMS
               ) -> MotionPlanResponse:
    """Plan ``request`` with CHOMP. Never raises for bad input: the response's MoveItErrorCode says
    what was wrong (MoveIt's codes; TIMED_OUT when allowed_planning_time ran out, PLANNING_FAILED
    when no valid path came out of the optimisation and its recovery attempts)."""
    return optimization.planned(PLANNER_ID, _plan, scene, request, params)


def _robot_spheres(scene: PlanningScene, group: str) -> BodySpheres:
    """The group's link spheres and those of attached objects on links the group moves."""
    model = scene.robot_model
    moving = moving_joints(model, model.group(group).variable_indices)
    items = []
    for body in scene.attached_bodies():
        frame = model.pin_model.frames[model.frame_id(body.link)]
        if int(frame.parentJoint) not in moving:
            continue
        for shape in body.object.shapes:
            placement = frame.placement.homogeneous @ np.asarray(body.object.pose) @ np.asarray(shape.pose)
            items.append((body.id, int(frame.parentJoint), shape.geometry, placement))
    return group_spheres(model, group) + spheres_of_bodies(items)


def _plan(scene: PlanningScene, request: MotionPlanRequest, params: ChompParams, started: float
          ) -> MotionPlanResponse:
    if isinstance(params, ChompParams) and params.trajectory_initialization_method == "fillTrajectory":
        raise failure(MoveItErrorCode.INVALID_MOTION_PLAN,
                      "CHOMP's trajectory_initialization_method 'fillTrajectory' needs an input trajectory "
                      "(CHOMP as a post-processor of another planner), which a request here does not carry; "
                      f"use one of {list(INITIALIZATION_METHODS[:3])}")
    problem = optimization.prepare_problem(scene, request, params)
    model, jmg, start, rng = scene.robot_model, problem.jmg, problem.start, problem.rng
    velocity_scaling, acceleration_scaling = problem.velocity_scaling, problem.acceleration_scaling
    start_vector = start.group_positions(jmg.name)
    goal_vector = _shortest_goal(model, jmg.joint_names, start_vector, problem.goals[0].group_positions(jmg.name))
    lower, upper = problem.lower, problem.upper
    spheres = _robot_spheres(scene, jmg.name)
    field = WorldDistanceField.of_scene(scene, sorted(set(spheres.bodies)), params.collision_clearance)
    kinematics = _SphereKinematics(model, jmg.name, start, spheres)
    points = int(TRAJECTORY_DURATION / DISCRETIZATION) + 1
    path = initial_path(start_vector, goal_vector, points, params.trajectory_initialization_method)

    def accept(candidate: np.ndarray) -> tuple[Any, str | None]:
        problem = polyline_problem(scene, jmg.name, start, candidate)
        if problem is not None:
            return None, problem
        return timed_and_validated(scene, jmg, start, candidate, None, velocity_scaling, acceleration_scaling)

    deadline = started + problem.budget
    attempt_params = params
    attempts = 1 + (params.max_recovery_attempts if params.enable_failure_recovery else 0)
    result = None
    for attempt in range(attempts):
        optimizer = ChompOptimizer(kinematics, field, path, lower, upper, attempt_params, rng)
        result = optimizer.optimize(deadline, time.perf_counter() + attempt_params.planning_time_limit,
                                    request.cancel, accept)
        if result.path is not None or result.status in ("PREEMPTED", "TIMEOUT"):
            break
        # MoveIt's recovery: go on from where the optimisation ended, bolder and longer
        path = optimizer.path
        attempt_params = replace(attempt_params,
                                 learning_rate=attempt_params.learning_rate + RECOVERY_LEARNING_RATE,
                                 ridge_factor=attempt_params.ridge_factor + RECOVERY_RIDGE_FACTOR,
                                 planning_time_limit=attempt_params.planning_time_limit + RECOVERY_TIME,
                                 max_iterations=attempt_params.max_iterations + RECOVERY_ITERATIONS)
    assert result is not None
    tried = f" and {attempt} recovery attempts" if attempt else ""
    # MoveIt's ChompPlanner answers with planner_id "chomp"
    return optimization.optimized_response(result, problem, PLANNER_ID, CHOMP_PIPELINE_ID, started, request, tried)


def _shortest_goal(model: RobotModel, joint_names: Sequence[str], start: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """The goal with each continuous joint moved the short way round (as MoveIt's ChompPlanner)."""
    goal = goal.copy()
    for k, name in enumerate(joint_names):
        if model.joint(name).type == "continuous":
            goal[k] = start[k] + (goal[k] - start[k] + math.pi) % (2.0 * math.pi) - math.pi
    return goal


class ChompPlanner(optimization.TrajectoryOptimizationPlanner[ChompParams]):
    """The ``chomp`` pipeline as a PlannerManager (core.planning_interface.planner_manager)."""

    pipeline_id = CHOMP_PIPELINE_ID
    description = "CHOMP"
    #: MoveIt's CHOMP ignores path constraints: the pipeline checks its path and refuses it if it leaves them
    enforces_path_constraints = False
    planner_id = PLANNER_ID
    default_params = DEFAULT_PARAMS

    def plan(self, scene: PlanningScene, request: MotionPlanRequest) -> MotionPlanResponse:
        return plan_chomp(scene, request, self.params)
