"""Time the benchmark's joint-space paths with toppra (run by the toppra peer venv's Python).

The full story: docs/bench.md, section mycobot_planning.bench.peers.toppra_runner.
"""
from __future__ import annotations

import json
import math
import sys
import time
from typing import Any, Callable, Iterator, Sequence

import numpy as np

PEER = "toppra"
DEFAULT_SAMPLE_PERIOD = 1e-3
DEFAULT_DENSE_MAX_STEP = 1e-3
_DUPLICATE_TOL = 1e-10  # as our time_parameterize: such consecutive waypoints are one
_CHUNK = 256  # samples per block in polyline_distance (block x segments x dof floats)


# ---------------------------------------------------------------- measures (no toppra needed)
def clean_path(waypoints: Sequence[Sequence[float]]) -> np.ndarray:
    """Waypoints without consecutive duplicates: a spline needs strictly increasing s."""
    pts = np.asarray(waypoints, dtype=float)
    keep = np.concatenate(([True], np.max(np.abs(np.diff(pts, axis=0)), axis=1) > _DUPLICATE_TOL))
    return pts[keep]


def chord_parameter(pts: np.ndarray) -> np.ndarray:
    """Cumulative chord length normalised to [0, 1] (the path parameter s)."""
    s = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))))
    return s / s[-1]


def dense_gridpoints(s: np.ndarray, max_step: float) -> np.ndarray:
    """Every waypoint parameter, each interval split evenly into pieces <= ``max_step``."""
    parts = [np.linspace(a, b, max(1, math.ceil((b - a) / max_step - 1e-9)) + 1)[:-1]
             for a, b in zip(s[:-1], s[1:])]
    return np.append(np.concatenate(parts), s[-1])


def sample_times(duration: float, period: float) -> np.ndarray:
    """0, period, 2 period, ... and the end itself."""
    ts = np.arange(0.0, duration, period)
    return np.append(ts, duration)


def polyline_distance(q: np.ndarray, waypoints: np.ndarray) -> np.ndarray:
    """Euclidean joint-space distance of each sample in ``q`` (M, d) to the nearest segment of
    the polyline through ``waypoints``: how far the motion strays from what was checked."""
    a, ab = waypoints[:-1], np.diff(waypoints, axis=0)
    den = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    out = np.empty(q.shape[0])
    for start in range(0, q.shape[0], _CHUNK):
        rel = q[start:start + _CHUNK, None, :] - a[None, :, :]  # (m, S, d)
        t = np.clip(np.einsum("msd,sd->ms", rel, ab) / den, 0.0, 1.0)
        gap = rel - t[:, :, None] * ab[None, :, :]
        out[start:start + _CHUNK] = np.sqrt(np.min(np.einsum("msd,msd->ms", gap, gap), axis=1))
    return out


def sampled_metrics(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, waypoints: np.ndarray,
                    vmax: np.ndarray, amax: np.ndarray) -> dict[str, float]:
    """Limit ratios (> 1: violated) and polyline deviation over a sampled trajectory."""
    return {
        "max_vel_ratio": float(np.max(np.abs(qd) / vmax)),
        "max_acc_ratio": float(np.max(np.abs(qdd) / amax)),
        "max_deviation": float(np.max(polyline_distance(q, waypoints))),
        "samples": int(q.shape[0]),
    }


# ---------------------------------------------------------------- toppra
def solve_toppra(pts: np.ndarray, vmax: np.ndarray, amax: np.ndarray, grid: str,
                 dense_max_step: float = DEFAULT_DENSE_MAX_STEP) -> tuple[Any, int]:
    """toppra's trajectory (None if it failed) and the number of gridpoints used."""
    import toppra
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    s = chord_parameter(pts)
    path = toppra.SplineInterpolator(s, pts)
    limits = [constraint.JointVelocityConstraint(np.stack((-vmax, vmax), axis=1)),
              constraint.JointAccelerationConstraint(np.stack((-amax, amax), axis=1))]
    gridpoints = None if grid == "default" else dense_gridpoints(s, dense_max_step)
    instance = algo.TOPPRA(limits, path, gridpoints=gridpoints)
    return instance.compute_trajectory(0, 0), int(len(instance.gridpoints))


Solver = Callable[..., tuple[Any, int]]


def evaluate(request: dict, solve: Solver = solve_toppra) -> Iterator[dict[str, Any]]:
    """One record per path and grid (see docs/bench.md (mycobot_planning.bench.peers.toppra_runner)). ``solve`` is the injection
    point: same signature as :func:`solve_toppra`, returning an object with ``duration`` and
    ``__call__(ts, order)`` (toppra's trajectory interface), or None on failure."""
    repeat = int(request.get("repeat", 1))
    period = float(request.get("sample_period", DEFAULT_SAMPLE_PERIOD))
    step = float(request.get("dense_max_step", DEFAULT_DENSE_MAX_STEP))
    for problem in request["paths"]:
        pts = clean_path(problem["waypoints"])
        vmax, amax = np.asarray(problem["vmax"], float), np.asarray(problem["amax"], float)
        for grid in request.get("grids", ["default"]):
            record: dict[str, Any] = {"name": problem["name"], "set": problem.get("set", ""),
                                      "grid": grid, "success": False, "compute_ms": []}
            try:
                solve(pts, vmax, amax, grid, step)  # warm-up, untimed
                for _ in range(repeat):
                    t0 = time.perf_counter()
                    traj, gridpoints = solve(pts, vmax, amax, grid, step)
                    record["compute_ms"].append((time.perf_counter() - t0) * 1e3)
                record["gridpoints"] = gridpoints
                if traj is None:
                    record["status"] = "toppra found no parameterisation"
                else:
                    ts = sample_times(float(traj.duration), period)
                    record.update(success=True, status="ok", duration_s=float(traj.duration),
                                  **sampled_metrics(traj(ts), traj(ts, 1), traj(ts, 2), pts,
                                                    vmax, amax))
            except Exception as error:  # one bad path must not lose the others' results
                record["status"] = f"error: {type(error).__name__}: {error}"
            yield record


def _versions() -> dict[str, str]:
    import importlib.metadata as metadata

    out = {}
    for name in ("toppra", "numpy", "scipy"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "unknown"
    return out


def main() -> int:
    if len(sys.argv) > 1 and sys.argv[1] != "-":
        with open(sys.argv[1]) as handle:
            request = json.load(handle)
    else:
        request = json.load(sys.stdin)
    versions = _versions()
    print(json.dumps({"meta": True, "peer": PEER, "version": versions["toppra"],
                      "numpy": versions["numpy"], "scipy": versions["scipy"]}), flush=True)
    for record in evaluate(request, solve_toppra):  # looked up now, so a test can replace it
        print(json.dumps(record), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
