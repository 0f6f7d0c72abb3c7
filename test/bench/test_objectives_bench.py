"""The `objectives` benchmark's plumbing: its tree really has 1,000 nodes that all tick, and the
summary carries the contract key. No timing is asserted here."""
from __future__ import annotations

import json

from mycobot_planning.behavior_tree import BehaviorTreeFactory, NodeStatus
from mycobot_planning.bench.objectives_scenarios import bench_objectives, nodes_ticked_per_tick, thousand_node_tree_xml
from mycobot_planning.bench.scenarios import SCENARIOS


def test_the_benchmark_tree_has_1000_nodes_and_ticks_them_all():
    tree = BehaviorTreeFactory().create_tree_from_text(thousand_node_tree_xml())
    assert sum(1 for _ in tree.nodes()) == 1000
    assert nodes_ticked_per_tick(tree) == 1000
    assert tree.tick_exactly_once() is NodeStatus.SUCCESS


def test_the_summary_has_the_contract_keys(capsys):
    assert SCENARIOS["objectives"] is bench_objectives
    bench_objectives(repeat=1, seed=0)
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    summary = lines[-1]
    assert summary["summary"] is True and summary["scenario"] == "objectives"
    assert summary["tree_nodes"] == 1000 and summary["tick_overhead_us"] > 0
    assert "my_pick_and_place_s" not in summary and "cancel_to_rest_ms" not in summary
