"""The `trajectory_cache` benchmark's plumbing: the cycle is planned, later cycles are answered
from the cache (hits valid in the pick-and-place scene and started at the settled state), and
the summary carries the contract keys. No timing is asserted here."""
from __future__ import annotations

import json

import numpy as np

from mycobot_planning.bench import trajectory_cache_scenarios as tcs
from mycobot_planning.bench.scenarios import SCENARIOS
from mycobot_planning.core import RobotModel
from mycobot_planning.core.planning_interface.planning_pipeline import PlanningPipeline

SUMMARY_KEYS = {"hit_ms", "hit_lookup_ms", "hit_validate_ms", "hit_sample_ms", "miss_ms", "hit_rate",
                "first_cycle_ms", "cached_cycle_ms", "requests", "refused"}


def test_later_cycles_are_answered_from_the_cache():
    model = RobotModel.mycobot()
    ctx = tcs.make_context(model, PlanningPipeline())
    records = tcs.run_cycles(ctx, 3, np.random.default_rng(0))
    assert len(records) == 3 * len(tcs.CYCLE)
    assert all(r["cache"] == "miss" for r in records[:len(tcs.CYCLE)])
    # the second cycle's home starts at "ready", not at every joint 0: one more miss, then hits
    assert [r["cache"] for r in records[len(tcs.CYCLE):]] == ["miss"] + ["hit"] * (2 * len(tcs.CYCLE) - 1)
    status = ctx.trajectory_cache.status(model)
    assert status["hits"] == 2 * len(tcs.CYCLE) - 1 and status["refused"] == 0 and status["entries"] == 5
    assert all(r["lookup_s"] > 0 and r["validate_s"] > 0 for r in records if r["cache"] == "hit")


def test_the_summary_has_the_contract_keys(capsys):
    assert SCENARIOS["trajectory_cache"] is tcs.bench_trajectory_cache
    tcs.bench_trajectory_cache(repeat=1, seed=0, cycles=2)
    summary = [json.loads(line) for line in capsys.readouterr().out.splitlines()][-1]
    assert summary["summary"] is True and summary["scenario"] == "trajectory_cache"
    assert SUMMARY_KEYS <= set(summary)
    assert summary["requests"] == 2 * len(tcs.CYCLE) and summary["hit_rate"] == (len(tcs.CYCLE) - 1) / (2 * len(tcs.CYCLE))
