"""An independent check of a timed trajectory against a planning scene and the joint limits.

The full story: docs/core.md, section mycobot_planning.core.trajectory_processing.trajectory_validator.
"""
from __future__ import annotations

import functools

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import PlanningError
from ..jit import compiled, numba_available
from ..planning_scene.planning_scene import PlanningScene
from ..robot_state.robot_state import RobotState
from ..robot_trajectory.robot_trajectory import TimedTrajectory, max_steps

__all__ = [
    "DEFAULT_RESOLUTION",
    "TrajectoryValidationError",
    "ValidationReport",
    "dense_samples",
    "validate_trajectory",
]

DEFAULT_RESOLUTION = 0.005
"""Max joint step (rad or m) between checked states: a few millimetres of link motion on the
myCobot. OMPL's edge checks (0.5 % of the space extent) are about 14 times coarser there (0.07
rad), which is why every plan is checked again here."""

# Limits are met *exactly* by Ruckig profiles (a phase at the velocity limit), so the stored and
# interpolated values sit on the limit up to rounding; this relative slack absorbs that and
# nothing a controller would notice.
LIMIT_RELATIVE_TOLERANCE = 1e-6
# Refinement stops at gaps this short (s): anything still moving more than the resolution over
# such a gap is a discontinuity, not motion.
_MIN_GAP = 1e-9
# At most this many new states per gap per refinement round, this many rounds, this many states
# in total: bounds the work on absurd input (positions of 1e6 rad) without affecting real
# trajectories (a 2 s myCobot motion needs ~1000 states).
_MAX_SPLIT = 1000
_MAX_ROUNDS = 20
_MAX_STATES = 500_000
# Separate collision stretches described in full (each costs a contact query).
_MAX_COLLISION_REPORTS = 3
# Problems of one kind listed individually before summarising the rest.
_MAX_PER_KIND = 5


class TrajectoryValidationError(PlanningError, ValueError):
    """The validator itself was called wrongly (not a trajectory, bad resolution or scaling)."""


@dataclass
class ValidationReport:
    """The verdict: ``valid`` (also ``bool(report)``), human-readable ``problems``, the earliest
    time something is wrong, and the contacts found (``str(Contact)``, deduplicated)."""

    valid: bool
    problems: list[str] = field(default_factory=list)
    first_invalid_time: float | None = None
    contacts: list[str] = field(default_factory=list)
    checked_states: int = 0

    def __bool__(self) -> bool:
        return self.valid

    def __str__(self) -> str:
        if self.valid:
            return f"trajectory valid ({self.checked_states} states checked)"
        return "trajectory invalid: " + "; ".join(self.problems)


class _Findings:
    """Problems collected so far, with the earliest time each one concerns."""

    def __init__(self) -> None:
        self.problems: list[str] = []
        self.times: list[float] = []
        self.contacts: list[str] = []

    def add(self, message: str, t: float | None) -> None:
        self.problems.append(message)
        if t is not None:
            self.times.append(float(t))

    def report(self, checked: int) -> ValidationReport:
        return ValidationReport(
            valid=not self.problems,
            problems=list(self.problems),
            first_invalid_time=min(self.times) if self.times else None,
            contacts=list(self.contacts),
            checked_states=checked,
        )


def _positive(value: float, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise TrajectoryValidationError(f"{what} must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v) or v <= 0.0:
        raise TrajectoryValidationError(f"{what} must be finite and > 0, got {value!r}")
    return v


def _scaling(value: float, what: str) -> float:
    v = _positive(value, what)
    if v > 1.0:
        raise TrajectoryValidationError(f"{what} must be in (0, 1], got {value!r}")
    return v


def _fmt_t(t: float) -> str:
    return f"t={t:.3f} s"


def _fmt_exceeds(value: float, limit: float) -> str:
    """'value > limit' with just enough decimals that the two numbers read differently."""
    for digits in range(3, 10):
        a, b = f"{value:.{digits}f}", f"{limit:.{digits}f}"
        if a != b:
            break
    return f"{a} > limit {b}"


# ---------------------------------------------------------------------------- sampling
# Intervals whose chord needs at least this many samples are sampled evenly along their motion
# rather than evenly in time (see _initial_times).
_EVEN_MOTION_MIN_COUNT = 8
# Points per such interval from which its motion is read.
_EVEN_MOTION_GRID = 64
# ... and the spacing they aim at, as a share of the resolution: reading the motion at 64
# points places a sample within a fraction of a per cent of where it belongs.
_EVEN_MOTION_SPACING = 0.98
# Only for trajectories of at most this many stored points (straight runs timed by Ruckig): a
# dense curve's many short intervals gain little and reading them costs more than it saves
# (on the myCobot's plan_ompl paths, 1.2 ms instead of 0.4 ms of sampling for 7 % fewer states).
_EVEN_MOTION_MAX_POINTS = 32


_GRID = np.linspace(0.0, 1.0, _EVEN_MOTION_GRID + 1)


def _initial_times(traj: TimedTrajectory, resolution: float) -> np.ndarray:
    """_initial_times_numpy's sample times, in one compiled call after one evaluation of the
    trajectory (each of its NumPy steps cost microseconds: ~120 us a straight motion). Its
    interval counts are the same; its times within rounding of NumPy's interpolation."""
    times = np.ascontiguousarray(traj.times, dtype=float)
    positions = np.ascontiguousarray(traj.positions, dtype=float)
    if not numba_available() or times.shape[0] < 2:
        return _initial_times_numpy(traj, resolution)
    chords = max_steps(positions)
    # an interval is long when ceil(chord / resolution) >= _EVEN_MOTION_MIN_COUNT; only then is
    # every interval read at the grid's points
    even = times.shape[0] <= _EVEN_MOTION_MAX_POINTS and bool(np.any(chords / resolution > _EVEN_MOTION_MIN_COUNT - 1))
    if even:
        sub = times[:-1, None] + np.diff(times)[:, None] * _GRID
        grid_q = traj.sample(sub.reshape(-1))[0].reshape(sub.shape[0], sub.shape[1], -1)
    else:
        sub, grid_q = np.zeros((0, 0)), np.zeros((0, 0, 0))
    return _initial_times_kernel(times, positions, chords, float(resolution), sub, grid_q, even)


@compiled
def _initial_times_kernel(times, positions, chords, resolution, sub, grid_q, even):  # pragma: no cover - compiled
    """_initial_times_numpy step by step: each interval's count from its chord (max_steps; NaN:
    one), with ``even`` the long ones recounted and placed evenly along their driving joint
    where it moves monotonically (``sub``, ``grid_q``: the intervals' grid times and states),
    else evenly in time, then the last stored time."""
    n, d = positions.shape
    counts = np.empty(n - 1, dtype=np.int64)
    for k in range(n - 1):
        chord = chords[k]
        counts[k] = 1 if chord != chord else int(min(max(np.ceil(chord / resolution), 1.0), float(_MAX_SPLIT)))
    long = np.zeros(n - 1, dtype=np.bool_)
    if even:
        for k in range(n - 1):
            if counts[k] >= _EVEN_MOTION_MIN_COUNT:
                long[k] = True
                counts[k] = int(min(max(np.ceil(chords[k] / (resolution * _EVEN_MOTION_SPACING)), 1.0),
                                    float(_MAX_SPLIT)))
    ts = np.empty(int(counts.sum()) + 1)
    first = 0
    g_last = sub.shape[1] - 1 if even else 0
    progress = np.empty(g_last + 1)
    for k in range(n - 1):
        count = counts[k]
        h = times[k + 1] - times[k]
        for i in range(count):
            ts[first + i] = times[k] + h * (i / count)
        if long[k]:
            drive = 0
            for j in range(d):  # np.argmax: the first of the largest
                if abs(positions[k + 1, j] - positions[k, j]) > abs(positions[k + 1, drive] - positions[k, drive]):
                    drive = j
            span = grid_q[k, g_last, drive] - grid_q[k, 0, drive]
            monotonic = True
            for g in range(g_last + 1):
                progress[g] = (grid_q[k, g, drive] - grid_q[k, 0, drive]) / span
                if not math.isfinite(progress[g]) or (g > 0 and not progress[g] > progress[g - 1]):
                    monotonic = False
                    break
            if monotonic:
                g = 0
                for i in range(1, count):
                    x = i / count
                    while g < g_last - 1 and progress[g + 1] <= x:
                        g += 1
                    ts[first + i] = sub[k, g] + (sub[k, g + 1] - sub[k, g]) * (
                        (x - progress[g]) / (progress[g + 1] - progress[g]))
        first += count
    ts[first] = times[n - 1]
    return ts


def _initial_times_numpy(traj: TimedTrajectory, resolution: float) -> np.ndarray:
    """Stored times plus a subdivision of each interval sized by its chord; refinement fixes
    gaps that still move more than the resolution.

    Short intervals are split evenly in time. Long ones (a straight motion timed from rest to
    rest is two or three intervals of hundreds of samples) are split evenly along the motion of
    their largest-moving joint, read from the trajectory at _EVEN_MOTION_GRID points: evenly in
    time, the samples of a phase that speeds up from rest bunch at its slow end and leave its
    fast end too coarse, and refinement then halves those gaps, half again as many samples as
    the resolution needs. Where that joint does not move monotonically the interval keeps the
    even split in time. Either way the refinement rounds check every gap."""
    times, pos = traj.times, traj.positions
    h = np.diff(times)
    chord = max_steps(pos)
    counts = np.clip(np.ceil(chord / resolution), 1, _MAX_SPLIT).astype(int)
    long = np.flatnonzero(counts >= _EVEN_MOTION_MIN_COUNT)
    if not long.size or times.shape[0] > _EVEN_MOTION_MAX_POINTS:
        return _subdivide(times[:-1], h, counts, times[-1])
    counts[long] = np.clip(np.ceil(chord[long] / (resolution * _EVEN_MOTION_SPACING)), 1, _MAX_SPLIT).astype(int)
    ts = _subdivide(times[:-1], h, counts, times[-1])
    first = np.cumsum(counts) - counts
    grid = np.linspace(0.0, 1.0, _EVEN_MOTION_GRID + 1)
    sub = times[long, None] + h[long, None] * grid  # (L, G + 1)
    q = traj.sample(sub.reshape(-1))[0].reshape(long.size, grid.size, -1)
    drive = np.argmax(np.abs(pos[long + 1] - pos[long]), axis=1)
    motion = q[np.arange(long.size), :, drive]  # (L, G + 1): the driving joint's position
    span = motion[:, -1] - motion[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        progress = (motion - motion[:, :1]) / span[:, None]
    # Intervals where the driving joint moves monotonically (the others keep the split in time)
    rows = np.flatnonzero(np.isfinite(progress).all(axis=1) & (np.diff(progress, axis=1) > 0.0).all(axis=1))
    if rows.size:
        # One np.interp for all of them: row r's progress is shifted by 2 r, so the rows line up
        # as one increasing sequence, and so do their targets.
        ks, shift = long[rows], 2.0 * np.arange(rows.size)
        n = counts[ks]
        row_of = np.repeat(np.arange(rows.size), n)
        local = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
        at = np.interp(local / n[row_of] + shift[row_of], (progress[rows] + shift[:, None]).reshape(-1),
                       sub[rows].reshape(-1))
        ts[first[ks][row_of] + local] = at
        ts[first[ks]] = times[ks]
    return ts


def _subdivide(starts: np.ndarray, widths: np.ndarray, counts: np.ndarray, last: float | None) -> np.ndarray:
    """For each gap [s, s + w], the points s + w * j / n for j = 0..n-1 (vectorised)."""
    total = int(counts.sum())
    gap = np.repeat(np.arange(counts.size), counts)
    first = np.cumsum(counts) - counts
    j = np.arange(total) - first[gap]
    ts = starts[gap] + widths[gap] * (j / counts[gap])
    if last is not None:
        ts = np.append(ts, last)
    return ts


def dense_samples(
    traj: TimedTrajectory, resolution: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
    """Times and (q, qd, qdd) such that every gap moves at most ``resolution`` (max-norm), except
    gaps already shorter than _MIN_GAP (discontinuities). The flag says the budget ran out."""
    times = traj.times
    if times.shape[0] == 1:
        q, qd, qdd = traj.sample(times)
        return times.copy(), q, qd, qdd, False
    ts = _initial_times(traj, resolution)
    exhausted = False
    for _ in range(_MAX_ROUNDS):
        q, qd, qdd = traj.sample(ts)
        step = max_steps(q)
        dt = np.diff(ts)
        coarse = (step > resolution) & (dt > _MIN_GAP)
        if not np.any(coarse):
            return ts, q, qd, qdd, False
        counts = np.clip(np.ceil(step[coarse] / resolution), 2, _MAX_SPLIT).astype(int)
        if ts.size + int(counts.sum()) > _MAX_STATES:
            exhausted = True
            break
        extra = _subdivide(ts[:-1][coarse], dt[coarse], counts, None)
        ts = np.union1d(ts, extra)  # sorted; drops the duplicated gap starts
    else:
        exhausted = True
    q, qd, qdd = traj.sample(ts)
    return ts, q, qd, qdd, exhausted


# ---------------------------------------------------------------------------- checks
def _check_structure(
    traj: TimedTrajectory, joint_names: list[str], group: str, findings: _Findings
) -> bool:
    """Joint names and array shapes/finiteness (a dataclass can be mutated after construction)."""
    names = list(traj.joint_names)
    if sorted(names) != sorted(joint_names) or len(set(names)) != len(names):
        missing = [n for n in joint_names if n not in names]
        extra = [n for n in names if n not in joint_names]
        findings.add(
            f"trajectory joints {names} do not match group '{group}' joints {joint_names}"
            + (f" (missing {missing})" if missing else "")
            + (f" (not in the group: {extra})" if extra else ""),
            None,
        )
        return False
    n = np.shape(traj.times)[0] if np.ndim(traj.times) == 1 else -1
    if n < 1:
        findings.add(f"trajectory times have shape {np.shape(traj.times)}, expected a non-empty vector", None)
        return False
    for what in ("positions", "velocities", "accelerations"):
        arr = getattr(traj, what)
        if np.shape(arr) != (n, len(names)):
            findings.add(
                f"trajectory {what} have shape {np.shape(arr)}, expected ({n}, {len(names)})", None
            )
            return False
    for what in ("times", "positions", "velocities", "accelerations"):
        arr = np.asarray(getattr(traj, what), dtype=float)
        bad = ~np.isfinite(arr)
        if np.any(bad):
            k = int(np.flatnonzero(bad.reshape(n, -1).any(axis=1))[0])
            findings.add(f"trajectory {what} contain NaN or infinite values (point {k})", None)
            return False
    return True


def _check_times(times: np.ndarray, findings: _Findings) -> bool:
    if times.shape[0] < 2:
        return True
    bad = np.flatnonzero(np.diff(times) <= 0.0)
    if bad.size == 0:
        return True
    k = int(bad[0])
    findings.add(
        f"time stamps not strictly increasing: point {k + 1} at {_fmt_t(times[k + 1])} "
        f"follows point {k} at {_fmt_t(times[k])}"
        + (f" ({bad.size - 1} more)" if bad.size > 1 else ""),
        float(times[k + 1]),
    )
    return False


def _check_start(
    names: list[str], first: np.ndarray, start: np.ndarray, t0: float, tolerance: float, findings: _Findings
) -> None:
    diff = np.abs(first - start)
    bad = np.flatnonzero(diff > tolerance)
    if bad.size:
        detail = "; ".join(
            f"{names[j]} is {first[j]:.6f} in the trajectory, {start[j]:.6f} in the start state" for j in bad
        )
        findings.add(f"trajectory does not start at the start state (tolerance {tolerance:g}): {detail}", t0)


def _check_rest(
    names: list[str], units: list[str], traj: TimedTrajectory, tolerance: float, findings: _Findings
) -> None:
    for label, k in (("start", 0), ("end", -1)):
        v = traj.velocities[k]
        bad = np.flatnonzero(np.abs(v) > tolerance)
        if bad.size:
            detail = ", ".join(f"{names[j]} {v[j]:.4g} {units[j]}/s" for j in bad)
            findings.add(
                f"trajectory not at rest at the {label} ({_fmt_t(traj.times[k])}): velocity {detail}",
                float(traj.times[k]),
            )


def _check_jumps(
    traj: TimedTrajectory, names: list[str], units: list[str], vmax: np.ndarray, tolerance: float, findings: _Findings
) -> None:
    """Discontinuities at stored points, and stored points too far apart for the velocity limit."""
    times, pos = traj.times, traj.positions
    if times.shape[0] < 2:
        return
    h = np.diff(times)
    # Left limits: the interpolation of interval k just before its end, compared with the stored
    # point that starts interval k+1. Evaluated 1e-9 of the interval early, which moves at most
    # speed * 1e-9 * h, well inside the tolerance below.
    delta = 1e-9 * h
    left, qd_left, _ = traj.sample(times[1:] - delta)
    speed = np.maximum(np.abs(qd_left), vmax)
    gap = np.abs(pos[1:] - left)
    # The 1e-9 relative floor keeps tolerance=0 from flagging rounding in the polynomial.
    jump = gap > tolerance + 1e-9 * (1.0 + np.abs(pos[1:])) + speed * delta[:, None] * 2.0
    # Stored points further apart than the (unscaled) velocity limit allows over their interval.
    chord = np.abs(np.diff(pos, axis=0))
    too_far = chord > vmax * h[:, None] * (1.0 + LIMIT_RELATIVE_TOLERANCE) + tolerance
    too_far &= ~jump.any(axis=1, keepdims=True)
    reported = 0
    for k, j in zip(*np.nonzero(jump | too_far)):
        if reported < _MAX_PER_KIND:
            t = float(times[k + 1])
            if jump[k, j]:
                findings.add(
                    f"position jump of {pos[k + 1, j] - left[k, j]:+.4f} {units[j]} in joint {names[j]} at {_fmt_t(t)} "
                    f"(the interpolation arrives at {left[k, j]:.4f}, the next point is {pos[k + 1, j]:.4f})",
                    t,
                )
            else:
                findings.add(
                    f"position jump in joint {names[j]}: {chord[k, j]:.4f} {units[j]} between {_fmt_t(times[k])} and "
                    f"{_fmt_t(t)} needs {chord[k, j] / h[k]:.3f} {units[j]}/s, more than the velocity limit "
                    f"{vmax[j]:.3f} {units[j]}/s",
                    float(times[k]),
                )
        reported += 1
    if reported > _MAX_PER_KIND:
        findings.add(f"{reported - _MAX_PER_KIND} more position jumps", None)


def _check_limit(
    kind: str,
    units: list[str],
    names: list[str],
    ts: np.ndarray,
    values: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    slack: np.ndarray | float,
    findings: _Findings,
    scale_note: str = "",
) -> None:
    """One sentence per joint that leaves [low - slack, high + slack]: its worst sample and when
    it first did (the message quotes the nominal limit)."""
    over = values - (high + slack)
    under = (low - slack) - values
    excess = np.maximum(over, under)
    bad_joints = np.flatnonzero(np.any(excess > 0.0, axis=0))
    for j in bad_joints:
        col = excess[:, j]
        first = int(np.argmax(col > 0.0))
        worst = int(np.argmax(col))
        v = values[worst, j]
        if kind == "position":
            bound = f"{'upper' if over[worst, j] > 0 else 'lower'} limit {high[j] if over[worst, j] > 0 else low[j]:.4f}"
            findings.add(
                f"joint {names[j]} position {v:.4f} {units[j]} outside its {bound} at {_fmt_t(ts[worst])}"
                + (f" (first at {_fmt_t(ts[first])})" if first != worst else ""),
                float(ts[first]),
            )
        else:
            findings.add(
                f"joint {names[j]} {kind} {_fmt_exceeds(abs(v), high[j])} {units[j]}{scale_note} "
                f"at {_fmt_t(ts[worst])}"
                + (f" (first exceeded at {_fmt_t(ts[first])})" if first != worst else ""),
                float(ts[first]),
            )


@functools.lru_cache(maxsize=512)
def halving_order(count: int) -> np.ndarray:
    """0 .. count-1 coarse to fine: the ends, then every 2^k-th index for falling k, so a
    collision anywhere is met after a few checks rather than after all those before it.
    Read-only and memoised: every plan asks for it (50 µs for 400 states)."""
    order = _halving_order(count)
    order.setflags(write=False)
    return order


def _halving_order(count: int) -> np.ndarray:
    taken = np.zeros(count, dtype=bool)
    parts = [np.array([0, count - 1])] if count > 1 else [np.zeros(count, dtype=int)]
    taken[parts[0]] = True
    step = 1 << max(0, (count - 1).bit_length() - 1)
    while step >= 1:
        idx = np.arange(0, count, step)
        idx = idx[~taken[idx]]
        taken[idx] = True
        parts.append(idx)
        step //= 2
    return np.concatenate(parts)


def _check_collisions(
    scene: PlanningScene,
    start: RobotState,
    indices: np.ndarray,
    ts: np.ndarray,
    q: np.ndarray,
    findings: _Findings,
    first_collision: bool = False,
    all_pairs: bool = True,
) -> None:
    model = scene.robot_model
    # Collisions only (the limits are the limit check's business); as a judge by the plain exact
    # check of every pair, not the scene's fast checker the planners decide with.
    if first_collision:
        invalid = scene.colliding_rows(indices, start, q, order=halving_order(q.shape[0]), stop_at_first=True,
                                       all_pairs=all_pairs)
    else:
        invalid = scene.colliding_rows(indices, start, q, all_pairs=all_pairs)
    if not np.any(invalid):
        return
    full = np.tile(np.asarray(start.positions, dtype=float), (q.shape[0], 1))
    full[:, indices] = q
    # Colliding stretches: runs of consecutive colliding samples.
    idx = np.flatnonzero(invalid)
    breaks = np.flatnonzero(np.diff(idx) > 1)
    run_starts = np.concatenate(([idx[0]], idx[breaks + 1]))
    run_ends = np.concatenate((idx[breaks], [idx[-1]]))
    for n, (a, b) in enumerate(zip(run_starts, run_ends)):
        if n >= _MAX_COLLISION_REPORTS:
            findings.add(f"collisions in {len(run_starts) - n} more stretches", None)
            break
        report = scene.check_collision(RobotState(model, full[a]), max_contacts=3, all_pairs=all_pairs)
        contacts = [str(c) for c in report.contacts] or ["contact not reported by the scene"]
        for c in contacts:
            if c not in findings.contacts:
                findings.contacts.append(c)
        when = _fmt_t(ts[a]) if a == b else f"{_fmt_t(ts[a])} to {_fmt_t(ts[b])}"
        findings.add(f"collision {'at' if a == b else 'from'} {when}: " + "; ".join(contacts), float(ts[a]))


# ---------------------------------------------------------------------------- entry point
def validate_trajectory(
    scene: PlanningScene,
    trajectory: TimedTrajectory,
    group: str,
    start_state: RobotState | None = None,
    resolution: float = DEFAULT_RESOLUTION,
    check_limits: bool = True,
    velocity_scaling: float = 1.0,
    acceleration_scaling: float = 1.0,
    tolerance: float = 1e-6,
    first_collision: bool = False,
    all_pairs: bool = True,
) -> ValidationReport:
    """Check ``trajectory`` (over ``group``'s joints) in ``scene``; see docs/core.md (mycobot_planning.core.trajectory_processing.trajectory_validator).

    ``start_state`` (default: the scene's current state) supplies the joints outside the group
    and the state the trajectory must start at (group joints within ``tolerance``). ``tolerance``
    is also the absolute slack for position limits, end velocities and position jumps.
    ``check_limits=False`` skips position/velocity/acceleration limits (collisions, continuity,
    start, time stamps and rest are still checked). ``first_collision=True`` checks the states
    coarse to fine and stops at the first collision (then the only one reported): the same
    verdict, sooner for a colliding trajectory (a planner trying a candidate); a valid one is
    checked at every state as always.

    Collisions are decided by the plain exact check of every active pair (``all_pairs=True``),
    so the validator judging a planner never shares the fast checker the planner used. A planner
    checking its own output at the validator's resolution passes ``all_pairs=False``: the scene's
    fast checker (broad phase, hull pre-test), whose verdicts are proved equal to the plain
    check's (test/core/test_collision_cross_check.py), at a fifth to a tenth of the cost.

    Raises :class:`TrajectoryValidationError` (or RobotModelError for an unknown group) when the
    call itself is wrong; every property of the trajectory is reported, never raised.
    """
    if not isinstance(scene, PlanningScene):
        raise TrajectoryValidationError(f"scene must be a PlanningScene, got {type(scene).__name__}")
    if not isinstance(trajectory, TimedTrajectory):
        raise TrajectoryValidationError(f"trajectory must be a TimedTrajectory, got {type(trajectory).__name__}")
    resolution = _positive(resolution, "resolution")
    velocity_scaling = _scaling(velocity_scaling, "velocity_scaling")
    acceleration_scaling = _scaling(acceleration_scaling, "acceleration_scaling")
    if isinstance(tolerance, bool) or not isinstance(tolerance, (int, float)) or not (
        math.isfinite(tolerance) and tolerance >= 0.0
    ):
        raise TrajectoryValidationError(f"tolerance must be finite and >= 0, got {tolerance!r}")
    model = scene.robot_model
    jmg = model.group(group)  # RobotModelError naming the known groups
    start = scene.current_state if start_state is None else start_state
    if not isinstance(start, RobotState) or start.model is not model:
        raise TrajectoryValidationError("start_state must be a RobotState of the scene's robot model")

    findings = _Findings()
    if not _check_structure(trajectory, list(jmg.joint_names), jmg.name, findings):
        return findings.report(0)
    names = list(trajectory.joint_names)
    indices = np.array([model.variable_index(n) for n in names], dtype=int)
    low, high = model.lower_limits[indices], model.upper_limits[indices]
    vmax, amax = model.velocity_limits[indices], model.acceleration_limits[indices]
    times = np.asarray(trajectory.times, dtype=float)
    units = ["m" if model.joint(n).type == "prismatic" else "rad" for n in names]

    _check_start(names, trajectory.positions[0], start.positions[indices], float(times[0]), tolerance, findings)
    _check_rest(names, units, trajectory, tolerance, findings)
    monotonic = _check_times(times, findings)

    if monotonic:
        _check_jumps(trajectory, names, units, vmax, tolerance, findings)
        ts, q, qd, qdd, exhausted = dense_samples(trajectory, resolution)
        if exhausted:
            findings.add(
                f"trajectory moves too far to check at resolution {resolution:g} "
                f"(more than {_MAX_STATES} states needed)",
                None,
            )
    else:
        # Without increasing time stamps there is no motion to interpolate: check what is stored.
        ts, q = times, trajectory.positions
        qd, qdd = trajectory.velocities, trajectory.accelerations

    if check_limits:
        rel = LIMIT_RELATIVE_TOLERANCE
        _check_limit("position", units, names, ts, q, low, high, tolerance, findings)
        vlim = vmax * velocity_scaling
        alim = amax * acceleration_scaling
        vnote = f" (velocity scaling {velocity_scaling:g})" if velocity_scaling != 1.0 else ""
        anote = f" (acceleration scaling {acceleration_scaling:g})" if acceleration_scaling != 1.0 else ""
        _check_limit(
            "velocity", [u + "/s" for u in units], names, ts, qd, -vlim, vlim, vlim * rel + tolerance, findings, vnote
        )
        _check_limit(
            "acceleration", [u + "/s^2" for u in units], names, ts, qdd, -alim, alim, alim * rel + tolerance,
            findings, anote,
        )
    _check_collisions(scene, start, indices, ts, q, findings, bool(first_collision), bool(all_pairs))
    return findings.report(int(ts.shape[0]))
