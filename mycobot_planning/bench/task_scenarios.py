"""Task-constructor benchmarks: the seeds' modular, fallbacks_move_to and ik_clearance_cost demos.

Each scenario builds the demo task afresh and times ``task.plan()`` (initialisation included,
as a node calls it), ``RUNS`` times per repeat. Summary keys (a contract, keep them stable):
``total_s`` (median planning time) and ``solutions`` (solutions found; the same in every run,
else the smallest), plus p90, the spread of per-repeat medians and the machine.

Register in scenarios.SCENARIOS as "modular", "fallbacks_move_to", "ik_clearance_cost".
"""
from __future__ import annotations

import numpy as np

from mycobot_planning.core import PlanningScene, RobotModel

from .common import emit, machine, spread, stats, timed

RUNS = 10


def _bench(name: str, build, repeat: int, seed: int, runs: int | None = None) -> None:
    runs = RUNS if runs is None else runs
    build(seed).plan()  # warm-up: IK seed tables, OMPL configuration, compiled collision models
    all_times: list[float] = []
    solutions: list[int] = []
    medians: list[float] = []
    for index in range(repeat):
        times = []
        for k in range(runs):
            task = build(seed * 1000 + index * runs + k)
            elapsed, _result = timed(task.plan)
            times.append(elapsed)
            solutions.append(task.numSolutions())
        record = {"scenario": name, "repeat": index, "runs": len(times), "solutions": solutions[-1]}
        record.update(stats(times, 1.0, "s"))
        medians.append(record["median_s"])
        emit(record)
        all_times += times
    summary = {
        "scenario": name,
        "summary": True,
        "total_s": round(float(np.median(all_times)), 4),
        "p90_s": round(float(np.percentile(all_times, 90)), 4),
        "solutions": int(min(solutions)),
        "solutions_max": int(max(solutions)),
    }
    emit({**summary, **spread(medians), **machine()})


def bench_modular(repeat: int, seed: int) -> None:
    """The modular demo: current → ready → 5 × (x +0.05, y -0.02, rz -18°, ready) → home."""
    from mycobot_planning.demos.mtc_demos import build_modular_task

    model = RobotModel.mycobot()
    scene = PlanningScene(model)
    _bench("modular", lambda s: build_modular_task(model, scene, seed=s), repeat, seed)


def bench_fallbacks_move_to(repeat: int, seed: int) -> None:
    """The fallbacks demo: three initial states × Fallbacks(Cartesian, PTP, OMPL)."""
    from mycobot_planning.demos.mtc_demos import build_fallbacks_move_to_task

    model = RobotModel.mycobot()
    scene = PlanningScene(model)
    _bench("fallbacks_move_to", lambda s: build_fallbacks_move_to_task(model, scene, seed=s), repeat, seed)


def bench_ik_clearance_cost(repeat: int, seed: int) -> None:
    """The IK clearance demo: all distinct IK solutions of one pose, ranked by clearance."""
    from mycobot_planning.demos.mtc_demos import build_ik_clearance_cost_task, ik_clearance_cost_scene

    model = RobotModel.mycobot()
    scene = ik_clearance_cost_scene(model)
    _bench("ik_clearance_cost", lambda s: build_ik_clearance_cost_task(model, scene, seed=s), repeat, seed)


TASK_SCENARIOS = {
    "modular": bench_modular,
    "fallbacks_move_to": bench_fallbacks_move_to,
    "ik_clearance_cost": bench_ik_clearance_cost,
}
