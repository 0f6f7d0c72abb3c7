"""The `planners` benchmark: the trajectory optimisers STOMP and CHOMP beside OMPL in one run.

Problems: the seeds' fallbacks_move_to cases (a) 90 degrees from the target, (b) directly
reachable, (c) the target behind a thin box, on the myCobot (demos.mtc_demos); and the peers
benchmark's Panda joint-goal problems (example-robot-data's Panda around its 0.1 m box,
bench.peers.problems.panda_parts_problems). Every planner gets the same request (a joint goal,
``allowed_planning_time``, a seed per repeat) through the planning pipeline, and every path it
returns is judged by the trajectory validator's plain check (every active pair, no broad phase,
every 0.005 rad): a returned path that fails it is counted as invalid, not as a success.

Per planner: success rate (valid paths over requests), median planning time, median joint-space
path length (radians, the timed trajectory's waypoints), and invalid paths; overall and per set.

The full story: docs/bench.md, section mycobot_planning.bench.planners_scenarios.
"""
from __future__ import annotations

import time
from typing import Any, Callable, Iterable

import numpy as np

from mycobot_planning.core import RobotModel, RobotState
from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest
from mycobot_planning.core.planning_interface.planning_pipeline import PlanningPipeline
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory
from mycobot_planning.demos.mtc_demos import fallbacks_initial_cases, fallbacks_target_state

from .common import emit, machine
from .peers.parts import OursParts
from .peers.problems import panda_parts_problems

__all__ = ["PLANNERS", "PLANNERS_SCENARIOS", "bench_planners", "fallback_problems", "panda_problems",
           "path_length", "summarize"]

#: (summary prefix, pipeline_id, planner_id) of each planner compared
PLANNERS: tuple[tuple[str, str, str], ...] = (
    ("ompl", "ompl", "RRTConnectkConfigDefault"),
    ("stomp", "stomp", "STOMP"),
    ("chomp", "chomp", "CHOMP"),
)
#: s: allowed_planning_time of every request (a failing optimiser spends all of it)
ALLOWED_PLANNING_TIME = 2.0
#: Panda joint-goal problems drawn (of the peers benchmark's plan part)
PANDA_COUNT = 12


def fallback_problems(model: RobotModel) -> list[dict[str, Any]]:
    """The seeds' fallbacks_move_to cases (a), (b), (c): start scene and the common joint goal."""
    target = fallbacks_target_state(model)
    goal = np.array([target[j] for j in model.group("arm").joint_names])
    return [{"set": "fallbacks", "name": f"({letter}) {name}", "scene": scene, "start": scene.current_state,
             "group": "arm", "goal": goal}
            for letter, (name, scene) in zip("abc", fallbacks_initial_cases(model))]


def panda_problems(seed: int, count: int = PANDA_COUNT) -> list[dict[str, Any]]:
    """The peers benchmark's Panda joint-goal problems (both ends collision-free, the 0.1 m box)."""
    parts = panda_parts_problems(seed, ik_count=0, check_count=0, plan_count=count)
    ours = OursParts(parts)
    problems = []
    for problem in parts["plan"]:
        start = ours.start.copy()
        start.set_group_positions(ours.group, np.asarray(problem["start"], dtype=float))
        problems.append({"set": "panda", "name": f"panda plan {problem['index']}", "scene": ours.scene,
                         "start": start, "group": ours.group, "goal": np.asarray(problem["goal"], dtype=float)})
    return problems


def path_length(positions: np.ndarray) -> float:
    """Joint-space length (rad, Euclidean) of a polyline of waypoints."""
    return float(np.sum(np.linalg.norm(np.diff(np.asarray(positions, dtype=float), axis=0), axis=1)))


def plan_once(pipeline: PlanningPipeline, problem: dict[str, Any], pipeline_id: str, planner_id: str, seed: int,
              allowed_planning_time: float) -> dict[str, Any]:
    """One request; the returned path judged by the validator's plain check."""
    start: RobotState = problem["start"]
    request = MotionPlanRequest(problem["group"], JointGoal(problem["goal"]), start_state=start,
                                pipeline_id=pipeline_id, planner_id=planner_id, seed=seed,
                                allowed_planning_time=allowed_planning_time)
    started = time.perf_counter()
    response = pipeline.plan(problem["scene"], request)
    seconds = time.perf_counter() - started
    record: dict[str, Any] = {"returned": response.success, "status": response.error_code.name,
                              "planning_ms": round(seconds * 1e3, 2)}
    if response.success:
        report = validate_trajectory(problem["scene"], response.trajectory, problem["group"], start_state=start)
        record["valid"] = bool(report.valid)
        record["path_length"] = round(path_length(response.trajectory.positions), 4)
        record["duration_s"] = round(float(response.trajectory.duration), 4)
        if not report.valid:
            record["problem"] = "; ".join(report.problems[:2])
    else:
        record["valid"] = False
    return record


def _median(values: Iterable[float]) -> float | None:
    values = [float(v) for v in values]
    return round(float(np.median(values)), 4) if values else None


def summarize(records: list[dict[str, Any]], prefixes: Iterable[str]) -> dict[str, Any]:
    """``<planner>_success_rate`` (valid paths / requests), ``<planner>_median_ms`` (all requests),
    ``<planner>_path_length`` (median over valid paths, rad), ``<planner>_invalid`` (returned
    paths the validator refused), ``<planner>_requests``; then the same per set under ``sets``."""
    def figures(rows: list[dict[str, Any]], prefix: str) -> dict[str, Any]:
        mine = [r for r in rows if r["planner"] == prefix]
        valid = [r for r in mine if r["valid"]]
        return {f"{prefix}_requests": len(mine),
                f"{prefix}_success_rate": round(len(valid) / len(mine), 4) if mine else None,
                f"{prefix}_median_ms": _median(r["planning_ms"] for r in mine),
                f"{prefix}_path_length": _median(r["path_length"] for r in valid),
                f"{prefix}_invalid": sum(1 for r in mine if r["returned"] and not r["valid"])}

    prefixes = list(prefixes)
    out: dict[str, Any] = {}
    for prefix in prefixes:
        out.update(figures(records, prefix))
    sets: dict[str, Any] = {}
    for name in dict.fromkeys(r["set"] for r in records):
        rows = [r for r in records if r["set"] == name]
        sets[name] = {"problems": len(dict.fromkeys(r["problem"] for r in rows))}
        for prefix in prefixes:
            sets[name].update(figures(rows, prefix))
    out["sets"] = sets
    return out


def bench_planners(repeat: int, seed: int, panda_count: int = PANDA_COUNT,
                   allowed_planning_time: float = ALLOWED_PLANNING_TIME,
                   planners: tuple[tuple[str, str, str], ...] = PLANNERS,
                   problems: Callable[[int], list[dict[str, Any]]] | None = None) -> None:
    """STOMP and CHOMP beside OMPL on the fallback cases and the Panda problems (module docstring)."""
    if problems is None:
        chosen = fallback_problems(RobotModel.mycobot()) + panda_problems(seed, panda_count)
    else:
        chosen = problems(seed)
    pipeline = PlanningPipeline()
    # warm-ups, untimed: each planner once on each robot (IK tables, compiled scenes, spheres)
    for problem in {id(p["scene"].robot_model): p for p in chosen}.values():
        for _, pipeline_id, planner_id in planners:
            plan_once(pipeline, problem, pipeline_id, planner_id, seed, allowed_planning_time)
    records = []
    for round_ in range(repeat):
        for problem in chosen:
            for prefix, pipeline_id, planner_id in planners:
                record = {"scenario": "planners", "set": problem["set"], "problem": problem["name"],
                          "planner": prefix, "repeat": round_,
                          **plan_once(pipeline, problem, pipeline_id, planner_id, seed + round_,
                                      allowed_planning_time)}
                emit(record)
                records.append(record)
    emit({"scenario": "planners", "summary": True, **summarize(records, [p for p, _, _ in planners]),
          "allowed_planning_time": allowed_planning_time, "panda_problems": panda_count,
          "repeat": repeat, "seed": seed, **machine()})


PLANNERS_SCENARIOS = {"planners": bench_planners}
