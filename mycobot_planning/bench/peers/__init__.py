"""The peers benchmarks: the same Panda problems solved by us, mplib, pyroboplan, roboplan (and
VAMP for the check and plan parts).

The full story: docs/bench.md, section mycobot_planning.bench.peers.__init__.
"""
from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

import numpy as np

from .problems import checker_for, panda_pose_problems, panda_srdf_path, write_absolute_urdf
from .venvs import PEERS, PeerUnavailable, cache_dir, ensure_peer_venv, log, read_stamp, run_runner

__all__ = [
    "PEER_NAMES", "panda_pose_problems", "run_peers", "run_peer", "run_ours", "compare",
    "report_records", "validate_path", "ensure_peer_venv", "PeerUnavailable",
]

PEER_NAMES: tuple[str, ...] = ("mplib", "pyroboplan", "roboplan")
RUNNERS = {"mplib": "mplib_runner.py", "pyroboplan": "pyroboplan_runner.py", "roboplan": "roboplan_runner.py",
           "vamp": "vamp_runner.py"}  # vamp: parts only (no IK, so no pose-goal problems)
DEFAULT_TIME_LIMIT = 1.0
GOAL_POSITION_TOLERANCE = 1e-2
GOAL_ROTATION_TOLERANCE = 2e-2
CHECK_STEP = 0.02  # rad, max joint step between collision-checked states when validating a path


def runner_path(name: str) -> Path:
    return Path(__file__).resolve().parent / RUNNERS[name]


def _planner_request(problems: list[dict], time_limit: float) -> dict:
    return {
        "urdf": str(write_absolute_urdf(cache_dir())),
        "srdf": str(panda_srdf_path()),
        "time_limit": float(time_limit),
        "problems": problems,
    }


def validate_path(problem: dict, path: Sequence[Sequence[float]] | None) -> tuple[bool, str]:
    """Check a returned arm path against the problem with our own Pinocchio + Coal model.

    Returns (ok, reason). Independent of every planner being compared, ours included, so a
    planner that cuts corners in collision checking or limits is caught the same way.
    """
    if path is None or len(path) == 0:
        return False, "no path"
    arr = np.asarray(path, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != len(problem["joint_names"]):
        return False, f"path shape {arr.shape} does not match {len(problem['joint_names'])} joints"
    if not np.all(np.isfinite(arr)):
        return False, "path has non-finite values"
    if np.max(np.abs(arr[0] - np.asarray(problem["start"]))) > 1e-3:
        return False, "path does not start at the start state"
    checker = checker_for(problem.get("obstacles", []))
    model = checker.model
    low = np.array([model.lowerPositionLimit[i] for i in checker.arm_q])
    high = np.array([model.upperPositionLimit[i] for i in checker.arm_q])
    if np.any(arr < low - 1e-3) or np.any(arr > high + 1e-3):
        return False, "path leaves the joint limits"
    finger = next(iter(problem.get("finger_positions", {}).values()), 0.0)
    for a, b in zip(arr[:-1], arr[1:]):
        steps = max(1, int(math.ceil(np.max(np.abs(b - a)) / CHECK_STEP)))
        for t in np.linspace(0.0, 1.0, steps + 1)[1:]:
            if checker.in_collision(checker.full_q(a + t * (b - a), finger)):
                return False, "path collides"
    if checker.in_collision(checker.full_q(arr[0], finger)):
        return False, "start state collides"
    return True, ""


def _goal_errors(problem: dict, final: np.ndarray) -> tuple[float, float]:
    checker = checker_for(problem.get("obstacles", []))
    finger = next(iter(problem.get("finger_positions", {}).values()), 0.0)
    position, quat = checker.tip_pose(checker.full_q(final, finger))
    goal_q = np.asarray(problem["goal"]["orientation_xyzw"], dtype=float)
    dot = min(1.0, abs(float(np.dot(quat, goal_q / np.linalg.norm(goal_q)))))
    return (float(np.linalg.norm(position - np.asarray(problem["goal"]["position"]))),
            2.0 * math.acos(dot))


def _finish_record(problem: dict, record: dict, keep_path: bool) -> dict:
    """Judge a record the same way for every planner, with our own model.

    success = the planner claimed a path and its last state reaches the goal pose by our FK
    (1 cm / 0.02 rad); path_valid/path_problem from :func:`validate_path`. The path is dropped
    unless asked to keep it.
    """
    path = record.get("path")
    if path is not None and len(path) > 0:
        arr = np.asarray(path, dtype=float)
        if arr.ndim == 2 and arr.shape[1] == len(problem["joint_names"]):
            pos_err, rot_err = _goal_errors(problem, arr[-1])
            record["goal_position_error"], record["goal_rotation_error"] = pos_err, rot_err
            record["success"] = bool(record.get("claimed_success", True)
                                     and pos_err < GOAL_POSITION_TOLERANCE
                                     and rot_err < GOAL_ROTATION_TOLERANCE)
        else:
            record["success"] = False
        ok, reason = validate_path(problem, path)
        record["path_valid"], record["path_problem"] = ok, reason
    else:
        record["success"] = False
        record["path_valid"], record["path_problem"] = False, "no path"
    if not keep_path:
        record.pop("path", None)
    return record


def run_peer(name: str, problems: list[dict], time_limit: float = DEFAULT_TIME_LIMIT,
             keep_paths: bool = False) -> dict[str, Any]:
    """Solve ``problems`` with one peer in its venv.

    Returns ``{"available": True, "peer", "version", "setup_seconds", "results": [...]}`` or
    ``{"available": False, "peer", "reason"}`` when the venv cannot be built or the runner fails;
    never raises for a peer's own failure.
    """
    if name not in RUNNERS:
        raise KeyError(f"unknown peer '{name}'; known: {', '.join(RUNNERS)}")
    timeout = 120.0 + len(problems) * (3.0 * time_limit + 5.0)
    log(f"{name}: solving {len(problems)} problems (time limit {time_limit} s each)")
    outcome = run_runner(name, ensure_peer_venv, runner_path(name), _planner_request(problems, time_limit), timeout)
    if isinstance(outcome, dict):
        return outcome
    records, proc = outcome
    meta = next((r for r in records if r.get("meta")), {})
    by_index = {int(r["index"]): r for r in records if not r.get("meta") and "index" in r}
    results = []
    for problem in problems:
        record = by_index.get(problem["index"]) or {
            "index": problem["index"], "success": False, "claimed_success": False, "seconds": None,
            "status": f"no result (runner exit code {proc.returncode})"}
        results.append(_finish_record(problem, record, keep_paths))
    stamp = read_stamp(name) or {}
    return {"available": True, "peer": name,
            "version": meta.get("version") or stamp.get("version", "unknown"),
            "pins": PEERS[name].pins,
            "setup_seconds": meta.get("setup_seconds"), "results": results}


def run_peers(problems: list[dict], peers: Iterable[str] = PEER_NAMES,
              time_limit: float = DEFAULT_TIME_LIMIT, keep_paths: bool = False) -> dict[str, dict]:
    """``{peer name: run_peer(...)}`` for each peer, one after the other (never in parallel,
    so they do not compete for the 2 cores while being timed)."""
    return {name: run_peer(name, problems, time_limit, keep_paths) for name in peers}


PlanFn = Callable[[dict], Any]


def run_ours(problems: list[dict], plan: PlanFn, time_limit: float = DEFAULT_TIME_LIMIT,
             keep_paths: bool = False, warm_up: bool = True) -> list[dict]:
    """Time our planner on the problems: the injection point for the OMPL pipeline.

    ``plan(problem)`` gets one problem dict (start over ``joint_names``, goal pose of
    ``tip_link`` in ``base_frame``, ``obstacles`` boxes, and ``time_limit``: the planning time
    the peers were given; use it as allowed_planning_time) and
    returns the arm path as a sequence of joint vectors (``joint_names`` order, first = start),
    or None on failure, or a dict ``{"path": ..., "status": ...}``. ``seconds`` is wall time
    around that call only, so scene setup belongs outside it (build it lazily on the first call:
    the untimed warm-up call on problem 0 absorbs it, as the peer runners do).
    """
    problems = [{**problem, "time_limit": float(time_limit)} for problem in problems]
    if warm_up and problems:
        plan(problems[0])
    results = []
    for problem in problems:
        record: dict[str, Any] = {"index": problem["index"], "success": False}
        t0 = time.perf_counter()
        try:
            outcome = plan(problem)
            record["seconds"] = time.perf_counter() - t0
        except Exception as error:  # a crash on one problem is a failure, not the end of the run
            record["seconds"] = time.perf_counter() - t0
            record["status"] = f"error: {type(error).__name__}: {error}"
            results.append(_finish_record(problem, record, keep_paths))
            continue
        status = None
        if isinstance(outcome, dict):
            status, outcome = outcome.get("status"), outcome.get("path")
        if outcome is not None and len(outcome) > 0:
            arr = np.asarray(outcome, dtype=float)
            record["path"] = arr.tolist()
            record["waypoints"] = int(len(arr))
            record["path_length"] = float(np.sum(np.linalg.norm(np.diff(arr, axis=0), axis=1)))
            record["claimed_success"] = True
            record["status"] = status or "Success"
        else:
            record["claimed_success"] = False
            record["status"] = status or "failed"
        results.append(_finish_record(problem, record, keep_paths))
    return results


def _median(values: list[float]) -> float | None:
    return round(float(np.median(values)), 6) if values else None


def _ratio(a: float | None, b: float | None) -> float | None:
    if a is None or b is None or b == 0:
        return None
    return round(a / b, 4)


def summarize(results: list[dict]) -> dict[str, Any]:
    """success_rate, valid_path_rate and median time (solved problems / all attempts)."""
    n = len(results)
    solved = [r for r in results if r.get("success")]
    times = [float(r["seconds"]) for r in solved if r.get("seconds") is not None]
    all_times = [float(r["seconds"]) for r in results if r.get("seconds") is not None]
    lengths = [float(r["path_length"]) for r in solved if r.get("path_length") is not None]
    return {
        "problems": n,
        "solved": len(solved),
        "success_rate": round(len(solved) / n, 4) if n else None,
        "valid_path_rate": round(sum(bool(r.get("path_valid")) for r in solved) / n, 4) if n else None,
        "median_s": _median(times),
        "p90_s": round(float(np.percentile(times, 90)), 6) if times else None,
        "median_all_s": _median(all_times),
        "median_path_length": _median(lengths),
    }


def _results_of(run: Any) -> list[dict] | None:
    """Accept either a run dict from run_peer or a bare list of results."""
    if isinstance(run, list):
        return run
    if isinstance(run, dict) and run.get("available", True) and "results" in run:
        return run["results"]
    return None


def compare(ours: list[dict] | None, peers: dict[str, Any]) -> dict[str, Any]:
    """Per-peer success rate and median time, and our time relative to each peer.

    Ratios are ours / peer (below 1: we are faster):
      ratio_median_both    median over problems both solved, ours / peer's
      ratio_median_overall our median over our solved problems / the peer's over its own
      ratio_paired_median  median over problems both solved of (our time / peer's time)
    ``ours`` may be None (peers only); an unavailable peer is reported with its reason.
    """
    report: dict[str, Any] = {"ours": summarize(ours) if ours is not None else None, "peers": {}}
    ours_by_index = {r["index"]: r for r in ours or []}
    for name, run in peers.items():
        results = _results_of(run)
        if results is None:
            report["peers"][name] = {"available": False,
                                     "reason": run.get("reason", "no results") if isinstance(run, dict)
                                     else "no results"}
            continue
        entry: dict[str, Any] = {"available": True}
        if isinstance(run, dict):
            entry.update({k: run[k] for k in ("version", "pins", "setup_seconds") if k in run})
        entry.update(summarize(results))
        if ours is not None:
            both = [(ours_by_index[r["index"]], r) for r in results
                    if r.get("success") and ours_by_index.get(r["index"], {}).get("success")]
            ours_t = [float(o["seconds"]) for o, _ in both]
            peer_t = [float(p["seconds"]) for _, p in both]
            entry["both_solved"] = len(both)
            entry["ours_median_both_s"] = _median(ours_t)
            entry["peer_median_both_s"] = _median(peer_t)
            entry["ratio_median_both"] = _ratio(_median(ours_t), _median(peer_t))
            entry["ratio_median_overall"] = _ratio(report["ours"]["median_s"], entry["median_s"])
            paired = [o / p for o, p in zip(ours_t, peer_t) if p > 0]
            entry["ratio_paired_median"] = round(float(np.median(paired)), 4) if paired else None
        report["peers"][name] = entry
    return report


def report_records(report: dict[str, Any], scenario: str = "peers") -> list[dict[str, Any]]:
    """Flat JSON-line records for a compare() report: one per planner, ours first."""
    records = []
    if report.get("ours") is not None:
        records.append({"scenario": scenario, "planner": "ours", **report["ours"]})
    for name, entry in report["peers"].items():
        records.append({"scenario": scenario, "planner": name, **entry})
    return records
