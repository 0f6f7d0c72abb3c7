"""Method "segments": one Ruckig profile per straight run of the polyline, exact on it.

Why per segment and not Ruckig's waypoints, and how corners are blended: see
docs/time_parameterization.md.
"""
from __future__ import annotations

import math

import numpy as np
import ruckig

from ..errors import TimeParameterizationError
from ..robot_trajectory.robot_trajectory import TimedTrajectory
from .path_geometry import COLLINEAR_TOL

# A blend may use at most this fraction of each adjacent segment, so blends never overlap.
_BLEND_SEGMENT_FRACTION = 0.5
# Breakpoints closer than this (s) are merged: see time_segments. The merged phase changes the
# acceleration by at most jerk * 1e-9, far below any tolerance that matters.
_MIN_INTERVAL = 1e-9


def _max_reachable_speed(v_other: float, length: float, a: float, j: float) -> float:
    """Largest speed v >= v_other that can be changed into v_other (or reached from it) within
    ``length`` of path, with zero acceleration at both ends, under acceleration bound ``a``
    and jerk bound ``j`` (``inf`` allowed).

    The fastest velocity change is point-symmetric about its midpoint, so it covers
    (v + v_other) / 2 * T, with T = dv/a + a/j if it reaches ``a`` (dv >= a^2/j), else
    T = 2 sqrt(dv/j), and T = dv/a without a jerk limit. Solving that for dv in closed form
    keeps the forward/backward passes exact, so each segment's Ruckig profile is feasible
    without overshooting the segment end."""
    if length <= 0.0:
        return v_other
    if math.isinf(j):
        return math.sqrt(v_other * v_other + 2.0 * a * length)
    # Without reaching a: x = sqrt(dv) solves f(x) = x^3 + 2 v_other x - length sqrt(j) = 0,
    # monotone in x with one real root: Cardano, polished by Newton (Cardano cancels badly
    # when v_other dominates).
    p, q = 2.0 * v_other, -length * math.sqrt(j)
    disc = math.sqrt(q * q / 4.0 + p ** 3 / 27.0)
    x = float(np.cbrt(-q / 2.0 + disc) + np.cbrt(-q / 2.0 - disc))
    for _ in range(3):
        x -= (x * x * x + p * x + q) / (3.0 * x * x + p)
    dv = x * x
    if dv * j >= a * a:
        # Reaches a: (v_other + dv/2)(dv/a + a/j) = length, i.e. qa dv^2 + qb dv + qc = 0 with
        # qc <= 0 here; the cancellation-free form of the positive root.
        qa, qb, qc = 0.5 / a, v_other / a + 0.5 * a / j, v_other * a / j - length
        dv = -2.0 * qc / (qb + math.sqrt(qb * qb - 4.0 * qa * qc))
    dv = max(dv, 0.0)
    v = v_other + dv
    if v - v_other > dv:  # rounded up: never hand Ruckig a change it cannot make in `length`
        v = float(np.nextafter(v, 0.0))
    return v


def time_segments(pts: np.ndarray, vmax: np.ndarray, amax: np.ndarray, jmax: np.ndarray,
                  tol: float, names: list[str]) -> TimedTrajectory:
    n, d = pts.shape
    zeros = np.zeros(d)
    if n == 1:
        z = np.zeros((1, d))
        return TimedTrajectory(names, np.zeros(1), pts.copy(), z, z.copy(), interpolation="cubic",
                               path=pts.copy(), waypoint_times=np.zeros(1))

    sub_len = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    sub_dir = np.diff(pts, axis=0) / sub_len[:, None]

    # Timing vertices: the ends and every real corner. Runs of collinear waypoints (e.g. an
    # interpolated OMPL path) form one straight segment, timed by one Ruckig profile; the
    # waypoints inside are stamped where the profile passes them. Timing them separately
    # would force zero acceleration at each (Ruckig's target state), which with a jerk limit
    # means needless slowdowns. Collinearity is checked against the run's first direction so
    # tiny bends cannot accumulate.
    verts = [0]
    run_dir = sub_dir[0]
    for i in range(1, n - 1):
        if np.max(np.abs(sub_dir[i] - run_dir)) > COLLINEAR_TOL:
            verts.append(i)
            run_dir = sub_dir[i]
    verts.append(n - 1)
    vidx = np.array(verts)
    nv = vidx.shape[0]
    nseg = nv - 1
    deltas = pts[vidx[1:]] - pts[vidx[:-1]]
    lengths = np.linalg.norm(deltas, axis=1)
    dirs = deltas / lengths[:, None]
    absu = np.abs(dirs)
    with np.errstate(divide="ignore"):
        seg_v = np.min(np.where(absu > 0, vmax / absu, np.inf), axis=1)
        seg_a = np.min(np.where(absu > 0, amax / absu, np.inf), axis=1)
        seg_j = np.min(np.where(absu > 0, jmax / absu, np.inf), axis=1)

    # Per-vertex speed caps (vertex m joins segments m-1 and m) and blend geometry.
    cap = np.zeros(nv)            # 0 at the ends: start and end at rest; 0 at unblended corners
    blend_k = np.zeros(nv)        # blend duration tau = speed * k
    blend_du = np.zeros((nv, d))  # u_out - u_in
    if tol > 0.0:
        for m in range(1, nv - 1):
            du = dirs[m] - dirs[m - 1]
            k = float(np.max(np.abs(du) / amax))
            # A blend may take at most a fraction of the sub-segments touching the corner, so
            # it never overlaps another blend nor swallows a collinear waypoint.
            room = min(sub_len[vidx[m] - 1], sub_len[vidx[m]])
            cap[m] = min(seg_v[m - 1], seg_v[m],
                         math.sqrt(8.0 * tol / (k * float(np.linalg.norm(du)))),
                         math.sqrt(2.0 * _BLEND_SEGMENT_FRACTION * room / k))
            blend_k[m] = k
            blend_du[m] = du

    # Blend lengths along each adjacent segment at the cap speed: an upper bound, so the
    # straight remainder used in the passes is a lower bound and the passes stay feasible.
    bmax = 0.5 * cap * cap * blend_k
    straight_min = np.maximum(lengths - bmax[:-1] - bmax[1:], 0.0)

    speed = cap.copy()
    for m in range(nseg):  # forward: reachable from the previous vertex
        speed[m + 1] = min(speed[m + 1],
                           _max_reachable_speed(speed[m], straight_min[m], seg_a[m], seg_j[m]))
    for m in range(nseg - 1, -1, -1):  # backward: able to slow down for the next vertex
        speed[m] = min(speed[m],
                       _max_reachable_speed(speed[m + 1], straight_min[m], seg_a[m], seg_j[m]))

    tau = speed * blend_k
    blen = 0.5 * speed * tau  # arc length a blend takes from each adjacent segment

    otg = ruckig.Ruckig(1)  # no waypoint capacity: never the cloud path
    inp = ruckig.InputParameter(1)
    out = ruckig.Trajectory(1)

    # Candidate points: (time, q, qd, qdd from here on, is_waypoint_or_end). Times accumulate
    # exactly; near-coincident points are thinned afterwards.
    cands: list[tuple[float, np.ndarray, np.ndarray, np.ndarray, bool]] = [
        (0.0, pts[0].copy(), zeros.copy(), zeros.copy(), True)]
    wp_times = np.zeros(n)
    t = 0.0
    for m in range(nseg):
        u = dirs[m]
        w = pts[vidx[m]]
        s0 = blen[m]
        straight = lengths[m] - blen[m] - blen[m + 1]
        v0, v1 = min(speed[m], seg_v[m]), min(speed[m + 1], seg_v[m])
        if straight > 1e-12 or abs(v1 - v0) > 1e-12:
            a_start, boundaries = _segment_profile(otg, inp, out, max(straight, 0.0), v0, v1,
                                                   seg_v[m], seg_a[m], seg_j[m], m)
            tq, q, v, _, prot = cands[-1]
            cands[-1] = (tq, q, v, a_start * u, prot)  # acceleration from here on
            seg_cands = []
            t_rel = 0.0
            for dt, p, v, a in boundaries:
                t_rel += dt
                seg_cands.append((t_rel, w + (s0 + p) * u, v * u, a * u, False))
            for i in range(vidx[m] + 1, vidx[m + 1]):  # collinear waypoints inside
                s_i = float((pts[i] - w) @ u) - s0
                t_i = _time_at_arc_length(out, min(max(s_i, 0.0), straight))
                _, v, a = out.at_time(t_i)  # right-hand limits at phase boundaries
                seg_cands.append((t_i, pts[i].copy(), v[0] * u, a[0] * u, True))
                wp_times[i] = t + t_i
            seg_cands.sort(key=lambda c: c[0])
            cands.extend((t + c[0],) + c[1:] for c in seg_cands)
            t += t_rel
        if m + 1 < nv - 1 and tau[m + 1] > 0.0:
            # Parabolic blend around vertex m+1: starts where the straight part ended.
            s, t_b, du = speed[m + 1], tau[m + 1], blend_du[m + 1]
            tq, q, v, _, prot = cands[-1]
            cands[-1] = (tq, q, v, s * du / t_b, prot)
            wp_times[vidx[m + 1]] = t + 0.5 * t_b
            t += t_b
            cands.append((t, pts[vidx[m + 1]] + blen[m + 1] * dirs[m + 1], s * dirs[m + 1],
                          zeros.copy(), False))
        else:
            tq, _, v, a, _ = cands[-1]
            cands[-1] = (tq, pts[vidx[m + 1]].copy(), v, a, True)  # exact waypoint
            wp_times[vidx[m + 1]] = t
    tq, q, _, _, _ = cands[-1]
    cands[-1] = (tq, q, zeros.copy(), zeros.copy(), True)

    # Ruckig profiles can contain phases of 1e-12 s (a limit touched by a hair). Such short
    # intervals make any interpolation ill-conditioned and carry no motion, so drop phase /
    # blend boundaries closer than _MIN_INTERVAL to their predecessor; waypoints are kept.
    # Two waypoints passed within _MIN_INTERVAL of each other (nearly coincident waypoints on
    # a fast segment) keep only the first as a stored point (the last one if it is the end);
    # the other is still passed, within max speed * 1e-9 s, at its waypoint_times entry.
    kept = [cands[0]]
    last = len(cands) - 1
    for idx, c in enumerate(cands[1:], start=1):
        if c[0] - kept[-1][0] < _MIN_INTERVAL and not (idx == last and len(kept) == 1):
            if not kept[-1][4] or idx == last:
                kept[-1] = c
            else:
                # Keep the earlier point, but what follows the dropped one is c's acceleration.
                kept[-1] = kept[-1][:3] + (c[3], True)
            continue
        kept.append(c)
    return TimedTrajectory(names, np.array([c[0] for c in kept]), np.array([c[1] for c in kept]),
                           np.array([c[2] for c in kept]), np.array([c[3] for c in kept]),
                           interpolation="cubic", path=pts.copy(), waypoint_times=wp_times)


def _time_at_arc_length(out: ruckig.Trajectory, s: float) -> float:
    """First time the (monotone, non-decreasing) 1-DoF profile reaches position ``s``.

    Ruckig's root finder can miss a position that sits on a phase boundary by a rounding
    error (returns None); bisection on the monotone profile is the fallback."""
    t = out.get_first_time_at_position(0, s)
    if t is not None:
        return float(t)
    lo, hi = 0.0, float(out.duration)
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if out.at_time(mid)[0][0] < s:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-15 * max(1.0, hi):
            break
    return hi


def _segment_profile(otg: ruckig.Ruckig, inp: ruckig.InputParameter, out: ruckig.Trajectory,
                     length: float, v0: float, v1: float, vmax: float, amax: float, jmax: float,
                     index: int):
    """Ruckig 1-DoF profile from (0, v0, 0) to (length, v1, 0).

    Returns (s_ddot right after the start, [(phase duration, s, s_dot, s_ddot right after the
    boundary) for each phase boundary after the start])."""
    inp.current_position = [0.0]
    inp.current_velocity = [v0]
    inp.current_acceleration = [0.0]
    inp.target_position = [length]
    inp.target_velocity = [v1]
    inp.target_acceleration = [0.0]
    inp.max_velocity = [vmax]
    inp.max_acceleration = [amax]
    inp.max_jerk = [jmax]
    last_err = ""
    # The passes make (v0, v1, length) feasible, sometimes exactly at the boundary; floating
    # point can tip Ruckig over it, so retry with speeds shaved by a relative 1e-9, then 1e-6.
    for shave in (0.0, 1e-9, 1e-6):
        inp.current_velocity = [v0 * (1.0 - shave)]
        inp.target_velocity = [v1 * (1.0 - shave)]
        try:
            result = otg.calculate(inp, out)
        except ruckig.RuckigError as exc:
            last_err = str(exc)
            continue
        if result not in (ruckig.Result.Working, ruckig.Result.Finished):
            last_err = str(result)
            continue
        ext = out.position_extrema[0]
        if ext.min < -1e-9 * max(1.0, length) or ext.max > length + 1e-9 * max(1.0, length):
            last_err = f"profile overshoots the segment (s in [{ext.min}, {ext.max}])"
            continue
        prof = out.profiles[0][0]
        if prof.brake.duration > 0.0:
            last_err = "profile needs a pre-trajectory brake"
            continue
        # prof.p/v/a[k] is the state at the start of phase k. Without a jerk limit, a[k] is
        # phase k's constant acceleration and zero-length phases carry unrelated values, so the
        # acceleration after a boundary is that of the next phase that has a duration.
        durations = list(prof.t)

        def accel_from(k: int) -> float:
            m = next((m for m in range(k, len(durations)) if durations[m] > 0.0), len(durations))
            return prof.a[m]

        boundaries = [(dt, prof.p[k + 1], prof.v[k + 1], accel_from(k + 1))
                      for k, dt in enumerate(durations) if dt > 0.0]
        return accel_from(0), boundaries
    raise TimeParameterizationError(
        f"Ruckig could not time segment {index} (length {length:g}, speeds {v0:g} -> {v1:g}): "
        f"{last_err}")

