"""Benchmark ``trajectory_cache``: a repeated pick-and-place cycle of motions planned through the
plan capability (capabilities.plan.plan, what both move_group faces call) with the trajectory
cache enabled (":memory:", the planning_server's default settings).

The cycle, in the seeds' pick-and-place scene (table and cylinder): home -> above the pick side
-> above the place side -> ready -> home, as joint and named goals, with OMPL (RRTConnect). After
each motion the current state becomes its last point plus up to 2 mrad per joint of settling
error, as a real arm stops (so every hit is stitched to the actual start). The first cycle
plans (misses), the following ``CYCLES - 1`` should be answered from the cache. Every repeat
starts with an empty cache.

Summary keys (a contract, keep them stable): ``hit_ms`` (median wall time of a plan request
answered from the cache, the whole typed call: lookup, stitching and validation in the current
scene, and the sampling into the JointTrajectory every plan gets), ``hit_lookup_ms`` (of that:
key, SQLite query, decoding), ``hit_validate_ms`` (of that: stitching and the pipelines'
validator), ``hit_sample_ms`` (the rest: sampling the trajectory into the JointTrajectory message,
as every plan does), ``miss_ms`` (median of a request that was planned, insert included),
``hit_rate`` (hits / requests, all cycles), ``first_cycle_ms`` / ``cached_cycle_ms`` (median
time of the whole cycle's four requests: the first, planned, and the later ones), p90s,
``requests``, ``refused`` (entries the validator refused: 0 in this unchanging world) and the
machine. The first cycle's home request starts at every joint 0, the later ones at "ready":
five distinct motions, so at most 35 of 40 requests can hit.

Register in scenarios.SCENARIOS as ``"trajectory_cache": bench_trajectory_cache``.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from interfaces_py.msgs import MoveItErrorCode
from mycobot_planning.capabilities import plan, trajectory_cache
from mycobot_planning.capabilities.move_group_context import MoveGroupContext, planning_only
from mycobot_planning.core import RobotModel
from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest, NamedGoal
from mycobot_planning.core.planning_interface.planning_pipeline import PlanningPipeline
from mycobot_planning.demos.pick_place import PickPlaceParameters, seed_scene_objects

from .common import emit, machine, spread

#: cycles per repeat (the first one plans)
CYCLES = 10
#: rad: largest settling error added to each joint after a motion (start_tolerance / 2 is 12.5 mrad)
SETTLE = 0.002
PICK = [-1.2, -0.7, -0.8, 0.2, -0.1, 0.4]
PLACE = [-0.35, -0.75, -0.6, 0.15, -0.1, 0.4]  # across the cylinder from PICK: the straight motion hits it
#: the cycle's goals: named states and joint values (arm)
CYCLE: tuple[Any, ...] = ("home", PICK, PLACE, "ready")


def make_context(model: RobotModel, pipeline: PlanningPipeline) -> MoveGroupContext:
    """A context in the seeds' pick-and-place scene, at every joint 0, with the cache enabled."""
    ctx = planning_only(MoveGroupContext, model, pipeline)
    for obj in seed_scene_objects(PickPlaceParameters()):
        if obj is not None:
            ctx.apply_collision_objects([obj.to_dict()])
    names = list(model.variable_names)
    if ctx.update_joint_state(names, [0.0] * len(names)) is not None:
        raise RuntimeError("benchmark set-up: the start state was refused")
    trajectory_cache.configure(ctx, trajectory_cache.TrajectoryCacheSettings(enabled=True))
    return ctx


def run_cycles(ctx: MoveGroupContext, cycles: int, rng: np.random.Generator) -> list[dict[str, Any]]:
    """Plan the cycle ``cycles`` times, moving the current state to each plan's end (plus
    settling error); one record per request."""
    model = ctx.model
    names = list(model.variable_names)
    arm = list(model.group("arm").joint_names)
    records = []
    for cycle in range(cycles):
        for target in CYCLE:
            goal = NamedGoal(target, 1e-3) if isinstance(target, str) else JointGoal(dict(zip(arm, target)), 1e-3)
            request = MotionPlanRequest("arm", goal, allowed_planning_time=5.0, num_planning_attempts=1,
                                        seed=int(rng.integers(2**31)))
            result = plan.plan(ctx, request, display=False)
            if result.error_code.val != MoveItErrorCode.SUCCESS or result.trajectory is None:
                raise RuntimeError(f"benchmark: planning to {target} failed: {result.error_code}")
            end = np.asarray(result.trajectory.points[-1].positions, dtype=float)
            settled = dict(zip(arm, end + rng.uniform(-SETTLE, SETTLE, len(arm))))
            positions = ctx.joint_positions()[0] or {}
            if ctx.update_joint_state(names, [settled.get(n, positions.get(n, 0.0)) for n in names]) is not None:
                raise RuntimeError("benchmark: the settled state was refused")
            records.append({"cycle": cycle, "target": target if isinstance(target, str) else "joints",
                            "cache": result.trajectory_cache, "total_s": result.planning_time,
                            "lookup_s": result.cache_lookup_time, "validate_s": result.cache_validate_time})
    return records


def _ms(values: list[float], q: float = 50.0) -> float:
    return round(float(np.percentile(values, q)) * 1e3, 4) if values else float("nan")


def summarise(records: list[dict[str, Any]]) -> dict[str, Any]:
    hits = [r for r in records if r["cache"] == "hit"]
    misses = [r for r in records if r["cache"] == "miss"]
    cycles: dict[tuple[int, int], float] = {}
    for r in records:
        cycles[(r.get("run", 0), r["cycle"])] = cycles.get((r.get("run", 0), r["cycle"]), 0.0) + r["total_s"]
    return {
        "hit_ms": _ms([r["total_s"] for r in hits]),
        "hit_lookup_ms": _ms([r["lookup_s"] for r in hits]),
        "hit_validate_ms": _ms([r["validate_s"] for r in hits]),
        "hit_sample_ms": _ms([r["total_s"] - r["lookup_s"] - r["validate_s"] for r in hits]),
        "miss_ms": _ms([r["total_s"] for r in misses]),
        "hit_rate": round(len(hits) / len(records), 4) if records else float("nan"),
        "p90_hit_ms": _ms([r["total_s"] for r in hits], 90.0),
        "p90_hit_lookup_ms": _ms([r["lookup_s"] for r in hits], 90.0),
        "p90_miss_ms": _ms([r["total_s"] for r in misses], 90.0),
        "first_cycle_ms": _ms([t for (_, c), t in cycles.items() if c == 0]),
        "cached_cycle_ms": _ms([t for (_, c), t in cycles.items() if c > 0]),
        "requests": len(records),
    }


def bench_trajectory_cache(repeat: int, seed: int, cycles: int | None = None) -> None:
    """The repeated pick-and-place cycle with the trajectory cache (see the module docstring)."""
    cycles = CYCLES if cycles is None else cycles
    model = RobotModel.mycobot()
    pipeline = PlanningPipeline()
    run_cycles(make_context(model, pipeline), 1, np.random.default_rng(seed + 10**6))  # warm-up
    records: list[dict[str, Any]] = []
    medians: list[float] = []
    refused = 0
    for index in range(repeat):
        ctx = make_context(model, pipeline)
        batch = [{**r, "run": index} for r in run_cycles(ctx, cycles, np.random.default_rng(seed * 1000 + index))]
        refused += ctx.trajectory_cache.status(model)["refused"]
        record = {"scenario": "trajectory_cache", "repeat": index, "cycles": cycles, **summarise(batch)}
        medians.append(record["hit_ms"])
        emit(record)
        records += batch
    summary = {"scenario": "trajectory_cache", "summary": True, **summarise(records), "refused": refused,
               "cycles": cycles, "motions_per_cycle": len(CYCLE)}
    emit({**summary, **spread(medians), **machine()})


TRAJECTORY_CACHE_SCENARIOS = {"trajectory_cache": bench_trajectory_cache}
