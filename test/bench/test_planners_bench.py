"""The `planners` benchmark's plumbing, on a tiny run: STOMP and CHOMP beside OMPL on the seeds'
fallback cases and one Panda problem, every returned path judged by the validator, the summary
carries the contract keys. No timing is asserted here."""
from __future__ import annotations

import json

import numpy as np

from mycobot_planning.bench.planners_scenarios import bench_planners, fallback_problems, path_length
from mycobot_planning.bench.scenarios import SCENARIOS
from mycobot_planning.core import RobotModel


def test_path_length_is_the_polyline_length():
    assert path_length(np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 5.0]])) == 6.0


def test_the_fallback_cases_are_the_seeds_three(mycobot: RobotModel):
    problems = fallback_problems(mycobot)
    assert [p["name"][:3] for p in problems] == ["(a)", "(b)", "(c)"]
    assert [p["scene"].world_object_ids() for p in problems] == [[], [], ["box"]]
    assert all(np.allclose(p["goal"], problems[0]["goal"]) for p in problems)


def test_a_tiny_run_has_the_contract_keys(capsys):
    assert SCENARIOS["planners"] is bench_planners
    # a budget generous for a loaded machine: (b) must not fail for time; (c) costs the optimisers all of it
    bench_planners(repeat=1, seed=0, panda_count=1, allowed_planning_time=3.0)
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    records, summary = lines[:-1], lines[-1]
    assert summary["summary"] is True and summary["scenario"] == "planners"
    assert len(records) == 4 * 3  # (a), (b), (c) and one Panda problem, three planners
    for prefix in ("ompl", "stomp", "chomp"):
        for key in ("success_rate", "median_ms", "path_length", "invalid", "requests"):
            assert f"{prefix}_{key}" in summary
        assert summary[f"{prefix}_requests"] == 4
        assert 0.0 <= summary[f"{prefix}_success_rate"] <= 1.0
        assert set(summary["sets"]) == {"fallbacks", "panda"}
    for record in records:
        # success means a path the validator passed; a refused one is counted as invalid
        assert record["valid"] <= record["returned"]
        if record["valid"]:
            assert record["path_length"] > 0.0
    # the directly reachable case (b) is solved by every planner
    assert all(r["valid"] for r in records if r["problem"].startswith("(b)"))
