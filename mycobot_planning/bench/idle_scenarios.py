"""Idle CPU of a robot's nodes: what they cost before any request (issue 27).

* ``idle_cpu``: mock_controllers, robot_state_publisher and the planning_server brought up on a
  ROS domain of their own (as ``scripts/robot.sh start`` does), left alone for a few seconds to
  settle, then each node's CPU time (user + system, every process of its process group) read
  from ``/proc/<pid>/stat`` at the start and the end of a 10 s window. Summary keys: one per
  node, its percent of one core (the median over the repeats), and ``max_percent``.

Nothing talks to the nodes during the window: this measures their timers, their /joint_states
traffic and their executors' own overhead, what every test and benchmark on the machine pays.
"""
from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from .common import emit, machine
from .ros_scenarios import RobotProcesses, bench_domain_id

IDLE_WINDOW_S = 10.0
SETTLE_S = 3.0
NODES = ("mock_controllers", "robot_state_publisher", "planning_server")


def group_cpu_seconds(pgid: int) -> float:
    """User + system CPU seconds of every live process whose process group is ``pgid``."""
    ticks = os.sysconf("SC_CLK_TCK")
    total = 0
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        # after the command: state ppid pgrp session tty tpgid flags minflt cminflt majflt cmajflt utime stime
        if int(fields[2]) == pgid:
            total += int(fields[11]) + int(fields[12])
    return total / ticks


def measure_idle(pids: dict[str, int], window: float = IDLE_WINDOW_S) -> dict[str, float]:
    """Percent of one core used by each process group over ``window`` seconds."""
    before = {name: group_cpu_seconds(pid) for name, pid in pids.items()}
    start = time.monotonic()
    time.sleep(window)
    elapsed = time.monotonic() - start
    return {name: round(100.0 * (group_cpu_seconds(pid) - before[name]) / elapsed, 2) for name, pid in pids.items()}


def bench_idle_cpu(repeat: int, seed: int) -> None:
    """See the module docstring."""
    del seed  # nothing random
    per_node: dict[str, list[float]] = {name: [] for name in NODES}
    with RobotProcesses(bench_domain_id(), extra_nodes={"robot_state_publisher": ([], "robot_state_publisher ready")}) as robot:
        time.sleep(SETTLE_S)
        for index in range(repeat):
            figures = measure_idle({name: robot.procs[name].pid for name in NODES})
            emit({"scenario": "idle_cpu", "repeat": index, "window_s": IDLE_WINDOW_S, **figures})
            for name, value in figures.items():
                per_node[name].append(value)
    summary = {name: round(float(np.median(values)), 2) for name, values in per_node.items()}
    emit({"scenario": "idle_cpu", "summary": True, "window_s": IDLE_WINDOW_S, **summary,
          "max_percent": max(summary.values()), **machine()})


IDLE_SCENARIOS = {"idle_cpu": bench_idle_cpu}
