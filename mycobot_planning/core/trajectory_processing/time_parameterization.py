"""Time parameterisation of collision-checked joint-space paths (MoveIt's TOTG / Ruckig role).

``time_parameterize`` checks the input and picks a method: "segments" (exact on the polyline,
one Ruckig profile per straight run) or "smooth" (discrete TOPP along a curve within
``max_deviation``); "auto" picks by the path's shape. docs/time_parameterization.md explains
both and the trajectory form they return. No ROS dependency.
"""
from __future__ import annotations

import math
from typing import Literal, Sequence

import numpy as np

from ..errors import TimeParameterizationError
from ..robot_trajectory.robot_trajectory import DEFAULT_SAMPLE_PERIOD, TimedTrajectory, positive_float
from .dense_path_topp import DEFAULT_MAX_DEVIATION, SMOOTH_MAX_TURN, path_deviation, time_smooth_path
from .path_geometry import drop_duplicates, turning_angles, validate_path
from .ruckig_segments import time_segments

__all__ = [
    "DEFAULT_MAX_DEVIATION",
    "DEFAULT_SAMPLE_PERIOD",
    "TimeParameterizationError",
    "TimedTrajectory",
    "path_deviation",
    "retime",
    "time_parameterize",
]


def time_parameterize(
    path: np.ndarray | Sequence[Sequence[float]],
    max_velocity: float | Sequence[float] | np.ndarray,
    max_acceleration: float | Sequence[float] | np.ndarray,
    max_jerk: float | Sequence[float] | np.ndarray | None = None,
    velocity_scaling: float = 1.0,
    acceleration_scaling: float = 1.0,
    joint_names: Sequence[str] | None = None,
    sample_period: float | None = None,
    path_tolerance: float = 0.0,
    method: Literal["segments", "smooth", "auto"] = "segments",
    max_deviation: float = DEFAULT_MAX_DEVIATION,
) -> TimedTrajectory:
    """Time a joint-space path: per straight segment, exactly on the polyline (``"segments"``,
    default), or near time-optimal along a smooth curve through the waypoints (``"smooth"``).

    Args:
        path: (N, d) waypoints; consecutive duplicates are dropped.
        max_velocity, max_acceleration: per-joint limits (scalar or (d,)), > 0, finite.
        max_jerk: per-joint jerk limits, or None for acceleration-limited (infinite-jerk)
            trapezoidal profiles. ``inf`` entries mean the same as None.
        velocity_scaling, acceleration_scaling: MoveIt-style factors in (0, 1].
        joint_names: d names; default ``joint_0 .. joint_{d-1}``.
        sample_period: None keeps only the polynomial breakpoints and waypoint instants
            (exact, compact); a period (e.g. :data:`DEFAULT_SAMPLE_PERIOD`) adds exact samples
            at that period (see :meth:`TimedTrajectory.resample`). Both use cubic
            interpolation and are exact.
        path_tolerance: how far (joint-space Euclidean norm) the trajectory may round a corner
            waypoint to avoid stopping there. 0 (default) follows the polyline exactly and stops
            at every non-collinear waypoint. Only allowed without a jerk limit. Applies to
            ``method="segments"``.
        method: ``"segments"`` (default) times each straight run with its own Ruckig profile
            and stays exactly on the polyline, resting at every real corner (see the module
            docstring). ``"smooth"`` passes through every waypoint along a C2 spline that stays
            within ``max_deviation`` of the polyline, with near time-optimal path speeds
            (discrete TOPP, see "Dense curved paths" in the module docstring); it rests only at
            the ends and at bends sharper than 0.35 rad, and needs ``max_jerk=None`` and
            ``path_tolerance=0``. ``"auto"`` picks ``"smooth"`` for paths with at least one
            gentle bend (densely sampled curves such as Cartesian paths) when those conditions
            hold, else ``"segments"``.
        max_deviation: largest distance (joint-space Euclidean norm) the ``"smooth"``
            trajectory may keep from the polyline.

    Returns:
        A trajectory that starts and ends at rest, passes through every waypoint (or within
        ``path_tolerance`` of corner waypoints) and respects the scaled limits. With
        ``"smooth"`` it stays within ``max_deviation`` of the polyline between waypoints
        (:func:`path_deviation`).

    Raises:
        TimeParameterizationError (a ValueError) on bad input, naming the problem.
    """
    pts = validate_path(path)
    d = pts.shape[1]
    vmax = _limit_vector(max_velocity, d, "max_velocity")
    amax = _limit_vector(max_acceleration, d, "max_acceleration")
    jmax = (np.full(d, math.inf) if max_jerk is None
            else _limit_vector(max_jerk, d, "max_jerk", allow_inf=True))
    vmax = vmax * _scaling(velocity_scaling, "velocity_scaling")
    amax = amax * _scaling(acceleration_scaling, "acceleration_scaling")
    if joint_names is None:
        names = [f"joint_{i}" for i in range(d)]
    else:
        names = [str(n) for n in joint_names]
        if len(names) != d:
            raise TimeParameterizationError(
                f"joint_names has {len(names)} entries but the path has {d} joints")
        if len(set(names)) != d:
            raise TimeParameterizationError(f"joint_names contains duplicates: {names}")
    if sample_period is not None:
        sample_period = positive_float(sample_period, "sample_period")
    try:
        tol = float(path_tolerance)
    except (TypeError, ValueError):
        raise TimeParameterizationError(
            f"path_tolerance must be a number, got {path_tolerance!r}") from None
    if not math.isfinite(tol) or tol < 0.0:
        raise TimeParameterizationError(
            f"path_tolerance must be finite and >= 0, got {path_tolerance!r}")
    if tol > 0.0 and np.any(np.isfinite(jmax)):
        raise TimeParameterizationError(
            "path_tolerance > 0 (corner blending) needs an acceleration step at the blend and is "
            "only supported without max_jerk; use path_tolerance=0 with jerk limits")

    if method not in ("segments", "smooth", "auto"):
        raise TimeParameterizationError(
            f"unknown method {method!r}; expected 'segments', 'smooth' or 'auto'")
    try:
        max_dev = float(max_deviation)
    except (TypeError, ValueError):
        raise TimeParameterizationError(
            f"max_deviation must be a number, got {max_deviation!r}") from None
    if not math.isfinite(max_dev) or max_dev <= 0.0:
        raise TimeParameterizationError(
            f"max_deviation must be finite and > 0, got {max_deviation!r}")
    if method == "smooth" and np.any(np.isfinite(jmax)):
        raise TimeParameterizationError(
            "method 'smooth' is acceleration-limited and does not support max_jerk; use "
            "method='segments' (or 'auto') with jerk limits")
    if method == "smooth" and tol > 0.0:
        raise TimeParameterizationError(
            "path_tolerance applies to method 'segments'; method 'smooth' is bounded by "
            "max_deviation")

    pts = drop_duplicates(pts)
    if method == "auto":
        method = _choose_method(pts, jmax, tol)
    if method == "smooth":
        traj = time_smooth_path(pts, vmax, amax, names, max_dev)
    else:
        traj = time_segments(pts, vmax, amax, jmax, tol, names)
    if sample_period is not None:
        traj = traj.resample(sample_period)
    return traj


def retime(
    trajectory_or_path: TimedTrajectory | np.ndarray | Sequence[Sequence[float]],
    max_velocity: float | Sequence[float] | np.ndarray,
    max_acceleration: float | Sequence[float] | np.ndarray,
    max_jerk: float | Sequence[float] | np.ndarray | None = None,
    velocity_scaling: float = 1.0,
    acceleration_scaling: float = 1.0,
    joint_names: Sequence[str] | None = None,
    sample_period: float | None = None,
    path_tolerance: float = 0.0,
    method: Literal["segments", "smooth", "auto"] = "segments",
    max_deviation: float = DEFAULT_MAX_DEVIATION,
) -> TimedTrajectory:
    """Re-time an existing trajectory (or a bare path) under new limits/scaling factors.

    For a :class:`TimedTrajectory` its geometric ``path`` is re-timed when known (so sampled
    points and blend arcs are not mistaken for waypoints), else its stored positions are the
    path; its joint names are kept unless ``joint_names`` is given.
    """
    if isinstance(trajectory_or_path, TimedTrajectory):
        src = trajectory_or_path
        path = src.path if src.path is not None else src.positions
        names = src.joint_names if joint_names is None else joint_names
    else:
        path, names = trajectory_or_path, joint_names
    return time_parameterize(path, max_velocity, max_acceleration, max_jerk=max_jerk,
                             velocity_scaling=velocity_scaling,
                             acceleration_scaling=acceleration_scaling, joint_names=names,
                             sample_period=sample_period, path_tolerance=path_tolerance,
                             method=method, max_deviation=max_deviation)


def _limit_vector(value, d: int, what: str, allow_inf: bool = False) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise TimeParameterizationError(f"{what} must be numeric, got {value!r}") from None
    if arr.ndim == 0:
        arr = np.full(d, float(arr))
    if arr.shape != (d,):
        raise TimeParameterizationError(
            f"{what} has shape {arr.shape}, expected a scalar or ({d},) to match the path's "
            f"{d} joints")
    if np.any(np.isnan(arr)):
        raise TimeParameterizationError(f"{what} contains NaN: {arr.tolist()}")
    if not allow_inf and not np.all(np.isfinite(arr)):
        raise TimeParameterizationError(f"{what} must be finite: {arr.tolist()}")
    if np.any(arr <= 0.0):
        raise TimeParameterizationError(f"{what} must be positive for every joint: {arr.tolist()}")
    return arr


def _scaling(value: float, what: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TimeParameterizationError(f"{what} must be a number, got {value!r}") from None
    if not (0.0 < v <= 1.0):  # also rejects NaN
        raise TimeParameterizationError(f"{what} must be in (0, 1], got {value!r}")
    return v


def _choose_method(pts: np.ndarray, jmax: np.ndarray, tol: float) -> str:
    """'smooth' for paths with at least one gentle bend (dense curves: Cartesian paths, B-spline
    smoothed OMPL paths), else 'segments' (straight runs and real corners: exact and optimal)."""
    if pts.shape[0] < 3 or tol > 0.0 or np.any(np.isfinite(jmax)):
        return "segments"
    angle, bend = turning_angles(pts)
    return "smooth" if np.any(bend & (angle <= SMOOTH_MAX_TURN)) else "segments"

