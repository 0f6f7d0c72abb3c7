"""A long plan-and-execute soak on move_group's /move_action (issue 27: memory bounded).

* ``soak``: mock controllers and the planning_server on a ROS domain of the bench's own; GOALS
  MoveGroup goals (plan and execute, joint goals alternating between two valid states about
  0.4 rad apart, full speed) sent one after the other, as a client looping over a task would.
  The planning_server's resident memory (VmRSS of every process of its process group, from
  /proc) is read after WARMUP goals and at the end. Summary keys (a contract): goals, failures
  (results other than SUCCESS, or no result), rss_growth_pct (end against after warm-up),
  plus rss_warm_mb, rss_end_mb, growth_kb_per_goal and goal_s (median seconds per goal); each
  repeat's line names its first failures (failure_reasons).

Run it with ``--repeat 1`` (each repeat is a soak of its own, about 0.5 s per goal here).
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .common import emit, machine

GOALS = 1000
#: goals before the reference memory reading (caches, pools and the first plans settle)
WARMUP = 100
#: the two arm states the goals alternate between
STATE_A = (0.0, -0.4, -0.4, 0.0, 0.0, 0.0)
STATE_B = (0.35, -0.2, -0.6, 0.2, 0.1, -0.2)


def group_rss_kb(pgid: int) -> int:
    """Resident memory (kB) of every live process whose process group is ``pgid``."""
    total = 0
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            if int((entry / "stat").read_text().rsplit(")", 1)[1].split()[2]) != pgid:
                continue
            status = (entry / "status").read_text()
        except (OSError, IndexError):
            continue
        for line in status.splitlines():
            if line.startswith("VmRSS:"):
                total += int(line.split()[1])
    return total


def _soak(goals: int, warmup: int) -> dict[str, float]:
    from interfaces_py.clients import MoveGroupClient
    from mycobot_planning.ros.demos.react_demo import ReactProbe, joint_goal, run_goal

    from .ros_scenarios import RobotProcesses, bench_domain_id, robot_ready

    with RobotProcesses(bench_domain_id()) as robot:
        probe = ReactProbe()
        server = MoveGroupClient("arm", node=probe.node, timeout=15.0)
        try:
            robot_ready(server, lambda: len(probe.history) > 0)
            pgid = robot.procs["planning_server"].pid
            failures, reasons, durations, warm = 0, [], [], None
            for k in range(goals):
                if k == warmup:
                    warm = group_rss_kb(pgid)
                start = time.perf_counter()
                try:
                    result = run_goal(probe, joint_goal(STATE_B if k % 2 else STATE_A, 1.0, replan=False), timeout=60.0)
                    if result.error_code.val != 1:
                        failures += 1
                        reasons.append(f"goal {k}: {result.error_code.val} {getattr(result.error_code, 'message', '')}")
                except RuntimeError as exc:  # no answer within the timeout
                    failures += 1
                    reasons.append(f"goal {k}: {exc}")
                durations.append(time.perf_counter() - start)
            end = group_rss_kb(pgid)
        finally:
            server.close()
            probe.close()
    warm = warm if warm is not None else end
    return {"goals": goals, "failures": failures, "rss_warm_mb": round(warm / 1024, 1),
            "rss_end_mb": round(end / 1024, 1), "rss_growth_pct": round(100.0 * (end - warm) / warm, 2),
            "growth_kb_per_goal": round((end - warm) / max(goals - warmup, 1), 2),
            "goal_s": round(float(np.median(durations)), 3), "failure_reasons": reasons[:5]}


def bench_soak(repeat: int, seed: int) -> None:
    """See the module docstring."""
    del seed  # the goals are fixed
    runs = []
    for index in range(repeat):
        figures = _soak(GOALS, min(WARMUP, GOALS // 2))
        emit({"scenario": "soak", "repeat": index, **figures})
        runs.append(figures)
    summary = {key: (sum(r[key] for r in runs) if key in ("goals", "failures")
                     else round(float(np.median([r[key] for r in runs])), 3)) for key in runs[0] if key != "failure_reasons"}
    emit({"scenario": "soak", "summary": True, **summary, **machine()})


SOAK_SCENARIOS = {"soak": bench_soak}
