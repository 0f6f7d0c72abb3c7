"""The last line before motion: a commanded trajectory's velocities and accelerations against the
joint limits.

Why a check of its own: the trajectory validator samples a TimedTrajectory densely and checks
collisions, which is the planner's job; a controller gets a trajectory_msgs message from anyone on
the network, possibly with positions only, and must refuse one that would whip the arm (1.5 rad in
1 ms) before anything moves. Both the planning server (before it sends) and the controllers
(before they follow) call this one function.

What it can prove from the points alone, for any trajectory whose motion between points is
continuously differentiable (every interpolation a controller uses):
- the mean velocity over a segment, |dq| / dt, is a velocity the motion reaches somewhere in the
  segment (mean value theorem), so it must be within the velocity limit;
- two consecutive mean velocities are velocities at two instants at most (dt1 + dt2) apart, so
  their difference divided by (dt1 + dt2) is at most the acceleration limit;
- velocities and accelerations the points state are checked as given.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

__all__ = ["DEFAULT_LIMIT_TOLERANCE", "motion_limit_problem"]

#: Relative slack on the velocity and acceleration limits (0.05: 5 % over a limit is refused).
#: Time parameterisation meets the limits to rounding; a sampled trajectory's finite differences
#: stay below them; the slack absorbs what an external planner's rounding adds.
DEFAULT_LIMIT_TOLERANCE = 0.05


def _limited(limits: np.ndarray) -> np.ndarray:
    """Limits as an array in which 'no limit' (non-positive, NaN or infinite) is +inf."""
    limits = np.asarray(limits, dtype=float)
    return np.where(np.isfinite(limits) & (limits > 0), limits, np.inf)


def _first(excess: np.ndarray) -> tuple[int, int] | None:
    if excess.size == 0 or not np.any(excess > 0):
        return None
    i, j = np.argwhere(excess > 0)[0]
    return int(i), int(j)


def motion_limit_problem(
    joint_names: Sequence[str],
    times: np.ndarray,
    positions: np.ndarray,
    velocities: np.ndarray | None,
    accelerations: np.ndarray | None,
    velocity_limits: np.ndarray,
    acceleration_limits: np.ndarray,
    tolerance: float = DEFAULT_LIMIT_TOLERANCE,
) -> str | None:
    """Why the trajectory exceeds a joint's velocity or acceleration limit (one sentence naming
    the joint, the point and by how much), or None.

    ``times`` (n,) strictly increasing; ``positions`` (n, d); ``velocities`` / ``accelerations``
    (n, d) or None when the points do not give them; limits (d,) in the same joint order.
    """
    times = np.asarray(times, dtype=float)
    pos = np.asarray(positions, dtype=float)
    vmax = _limited(velocity_limits) * (1.0 + tolerance)
    amax = _limited(acceleration_limits) * (1.0 + tolerance)
    names = list(joint_names)

    def sentence(point: int, j: int, kind: str, value: float, limit: float, how: str) -> str:
        nominal = limit / (1.0 + tolerance)
        return (f"trajectory point {point}: joint '{names[j]}' {kind} {abs(value):.4g} {how}exceeds its limit "
                f"{nominal:.4g} ({abs(value) / nominal:.3g}x; tolerance {tolerance:.0%})")

    if velocities is not None:
        vel = np.asarray(velocities, dtype=float)
        hit = _first(np.abs(vel) - vmax)
        if hit is not None:
            return sentence(hit[0], hit[1], "velocity", vel[hit], vmax[hit[1]], "rad/s ")
    if accelerations is not None:
        acc = np.asarray(accelerations, dtype=float)
        hit = _first(np.abs(acc) - amax)
        if hit is not None:
            return sentence(hit[0], hit[1], "acceleration", acc[hit], amax[hit[1]], "rad/s^2 ")
    if times.shape[0] < 2:
        return None
    dt = np.diff(times)[:, None]
    mean_velocity = np.diff(pos, axis=0) / dt
    hit = _first(np.abs(mean_velocity) - vmax)
    if hit is not None:
        k, j = hit
        return sentence(k + 1, j, "velocity", mean_velocity[hit], vmax[j],
                        f"rad/s (it moves {abs(pos[k + 1, j] - pos[k, j]):.4g} rad in {float(dt[k, 0]):.4g} s) ")
    if times.shape[0] < 3:
        return None
    span = dt[1:] + dt[:-1]
    change = np.diff(mean_velocity, axis=0) / span
    hit = _first(np.abs(change) - amax)
    if hit is not None:
        k, j = hit
        return sentence(k + 1, j, "acceleration", change[hit], amax[j], "rad/s^2 (at least, from its positions) ")
    return None
