"""Benchmark of servo_node (issue 30): its loop's rate and jitter, command-to-motion latency, CPU,
and planning with and without servoing.

``servo``: starts mock_controllers + planning_server + servo_node (config/servo_node.yaml) on a ROS
domain of its own. This process plans (MoveGroupClient, OMPL, plan only) and watches /joint_states,
the same work whether the servo runs or not; the teleoperation client runs in a process of its own
(servo_stream: joint jogs at 50 Hz, the servo's output stamps recorded). Each repeat:

* ``plan_ms_idle``: back-to-back joint-goal plans for IDLE_S with the servo idle, before the stream
  and again after it (the servo quiet);
* the stream, STREAM_S seconds (joint 1 at 0.5 unitless, reversing every second), with back-to-back
  plans from RAMP_S in: ``plan_ms_while_servoing``. ``loop_hz`` and ``loop_jitter_p99_ms`` come
  from the header stamps of the servo's commands to /arm_controller/joint_trajectory (one per loop
  iteration, stamped at its tick; jitter is |interval - publish_period|); ``loop_lateness_p99_ms``
  is each tick's lateness on the ideal schedule; ``bare_python_loop_jitter_p99_ms`` the same sleep
  loop alone in a normal-priority process at the same time (the machine's share of the jitter);
  ``cpu_percent`` the servo process's CPU time over the plans' wall time (/proc/<pid>/stat; 100 =
  one core), and every node's in ``cpu_percent_by_node_*``;
* ``command_to_motion_ms``: from publishing one joint jog to an idle servo (quiet for a second)
  to the first change beyond 1e-6 rad of an arm joint on /joint_states, LATENCY_SAMPLES times.
  It includes DDS delivery both ways, the servo's first iteration (the command wakes the idle
  loop), the controller's next cycle (100 Hz) and its /joint_states.

Summary keys: loop_hz, loop_jitter_p99_ms, loop_lateness_p99_ms, command_to_motion_ms (median;
_p90 too), cpu_percent, plan_ms_while_servoing, plan_ms_idle (medians of all plans), plan_ratio
(while / idle), load_average_1m (the machine's, other work shares it).
"""
from __future__ import annotations

import os
import subprocess
import sys
import time
from typing import Any

import numpy as np

from mycobot_planning.paths import config_file

from .common import emit, machine, spread
from .ros_scenarios import RobotProcesses, _JointWatcher, _wait, bench_domain_id

#: s of back-to-back plans in each idle phase (one before and one after each stream)
IDLE_S = 1.5
STREAM_S = 4.0
#: s from the stream's start before the loop's ticks and the plans count (the servo ramps up)
RAMP_S = 0.3
LATENCY_SAMPLES = 10
PERIOD = 0.01
GOALS = ([0.0, -0.3, 0.6, 0.2, 0.0, 0.0], [0.6, 0.3, -0.6, -0.2, 0.2, 0.4])


def _cpu_seconds(pid: int) -> float:
    fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


#: the same absolute-deadline sleep loop as the servo's, alone in a process at normal priority:
#: what this machine's scheduler allows an ordinary Python thread at the moment (the peer of
#: loop_jitter_p99_ms)
_BARE_LOOP = """
import sys, time
period, end, ticks = 0.01, time.monotonic() + float(sys.argv[1]), []
nxt = time.monotonic()
while time.monotonic() < end:
    nxt += period
    d = nxt - time.monotonic()
    if d > 0:
        time.sleep(d)
    ticks.append(time.monotonic())
print(" ".join(f"{t:.6f}" for t in ticks))
"""


def _cpu_by_node(procs: dict[str, Any]) -> dict[str, float]:
    return {name: _cpu_seconds(proc.pid) for name, proc in procs.items()}


def _cpu_percent(before: dict[str, float], after: dict[str, float], seconds: float) -> dict[str, float]:
    return {name: round(100.0 * (after[name] - before[name]) / seconds, 1) for name in before}


def _jitter_p99_ms(ticks: np.ndarray) -> float:
    return float(np.percentile(np.abs(np.diff(ticks) - PERIOD), 99)) * 1e3


def _lateness_p99_ms(ticks: np.ndarray) -> float:
    """p99 of how late each tick is on the ideal schedule (one tick every PERIOD from the
    earliest-placed one): a late tick counts once, where interval jitter counts it twice."""
    index = np.rint((ticks - ticks[0]) / PERIOD)
    offsets = ticks - index * PERIOD
    return float(np.percentile(offsets - offsets.min(), 99)) * 1e3


def _plans_for(arm: Any, seconds: float, offset: int, stop: Any = None) -> list[float]:
    """Back-to-back joint-goal plans for ``seconds`` (or until ``stop()``): their durations."""
    samples: list[float] = []
    end = time.monotonic() + seconds
    i = offset
    while time.monotonic() < end and not (stop is not None and stop()):
        arm.set_joint_value_target(GOALS[i % 2])
        started = time.perf_counter()
        ok, _, code = arm.plan()
        samples.append(time.perf_counter() - started)
        if not ok:
            raise RuntimeError(f"planning failed: {code}")
        i += 1
    return samples


def bench_servo(repeat: int, seed: int) -> None:
    from control_msgs.msg import JointJog
    from moveit_msgs.srv import ServoCommandType

    from interfaces_py.clients import MoveGroupClient

    extra = {"servo_node": (["--ros-args", "--params-file", str(config_file("servo_node.yaml"))], "servo_node ready")}
    summary: dict[str, list[float]] = {k: [] for k in ("loop_hz", "jitter", "late", "bare", "latency", "cpu", "busy",
                                                       "idle", "ratio", "load")}
    with RobotProcesses(bench_domain_id(), extra_nodes=extra) as robot:
        watcher = _JointWatcher()
        node = watcher.node
        arm = MoveGroupClient("arm", node=node, timeout=30.0)
        jog = node.create_publisher(JointJog, "/servo_node/delta_joint_cmds", 10)
        switch = node.create_client(ServoCommandType, "/servo_node/switch_command_type")

        def send(velocity: float) -> None:
            msg = JointJog()
            msg.header.stamp = node.get_clock().now().to_msg()
            msg.joint_names, msg.velocities = ["link1_to_link2"], [velocity]
            jog.publish(msg)

        try:
            if not arm.wait_for_server(30.0):
                raise RuntimeError("the planning_server does not answer")
            _wait(lambda: watcher.latest is not None, 30.0, "/joint_states here")
            if not switch.wait_for_service(timeout_sec=30.0):
                raise RuntimeError("servo_node's switch_command_type is not available")
            future = switch.call_async(ServoCommandType.Request(command_type=ServoCommandType.Request.JOINT_JOG))
            _wait(future.done, 10.0, "switch_command_type")
            _plans_for(arm, 0.5, 0)  # warm-up
            for index in range(repeat):
                load = os.getloadavg()[0]
                nodes0, idle_wall0 = _cpu_by_node(robot.procs), time.monotonic()
                idle = _plans_for(arm, IDLE_S, 0)
                nodes_idle = _cpu_percent(nodes0, _cpu_by_node(robot.procs), time.monotonic() - idle_wall0)
                # the teleop client (a process of its own) streams; meanwhile plan back to back
                stream = subprocess.Popen([sys.executable, "-m", "mycobot_planning.bench.servo_stream", str(STREAM_S)],
                                          stdout=subprocess.PIPE, text=True)
                if stream.stdout.readline().strip() != "streaming":
                    raise RuntimeError("the servo stream client did not start")
                wall0 = time.monotonic()
                bare = subprocess.Popen([sys.executable, "-c", _BARE_LOOP, str(STREAM_S - 0.5)],
                                        stdout=subprocess.PIPE, text=True)
                time.sleep(RAMP_S)
                nodes0, cpu_wall0 = _cpu_by_node(robot.procs), time.monotonic()
                busy = _plans_for(arm, STREAM_S - RAMP_S - 0.1, 1)
                nodes_busy = _cpu_percent(nodes0, _cpu_by_node(robot.procs), time.monotonic() - cpu_wall0)
                cpu = nodes_busy["servo_node"]
                out = np.array([float(v) for v in stream.communicate(timeout=30)[0].split()])
                bare_ticks = np.array([float(v) for v in bare.communicate(timeout=30)[0].split()])
                if out.size < 10:
                    raise RuntimeError(f"the servo published {out.size} commands during the stream")
                ticks = out[out > out[0] + RAMP_S]  # from RAMP_S in: the ramp-up's first
                intervals = np.diff(ticks)
                loop_hz = len(intervals) / float(np.sum(intervals))
                jitter_p99 = float(np.percentile(np.abs(intervals - PERIOD), 99)) * 1e3
                late_p99 = _lateness_p99_ms(ticks)
                bare_p99 = _jitter_p99_ms(bare_ticks)
                time.sleep(max(0.0, 1.0 - (time.monotonic() - wall0 - STREAM_S)))  # the servo goes quiet
                idle += _plans_for(arm, IDLE_S, 0)
                # command to motion, from an idle servo
                latencies = []
                for k in range(LATENCY_SAMPLES):
                    time.sleep(1.0)  # the servo goes quiet, the arm at rest
                    watcher.arm()
                    started = time.perf_counter()
                    send(0.5 if k % 2 == 0 else -0.5)
                    _wait(lambda: watcher.moved_at is not None, 10.0, "the first motion")
                    latencies.append(watcher.moved_at - started)
                busy_ms, idle_ms = float(np.median(busy)) * 1e3, float(np.median(idle)) * 1e3
                record = {
                    "scenario": "servo", "repeat": index, "loop_hz": round(loop_hz, 2),
                    "loop_jitter_p99_ms": round(jitter_p99, 3),
                    "loop_lateness_p99_ms": round(late_p99, 3),
                    "bare_python_loop_jitter_p99_ms": round(bare_p99, 3),
                    "command_to_motion_ms": round(float(np.median(latencies)) * 1e3, 2),
                    "command_to_motion_p90_ms": round(float(np.percentile(latencies, 90)) * 1e3, 2),
                    "cpu_percent": round(cpu, 1),
                    "plan_ms_while_servoing": round(busy_ms, 2),
                    "plan_ms_idle": round(idle_ms, 2),
                    "plan_ratio": round(busy_ms / idle_ms, 3),
                    "plans_while_servoing": len(busy), "plans_idle": len(idle),
                    "iterations": int(len(intervals) + 1),
                    "gaps": int(np.sum(intervals > 1.5 * PERIOD)),
                    "load_average_1m": round(load, 2),
                    "cpu_percent_by_node_idle": nodes_idle,
                    "cpu_percent_by_node_while_servoing": nodes_busy,
                }
                emit(record)
                summary["loop_hz"].append(loop_hz)
                summary["jitter"].append(jitter_p99)
                summary["late"].append(late_p99)
                summary["bare"].append(bare_p99)
                summary["latency"] += latencies
                summary["cpu"].append(cpu)
                summary["busy"] += busy
                summary["idle"] += idle
                summary["ratio"].append(busy_ms / idle_ms)
                summary["load"].append(load)
        finally:
            arm.close()
            watcher.close()
    busy_ms, idle_ms = float(np.median(summary["busy"])) * 1e3, float(np.median(summary["idle"])) * 1e3
    emit({
        "scenario": "servo", "summary": True,
        "loop_hz": round(float(np.median(summary["loop_hz"])), 2),
        "loop_jitter_p99_ms": round(float(np.median(summary["jitter"])), 3),
        "loop_lateness_p99_ms": round(float(np.median(summary["late"])), 3),
        "bare_python_loop_jitter_p99_ms": round(float(np.median(summary["bare"])), 3),
        "command_to_motion_ms": round(float(np.median(summary["latency"])) * 1e3, 2),
        "command_to_motion_p90_ms": round(float(np.percentile(summary["latency"], 90)) * 1e3, 2),
        "cpu_percent": round(float(np.median(summary["cpu"])), 1),
        "plan_ms_while_servoing": round(busy_ms, 2),
        "plan_ms_idle": round(idle_ms, 2),
        "plan_ratio": round(busy_ms / idle_ms, 3),
        "plan_ratio_per_repeat_median": round(float(np.median(summary["ratio"])), 3),
        "load_average_1m": round(float(np.median(summary["load"])), 2),
        **spread([round(v, 2) for v in summary["loop_hz"]]),
        **machine(),
    })


SERVO_SCENARIOS = {"servo": bench_servo}
