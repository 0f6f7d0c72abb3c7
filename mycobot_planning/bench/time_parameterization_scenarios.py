"""Benchmark ``time_parameterization``: our dense-path TOPP against the ``toppra`` package.

The full story: docs/bench.md, section mycobot_planning.bench.time_parameterization_scenarios.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np

from mycobot_planning.core import PlanningScene, RobotModel
from mycobot_planning.core.planning_interface.planning_interface import time_group_path
from mycobot_planning.core.trajectory_processing import path_deviation, time_parameterize

from .common import emit, machine, timed
from .pick_place_scenarios import best_solution_sub_trajectories
from .peers import toppra_runner
from .peers.venvs import PeerUnavailable, ensure_peer_venv, log

SAMPLE_PERIOD = 1e-3
TOPPRA_GRIDS = ("default", "dense")
IMPORT_RUNS = 5
OURS_MODULE = "mycobot_planning.core.trajectory_processing"
REPO = Path(__file__).resolve().parents[2]
RATIO_KEYS = ("max_vel_ratio", "max_acc_ratio", "max_deviation")


def make_problem(name: str, group_set: str, path: np.ndarray, model: RobotModel,
                 group: str) -> dict[str, Any]:
    """A path with its group's velocity/acceleration limits, in the runner's JSON form."""
    idx = model.group(group).variable_indices
    return {"name": name, "set": group_set, "group": group,
            "waypoints": np.asarray(path, dtype=float).tolist(),
            "vmax": model.velocity_limits[idx].tolist(), "amax": model.acceleration_limits[idx].tolist()}


def cartesian_problems(model: RobotModel) -> list[dict[str, Any]]:
    """The ``cartesian`` scenario's line, and a 0.3 m line down and sideways from its start."""
    from mycobot_planning.core.planners.cartesian.cartesian_path import compute_cartesian_path

    from .scenarios import cartesian_line_start  # lazy: scenarios imports this module

    scene = PlanningScene(model)
    start, start_pose, end_pose = cartesian_line_start(model)
    down = start_pose.copy()
    down[:3, 3] += 0.3 * np.array([0.0, 0.275, -0.12]) / np.hypot(0.275, 0.12)
    problems = []
    for name, target, step in (("line_across_0.3m", end_pose, 0.00025), ("line_down_sideways_0.3m", down, 0.001)):
        result = compute_cartesian_path(scene, "arm", start, [target], eef_step=step, jump_threshold=0.0)
        if result.fraction < 1.0:
            raise RuntimeError(f"benchmark set-up: Cartesian path {name} stopped at {result.fraction:.2f}"
                               f" ({result.stop_reason})")
        problems.append(make_problem(name, "cartesian", result.path, model, "arm"))
    return problems


def is_timed_smooth(model: RobotModel, group: str, path: np.ndarray) -> bool:
    """Whether the planner's timing (time_group_path, method "auto") picks "smooth" for ``path``."""
    jmg = model.group(group)
    auto = time_group_path(model, jmg, path, 1.0, 1.0)
    idx = jmg.variable_indices
    try:
        smooth = time_parameterize(path, model.velocity_limits[idx], model.acceleration_limits[idx],
                                   joint_names=list(jmg.joint_names), method="smooth")
    except ValueError:  # "smooth" refuses the path, so "auto" cannot have chosen it
        return False
    return auto.times.shape == smooth.times.shape and bool(np.array_equal(auto.times, smooth.times))


def pick_place_problems(model: RobotModel, seed: int) -> list[dict[str, Any]]:
    """Paths of the pick-and-place demo's best solution that our planner times as "smooth"."""
    problems = []
    for sub in best_solution_sub_trajectories(model, seed):
        traj = sub.trajectory
        if traj is None or traj.path is None or len(traj.path) < 3 or sub.group is None:
            continue
        if is_timed_smooth(model, sub.group, traj.path):
            name = sub.creator.path if sub.creator is not None else f"sub_{len(problems)}"
            problems.append(make_problem(name, "pick_place", traj.path, model, sub.group))
    return problems


def run_ours(problem: dict[str, Any], repeat: int) -> list[dict[str, Any]]:
    """Time ``problem`` with our "smooth" method ``repeat`` times; one record per repeat."""
    pts = toppra_runner.clean_path(problem["waypoints"])
    vmax, amax = np.asarray(problem["vmax"]), np.asarray(problem["amax"])

    def solve():
        return time_parameterize(problem["waypoints"], vmax, amax, method="smooth")

    traj = solve()  # warm-up, untimed
    seconds = [timed(solve)[0] for _ in range(repeat)]
    q, qd, qdd = traj.sample(toppra_runner.sample_times(traj.duration, SAMPLE_PERIOD))
    measures = {"success": True, "duration_s": traj.duration, "path_deviation": path_deviation(traj),
                **toppra_runner.sampled_metrics(q, qd, qdd, pts, vmax, amax)}
    return [_record(problem, "ours", index, s * 1e3, measures) for index, s in enumerate(seconds)]


def _record(problem: dict[str, Any], method: str, index: int, compute_ms: float | None,
            measures: dict[str, Any]) -> dict[str, Any]:
    return {"scenario": "time_parameterization", "set": problem["set"], "path": problem["name"],
            "waypoints": len(problem["waypoints"]), "method": method, "repeat": index,
            "compute_ms": compute_ms, **measures}


def toppra_request(problems: list[dict[str, Any]], repeat: int) -> dict[str, Any]:
    """What toppra_runner reads on stdin."""
    return {"repeat": int(repeat), "sample_period": SAMPLE_PERIOD, "grids": list(TOPPRA_GRIDS),
            "dense_max_step": toppra_runner.DEFAULT_DENSE_MAX_STEP,
            "paths": [{k: p[k] for k in ("name", "set", "waypoints", "vmax", "amax")} for p in problems]}


def toppra_records(problems: list[dict[str, Any]], results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The runner's per-(path, grid) results as per-repeat records, method ``toppra_<grid>``."""
    by_name = {p["name"]: p for p in problems}
    records = []
    for result in results:
        measures = {k: v for k, v in result.items() if k not in ("name", "set", "grid", "compute_ms")}
        for index, ms in enumerate(result.get("compute_ms") or [None]):
            records.append(_record(by_name[result["name"]], f"toppra_{result['grid']}", index, ms, measures))
    return records


def run_toppra(problems: list[dict[str, Any]], repeat: int) -> dict[str, Any]:
    """toppra's results from its peer venv: ``{"available", "python", "meta", "results"}`` or
    ``{"available": False, "reason"}``; never raises for toppra's own failure."""
    try:
        python = ensure_peer_venv("toppra")
    except PeerUnavailable as error:
        log(str(error))
        return {"available": False, "reason": error.reason}
    proc = subprocess.run([str(python), toppra_runner.__file__], input=json.dumps(toppra_request(problems, repeat)),
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=1800)
    lines = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    meta = next((line for line in lines if line.get("meta")), {})
    results = [line for line in lines if not line.get("meta")]
    if proc.returncode != 0 and not results:
        return {"available": False, "reason": f"runner exited with {proc.returncode}: {proc.stderr[-2000:]}"}
    return {"available": True, "python": str(python), "meta": meta, "results": results}


def process_ms(python: str, statement: str, runs: int = IMPORT_RUNS) -> float:
    """Median wall time (ms) of a fresh ``python -c statement`` process, run from the repo."""
    samples = []
    for _ in range(runs):
        seconds, proc = timed(lambda: subprocess.run([python, "-c", statement], cwd=REPO,
                                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE))
        if proc.returncode != 0:
            raise RuntimeError(f"{python} -c {statement!r} failed: {proc.stderr.decode()[-500:]}")
        samples.append(seconds * 1e3)
    return round(float(np.median(samples)), 1)


def _median(values: list[Any]) -> float | None:
    values = [float(v) for v in values if v is not None]
    return float(np.median(values)) if values else None


def summarize(records: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Per set: the median over paths of each method's figures side by side (compute_ms: of the
    per-path median over repeats), plus ``worst`` (largest ratio / deviation over paths).
    Keys: ``ours_*``, ``toppra_*`` (default grid), ``toppra_dense_*``."""
    prefix = {"ours": "ours", "toppra_default": "toppra", "toppra_dense": "toppra_dense"}
    sets: dict[str, dict[str, Any]] = {}
    for group_set in dict.fromkeys(r["set"] for r in records):
        in_set = [r for r in records if r["set"] == group_set]
        paths = list(dict.fromkeys(r["path"] for r in in_set))
        out: dict[str, Any] = {"paths": paths,
                               "waypoints": [next(r["waypoints"] for r in in_set if r["path"] == p) for p in paths]}
        worst: dict[str, Any] = {}
        for method, key in prefix.items():
            per_path = [[r for r in in_set if r["path"] == p and r["method"] == method] for p in paths]
            per_path = [rows for rows in per_path if rows]
            if not per_path:
                continue
            firsts = [rows[0] for rows in per_path]
            out[f"{key}_solved"] = sum(bool(r.get("success")) for r in firsts)
            for measure in ("duration_s", *RATIO_KEYS, "path_deviation", "gridpoints"):
                values = [r.get(measure) for r in firsts if r.get("success")]
                if any(v is not None for v in values):
                    out[f"{key}_{measure}"] = _median(values)
                    if measure in RATIO_KEYS:
                        worst[f"{key}_{measure}"] = max(v for v in values if v is not None)
            out[f"{key}_compute_ms"] = _median([_median([r["compute_ms"] for r in rows]) for rows in per_path])
        out["worst"] = worst
        sets[group_set] = out
    return sets


def bench_time_parameterization(repeat: int, seed: int) -> None:
    """Our "smooth" TOPP vs toppra on Cartesian and pick-and-place paths (module docstring)."""
    model = RobotModel.mycobot()
    problems = cartesian_problems(model) + pick_place_problems(model, seed)
    records: list[dict[str, Any]] = []
    for problem in problems:
        for record in run_ours(problem, repeat):
            emit(record)
            records.append(record)
    toppra = run_toppra(problems, repeat)
    if toppra["available"]:
        for record in toppra_records(problems, toppra["results"]):
            emit(record)
            records.append(record)
    summary: dict[str, Any] = {"scenario": "time_parameterization", "summary": True,
                               "toppra_available": toppra["available"], "sets": summarize(records)}
    summary["ours_import_ms"] = process_ms(sys.executable, f"import {OURS_MODULE}")
    summary["ours_python_startup_ms"] = process_ms(sys.executable, "pass")
    if toppra["available"]:
        meta = toppra["meta"]
        summary.update(toppra_version=meta.get("version"), toppra_numpy=meta.get("numpy"),
                       toppra_scipy=meta.get("scipy"),
                       toppra_import_ms=process_ms(toppra["python"], "import toppra"),
                       toppra_python_startup_ms=process_ms(toppra["python"], "pass"))
    else:
        summary["toppra_reason"] = toppra["reason"]
    emit({**summary, "repeat": repeat, "seed": seed, **machine()})


TIME_PARAMETERIZATION_SCENARIOS = {"time_parameterization": bench_time_parameterization}
