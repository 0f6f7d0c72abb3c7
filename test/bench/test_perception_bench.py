"""The `perception` benchmark prints JSON lines ending in a summary with the contract keys."""
from __future__ import annotations

import json

from mycobot_planning.bench import perception_scenarios


def test_bench_perception_summary(monkeypatch, capsys):
    monkeypatch.setattr(perception_scenarios, "RUNS", 2)
    perception_scenarios.bench_perception(repeat=1, seed=0)
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [line.get("summary", False) for line in lines] == [False, True]
    summary = lines[-1]
    assert summary["scenario"] == "perception"
    assert summary["latency_ms"] > 0 and summary["objects_found"] == summary["objects_expected"] == 2
    assert summary["cloud"] == "640x480" and summary["success_rate"] == 1.0
    # the benchmark reports accuracy against the ground truth too
    assert summary["worst_cylinder_center_mm"] < 5.0 and summary["worst_box_yaw_deg"] < 3.0
    assert summary["worst_missed"] == 0
