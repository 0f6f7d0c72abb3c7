"""Industrial motion generation: MoveIt's Pilz planner (PTP, LIN, CIRC) rebuilt on our core.

Why a second planner next to OMPL: industrial programs want *predictable* motion. PTP moves all
joints on one synchronised trapezoidal velocity profile (the same path every time, no sampling);
LIN moves the tool on a straight line, CIRC on a circular arc, both with a trapezoidal speed
profile under Cartesian limits (``config/pilz_cartesian_limits.yaml``). Nothing here searches
around obstacles: the motion is generated, then checked, and a colliding motion is reported the
way MoveIt reports it ("Invalid states at index locations: [ 4 5 ] out of 13"), which is what makes
the planner the cheap middle stage of an MTC Fallbacks container.

Behaviour, following MoveIt's ``pilz_industrial_motion_planner``:

* PTP: every joint moves from start to goal on a scaled copy of one trapezoidal profile, so all
  joints accelerate, cruise and decelerate together and stop together (Pilz's "full
  synchronisation"). The profile is the fastest one that keeps every joint within its own
  velocity/acceleration limit times the request's scaling. (Pilz itself applies the *most strict*
  limit of the group to every joint; with equal limits, as on the myCobot, the two are identical;
  with unequal ones, as on the Panda, ours is faster and still within each joint's limit.) Joint
  deceleration limits are not modelled by joint_limits.yaml here, so deceleration = acceleration.
* LIN: a straight line from the start pose (FK of the start state) to the goal pose, orientation
  interpolated about one fixed axis (slerp). As in Pilz (KDL ``Path_Line`` with an "equivalent
  radius" ``max_trans_vel / max_rot_vel``) the path parameter is the longer of the translation
  and the scaled rotation, so the translational speed stays under ``max_trans_vel`` and the
  rotational speed under ``max_rot_vel`` (both times the velocity scaling). Accelerations use
  ``max_trans_acc`` and ``|max_trans_dec|`` times the acceleration scaling.
* CIRC: an arc from the start to the goal position through a centre point (shorter arc, < 180
  degrees) or through an interim point (the arc that passes it, may exceed 180 degrees). Points
  that do not determine a circle (collinear) are rejected, like Pilz's "Circle_No_Plane".
* LIN/CIRC samples are converted to joint space by IK seeded with the previous sample (one
  IKSolver reused), and each sample's joint velocity and acceleration is checked against the
  joint limits (unscaled, as Pilz does: the scaling applies to the Cartesian limits); a failure
  gives NO_IK_SOLUTION (IK) or PLANNING_FAILED (limits), naming the sample.
* Afterwards every sample is checked against the planning scene. MoveIt's planning pipeline
  (``ValidateSolution`` response adapter) answers a colliding trajectory with INVALID_MOTION_PLAN
  and logs "Computed path is not valid. Invalid states at index locations: [ ... ] out of N"; we
  put that text and the first contact into the error message. We additionally check the motion
  *between* samples at ``collision_check_resolution`` (MoveIt only checks the samples; a 10 ms
  sample of a fast joint can step over a thin object).

Trajectory representation: samples every ``sample_time`` from t = 0, plus the last instant and
the profile's phase boundaries, which makes the PTP trajectory exact under the ``"cubic"``
interpolation of :class:`TimedTrajectory` (each interval is a single quadratic). LIN/CIRC
trajectories use ``"quintic"``: positions from IK, velocities and accelerations from the
Jacobian and its time derivative (not finite differences) for 6-joint groups, by central
differences for redundant groups (whose IK null-space motion has no closed form).

This module imports no ROS code.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Callable, Mapping

import numpy as np
import pinocchio as pin
import yaml

from interfaces_py.msgs import MoveItErrorCode

from ..paths import config_file
from .errors import PlanningError
from .kinematics import IKOptions, IKSolver
from .planning_interface import (
    JointGoal,
    MotionPlanRequest,
    MotionPlanResponse,
    NamedGoal,
    PlanningFailure,
    PoseGoal,
    check_group,
    check_pose_goal,
    check_request_numbers,
    check_scaling,
    failure,
    goal_state_in_scene,
    goal_states,
    joint_goal_vector,
    start_state_of,
    success,
)
from .planning_scene import PlanningScene
from .robot_model import JointModelGroup, RobotModel
from .robot_state import RobotState
from .robot_trajectory import TimedTrajectory

__all__ = [
    "CIRC",
    "COLLISION_ERROR_CODE",
    "CartesianLimits",
    "CartesianLimitsError",
    "DEFAULT_SAMPLE_TIME",
    "IndustrialMotionPlanner",
    "KNOWN_PLANNER_IDS",
    "LIN",
    "PILZ_PIPELINE_ID",
    "PTP",
    "TrapezoidProfile",
    "load_cartesian_limits",
    "plan_industrial",
    "sample_times",
]

PILZ_PIPELINE_ID = "pilz_industrial_motion_planner"
PTP, LIN, CIRC = "PTP", "LIN", "CIRC"
KNOWN_PLANNER_IDS = (PTP, LIN, CIRC)

#: Seconds between samples. (MoveIt's Pilz default ``max_sample_time`` is 0.1 s; a 10 ms grid is
#: what a ros2_control controller runs at and keeps the sample-only collision check meaningful.)
DEFAULT_SAMPLE_TIME = 0.01
#: Default joint step (rad or m, max over the group's joints) at which the motion between samples
#: is collision-checked, the trajectory validator's default resolution.
DEFAULT_COLLISION_CHECK_RESOLUTION = 0.005
#: MoveIt's code for a generated trajectory that fails the scene check (ValidateSolution adapter).
COLLISION_ERROR_CODE = MoveItErrorCode.INVALID_MOTION_PLAN

_CARTESIAN_KEYS = ("max_trans_vel", "max_trans_acc", "max_trans_dec", "max_rot_vel")
# Pilz's PathCircleGenerator tolerances: centre-to-start and centre-to-goal distances may differ
# by this much (m), and three points with |cross| of their unit directions below this are collinear.
_MAX_RADIUS_DIFF = 1e-2
_MAX_COLLINEAR_NORM = 1e-5
# Below this (rad or m, max over joints / path length) nothing moves: one-point trajectory.
_NO_MOTION = 1e-9
# Grid samples closer than this fraction of the sample time to a phase boundary or the end are
# dropped, so no interval is pathologically short (same rule as time_parameterization).
_MIN_SAMPLE_FRACTION = 0.01
# LIN/CIRC samples come from IK: intervals shorter than this fraction of the sample time would
# turn IK round-off into large apparent joint speeds, so the grid keeps its distance from phase
# boundaries.
_MIN_CARTESIAN_SAMPLE_FRACTION = 0.1
# Relative slack on the joint-limit checks of LIN/CIRC samples (rounding).
_LIMIT_SLACK = 1e-6
# IK tolerances for LIN/CIRC samples: far below the solver's defaults (1e-5 m, 1e-4 rad) because
# sample positions are differenced over a few milliseconds; Gauss-Newton converges
# quadratically, so this costs about one extra iteration per sample.
_TRACKING_IK = IKOptions(position_tolerance=1e-9, orientation_tolerance=1e-9)


class CartesianLimitsError(PlanningError, ValueError):
    """A pilz_cartesian_limits file or mapping is missing a value or holds an impossible one."""


# ---------------------------------------------------------------------------- Cartesian limits
@dataclass(frozen=True)
class CartesianLimits:
    """pilz_cartesian_limits.yaml: translational velocity/acceleration/deceleration, rotational
    velocity. ``max_trans_dec`` is negative, as in MoveIt's file."""

    max_trans_vel: float
    max_trans_acc: float
    max_trans_dec: float
    max_rot_vel: float

    @property
    def equivalent_radius(self) -> float:
        """Metres of path per radian of rotation (KDL's eqradius): with it, one speed limit on the
        path parameter keeps both the translational and the rotational speed within limits."""
        return self.max_trans_vel / self.max_rot_vel


def load_cartesian_limits(source: str | Path | Mapping | CartesianLimits | None = None) -> CartesianLimits:
    """Cartesian limits from a YAML file path, a mapping, or the package default file.

    The mapping may be the file's content (``{"cartesian_limits": {...}}``) or the inner mapping.
    All four values are required: max_trans_vel > 0, max_trans_acc > 0, max_trans_dec < 0 (a
    deceleration, MoveIt's sign convention), max_rot_vel > 0. Raises CartesianLimitsError naming
    the offending entry.
    """
    if isinstance(source, CartesianLimits):
        return source
    where = "cartesian limits"
    if source is None:
        source = config_file("pilz_cartesian_limits.yaml")
    if isinstance(source, (str, Path)):
        where = str(source)
        try:
            with open(source, encoding="utf-8") as handle:
                data = yaml.safe_load(handle)
        except OSError as exc:
            raise CartesianLimitsError(f"cannot read Cartesian limits file {source}: {exc}") from None
        except yaml.YAMLError as exc:
            raise CartesianLimitsError(f"{source} is not valid YAML: {exc}") from None
    else:
        data = source
    if not isinstance(data, Mapping):
        raise CartesianLimitsError(f"{where}: expected a mapping, got {type(data).__name__}")
    if "cartesian_limits" in data:
        extra = sorted(set(data) - {"cartesian_limits"})
        if extra:
            raise CartesianLimitsError(f"{where}: unknown top-level keys {extra}; expected only 'cartesian_limits'")
        data = data["cartesian_limits"]
        if not isinstance(data, Mapping):
            raise CartesianLimitsError(f"{where}: 'cartesian_limits' must be a mapping")
    unknown = sorted(set(data) - set(_CARTESIAN_KEYS))
    if unknown:
        raise CartesianLimitsError(f"{where}: unknown keys {unknown}; expected {list(_CARTESIAN_KEYS)}")
    missing = [k for k in _CARTESIAN_KEYS if k not in data]
    if missing:
        raise CartesianLimitsError(f"{where}: missing {missing}; all of {list(_CARTESIAN_KEYS)} are required")
    values = {}
    for key in _CARTESIAN_KEYS:
        value = data[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise CartesianLimitsError(f"{where}: {key} must be a finite number, got {value!r}")
        values[key] = float(value)
    for key in ("max_trans_vel", "max_trans_acc", "max_rot_vel"):
        if values[key] <= 0.0:
            raise CartesianLimitsError(f"{where}: {key} must be > 0, got {values[key]}")
    if values["max_trans_dec"] >= 0.0:
        raise CartesianLimitsError(
            f"{where}: max_trans_dec must be negative (a deceleration, as in MoveIt's "
            f"pilz_cartesian_limits.yaml), got {values['max_trans_dec']}"
        )
    return CartesianLimits(**values)


@lru_cache(maxsize=1)
def _default_cartesian_limits() -> CartesianLimits:
    return load_cartesian_limits(None)


# ---------------------------------------------------------------------------- velocity profile
class TrapezoidProfile:
    """Rest-to-rest trapezoidal (or triangular) velocity profile over ``distance`` >= 0 with
    separate acceleration and deceleration limits (KDL's VelocityProfile_ATrap role).

    Phases: accelerate for ``t_acc``, cruise at ``peak_velocity`` for ``t_cruise``, decelerate
    for ``t_dec``. :meth:`evaluate` is right-continuous in acceleration: at a phase boundary it
    returns the acceleration of the phase that starts there.
    """

    __slots__ = ("distance", "max_velocity", "max_acceleration", "max_deceleration",
                 "peak_velocity", "t_acc", "t_cruise", "t_dec")

    def __init__(self, distance: float, max_velocity: float, max_acceleration: float,
                 max_deceleration: float | None = None) -> None:
        if max_deceleration is None:
            max_deceleration = max_acceleration
        for name, value in (("max_velocity", max_velocity), ("max_acceleration", max_acceleration),
                            ("max_deceleration", max_deceleration)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"TrapezoidProfile: {name} must be finite and > 0, got {value}")
        if not (math.isfinite(distance) and distance >= 0.0):
            raise ValueError(f"TrapezoidProfile: distance must be finite and >= 0, got {distance}")
        v, a, d = float(max_velocity), float(max_acceleration), float(max_deceleration)
        self.distance = float(distance)
        self.max_velocity, self.max_acceleration, self.max_deceleration = v, a, d
        ramps = v * v / (2.0 * a) + v * v / (2.0 * d)
        if self.distance >= ramps:
            peak = v
            self.t_cruise = (self.distance - ramps) / v
        else:  # triangular: the peak speed the distance allows
            peak = math.sqrt(2.0 * self.distance * a * d / (a + d))
            self.t_cruise = 0.0
        self.peak_velocity = peak
        self.t_acc = peak / a
        self.t_dec = peak / d

    @property
    def duration(self) -> float:
        return self.t_acc + self.t_cruise + self.t_dec

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """Phase boundaries strictly inside (0, duration)."""
        points = [self.t_acc]
        if self.t_cruise > 0.0:
            points.append(self.t_acc + self.t_cruise)
        return tuple(p for p in points if 0.0 < p < self.duration)

    def evaluate(self, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity and acceleration along the profile at time(s) t (clamped to
        [0, duration]; at rest outside)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        a, d, vp = self.max_acceleration, self.max_deceleration, self.peak_velocity
        t1 = self.t_acc
        t2 = t1 + self.t_cruise
        total = self.duration
        s = np.empty_like(t)
        sd = np.empty_like(t)
        sdd = np.empty_like(t)
        p0 = t < t1
        p1 = (t >= t1) & (t < t2)
        p2 = (t >= t2) & (t < total)
        p3 = t >= total
        tt = np.maximum(t[p0], 0.0)
        s[p0], sd[p0], sdd[p0] = 0.5 * a * tt * tt, a * tt, a
        s[p1] = 0.5 * a * t1 * t1 + vp * (t[p1] - t1)
        sd[p1], sdd[p1] = vp, 0.0
        tau = total - t[p2]
        s[p2], sd[p2], sdd[p2] = self.distance - 0.5 * d * tau * tau, d * tau, -d
        s[p3], sd[p3], sdd[p3] = self.distance, 0.0, 0.0
        return s, sd, sdd


def sample_times(duration: float, breakpoints: tuple[float, ...], sample_time: float,
                 min_fraction: float = _MIN_SAMPLE_FRACTION) -> np.ndarray:
    """0, dt, 2dt, ... below the end, plus the phase boundaries and the end itself.

    Grid samples within ``min_fraction`` * dt of a boundary or the end are dropped (no
    near-zero intervals).
    """
    if duration <= 0.0:
        return np.zeros(1)
    n = int(math.floor(duration / sample_time + 1e-9))
    grid = sample_time * np.arange(n + 1)
    anchors = np.array([b for b in breakpoints if 0.0 < b < duration] + [duration])
    gap = np.min(np.abs(grid[:, None] - anchors[None, :]), axis=1)
    keep = (gap > min_fraction * sample_time) | (grid == 0.0)
    times = np.unique(np.concatenate([grid[keep], anchors]))
    times = times[times <= duration]
    # Points closer than 1 ns (a cruise phase of ~0 s) are merged, keeping 0 and the end.
    keep = np.ones(len(times), dtype=bool)
    for i in np.flatnonzero(np.diff(times) < 1e-9):
        keep[i if i + 1 == len(times) - 1 else i + 1] = False
    return times[keep]


# ---------------------------------------------------------------------------- planner
class IndustrialMotionPlanner:
    """The ``pilz_industrial_motion_planner`` pipeline: ``plan(scene, request)`` for planner ids
    PTP, LIN and CIRC, with Cartesian limits loaded once."""

    def __init__(self, cartesian_limits: str | Path | Mapping | CartesianLimits | None = None,
                 sample_time: float = DEFAULT_SAMPLE_TIME,
                 collision_check_resolution: float | None = DEFAULT_COLLISION_CHECK_RESOLUTION) -> None:
        self.cartesian_limits = (_default_cartesian_limits() if cartesian_limits is None
                                 else load_cartesian_limits(cartesian_limits))
        self.sample_time = sample_time
        self.collision_check_resolution = collision_check_resolution

    def plan(self, scene: PlanningScene, request: MotionPlanRequest) -> MotionPlanResponse:
        return plan_industrial(scene, request, self.cartesian_limits, self.sample_time,
                               collision_check_resolution=self.collision_check_resolution)


def plan_industrial(
    scene: PlanningScene,
    request: MotionPlanRequest,
    cartesian_limits: str | Path | Mapping | CartesianLimits | None = None,
    sample_time: float = DEFAULT_SAMPLE_TIME,
    *,
    collision_check_resolution: float | None = DEFAULT_COLLISION_CHECK_RESOLUTION,
) -> MotionPlanResponse:
    """Plan ``request`` with the industrial generator named by ``request.planner_id``.

    Never raises for bad input: the response's error code says what was wrong (MoveIt's codes).
    ``collision_check_resolution`` (joint units) also checks the motion between samples; None
    checks the samples only, as MoveIt does.
    """
    started = time.perf_counter()
    try:
        if request.planner_id not in KNOWN_PLANNER_IDS:
            raise failure(
                MoveItErrorCode.INVALID_MOTION_PLAN,
                f"unknown planner_id '{request.planner_id}' for {PILZ_PIPELINE_ID}; "
                f"known: {', '.join(KNOWN_PLANNER_IDS)}",
            )
        if isinstance(sample_time, bool) or not isinstance(sample_time, (int, float)) \
                or not math.isfinite(sample_time) or sample_time <= 0.0:
            raise failure(MoveItErrorCode.INVALID_MOTION_PLAN, f"sample_time must be > 0 s, got {sample_time!r}")
        if collision_check_resolution is not None and not (
            isinstance(collision_check_resolution, (int, float)) and math.isfinite(collision_check_resolution)
            and collision_check_resolution > 0.0
        ):
            raise failure(
                MoveItErrorCode.INVALID_MOTION_PLAN,
                f"collision_check_resolution must be > 0 or None, got {collision_check_resolution!r}",
            )
        limits = None
        if request.planner_id != PTP:
            try:
                limits = (_default_cartesian_limits() if cartesian_limits is None
                          else load_cartesian_limits(cartesian_limits))
            except CartesianLimitsError as exc:
                raise failure(MoveItErrorCode.INVALID_MOTION_PLAN, str(exc)) from None
        model = scene.robot_model
        check_request_numbers(request)
        jmg = check_group(model, request.group)
        vel_scale, acc_scale = check_scaling(model, request)
        start = start_state_of(scene, request)
        context = _Context(scene, model, jmg, start, float(sample_time), collision_check_resolution)
        if request.planner_id == PTP:
            trajectory, message = _plan_ptp(context, request, vel_scale, acc_scale)
        else:
            trajectory, message = _plan_cartesian(context, request, limits, vel_scale, acc_scale)
        return success(trajectory, started, request, start, path=trajectory.positions, message=message)
    except PlanningFailure as exc:
        return exc.to_response(started, request)


@dataclass
class _Context:
    scene: PlanningScene
    model: RobotModel
    jmg: JointModelGroup
    start: RobotState
    sample_time: float
    resolution: float | None


# ---------------------------------------------------------------------------- PTP
def _plan_ptp(ctx: _Context, request: MotionPlanRequest, vel_scale: float, acc_scale: float
              ) -> tuple[TimedTrajectory, str]:
    model, jmg = ctx.model, ctx.jmg
    idx = jmg.variable_indices
    names = list(jmg.joint_names)
    if isinstance(request.goal, PoseGoal):
        timeout = float(model.kinematics(jmg.name)["kinematics_solver_timeout"])
        rng = np.random.default_rng(request.seed)
        # Nearest (to the start) of the collision-free IK solutions, searched from the start.
        goal = goal_states(ctx.scene, jmg, ctx.start, request.goal, max(1, request.num_ik_goals), timeout, rng)[0]
    else:
        goal = _joint_goal_state(ctx, request.goal)
    q0 = ctx.start.positions[idx].copy()
    q1 = goal.positions[idx].copy()
    delta = q1 - q0
    moving = np.abs(delta) > _NO_MOTION
    if not moving.any():
        trajectory = TimedTrajectory(names, [0.0], q0[None, :], np.zeros((1, len(idx))), np.zeros((1, len(idx))),
                                     interpolation="cubic")
        return trajectory, "PTP: goal already reached (one point)"
    vmax = model.velocity_limits[idx] * vel_scale
    amax = model.acceleration_limits[idx] * acc_scale
    dist = np.abs(delta[moving])
    # Normalised progress s in [0, 1]: joint j moves delta_j * s(t). The fastest s keeping every
    # joint within its limits has these bounds; all joints then share one profile's phases.
    profile = TrapezoidProfile(
        1.0,
        float(np.min(vmax[moving] / dist)),
        float(np.min(amax[moving] / dist)),
    )
    # Pilz's leading axis: the joint whose own fastest profile takes longest.
    own = [TrapezoidProfile(float(d), float(v), float(a)).duration for d, v, a in zip(dist, vmax[moving], amax[moving])]
    leading = np.array(names)[moving][int(np.argmax(own))]
    times = sample_times(profile.duration, profile.breakpoints, ctx.sample_time)
    s, sd, sdd = profile.evaluate(times)
    positions = q0[None, :] + s[:, None] * delta[None, :]
    velocities = sd[:, None] * delta[None, :]
    accelerations = sdd[:, None] * delta[None, :]
    positions[-1] = q1
    velocities[-1] = 0.0
    accelerations[-1] = 0.0

    def between(intervals: np.ndarray, fractions: np.ndarray) -> np.ndarray:
        t = times[intervals] + fractions * (times[intervals + 1] - times[intervals])
        return q0[None, :] + profile.evaluate(t)[0][:, None] * delta[None, :]

    _check_in_scene(ctx, positions, between)
    trajectory = TimedTrajectory(names, times, positions, velocities, accelerations, interpolation="cubic")
    message = (f"PTP: {len(times)} samples, {profile.duration:.3f} s, leading axis {leading}")
    return trajectory, message


def _joint_goal_state(ctx: _Context, goal: object) -> RobotState:
    if not isinstance(goal, (JointGoal, NamedGoal)):
        raise failure(MoveItErrorCode.UNRECOGNIZED_GOAL_TYPE, f"unrecognised goal type {type(goal).__name__}")
    state = ctx.start.copy()
    state.set_group_positions(ctx.jmg.name, joint_goal_vector(ctx.model, ctx.jmg, goal))
    goal_state_in_scene(ctx.scene, state)
    return state


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
def _plan_cartesian(ctx: _Context, request: MotionPlanRequest, limits: CartesianLimits,
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
        goal_pose = _joint_goal_state(ctx, goal).frame_pose(link)
    try:
        solver = IKSolver(model, jmg.name, link, offset, options=_TRACKING_IK)
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
    if path.length <= _NO_MOTION:
        zeros = np.zeros((1, len(idx)))
        trajectory = TimedTrajectory(names, [0.0], q0[None, :], zeros, zeros.copy(), interpolation="quintic")
        return trajectory, f"{request.planner_id}: goal pose already reached (one point)"
    profile = TrapezoidProfile(
        path.length,
        limits.max_trans_vel * vel_scale,
        limits.max_trans_acc * acc_scale,
        -limits.max_trans_dec * acc_scale,
    )
    times = sample_times(profile.duration, profile.breakpoints, ctx.sample_time, _MIN_CARTESIAN_SAMPLE_FRACTION)
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
        over = np.flatnonzero(step > vmax * (1.0 + _LIMIT_SLACK) + 1e-9)
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
        if np.max(ratio) > 1.0 + _LIMIT_SLACK:
            i, j = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
            raise failure(
                MoveItErrorCode.PLANNING_FAILED,
                f"{request.planner_id}: joint {what} limit of {names[j]} violated at sample {i} of {n} "
                f"(t={times[i]:.3f} s): {abs(values[i, j]):.4f} > {limit[j]:.4f}; lower {hint}",
            )

    def between(intervals: np.ndarray, fractions: np.ndarray) -> np.ndarray:
        return positions[intervals] + fractions[:, None] * (positions[intervals + 1] - positions[intervals])

    _check_in_scene(ctx, positions, between)
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


def _joint_derivatives(ctx: _Context, solver: IKSolver, offset_pose: np.ndarray, positions: np.ndarray,
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


# ---------------------------------------------------------------------------- scene check
def _check_in_scene(ctx: _Context, positions: np.ndarray,
                    between: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> None:
    """Every sample (and, at ctx.resolution, the motion between samples) must be valid in the
    scene; otherwise COLLISION_ERROR_CODE with MoveIt's "Invalid states at index locations" text
    and the first contact.

    ``between(intervals, fractions)`` gives the group positions at those fractions of those
    sample intervals (vectorised: one call for the whole trajectory). Rows are built as full
    robot vectors up front so the loop is nothing but the scene's hot-path check.
    """
    is_valid = ctx.scene.is_valid_positions
    n = len(positions)
    fulls = _full_rows(ctx, positions)
    invalid = [i for i in range(n) if not is_valid(fulls[i])]
    if invalid:
        raise failure(
            COLLISION_ERROR_CODE,
            "Computed path is not valid. Invalid states at index locations: [ "
            + "".join(f"{i} " for i in invalid)
            + f"] out of {n}; " + _explain(ctx, fulls[invalid[0]]),
        )
    if ctx.resolution is None or n < 2:
        return
    steps = np.max(np.abs(np.diff(positions, axis=0)), axis=1)
    counts = np.ceil(steps / ctx.resolution).astype(int)
    counts[steps <= ctx.resolution] = 1
    if not np.any(counts > 1):
        return
    intervals = np.repeat(np.arange(n - 1), counts - 1)
    # k-th of (count - 1) intermediate states of an interval sits at fraction k / count.
    first = np.cumsum(counts - 1) - (counts - 1)
    k = np.arange(len(intervals)) - np.repeat(first, counts - 1) + 1
    fractions = k / counts[intervals]
    rows = _full_rows(ctx, between(intervals, fractions))
    for j in range(len(rows)):
        if not is_valid(rows[j]):
            i = int(intervals[j])
            raise failure(
                COLLISION_ERROR_CODE,
                f"Computed path is not valid. The motion between index locations {i} and {i + 1} "
                f"(out of {n}) is invalid although both states are valid; " + _explain(ctx, rows[j]),
            )


def _full_rows(ctx: _Context, group_rows: np.ndarray) -> np.ndarray:
    fulls = np.repeat(ctx.start.positions[None, :], len(group_rows), axis=0)
    fulls[:, ctx.jmg.variable_indices] = group_rows
    return fulls


def _explain(ctx: _Context, full: np.ndarray) -> str:
    """The first contact of an invalid state (or the joint limits it violates)."""
    state = RobotState(ctx.model, full)
    report = ctx.scene.check_collision(state, max_contacts=1)
    if report.collision and report.contacts:
        return str(report.contacts[0])
    violated = state.violated_bounds()
    if violated:
        return "joint limits violated: " + "; ".join(violated)
    return "state invalid"
