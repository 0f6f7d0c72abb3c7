"""The reacting-while-moving demo (scripts/react_demo.sh) and the `react` benchmark run on their
own processes and domains and report what they measured; no timing is asserted."""
from __future__ import annotations

import subprocess
import sys

from mycobot_planning.bench import react_scenarios
from bench_testing import run_bench
from ros_testing import REPO, ros_env


def test_the_demo_stops_short_replans_and_arrives(tmp_path):
    env = dict(ros_env(), MYCOBOT_DEMO_DIR=str(tmp_path))
    env.pop("ROS_DOMAIN_ID", None)  # the demo picks its own domain, as a newcomer's run does
    run = subprocess.run([sys.executable, "-m", "mycobot_planning.ros.demos.react_demo"], cwd=REPO, env=env,
                         capture_output=True, text=True, timeout=240)
    out = run.stdout + run.stderr
    assert run.returncode == 0, out[-3000:]
    assert "appears on /collision_object" in out
    assert "PLANNING (again: the arm stopped at joint 1 = -" in out  # stopped before the box at 0.0
    assert "after 1 replan" in out and "(at the goal)" in out
    assert "smallest clearance between the robot and the box:" in out
    assert not any(p.name.startswith("core") for p in tmp_path.iterdir())


def test_the_bench_measures_reactions_clearances_and_stops(monkeypatch, capsys):
    summary = run_bench(monkeypatch, capsys, react_scenarios.bench_react, seed=3, own_domain=True, INTRUSIONS=2,
                        STOPS=2)[-1]
    assert summary["summary"] is True and summary["intrusions"] == 2
    for key in ("reaction_ms", "reaction_p90_ms", "min_clearance_m", "replan_success_rate", "stop_latency_ms",
                "stop_decel_ms", "stop_overhead_ms", "invalidated"):
        assert key in summary, key
    assert summary["invalidated"] >= 1 and summary["reaction_ms"] > 0
    # a run whose box this client published with under half its lead (itself too late on a
    # loaded machine) tests the client, not the stop; at least one must test the stop
    assert summary["late_intrusions"] < summary["intrusions"]
    assert summary["min_clearance_m"] > 0.0  # the stops never touched the boxes
    assert summary["stop_latency_ms"] > 0 and summary["stop_decel_ms"] > 0
