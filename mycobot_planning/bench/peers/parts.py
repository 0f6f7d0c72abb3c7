"""The `peers` benchmark's three parts (IK, validity check, joint-goal RRTConnect) for us, mplib,
pyroboplan, roboplan and VAMP (check and plan only) in one run, judged by one independent checker.

The full story: docs/bench.md, section mycobot_planning.bench.peers.parts.
"""
from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from . import PEER_NAMES, RUNNERS, runner_path
from .problems import checker_for, panda_parts_problems, panda_srdf_path, write_absolute_urdf
from .venvs import PEERS, cache_dir, ensure_peer_venv, log, read_stamp, run_runner

__all__ = ["PARTS_PEERS", "OursParts", "run_ours_parts", "run_peer_parts", "judge_parts",
           "summarize_parts", "parts_ratios", "vamp_figures", "bench_peers_parts"]

PARTS_PEERS: tuple[str, ...] = PEER_NAMES + ("vamp",)
NO_IK_PEERS: frozenset[str] = frozenset({"vamp"})  # asked only the check and plan parts
TIME_LIMIT = 1.0  # s of planning time per joint-goal problem, every planner
RECHECK_STEP = 0.01  # rad: the independent recheck of every returned path
IK_POSITION_TOLERANCE = 2e-3  # m, judged by our independent FK (roboplan's own tolerance is 1e-3)
IK_ROTATION_TOLERANCE = 2e-3  # rad
GOAL_TOLERANCE = 1e-3  # rad: a joint-goal path must end this close to the goal (max-norm)


# ---------------------------------------------------------------------------------------------
# Ours (in this process)
# ---------------------------------------------------------------------------------------------


class OursParts:
    """Our library on the parts: Panda from example-robot-data, the box, the SRDF start.

    IK: ``IKSolver.solve`` (one solution, checked against the scene, seeded by the start).
    Check: the validity checker OMPL calls (``PlanningScene.validity_checker(check_bounds=False)``:
    states are inside the limits by construction). Plan: ``OmplPlanner.plan`` of a JointGoal with
    RRTConnect: simplification, time parameterisation and the trajectory validator included.
    """

    def __init__(self, parts: dict) -> None:
        from interfaces_py.msgs import CollisionObject
        from mycobot_planning.core import PlanningScene, RobotModel, RobotState
        from mycobot_planning.core.kinematics.ik_solver import IKSolver
        from mycobot_planning.core.planners.ompl import OmplPlanner
        from mycobot_planning.core.transforms import make_pose
        from mycobot_planning.paths import example_robot_data_dir

        root = example_robot_data_dir() / "panda_description"
        self.model = RobotModel.from_files(root / "urdf" / "panda.urdf", root / "srdf" / "panda.srdf")
        self.scene = PlanningScene(self.model)
        for box in parts["obstacles"]:
            pose = make_pose(box["position"], quat_xyzw=box["orientation_xyzw"])
            self.scene.add_object(CollisionObject.box(box["id"], box["size"], pose))
        self.joint_names = list(parts["joint_names"])
        self.start = RobotState(self.model)
        self.start.set_joint_positions(dict(zip(self.joint_names, parts["start"])))
        self.start.set_joint_positions({j: v for j, v in parts["finger_positions"].items()
                                        if j in self.model.variable_names})
        self.scene.set_current_state(self.start)
        self.group = "arm"
        self.indices = np.array([self.model.variable_index(j) for j in self.joint_names])
        self.ik_solver = IKSolver(self.model, self.group, parts["tip_link"])
        self.planner = OmplPlanner()
        self.check = self.scene.validity_checker(self.group, self.start, check_bounds=False)
        self._RobotState = RobotState

    def ik(self, problem: dict, rng: np.random.Generator) -> tuple[float, list[float] | None]:
        from mycobot_planning.core.transforms import make_pose

        pose = make_pose(problem["goal"]["position"], quat_xyzw=problem["goal"]["orientation_xyzw"])
        t0 = time.perf_counter()
        solutions = self.ik_solver.solve(pose, seed=self.start, max_solutions=1, validity=self.scene, rng=rng)
        seconds = time.perf_counter() - t0
        if not solutions:
            return seconds, None
        return seconds, [float(v) for v in solutions[0].positions[self.indices]]

    def plan(self, problem: dict, seed: int) -> dict:
        from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest

        start = self.start.copy()
        start.set_group_positions(self.group, np.asarray(problem["start"], dtype=float))
        request = MotionPlanRequest(self.group, JointGoal(np.asarray(problem["goal"], dtype=float)),
                                    start_state=start, allowed_planning_time=TIME_LIMIT, seed=seed)
        t0 = time.perf_counter()
        response = self.planner.plan(self.scene, request)
        seconds = time.perf_counter() - t0
        if not response.success:
            return {"seconds": seconds, "status": response.error_code.name, "path": None}
        # What is executed is the timed trajectory: sample it finely (untimed) for the recheck.
        trajectory = response.trajectory
        ts = np.linspace(trajectory.times[0], trajectory.times[-1],
                         max(2, int(math.ceil(trajectory.duration / 0.002)) + 1))
        q = trajectory.sample(ts)[0]
        order = [list(trajectory.joint_names).index(j) for j in self.joint_names]
        return {"seconds": seconds, "status": "SUCCESS", "path": q[:, order].tolist()}


def run_ours_parts(parts: dict, time_limit: float = TIME_LIMIT, seed: int = 0) -> dict[str, Any]:
    """Our side of the parts, with the peers' runners' record shapes (warm-ups untimed)."""
    started = time.perf_counter()
    ours = OursParts(parts)
    setup_seconds = time.perf_counter() - started
    rng = np.random.default_rng(seed + 1)
    if parts["ik"]:
        ours.ik(parts["ik"][0], np.random.default_rng(0))  # builds the IK seed table
    if parts["plan"]:
        ours.plan(parts["plan"][0], 1)
    ik = []
    for problem in parts["ik"]:
        seconds, solution = ours.ik(problem, rng)
        ik.append({"part": "ik", "index": problem["index"], "seconds": seconds, "solution": solution})
    clock, check = time.perf_counter, ours.check
    states = [np.asarray(q, dtype=float) for q in parts["check"]]
    seconds, colliding = [], []
    for q in states:
        t0 = clock()
        free = check(q)
        seconds.append(clock() - t0)
        colliding.append(not free)
    plan = []
    for problem in parts["plan"]:
        plan.append({"part": "plan", "index": problem["index"], **ours.plan(problem, problem["index"] + 1)})
    import mycobot_planning

    return {"available": True, "peer": "ours", "version": getattr(mycobot_planning, "__version__", "checkout"),
            "setup_seconds": round(setup_seconds, 4), "ik": ik,
            "check": {"seconds": seconds, "colliding": colliding}, "plan": plan}


# ---------------------------------------------------------------------------------------------
# Peers (each in its venv)
# ---------------------------------------------------------------------------------------------


def run_peer_parts(name: str, parts: dict, time_limit: float = TIME_LIMIT, seed: int = 0) -> dict[str, Any]:
    """One peer's side of the parts from its runner; ``{"available": False, ...}`` when the
    venv cannot be built or the runner gives nothing (never raises for a peer's failure)."""
    if name not in RUNNERS:
        raise KeyError(f"unknown peer '{name}'; known: {', '.join(RUNNERS)}")
    if name in NO_IK_PEERS:
        parts = {**parts, "ik": []}
    request = {"urdf": str(write_absolute_urdf(cache_dir())), "srdf": str(panda_srdf_path()),
               "time_limit": float(time_limit), "seed": int(seed), "parts": parts}
    timeout = 300.0 + len(parts["plan"]) * (3.0 * time_limit + 5.0) + len(parts["ik"]) * 2.0
    log(f"{name}: parts ({len(parts['ik'])} IK, {len(parts['check'])} checks, {len(parts['plan'])} plans)")
    outcome = run_runner(name, ensure_peer_venv, runner_path(name), request, timeout)
    if isinstance(outcome, dict):
        return outcome
    records, proc = outcome
    meta = next((r for r in records if r.get("meta")), {})
    ik = {int(r["index"]): r for r in records if r.get("part") == "ik"}
    plan = {int(r["index"]): r for r in records if r.get("part") == "plan"}
    check = next((r for r in records if r.get("part") == "check"), None)
    missing = f"no result (runner exit code {proc.returncode})"
    stamp = read_stamp(name) or {}
    return {
        "available": True, "peer": name,
        "version": meta.get("version") or stamp.get("version", "unknown"),
        "pins": PEERS[name].pins,
        "setup_seconds": meta.get("setup_seconds"),
        "ik": [ik.get(p["index"]) or {"part": "ik", "index": p["index"], "seconds": None, "solution": None,
                                       "status": missing} for p in parts["ik"]],
        "check": check or {"seconds": [], "colliding": [], "status": missing},
        "plan": [plan.get(p["index"]) or {"part": "plan", "index": p["index"], "seconds": None, "path": None,
                                           "status": missing} for p in parts["plan"]],
    }


# ---------------------------------------------------------------------------------------------
# Judging (one independent checker for everybody) and summaries
# ---------------------------------------------------------------------------------------------


def reference_colliding(parts: dict) -> list[bool]:
    """The independent verdict on every check state (plain Pinocchio + Coal on the meshes)."""
    checker = checker_for(parts["obstacles"])
    finger = next(iter(parts["finger_positions"].values()), 0.0)
    return [checker.in_collision(checker.full_q(np.asarray(q), finger)) for q in parts["check"]]


def _ik_ok(parts: dict, problem: dict, solution: Any) -> bool:
    if solution is None:
        return False
    arr = np.asarray(solution, dtype=float)
    if arr.shape != (len(parts["joint_names"]),) or not np.all(np.isfinite(arr)):
        return False
    checker = checker_for(parts["obstacles"])
    model = checker.model
    low = np.array([model.lowerPositionLimit[i] for i in checker.arm_q])
    high = np.array([model.upperPositionLimit[i] for i in checker.arm_q])
    if np.any(arr < low - 1e-6) or np.any(arr > high + 1e-6):
        return False
    finger = next(iter(parts["finger_positions"].values()), 0.0)
    q = checker.full_q(arr, finger)
    if checker.in_collision(q):
        return False
    position, quat = checker.tip_pose(q)
    goal = np.asarray(problem["goal"]["orientation_xyzw"], dtype=float)
    dot = min(1.0, abs(float(np.dot(quat, goal / np.linalg.norm(goal)))))
    return (float(np.linalg.norm(position - np.asarray(problem["goal"]["position"]))) <= IK_POSITION_TOLERANCE
            and 2.0 * math.acos(dot) <= IK_ROTATION_TOLERANCE)


def recheck_path(parts: dict, problem: dict, path: Any) -> tuple[bool, bool, str]:
    """(reaches, valid, why): the path starts at the start, ends at the goal (GOAL_TOLERANCE),
    and stays inside the limits and collision-free at RECHECK_STEP between waypoints."""
    if path is None or len(path) == 0:
        return False, False, "no path"
    arr = np.asarray(path, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != len(parts["joint_names"]) or not np.all(np.isfinite(arr)):
        return False, False, f"malformed path of shape {arr.shape}"
    reaches = bool(np.max(np.abs(arr[0] - problem["start"])) <= GOAL_TOLERANCE
                   and np.max(np.abs(arr[-1] - problem["goal"])) <= GOAL_TOLERANCE)
    checker = checker_for(parts["obstacles"])
    model = checker.model
    low = np.array([model.lowerPositionLimit[i] for i in checker.arm_q])
    high = np.array([model.upperPositionLimit[i] for i in checker.arm_q])
    if np.any(arr < low - 1e-6) or np.any(arr > high + 1e-6):
        return reaches, False, "path leaves the joint limits"
    finger = next(iter(parts["finger_positions"].values()), 0.0)
    if checker.in_collision(checker.full_q(arr[0], finger)):
        return reaches, False, "first state collides"
    for a, b in zip(arr[:-1], arr[1:]):
        steps = max(1, int(math.ceil(float(np.max(np.abs(b - a))) / RECHECK_STEP)))
        for t in np.arange(1, steps + 1) / steps:
            if checker.in_collision(checker.full_q(a + t * (b - a), finger)):
                return reaches, False, "path collides"
    return reaches, True, ""


def judge_parts(parts: dict, run: dict, reference: list[bool]) -> dict:
    """Adds ``ok`` to every IK record, ``reaches``/``valid``/``problem`` to every plan record and
    ``agree`` (count of verdicts equal to the reference) and ``missed`` (colliding states called
    free) to the check record, in place."""
    by_index = {p["index"]: p for p in parts["ik"]}
    for record in run["ik"]:
        record["ok"] = _ik_ok(parts, by_index[record["index"]], record.get("solution"))
    plans = {p["index"]: p for p in parts["plan"]}
    for record in run["plan"]:
        reaches, valid, why = recheck_path(parts, plans[record["index"]], record.get("path"))
        record["reaches"], record["valid"], record["problem"] = reaches, valid, why
    verdicts = run["check"].get("colliding") or []
    run["check"]["agree"] = int(sum(bool(a) == b for a, b in zip(verdicts, reference)))
    run["check"]["missed"] = int(sum(b and not a for a, b in zip(verdicts, reference)))
    return run


def _ms(values: list[float], q: float = 50.0) -> float | None:
    return round(float(np.percentile(values, q)) * 1e3, 4) if values else None


def summarize_parts(runs: list[dict]) -> dict[str, Any]:
    """One planner's figures pooled over judged runs (repeats): IK success and median (over all
    queries, and over solved ones), check median, plan success/median/p90 (solved plans: the path
    reaches the goal and passes the recheck) and ``invalid_paths`` (claimed paths failing it)."""
    ik = [r for run in runs for r in run["ik"]]
    ik_times = [r["seconds"] for r in ik if r.get("seconds") is not None]
    ik_solved = [r["seconds"] for r in ik if r.get("ok") and r.get("seconds") is not None]
    checks = [s for run in runs for s in run["check"].get("seconds", [])]
    agree = sum(run["check"].get("agree", 0) for run in runs)
    plans = [r for run in runs for r in run["plan"]]
    solved = [r for r in plans if r.get("reaches") and r.get("valid") and r.get("seconds") is not None]
    claimed = [r for r in plans if r.get("path")]
    out: dict[str, Any] = {
        "ik_problems": len(ik),
        "ik_solved": sum(bool(r.get("ok")) for r in ik),
        "ik_success_rate": round(sum(bool(r.get("ok")) for r in ik) / len(ik), 4) if ik else None,
        "ik_median_ms": _ms(ik_times),
        "ik_median_solved_ms": _ms(ik_solved),
        "check_states": len(checks),
        "check_median_us": round(float(np.median(checks)) * 1e6, 3) if checks else None,
        "check_agreement": round(agree / len(checks), 5) if checks else None,
        # colliding by the reference, called free: the unsafe side of a disagreement
        "check_missed": sum(run["check"].get("missed", 0) for run in runs),
        "plan_problems": len(plans),
        "plan_solved": len(solved),
        "plan_success_rate": round(len(solved) / len(plans), 4) if plans else None,
        "plan_median_ms": _ms([r["seconds"] for r in solved]),
        "plan_p90_ms": _ms([r["seconds"] for r in solved], 90.0),
        "invalid_paths": sum(1 for r in claimed if not r.get("valid")),
        "paths_missing_goal": sum(1 for r in claimed if r.get("valid") and not r.get("reaches")),
    }
    if solved and "shortcut_seconds" in solved[0]:
        out["plan_median_without_shortcut_ms"] = _ms([r["plan_seconds"] for r in solved])
    return out


def _ratio(a: float | None, b: float | None) -> float | None:
    return None if a is None or b is None or b == 0 else round(a / b, 4)


def parts_ratios(summaries: dict[str, dict]) -> dict[str, Any]:
    """``ik_ratio``, ``check_ratio``, ``plan_ratio`` (ours / roboplan medians) and
    ``invalid_paths`` per planner."""
    ours, peer = summaries.get("ours") or {}, summaries.get("roboplan") or {}
    return {
        "ik_ratio": _ratio(ours.get("ik_median_ms"), peer.get("ik_median_ms")),
        "check_ratio": _ratio(ours.get("check_median_us"), peer.get("check_median_us")),
        "plan_ratio": _ratio(ours.get("plan_median_ms"), peer.get("plan_median_ms")),
        "invalid_paths": {name: s.get("invalid_paths") for name, s in summaries.items() if s},
    }


def vamp_figures(summaries: dict[str, dict]) -> dict[str, Any]:
    """VAMP's figures and ours / VAMP's ratios: ``vamp_check_us`` (median per state),
    ``vamp_plan_ms`` (median over solved plans, RRTConnect + simplification), ``vamp_success_rate``
    (plans reaching the goal and passing our recheck), ``vamp_invalid_paths`` (returned paths
    failing it), ``vamp_check_agreement``/``vamp_check_missed`` (its sphere-model verdicts against
    our exact meshes), ``check_ratio_vamp``, ``plan_ratio_vamp``; all None when VAMP did not run."""
    ours, vamp = summaries.get("ours") or {}, summaries.get("vamp") or {}
    return {
        "vamp_check_us": vamp.get("check_median_us"),
        "vamp_plan_ms": vamp.get("plan_median_ms"),
        "vamp_success_rate": vamp.get("plan_success_rate"),
        "vamp_invalid_paths": vamp.get("invalid_paths"),
        "vamp_check_agreement": vamp.get("check_agreement"),
        "vamp_check_missed": vamp.get("check_missed"),
        "check_ratio_vamp": _ratio(ours.get("check_median_us"), vamp.get("check_median_us")),
        "plan_ratio_vamp": _ratio(ours.get("plan_median_ms"), vamp.get("plan_median_ms")),
    }


def bench_peers_parts(repeat: int, seed: int, emit=None, peers: tuple[str, ...] = PARTS_PEERS,
                      ik_count: int | None = None, check_count: int | None = None,
                      plan_count: int | None = None) -> dict[str, Any]:
    """The ``peers`` scenario: per repeat a fresh problem set (seed + repeat), each peer's runner
    one after the other, then ours; one record per planner and repeat, then the summary (figures
    pooled over the repeats, ratios ours / roboplan from those pooled medians)."""
    from ..common import emit as default_emit, machine

    emit = emit or default_emit
    counts = {k: v for k, v in (("ik_count", ik_count), ("check_count", check_count),
                                ("plan_count", plan_count)) if v is not None}
    judged: dict[str, list[dict]] = {name: [] for name in ("ours", *peers)}
    meta: dict[str, dict] = {}
    unavailable: dict[str, str] = {}
    for index in range(repeat):
        parts = panda_parts_problems(seed + index, **counts)
        reference = reference_colliding(parts)
        runs = {name: run_peer_parts(name, parts, TIME_LIMIT, seed + index) for name in peers}
        runs["ours"] = run_ours_parts(parts, TIME_LIMIT, seed + index)
        for name in ("ours", *peers):
            run = runs[name]
            if not run.get("available"):
                unavailable[name] = run.get("reason", "unavailable")
                emit({"scenario": "peers", "repeat": index, "planner": name, "available": False,
                      "reason": unavailable[name]})
                continue
            judge_parts(parts, run, reference)
            judged[name].append(run)
            meta[name] = {k: run[k] for k in ("version", "pins") if k in run}
            emit({"scenario": "peers", "repeat": index, "planner": name, **meta[name],
                  **summarize_parts([run])})
    summaries = {name: summarize_parts(runs) for name, runs in judged.items() if runs}
    planners = {name: {**meta.get(name, {}), **summary} for name, summary in summaries.items()}
    for name, reason in unavailable.items():
        planners.setdefault(name, {"available": False, "reason": reason})
    summary = {"scenario": "peers", "summary": True, **parts_ratios(summaries), **vamp_figures(summaries),
               "planners": planners,
               "time_limit_s": TIME_LIMIT, "recheck_step_rad": RECHECK_STEP, **machine()}
    emit(summary)
    return summary
