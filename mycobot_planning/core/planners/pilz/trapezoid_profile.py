"""The trapezoidal velocity profile all three generators share, and its sample grid."""
from __future__ import annotations

import math

import numpy as np

from .common import MIN_SAMPLE_FRACTION


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
                 min_fraction: float = MIN_SAMPLE_FRACTION) -> np.ndarray:
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

