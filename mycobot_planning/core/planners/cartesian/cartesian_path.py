"""Cartesian paths (MoveIt's computeCartesianPath) and relative motions (MTC's MoveRelative).

The full story: docs/core.md, section mycobot_planning.core.planners.cartesian.cartesian_path.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np
import pinocchio as pin

from interfaces_py.msgs import MoveItErrorCode

from .cartesian_precision import CartesianPrecision, PrecisionCheck
from .step_solver import ORIENTATION_TOLERANCE, POSITION_TOLERANCE, step_solver
from ...errors import PlanningError
from ...kinematic_constraints.kinematic_constraints import CONSTRAINT_CHECK_STEP
from ...kinematics.ik_solver import IKSolver, thread_ik_solver
from ...planning_interface.planning_interface import (MotionPlanResponse, PlanningFailure, check_group, check_start_state,
                                                       failure, time_group_path)
from ...planning_scene.planning_scene import PlanningScene
from ...robot_model.robot_model import JointModelGroup, RobotModel
from ...robot_state.robot_state import RobotState
from ...robot_trajectory.robot_trajectory import TimedTrajectory
from ...transforms import check_pose
from ...moveit_error_code import ErrorCodeResult

__all__ = [
    "CartesianPathResult",
    "STOP_COLLISION",
    "STOP_PATH_CONSTRAINTS",
    "STOP_COMPLETE",
    "STOP_INVALID_REQUEST",
    "STOP_JOINT_JUMP",
    "STOP_NO_IK",
    "STOP_PRECISION",
    "compute_cartesian_path",
    "nearest_rotation",
    "slerp_rotations",
]

# stop_reason values
STOP_COMPLETE = "complete"
STOP_NO_IK = "no_ik_solution"
STOP_COLLISION = "collision"
STOP_JOINT_JUMP = "joint_space_jump"
STOP_PATH_CONSTRAINTS = "path_constraints"
STOP_PRECISION = "precision"
STOP_INVALID_REQUEST = "invalid_request"

#: MoveIt forces at least this many steps per segment when the relative jump test is on, so the
#: mean step it compares against is meaningful; with fewer states the test is skipped.
MIN_STEPS_FOR_JUMP_THRESHOLD = 10
#: Default rotation bound per step: eef_step / this radius (rad), i.e. a point this far from the
#: ik frame's origin moves at most eef_step per step through rotation alone.
ROTATION_STEP_RADIUS = 0.1
#: Refuse requests needing more steps than this (eef_step far too small for the path): the
#: arrays alone would exhaust memory long before the IK finished.
MAX_STEPS = 1_000_000
#: Joint-space resolution (rad, max-norm) of the collision checks between consecutive steps;
#: equal to the trajectory validator's default so both look at the motion equally finely.
DEFAULT_COLLISION_CHECK_RESOLUTION = 0.005

#: Steps whose IK is solved before their checks run (vectorised): the IK done past a refused
#: step is at most this many steps of wasted work.
_CHUNK = 32


# ---------------------------------------------------------------------------- results
@dataclass
class CartesianPathResult(ErrorCodeResult):
    """Outcome of :func:`compute_cartesian_path`.

    ``error_code`` is SUCCESS whenever the request was well-formed, even when the path stops
    early (MoveIt returns the fraction and lets the caller decide); then ``fraction`` < 1,
    ``stop_reason`` says why (``no_ik_solution``, ``collision``, ``joint_space_jump``) and the
    message gives the details. ``path`` (N x group dof, row 0 = start) and ``trajectory`` hold
    the reachable prefix; with fraction 0 they hold only the start state.
    """

    error_code: MoveItErrorCode
    fraction: float = 0.0
    trajectory: TimedTrajectory | None = None
    path: np.ndarray | None = field(default=None, repr=False)
    stop_reason: str = ""
    group_name: str = ""
    link: str = ""
    start_state: RobotState | None = field(default=None, repr=False)
    planning_time: float = 0.0

    def states(self) -> list[RobotState]:
        """The path as full robot states (joints outside the group keep the start's values)."""
        if self.path is None or self.start_state is None:
            return []
        jmg = self.start_state.model.group(self.group_name)
        out = []
        for row in self.path:
            state = self.start_state.copy()
            positions = state.positions.copy()
            positions[jmg.variable_indices] = row
            state.set_positions(positions)
            out.append(state)
        return out

    def to_motion_plan_response(self, planner_id: str = "cartesian") -> MotionPlanResponse:
        """The same result in the shared MotionPlanResponse form (fraction goes into the message)."""
        return MotionPlanResponse(
            error_code=self.error_code,
            trajectory=self.trajectory,
            planning_time=self.planning_time,
            group_name=self.group_name,
            planner_id=planner_id,
            start_state=self.start_state,
            path=self.path,
        )


def failed_result(code: int, message: str, group: str = "", started: float | None = None) -> CartesianPathResult:
    return CartesianPathResult(
        error_code=MoveItErrorCode(code, message),
        stop_reason=STOP_INVALID_REQUEST,
        group_name=group if isinstance(group, str) else "",
        planning_time=0.0 if started is None else time.perf_counter() - started,
    )


# ---------------------------------------------------------------------------- request checks
def finite_number(value: object, name: str, minimum: float = 0.0, strict: bool = False) -> float:
    ok = isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, bool)
    if ok:
        value = float(value)
        ok = math.isfinite(value) and (value > minimum if strict else value >= minimum)
    if not ok:
        bound = f"> {minimum:g}" if strict else f">= {minimum:g}"
        raise failure(MoveItErrorCode.INVALID_MOTION_PLAN, f"{name} must be a finite number {bound}, got {value!r}")
    return float(value)


def _scaling(value: float | None, default: float, name: str) -> float:
    value = default if value is None else value
    if (not isinstance(value, (int, float, np.floating)) or isinstance(value, bool) or not math.isfinite(value)
            or not 0.0 < value <= 1.0):
        raise failure(MoveItErrorCode.INVALID_MOTION_PLAN, f"{name} must be in (0, 1], got {value!r}")
    return float(value)


def _start_state(scene: PlanningScene, start_state: RobotState | None, avoid_collisions: bool) -> RobotState:
    start = scene.current_state if start_state is None else start_state
    if not isinstance(start, RobotState) or start.model is not scene.robot_model:
        raise failure(MoveItErrorCode.INVALID_ROBOT_STATE, "start state is not a RobotState of the scene's robot")
    check_start_state(scene, start, avoid_collisions)
    return start.copy()


def _joint_jump(delta: np.ndarray, limits: Sequence[tuple[np.ndarray, float, str, str]], step: int) -> str | None:
    """Why the step ``delta`` (group values) jumps: the first (mask, threshold, kind, unit) of
    ``limits`` with a positive threshold that a masked joint's step exceeds; None when none does."""
    for mask, threshold, kind, unit in limits:
        if threshold > 0 and np.any(np.abs(delta[mask]) > threshold):
            return (f"{kind} joint step {float(np.max(np.abs(delta[mask]))):.4f} {unit} exceeds "
                    f"{kind}_jump_threshold {threshold:g} at step {step}")
    return None


def _check_link(model: RobotModel, jmg: JointModelGroup, link: str | None) -> str:
    return check_link_name(model, jmg.tip_link if link is None else link)


def check_link_name(model: RobotModel, link: object) -> str:
    """``link`` if it names a link or frame of the model, else INVALID_LINK_NAME."""
    if not isinstance(link, str) or not link:
        raise failure(MoveItErrorCode.INVALID_LINK_NAME, f"invalid link name {link!r}")
    try:
        model.frame_id(link)
    except ValueError:
        raise failure(MoveItErrorCode.INVALID_LINK_NAME, f"unknown link '{link}' of robot '{model.name}'") from None
    return link


def check_offset(ik_frame_offset: np.ndarray | None) -> np.ndarray | None:
    if ik_frame_offset is None:
        return None
    try:
        return check_pose(ik_frame_offset, "ik_frame_offset")
    except ValueError as exc:
        raise failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, str(exc)) from None


def _check_waypoints(waypoints: object) -> list[np.ndarray]:
    if waypoints is None:
        raise failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "no waypoints given")
    if isinstance(waypoints, np.ndarray) and waypoints.shape == (4, 4):
        waypoints = [waypoints]
    try:
        items = list(waypoints)  # type: ignore[arg-type]
    except TypeError:
        raise failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "waypoints must be a list of 4x4 poses") from None
    if not items:
        raise failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "the waypoint list is empty: nothing to move to")
    out = []
    for i, pose in enumerate(items):
        try:
            out.append(check_pose(pose, f"waypoint {i}"))
        except ValueError as exc:
            raise failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, str(exc)) from None
    return out


def pose_of_frame(scene: PlanningScene, frame: str, state: RobotState) -> np.ndarray:
    if frame == "world" or frame == scene.robot_model.pin_model.frames[0].name:
        return np.eye(4)
    try:
        return scene.frame_pose(frame, state)
    except (PlanningError, ValueError) as exc:
        raise failure(MoveItErrorCode.FRAME_TRANSFORM_FAILURE, str(exc)) from None


# ---------------------------------------------------------------------------- interpolation
_EYE3 = np.eye(3)


def nearest_rotation(matrix: np.ndarray) -> np.ndarray:
    """The rotation nearest to ``matrix`` (Frobenius norm; check_pose lets rotations be
    orthonormal to 1e-6 only): the steps interpolate between true rotations."""
    if np.abs(matrix @ matrix.T - _EYE3).max() <= 1e-13 and np.linalg.det(matrix) > 0:
        return matrix  # a rotation already (within rounding): the SVD would give it back
    u, _, vt = np.linalg.svd(matrix)
    rotation = u @ vt
    if np.linalg.det(rotation) < 0:  # never for a pose check_pose accepts (det > 0)
        u[:, -1] = -u[:, -1]
        rotation = u @ vt
    return rotation


def slerp_rotations(r0: np.ndarray, rotvec: np.ndarray, fractions: np.ndarray) -> np.ndarray:
    """r0 @ exp(f * rotvec) for every f of ``fractions``, (F, 3, 3): the rotations a constant
    angular velocity passes from r0 about r0's ``rotvec`` (Rodrigues' formula, vectorised; SciPy's
    Rotation did the same through quaternions at ~1 ms a segment)."""
    angle = float(np.linalg.norm(rotvec))
    out = np.broadcast_to(r0, (len(fractions), 3, 3)).copy()
    if angle == 0.0:
        return out
    x, y, z = rotvec / angle
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    theta = np.asarray(fractions, dtype=float) * angle
    steps = np.eye(3) + np.sin(theta)[:, None, None] * k + (1.0 - np.cos(theta))[:, None, None] * (k @ k)
    return np.matmul(r0, steps, out=out)


def _interpolate_segments(
    start: np.ndarray, waypoints: list[np.ndarray], eef_step: float, rotation_step: float, min_steps: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every step target of the path, vectorised.

    Returns positions (S, 3), rotations (S, 3, 3), the segment of each step and the number of
    steps of each segment. A segment of translation d and rotation angle a gets
    max(ceil(d / eef_step), ceil(a / rotation_step), min_steps, 1) equal steps.
    """
    plan = []
    previous = start
    r0 = nearest_rotation(start[:3, :3])
    for target in waypoints:
        r1 = nearest_rotation(target[:3, :3])
        rotvec = pin.log3(r0.T @ r1)  # angle in [0, pi]
        angle = float(np.linalg.norm(rotvec))
        distance = float(np.linalg.norm(target[:3, 3] - previous[:3, 3]))
        steps = max(1, min_steps, math.ceil(distance / eef_step - 1e-9), math.ceil(angle / rotation_step - 1e-9))
        plan.append((previous, target, r0, rotvec, steps))
        previous, r0 = target, r1
    total = sum(item[-1] for item in plan)
    if total > MAX_STEPS:
        raise failure(
            MoveItErrorCode.INVALID_MOTION_PLAN,
            f"the path would need {total} steps (more than {MAX_STEPS}): eef_step {eef_step:g} m / rotation step "
            f"{rotation_step:g} rad is too small for it",
        )
    positions, rotations, segment_of, steps_of = [], [], [], []
    for index, (previous, target, r0, rotvec, steps) in enumerate(plan):
        p0, p1 = previous[:3, 3], target[:3, 3]
        t = np.arange(1, steps + 1) / steps
        positions.append(p0[None, :] + t[:, None] * (p1 - p0)[None, :])
        # slerp from r0 to the target: r0 * exp(t * log(r0^-1 r1))
        step_rot = slerp_rotations(r0, rotvec, t)
        step_rot[-1] = target[:3, :3]  # land exactly on the waypoint
        positions[-1][-1] = p1
        rotations.append(step_rot)
        segment_of.append(np.full(steps, index))
        steps_of.append(steps)
    return (np.concatenate(positions), np.concatenate(rotations), np.concatenate(segment_of),
            np.array(steps_of, dtype=int))


# ---------------------------------------------------------------------------- main entry
def compute_cartesian_path(
    scene: PlanningScene,
    group: str,
    start_state: RobotState | None,
    waypoints: Sequence[np.ndarray] | np.ndarray,
    link: str | None = None,
    ik_frame_offset: np.ndarray | None = None,
    eef_step: float = 0.01,
    jump_threshold: float = 0.0,
    avoid_collisions: bool = True,
    velocity_scaling: float | None = None,
    acceleration_scaling: float | None = None,
    revolute_jump_threshold: float = 0.0,
    prismatic_jump_threshold: float = 0.0,
    max_rotation_step: float | None = None,
    collision_check_resolution: float = DEFAULT_COLLISION_CHECK_RESOLUTION,
    frame: str = "world",
    sample_period: float | None = None,
    path_constraints: Any = None,
    precision: CartesianPrecision | None = None,
) -> CartesianPathResult:
    """MoveIt's computeCartesianPath: move the ik frame through waypoints along straight lines.

    Args:
        scene: planning scene (collision world, ACM, frames).
        group: planning group whose joints move.
        start_state: where the path starts (None: the scene's current state). As in MoveIt,
            the waypoints do NOT include the start pose: the first segment runs from the ik
            frame's pose at the start state to ``waypoints[0]``.
        waypoints: 4x4 poses of the ik frame, in ``frame`` (default the world/model frame).
        link: the link to move (default: the group's tip link).
        ik_frame_offset: pose of the ik frame in ``link``'s frame (e.g. a TCP); the waypoints
            are poses of that frame.
        eef_step: maximum translation (m) of the ik frame between consecutive path states.
        jump_threshold: MoveIt's relative test: a step whose joint-space distance (sum of
            per-joint distances) exceeds jump_threshold x the mean step cuts the path before
            it. 0 disables it; when > 0 every segment gets at least 10 steps, and (as in MoveIt)
            the test is skipped when fewer than 10 states were computed.
        avoid_collisions: check every state (and the joint-space motion between consecutive
            states at ``collision_check_resolution``) against the scene.
        velocity_scaling, acceleration_scaling: timing factors in (0, 1]; None takes
            joint_limits.yaml's defaults.
        revolute_jump_threshold, prismatic_jump_threshold: MoveIt 2's absolute test: a step
            moving any revolute joint more than this (rad) / prismatic joint more than this (m)
            cuts the path before it. 0 disables.
        max_rotation_step: maximum rotation (rad) of the ik frame per step; default
            eef_step / 0.1 (a point 10 cm from the ik frame moves at most eef_step).
        collision_check_resolution: joint-space spacing (rad, max-norm) of the collision checks
            between consecutive states.
        frame: frame the waypoints are expressed in: 'world', a link, or a collision object
            (resolved at the start state).
        sample_period: passed to the time parameterisation (None: breakpoints only).
        precision: MoveIt's CartesianPrecision (None: not checked): the ik frame, halfway
            between consecutive states, stays within ``translational`` m and ``rotational`` rad
            of the line; the steps are halved until it does, or the path stops (stop_reason
            ``precision``) where a step would be shorter than ``max_resolution`` of the path.

    Returns:
        A CartesianPathResult; never raises for bad input (error codes instead).
    """
    started = time.perf_counter()
    if precision is not None and not isinstance(precision, CartesianPrecision):
        return failed_result(MoveItErrorCode.INVALID_MOTION_PLAN,
                             f"precision must be a CartesianPrecision, got {type(precision).__name__}", group, started)
    try:
        while True:
            try:
                return _compute(
                    scene, group, start_state, waypoints, link, ik_frame_offset, eef_step, jump_threshold,
                    avoid_collisions, velocity_scaling, acceleration_scaling, revolute_jump_threshold,
                    prismatic_jump_threshold, max_rotation_step, collision_check_resolution, frame, sample_period,
                    started, path_constraints, precision,
                )
            except _RefineSteps:  # a step left the line by more than the precision: halve them all
                eef_step = eef_step / 2.0
                if max_rotation_step is not None:
                    max_rotation_step = max_rotation_step / 2.0
    except PlanningFailure as exc:
        return failed_result(exc.code, exc.message, group, started)


class _RefineSteps(Exception):
    """Raised by _compute when a step misses the precision and halved steps are still longer
    than the precision's max_resolution of the path."""


def _compute(
    scene, group, start_state, waypoints, link, ik_frame_offset, eef_step, jump_threshold, avoid_collisions,
    velocity_scaling, acceleration_scaling, revolute_jump_threshold, prismatic_jump_threshold, max_rotation_step,
    collision_check_resolution, frame, sample_period, started, path_constraints=None, precision=None,
) -> CartesianPathResult:
    if not isinstance(scene, PlanningScene):
        raise failure(MoveItErrorCode.INVALID_MOTION_PLAN, f"scene must be a PlanningScene, got {type(scene).__name__}")
    model = scene.robot_model
    jmg = check_group(model, group)
    link = _check_link(model, jmg, link)
    offset = check_offset(ik_frame_offset)
    poses = _check_waypoints(waypoints)
    eef_step = finite_number(eef_step, "eef_step", strict=True)
    jump_threshold = finite_number(jump_threshold, "jump_threshold")
    revolute_jump_threshold = finite_number(revolute_jump_threshold, "revolute_jump_threshold")
    prismatic_jump_threshold = finite_number(prismatic_jump_threshold, "prismatic_jump_threshold")
    rotation_step = (eef_step / ROTATION_STEP_RADIUS if max_rotation_step is None
                     else finite_number(max_rotation_step, "max_rotation_step", strict=True))
    resolution = finite_number(collision_check_resolution, "collision_check_resolution", strict=True)
    vel = _scaling(velocity_scaling, model.default_velocity_scaling_factor, "velocity_scaling")
    acc = _scaling(acceleration_scaling, model.default_acceleration_scaling_factor, "acceleration_scaling")
    if sample_period is not None:
        sample_period = finite_number(sample_period, "sample_period", strict=True)
    if not isinstance(frame, str) or not frame:
        raise failure(MoveItErrorCode.FRAME_TRANSFORM_FAILURE, f"invalid frame {frame!r}")
    start = _start_state(scene, start_state, bool(avoid_collisions))

    # The link must actually be moved by the group, or no waypoint can ever be reached.
    if not np.any(np.abs(start.jacobian(link, jmg.name)) > 1e-12):
        raise failure(MoveItErrorCode.INVALID_LINK_NAME, f"link '{link}' is not moved by group '{jmg.name}'")

    frame_pose = pose_of_frame(scene, frame, start)
    if frame != "world":
        poses = [frame_pose @ p for p in poses]
    link_start = start.frame_pose(link)
    ik_start = link_start if offset is None else link_start @ offset

    min_steps = MIN_STEPS_FOR_JUMP_THRESHOLD if jump_threshold > 0 else 1
    p_ik, r_ik, segment_of, steps_of = _interpolate_segments(ik_start, poses, eef_step, rotation_step, min_steps)
    # IK targets of the link itself: T_link = T_ik * offset^-1.
    if offset is None:
        p_link, r_link = p_ik, r_ik
    else:
        r_off_t = offset[:3, :3].T
        r_link = r_ik @ r_off_t
        p_link = p_ik - r_link @ offset[:3, 3]
    n_steps = len(p_link)

    idx = jmg.variable_indices
    full = start.positions.copy()
    solver = step_solver(model, jmg, link, full)
    path = np.empty((n_steps + 1, len(idx)))
    path[0] = full[idx]
    revolute = np.array([model.joint(j).type in ("revolute", "continuous") for j in jmg.joint_names])
    prismatic = np.array([model.joint(j).type == "prismatic" for j in jmg.joint_names])
    continuous = np.array([model.joint(j).type == "continuous" for j in jmg.joint_names])
    jump_limits = ((revolute, revolute_jump_threshold, "revolute", "rad"),
                   (prismatic, prismatic_jump_threshold, "prismatic", "m"))
    # States are within the limits by construction (every IK step is clipped to them).
    # The batch sphere test first for a whole chunk of states, the exact check for the rest.
    batch_free = scene.batch_free_checker(jmg.name, start) if avoid_collisions else None
    is_valid = scene.validity_checker(jmg.name, start, check_bounds=False, sphere_pretest=batch_free is None)
    check_buffer = full.copy()
    jump_checked = revolute_jump_threshold > 0 or prismatic_jump_threshold > 0
    fallback: list[IKSolver] = []

    def fallback_refine(previous: np.ndarray, s: int) -> np.ndarray | None:
        """A longer descent from the previous solution only (no table seeds, no restarts): the
        path stays on the seed's IK branch or stops, it never hops to another branch."""
        if not fallback:
            fallback.append(thread_ik_solver(model, jmg.name, link))
        seed_positions = full.copy()
        seed_positions[idx] = previous
        target = np.eye(4)
        target[:3, :3], target[:3, 3] = r_link[s], p_link[s]
        refined = fallback[0].refine(target, RobotState(model, seed_positions))
        if refined is None:
            return None
        x = refined.positions[idx].copy()
        if continuous.any():  # stay continuous: nearest 2*pi-equivalent to the seed
            x[continuous] = previous[continuous] + (
                (x[continuous] - previous[continuous] + math.pi) % (2 * math.pi) - math.pi)
        return x
    straightness = None if precision is None else PrecisionCheck(
        model, idx, link, offset, full, precision, revolute_only=bool(np.all(revolute)),
        tolerances=(POSITION_TOLERANCE, ORIENTATION_TOLERANCE))

    if path_constraints:
        problem = path_constraints.violation(start)
        if problem:
            raise failure(MoveItErrorCode.START_STATE_VIOLATES_PATH_CONSTRAINTS,
                          f"the start state violates the path constraints: {problem}")
    stop_reason, detail = STOP_COMPLETE, ""
    done = 0  # steps achieved
    # The steps go in chunks: the IK of a chunk first (the solver only ever continues from its
    # own last solution, so what the checks decide never changes it), then the chunk's checks
    # vectorised and in the order one step at a time would meet them (joint jump, precision,
    # collision, path constraints), the path ending before the first step any of them refuses.
    while done < n_steps and stop_reason == STOP_COMPLETE:
        end = min(n_steps, done + _CHUNK)
        reached = solver.follow(p_link, r_link, done, end, path, fallback_refine)
        limit = reached  # steps [done, limit) still pass every check so far
        if reached < end:
            stop_reason = STOP_NO_IK
            detail = f"no IK solution for '{link}' at step {reached + 1}"
        deltas = path[done + 1:reached + 1] - path[done:reached]
        if jump_checked and len(deltas):
            jumps = np.zeros(len(deltas), dtype=bool)
            for mask, threshold, _, _ in jump_limits:
                if threshold > 0:
                    jumps |= np.any(np.abs(deltas[:, mask]) > threshold, axis=1)
            first = np.flatnonzero(jumps)
            if first.size:
                limit = done + int(first[0])
                stop_reason = STOP_JOINT_JUMP
                detail = _joint_jump(deltas[limit - done], jump_limits, limit + 1) or ""
        largest = np.abs(deltas).max(axis=1) if len(deltas) else np.zeros(0)
        refine = False
        if straightness is not None:
            for s in np.flatnonzero(straightness.needs_checks(deltas[:limit - done], largest[:limit - done])).tolist():
                s += done
                p0, r0 = (p_ik[s - 1], r_ik[s - 1]) if s > 0 else (ik_start[:3, 3], ik_start[:3, :3])
                off_line, turned = straightness.deviation(path[s], path[s + 1], p0, r0, p_ik[s], r_ik[s])
                if straightness.exceeded(off_line, turned):
                    limit = s
                    refine = 0.5 / n_steps >= precision.max_resolution
                    stop_reason = STOP_PRECISION
                    detail = (f"the motion to step {s + 1} leaves the line by {off_line * 1000:.3f} mm / "
                              f"{turned:.4f} rad with steps at the finest resolution ({precision})")
                    break
        if avoid_collisions and limit > done:
            hit = _first_invalid_motion(is_valid, batch_free, path, done, limit, largest[:limit - done], resolution)
            if hit is not None:
                s, values, at_state = hit
                limit, refine = s, False
                check_buffer[idx] = values
                stop_reason = STOP_COLLISION
                report = scene.check_collision(RobotState(model, check_buffer.copy()), max_contacts=3)
                what = "; ".join(str(c) for c in report.contacts) or "joint limits"
                detail = f"{'state' if at_state else 'motion to the state'} of step {s + 1} invalid: {what}"
        if path_constraints:
            for s in range(done, limit):
                previous, x = path[s], path[s + 1]
                delta = x - previous
                # the state, and the joint-space motion to it, every CONSTRAINT_CHECK_STEP
                between = max(1, int(math.ceil(float(np.abs(delta).max()) / CONSTRAINT_CHECK_STEP)))
                problem = None
                for j in range(between, 0, -1):
                    check_buffer[idx] = x if j == between else previous + (j / between) * delta
                    problem = path_constraints.violation(RobotState(model, check_buffer.copy()))
                    if problem:
                        break
                if problem:
                    limit, refine = s, False
                    stop_reason = STOP_PATH_CONSTRAINTS
                    detail = f"step {s + 1} violates the path constraints: {problem}"
                    break
        if refine:
            raise _RefineSteps()
        done = limit

    # MoveIt's relative jump test over the computed path.
    if jump_threshold > 0 and done + 1 >= MIN_STEPS_FOR_JUMP_THRESHOLD:
        distances = _step_distances(path[: done + 1], continuous)
        limit = jump_threshold * float(np.mean(distances))
        over = np.flatnonzero(distances > limit)
        if over.size:
            cut = int(over[0])  # the step from path[cut] to path[cut + 1] jumps
            detail = (f"joint-space jump at step {cut + 1}: {distances[cut]:.4f} > jump_threshold "
                      f"{jump_threshold:g} x mean step {limit / jump_threshold:.4f}")
            stop_reason = STOP_JOINT_JUMP
            done = cut

    path = path[: done + 1].copy()
    if done == n_steps:
        fraction = 1.0
    else:
        seg = int(segment_of[done])  # the segment of the first step not achieved
        first_of_seg = int(np.sum(steps_of[:seg]))
        fraction = (seg + (done - first_of_seg) / steps_of[seg]) / len(poses)
    if len(path) >= 2:
        try:
            trajectory = time_group_path(model, jmg, path, vel, acc, sample_period)
        except (PlanningError, ValueError) as exc:
            raise failure(MoveItErrorCode.PLANNING_FAILED, f"time parameterisation failed: {exc}") from None
    else:
        zeros = np.zeros_like(path)
        trajectory = TimedTrajectory(list(jmg.joint_names), np.zeros(1), path.copy(), zeros, zeros.copy())
    if stop_reason == STOP_COMPLETE:
        message = f"Cartesian path complete ({len(path) - 1} steps)"
    else:
        message = f"Cartesian path stopped at {100.0 * fraction:.2f}% ({stop_reason}): {detail}"
    return CartesianPathResult(
        error_code=MoveItErrorCode(MoveItErrorCode.SUCCESS, message),
        fraction=float(fraction),
        trajectory=trajectory,
        path=path,
        stop_reason=stop_reason,
        group_name=jmg.name,
        link=link,
        start_state=start,
        planning_time=time.perf_counter() - started,
    )


def _first_invalid_motion(is_valid: Callable[[np.ndarray], bool], batch_free: Callable[[np.ndarray], np.ndarray] | None,
                          path: np.ndarray, start: int, end: int, largest: np.ndarray,
                          resolution: float) -> tuple[int, np.ndarray, bool] | None:
    """The first invalid state of the motions from ``path[s]`` to ``path[s + 1]`` for steps
    ``start``..``end - 1``, each checked every ``resolution`` (max-norm; ``largest`` holds each
    step's largest joint motion) and at its end: (step, the invalid values, whether they are
    the step's state itself), or None when all are valid.

    All the states go through ``batch_free`` (the scene's batch sphere test, when it has one)
    in one call; ``is_valid`` (the exact check) then sees, in order, only those it left
    undecided. The verdicts are the exact check's: the sphere test never calls a colliding
    state free (test/core/test_batch_check.py)."""
    between = np.where(largest > resolution, np.ceil(largest / resolution), 1.0).astype(int)
    steps = np.arange(start, end)
    if np.all(between == 1):  # steps shorter than the resolution: the states alone
        values = path[start + 1:end + 1]
        step_of, at_state = steps, np.ones(len(steps), dtype=bool)
    else:
        step_of = np.repeat(steps, between)
        first = np.repeat(np.cumsum(between) - between, between)
        count = np.repeat(between, between)
        j = np.arange(len(step_of)) - first + 1  # 1..count within each step
        previous = path[step_of]
        values = previous + (j / count)[:, None] * (path[step_of + 1] - previous)
        at_state = j == count
        values[at_state] = path[step_of[at_state] + 1]
    free = batch_free(values) if batch_free is not None else np.zeros(len(values), dtype=bool)
    for i in np.flatnonzero(~free).tolist():
        state = values[i]
        if not is_valid(state):
            return int(step_of[i]), state.copy(), bool(at_state[i])
    return None


def _step_distances(path: np.ndarray, continuous: np.ndarray) -> np.ndarray:
    """MoveIt's RobotState::distance between consecutive states: sum of per-joint distances."""
    delta = np.abs(np.diff(path, axis=0))
    if continuous.any():
        delta[:, continuous] = np.minimum(delta[:, continuous], 2 * math.pi - delta[:, continuous])
    return delta.sum(axis=1)


