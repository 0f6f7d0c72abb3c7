"""LIN and CIRC: straight-line and circular tool paths under Cartesian limits, followed by IK at every sample."""
from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from interfaces_py.msgs import MoveItErrorCode

from ...kinematics.ik_solver import IKSolver
from ...planning_interface.planning_interface import (
    MotionPlanRequest,
    PoseGoal,
    check_pose_goal,
    failure,
)
from ...robot_state.robot_state import RobotState
from ...robot_trajectory.robot_trajectory import TimedTrajectory
from .common import (
    LIMIT_SLACK,
    LIN,
    MIN_CARTESIAN_SAMPLE_FRACTION,
    NO_MOTION,
    TRACKING_IK,
    PilzContext,
    check_in_scene,
    joint_goal_state,
)
from .limits import CartesianLimits
from .trapezoid_profile import TrapezoidProfile, sample_times

# Pilz's PathCircleGenerator tolerances: centre-to-start and centre-to-goal distances may differ
# by this much (m), and three points with |cross| of their unit directions below this are collinear.
_MAX_RADIUS_DIFF = 1e-2
_MAX_COLLINEAR_NORM = 1e-5


# ---------------------------------------------------------------------------- Cartesian paths
class _CartesianPath:
    """Pose of the IK frame as a function of the path parameter s in [0, length]: position along
    a curve, orientation R0 * exp(axis * angle * s / length) (slerp about one fixed axis).

    ``length`` is the larger of the curve length and eqradius * rotation angle (KDL's rule), so a
    speed limit on s bounds both the translational and the rotational speed."""

    def _init_rotation(self, start: np.ndarray, goal: np.ndarray, geometric_length: float,
                       eqradius: float) -> None:
        self.rot0 = start[:3, :3].copy()
        self._rel = pin.log3(self.rot0.T @ goal[:3, :3])  # axis * angle in the start frame
        self.angle = float(np.linalg.norm(self._rel))
        self.length = max(geometric_length, eqradius * self.angle)
        # World angular velocity per unit of s (constant: the axis is fixed in the start frame).
        self.omega_per_s = (self.rot0 @ self._rel) / self.length if self.length > 0 else np.zeros(3)

    def rotations(self, s: np.ndarray) -> list[np.ndarray]:
        return [self.rot0 @ pin.exp3(self._rel * f) for f in s / self.length]

    def points(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions and their first and second derivatives with respect to s."""
        raise NotImplementedError


class _LinePath(_CartesianPath):
    def __init__(self, start: np.ndarray, goal: np.ndarray, eqradius: float) -> None:
        self.p0 = start[:3, 3].copy()
        self.delta = goal[:3, 3] - self.p0
        self._init_rotation(start, goal, float(np.linalg.norm(self.delta)), eqradius)

    def points(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        f = s / self.length
        pos = self.p0[None, :] + f[:, None] * self.delta[None, :]
        d1 = np.repeat((self.delta / self.length)[None, :], len(s), axis=0)
        return pos, d1, np.zeros_like(d1)


class _ArcPath(_CartesianPath):
    """Arc about ``centre`` in the plane with unit ``normal``, from the start position, sweeping
    ``alpha`` counter-clockwise about the normal. The radius is blended linearly from the start's
    to the goal's (they differ by at most Pilz's 1 cm tolerance for a centre point; zero for an
    interim point), so the arc ends exactly at the goal."""

    def __init__(self, start: np.ndarray, goal: np.ndarray, centre: np.ndarray, normal: np.ndarray,
                 alpha: float, eqradius: float) -> None:
        p0, p1 = start[:3, 3], goal[:3, 3]
        self.centre = centre
        self.radius0 = float(np.linalg.norm(p0 - centre))
        self.radius1 = float(np.linalg.norm(p1 - centre))
        self.u = (p0 - centre) / self.radius0
        self.w = np.cross(normal, self.u)
        self.alpha = alpha
        self._init_rotation(start, goal, 0.5 * (self.radius0 + self.radius1) * alpha, eqradius)

    def points(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        f = s / self.length
        phi = self.alpha * f
        dr = self.radius1 - self.radius0
        radius = (self.radius0 + dr * f)[:, None]
        cos, sin = np.cos(phi)[:, None], np.sin(phi)[:, None]
        radial = cos * self.u[None, :] + sin * self.w[None, :]
        tangent = -sin * self.u[None, :] + cos * self.w[None, :]
        k = 1.0 / self.length
        pos = self.centre[None, :] + radius * radial
        d1 = k * (dr * radial + radius * self.alpha * tangent)
        d2 = k * k * (2.0 * dr * self.alpha * tangent - radius * self.alpha ** 2 * radial)
        return pos, d1, d2


def _make_arc(start: np.ndarray, goal: np.ndarray, request: MotionPlanRequest, eqradius: float) -> _ArcPath:
    """The CIRC arc from the request's centre or interim point, or INVALID_MOTION_PLAN."""
    given = [(n, v) for n, v in (("circ_center", request.circ_center), ("circ_interim", request.circ_interim))
             if v is not None]
    if len(given) != 1:
        raise failure(
            MoveItErrorCode.INVALID_MOTION_PLAN,
            "CIRC needs exactly one auxiliary point: circ_center or circ_interim "
            f"({'both' if given else 'neither'} given)",
        )
    kind, raw = given[0]
    try:
        point = np.array(raw, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise failure(MoveItErrorCode.INVALID_MOTION_PLAN, f"CIRC {kind} is not a 3-vector: {raw!r}") from None
    if point.shape != (3,) or not np.all(np.isfinite(point)):
        raise failure(MoveItErrorCode.INVALID_MOTION_PLAN, f"CIRC {kind} must be 3 finite numbers, got {raw!r}")
    p0, p1 = start[:3, 3], goal[:3, 3]

    def unit(v: np.ndarray) -> np.ndarray:
        n = np.linalg.norm(v)
        return v / n if n > 0 else v

    if kind == "circ_center":
        centre = point
        a, b = float(np.linalg.norm(p0 - centre)), float(np.linalg.norm(p1 - centre))
        if abs(a - b) > _MAX_RADIUS_DIFF:
            raise failure(
                MoveItErrorCode.INVALID_MOTION_PLAN,
                f"CIRC centre {centre.round(4).tolist()} is {a:.4f} m from the start but {b:.4f} m from the "
                f"goal (they may differ by {_MAX_RADIUS_DIFF} m): no circle through both",
            )
        cross = np.cross(unit(p0 - centre), unit(p1 - centre))
        if a < 1e-9 or b < 1e-9 or np.linalg.norm(cross) < _MAX_COLLINEAR_NORM:
            raise failure(
                MoveItErrorCode.INVALID_MOTION_PLAN,
                f"CIRC start {p0.round(4).tolist()}, centre {centre.round(4).tolist()} and goal "
                f"{p1.round(4).tolist()} are collinear: the circle's plane is undetermined "
                "(for a half circle give an interim point instead of the centre)",
            )
        normal = unit(cross)  # the shorter arc (< 180 degrees) turns about it
    else:
        interim = point
        t, v = interim - p0, p1 - p0
        cross = np.cross(t, v)
        if min(np.linalg.norm(t), np.linalg.norm(v), np.linalg.norm(p1 - interim)) < 1e-9 \
                or np.linalg.norm(np.cross(unit(t), unit(v))) < _MAX_COLLINEAR_NORM:
            raise failure(
                MoveItErrorCode.INVALID_MOTION_PLAN,
                f"CIRC start {p0.round(4).tolist()}, interim {interim.round(4).tolist()} and goal "
                f"{p1.round(4).tolist()} are collinear (or coincide): they determine no circle",
            )
        # Circumcentre of the triangle (start, interim, goal).
        centre = p0 + (np.dot(t, t) * np.cross(v, cross) + np.dot(v, v) * np.cross(cross, t)) / (
            2.0 * float(np.dot(cross, cross)))
        # Start -> interim -> goal runs counter-clockwise about the triangle's normal, so sweeping
        # about it from the start meets the interim point before the goal.
        normal = unit(cross)
    u = unit(p0 - centre)
    w = np.cross(normal, u)
    alpha = math.atan2(float(np.dot(p1 - centre, w)), float(np.dot(p1 - centre, u))) % (2.0 * math.pi)
    return _ArcPath(start, goal, centre, normal, alpha, eqradius)


# ---------------------------------------------------------------------------- LIN / CIRC
def plan_lin_circ(ctx: PilzContext, request: MotionPlanRequest, limits: CartesianLimits,
                    vel_scale: float, acc_scale: float) -> tuple[TimedTrajectory, str]:
    model, jmg = ctx.model, ctx.jmg
    idx = jmg.variable_indices
    names = list(jmg.joint_names)
    goal = request.goal
    offset = None
    if isinstance(goal, PoseGoal):
        link, goal_pose = check_pose_goal(model, jmg, goal)
        offset = goal.ik_frame_offset
    else:
        link = jmg.tip_link
        goal_pose = joint_goal_state(ctx, goal).frame_pose(link)
    try:
        solver = IKSolver(model, jmg.name, link, offset, options=TRACKING_IK)
    except ValueError as exc:
        raise failure(MoveItErrorCode.INVALID_LINK_NAME, str(exc)) from None
    offset_pose = np.eye(4) if offset is None else np.asarray(offset, dtype=float)
    start_pose = ctx.start.frame_pose(link) @ offset_pose
    eqradius = limits.equivalent_radius
    if request.planner_id == LIN:
        path: _CartesianPath = _LinePath(start_pose, goal_pose, eqradius)
    else:
        path = _make_arc(start_pose, goal_pose, request, eqradius)
    q0 = ctx.start.positions[idx].copy()
    if path.length <= NO_MOTION:
        zeros = np.zeros((1, len(idx)))
        trajectory = TimedTrajectory(names, [0.0], q0[None, :], zeros, zeros.copy(), interpolation="quintic")
        return trajectory, f"{request.planner_id}: goal pose already reached (one point)"
    profile = TrapezoidProfile(
        path.length,
        limits.max_trans_vel * vel_scale,
        limits.max_trans_acc * acc_scale,
        -limits.max_trans_dec * acc_scale,
    )
    times = sample_times(profile.duration, profile.breakpoints, ctx.sample_time, MIN_CARTESIAN_SAMPLE_FRACTION)
    s, sd, sdd = profile.evaluate(times)
    pos, d1, d2 = path.points(s)
    rotations = path.rotations(s)
    lin_vel = d1 * sd[:, None]
    lin_acc = d2 * (sd * sd)[:, None] + d1 * sdd[:, None]
    ang_vel = path.omega_per_s[None, :] * sd[:, None]
    ang_acc = path.omega_per_s[None, :] * sdd[:, None]

    n = len(times)
    positions = np.empty((n, len(idx)))
    positions[0] = q0
    kin_timeout = float(model.kinematics(jmg.name)["kinematics_solver_timeout"])
    vmax = model.velocity_limits[idx]
    amax = model.acceleration_limits[idx]
    state = ctx.start.copy()
    target = np.eye(4)
    for i in range(1, n):
        target[:3, :3] = rotations[i]
        target[:3, 3] = pos[i]
        h = times[i] - times[i - 1]
        solution = _track_ik(solver, target, state, vmax * h * 1.5 + 1e-3, kin_timeout)
        if solution is None:
            raise failure(
                MoveItErrorCode.NO_IK_SOLUTION,
                f"{request.planner_id}: no IK solution for sample {i} of {n} (t={times[i]:.3f} s) at position "
                f"{np.round(pos[i], 4).tolist()} for link '{link}' of group '{jmg.name}'",
            )
        positions[i] = solution.positions[idx]
        # Pilz's check between samples: the joint speed implied by consecutive IK solutions.
        step = np.abs(positions[i] - positions[i - 1]) / h
        over = np.flatnonzero(step > vmax * (1.0 + LIMIT_SLACK) + 1e-9)
        if over.size:
            j = int(over[0])
            raise failure(
                MoveItErrorCode.PLANNING_FAILED,
                f"{request.planner_id}: joint velocity limit of {names[j]} violated between samples {i - 1} and "
                f"{i} of {n} (t={times[i]:.3f} s): {step[j]:.4f} rad/s > {vmax[j]:.4f} (IK branch switch or "
                "singularity on the path, or lower max_velocity_scaling_factor)",
            )
        state = solution

    velocities, accelerations = _joint_derivatives(
        ctx, solver, offset_pose, positions, times, lin_vel, ang_vel, lin_acc, ang_acc)
    velocities[0] = 0.0
    velocities[-1] = 0.0
    accelerations[-1] = 0.0
    for what, values, limit, hint in (
        ("velocity", velocities, vmax, "max_velocity_scaling_factor"),
        ("acceleration", accelerations, amax, "max_acceleration_scaling_factor"),
    ):
        ratio = np.abs(values) / limit[None, :]
        if np.max(ratio) > 1.0 + LIMIT_SLACK:
            i, j = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
            raise failure(
                MoveItErrorCode.PLANNING_FAILED,
                f"{request.planner_id}: joint {what} limit of {names[j]} violated at sample {i} of {n} "
                f"(t={times[i]:.3f} s): {abs(values[i, j]):.4f} > {limit[j]:.4f}; lower {hint}",
            )

    def between(intervals: np.ndarray, fractions: np.ndarray) -> np.ndarray:
        return positions[intervals] + fractions[:, None] * (positions[intervals + 1] - positions[intervals])

    check_in_scene(ctx, positions, between)
    trajectory = TimedTrajectory(names, times, positions, velocities, accelerations, interpolation="quintic")
    shape = "line" if request.planner_id == LIN else "arc"
    message = (f"{request.planner_id}: {n} samples, {profile.duration:.3f} s, {shape} of "
               f"{path.length:.4f} m (path parameter) for '{link}'")
    return trajectory, message


def _track_ik(solver: IKSolver, target: np.ndarray, previous: RobotState, max_step: np.ndarray,
              timeout: float) -> RobotState | None:
    """IK for the next sample, staying on the previous sample's branch when possible.

    The solver may start from a precomputed table seed before the given one; the first call only
    accepts solutions within max_step of the previous sample and allows enough attempts for the
    seed's own descent, so a table seed on another branch cannot win. Without such a solution any
    solution is returned, and the caller's velocity check then names the jump (PLANNING_FAILED,
    as Pilz), rather than calling a reachable pose unreachable."""
    idx = solver.group.variable_indices
    prev = previous.positions[idx]

    def near(state: RobotState) -> bool:
        return bool(np.all(np.abs(state.positions[idx] - prev) <= max_step))

    attempts = solver.options.seed_neighbours + 1
    found = solver.solve(target, seed=previous, timeout=timeout, max_solutions=1, min_solution_distance=0.0,
                         validity=near, attempts=attempts)
    if found:
        return found[0]
    found = solver.solve(target, seed=previous, timeout=timeout, max_solutions=1, min_solution_distance=0.0)
    return found[0] if found else None


def _joint_derivatives(ctx: PilzContext, solver: IKSolver, offset_pose: np.ndarray, positions: np.ndarray,
                       times: np.ndarray, lin_vel: np.ndarray, ang_vel: np.ndarray, lin_acc: np.ndarray,
                       ang_acc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Joint velocities/accelerations realising the Cartesian twist and its derivative.

    6-joint groups: qd = J^-1 [v; w], qdd = J^-1 ([a; alpha] - Jdot qd) with J of the link at its
    origin (world-aligned), the IK frame's offset moved to the link origin by rigid-body
    kinematics. Other groups: central differences of the IK positions (redundant IK's null-space
    motion has no closed form)."""
    model, jmg = ctx.model, ctx.jmg
    idx = jmg.variable_indices
    n, dof = positions.shape
    if dof != 6:
        if n < 3:
            return np.zeros_like(positions), np.zeros_like(positions)
        velocities = np.gradient(positions, times, axis=0)
        velocities[0] = velocities[-1] = 0.0  # at rest at both ends, as the profile is
        return velocities, np.gradient(velocities, times, axis=0)
    pmodel, pdata = model.pin_model, model.pin_data
    fid = solver.frame_id
    jmap = model.jacobian_map(idx)
    world = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    full = ctx.start.positions.copy()
    offset_p = offset_pose[:3, 3]
    velocities = np.empty_like(positions)
    accelerations = np.empty_like(positions)
    for i in range(n):
        full[idx] = positions[i]
        q = model.to_q(full)
        pin.computeJointJacobians(pmodel, pdata, q)
        placement = pin.updateFramePlacement(pmodel, pdata, fid)
        jac = pin.getFrameJacobian(pmodel, pdata, fid, world) @ jmap
        r = placement.rotation @ offset_p  # link origin -> IK frame origin, world axes
        w, alpha = ang_vel[i], ang_acc[i]
        w_r = _cross(w, r)
        twist = np.concatenate([lin_vel[i] - w_r, w])
        qd = _solve(jac, twist)
        pin.computeJointJacobiansTimeVariation(pmodel, pdata, q, jmap @ qd)
        jdot = pin.getFrameJacobianTimeVariation(pmodel, pdata, fid, world) @ jmap
        a_link = lin_acc[i] - _cross(alpha, r) - _cross(w, w_r)
        velocities[i] = qd
        accelerations[i] = _solve(jac, np.concatenate([a_link, alpha]) - jdot @ qd)
    return velocities, accelerations


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """3-vector cross product (np.cross costs ~20 us of argument handling per call)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _solve(jac: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """J x = rhs for a square Jacobian, least squares when it is singular."""
    try:
        return np.linalg.solve(jac, rhs)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(jac, rhs, rcond=None)[0]

