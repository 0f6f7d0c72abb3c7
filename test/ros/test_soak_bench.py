"""The `soak` benchmark (issue 27: memory bounded) on its own processes and domain: a short soak
answers every goal and reports the planning_server's memory; no timing or growth is asserted
(the 1,000-goal figure is the bench's, docs/bench.md)."""
from __future__ import annotations

import os

from mycobot_planning.bench import soak_scenarios
from bench_testing import run_bench


def test_a_short_soak_answers_every_goal_and_reads_the_servers_memory(monkeypatch, capsys):
    summary = run_bench(monkeypatch, capsys, soak_scenarios.bench_soak, own_domain=True, GOALS=8, WARMUP=4)[-1]
    assert summary["summary"] is True and summary["goals"] == 8 and summary["failures"] == 0
    # a planning_server holds a robot model, OMPL and Pinocchio: tens of MB at least
    assert 50 < summary["rss_warm_mb"] < 4096 and 50 < summary["rss_end_mb"] < 4096
    assert "rss_growth_pct" in summary and summary["goal_s"] > 0


def test_group_rss_reads_this_process(capsys):
    assert soak_scenarios.group_rss_kb(os.getpgid(0)) > 10_000
