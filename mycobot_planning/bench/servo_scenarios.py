"""Benchmark of servo_node (issue 30): its loop's rate and jitter, command-to-motion latency, CPU,
and planning with and without servoing.

``servo``: starts mock_controllers + planning_server + servo_node (config/servo_node.yaml) on a ROS
domain of its own, and from this process (one private node):

* ``plan_ms_idle``: PLANS_PER_PHASE joint-goal plans through the planning_server (MoveGroupClient,
  OMPL, plan only) while the servo is idle;
* then streams joint jog commands at 50 Hz for STREAM_S seconds (joint 1 at 0.25 rad/s, reversing
  every second) and meanwhile plans PLANS_PER_PHASE times again: ``plan_ms_while_servoing``;
  ``loop_hz`` and ``loop_jitter_p99_ms`` come from the header stamps of the servo's commands to
  /arm_controller/joint_trajectory over that stream (one per loop iteration, stamped in the loop:
  jitter is |interval - publish_period|; ``bare_python_loop_jitter_p99_ms`` is the same sleep
  loop alone in a process at the same time: the machine's share of the jitter); ``cpu_percent`` is the servo process's CPU time over the
  stream's wall time (/proc/<pid>/stat; 100 = one core);
* ``command_to_motion_ms``: from publishing one joint jog to an idle servo (quiet for a second)
  to the first change beyond 1e-6 rad of an arm joint on /joint_states, LATENCY_SAMPLES times.
  It includes DDS delivery both ways, the servo's first iteration (the command wakes the idle
  loop), the controller's next cycle (100 Hz) and its /joint_states.

Summary keys: loop_hz, loop_jitter_p99_ms, command_to_motion_ms (median; _p90 too), cpu_percent,
plan_ms_while_servoing, plan_ms_idle (medians), plan_ratio (while / idle).
"""
from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from typing import Any

import numpy as np

from mycobot_planning.paths import config_file

from .common import emit, machine, spread
from .ros_scenarios import RobotProcesses, _JointWatcher, _wait, bench_domain_id

PLANS_PER_PHASE = 10
STREAM_S = 4.0
LATENCY_SAMPLES = 10
PERIOD = 0.01
GOALS = ([0.0, -0.3, 0.6, 0.2, 0.0, 0.0], [0.6, 0.3, -0.6, -0.2, 0.2, 0.4])


def _cpu_seconds(pid: int) -> float:
    fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


#: the same absolute-deadline sleep loop as the servo's, alone in a process: what this machine's
#: scheduler allows a Python thread at the moment (the peer of loop_jitter_p99_ms)
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


def _jitter_p99_ms(ticks: np.ndarray) -> float:
    return float(np.percentile(np.abs(np.diff(ticks) - PERIOD), 99)) * 1e3


def _plans(arm: Any, count: int, offset: int) -> list[float]:
    samples = []
    for i in range(count):
        arm.set_joint_value_target(GOALS[(i + offset) % 2])
        started = time.perf_counter()
        ok, _, code = arm.plan()
        samples.append(time.perf_counter() - started)
        if not ok:
            raise RuntimeError(f"planning failed: {code}")
    return samples


def bench_servo(repeat: int, seed: int) -> None:
    from control_msgs.msg import JointJog
    from moveit_msgs.srv import ServoCommandType
    from trajectory_msgs.msg import JointTrajectory

    from interfaces_py.clients import MoveGroupClient

    extra = {"servo_node": (["--ros-args", "--params-file", str(config_file("servo_node.yaml"))], "servo_node ready")}
    summary: dict[str, list[float]] = {k: [] for k in ("loop_hz", "jitter", "bare", "latency", "cpu", "busy", "idle")}
    with RobotProcesses(bench_domain_id(), extra_nodes=extra) as robot:
        watcher = _JointWatcher()
        node = watcher.node
        arm = MoveGroupClient("arm", node=node, timeout=30.0)
        stamps: list[float] = []
        lock = threading.Lock()

        def on_output(msg: Any) -> None:
            with lock:
                stamps.append(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)

        node.create_subscription(JointTrajectory, "/arm_controller/joint_trajectory", on_output, 1000)
        jog = node.create_publisher(JointJog, "/servo_node/delta_joint_cmds", 10)
        switch = node.create_client(ServoCommandType, "/servo_node/switch_command_type")
        pid = robot.procs["servo_node"].pid

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
            _plans(arm, 2, 0)  # warm-up
            for index in range(repeat):
                idle = _plans(arm, PLANS_PER_PHASE, 0)
                # stream and plan at once
                stop = threading.Event()

                def stream() -> None:
                    begin = time.monotonic()
                    while not stop.is_set():
                        send(0.5 if int(time.monotonic() - begin) % 2 == 0 else -0.5)
                        time.sleep(0.02)

                with lock:
                    stamps.clear()
                thread = threading.Thread(target=stream, daemon=True)
                cpu0, wall0 = _cpu_seconds(pid), time.monotonic()
                thread.start()
                bare = subprocess.Popen([sys.executable, "-c", _BARE_LOOP, str(STREAM_S - 0.5)],
                                        stdout=subprocess.PIPE, text=True)
                time.sleep(0.3)
                busy = _plans(arm, PLANS_PER_PHASE, 1)
                remaining = STREAM_S - (time.monotonic() - wall0)
                if remaining > 0:
                    time.sleep(remaining)
                stop.set()
                thread.join()
                bare_ticks = np.array([float(v) for v in bare.communicate(timeout=30)[0].split()])
                cpu = 100.0 * (_cpu_seconds(pid) - cpu0) / (time.monotonic() - wall0)
                time.sleep(0.3)
                with lock:
                    out = np.array(stamps)
                intervals = np.diff(out[out > out[0] + 0.2])  # from 0.2 s in: the ramp-up's first
                loop_hz = len(intervals) / float(np.sum(intervals))
                jitter_p99 = float(np.percentile(np.abs(intervals - PERIOD), 99)) * 1e3
                bare_p99 = _jitter_p99_ms(bare_ticks)
                # command to motion, from an idle servo
                latencies = []
                for k in range(LATENCY_SAMPLES):
                    time.sleep(1.0)  # the servo goes quiet, the arm at rest
                    watcher.arm()
                    started = time.perf_counter()
                    send(0.5 if k % 2 == 0 else -0.5)
                    _wait(lambda: watcher.moved_at is not None, 10.0, "the first motion")
                    latencies.append(watcher.moved_at - started)
                record = {
                    "scenario": "servo", "repeat": index, "loop_hz": round(loop_hz, 2),
                    "loop_jitter_p99_ms": round(jitter_p99, 3),
                    "bare_python_loop_jitter_p99_ms": round(bare_p99, 3),
                    "command_to_motion_ms": round(float(np.median(latencies)) * 1e3, 2),
                    "command_to_motion_p90_ms": round(float(np.percentile(latencies, 90)) * 1e3, 2),
                    "cpu_percent": round(cpu, 1),
                    "plan_ms_while_servoing": round(float(np.median(busy)) * 1e3, 2),
                    "plan_ms_idle": round(float(np.median(idle)) * 1e3, 2),
                    "iterations": int(len(intervals) + 1),
                }
                emit(record)
                summary["loop_hz"].append(loop_hz)
                summary["jitter"].append(jitter_p99)
                summary["bare"].append(bare_p99)
                summary["latency"] += latencies
                summary["cpu"].append(cpu)
                summary["busy"] += busy
                summary["idle"] += idle
        finally:
            arm.close()
            watcher.close()
    busy_ms, idle_ms = float(np.median(summary["busy"])) * 1e3, float(np.median(summary["idle"])) * 1e3
    emit({
        "scenario": "servo", "summary": True,
        "loop_hz": round(float(np.median(summary["loop_hz"])), 2),
        "loop_jitter_p99_ms": round(float(np.median(summary["jitter"])), 3),
        "bare_python_loop_jitter_p99_ms": round(float(np.median(summary["bare"])), 3),
        "command_to_motion_ms": round(float(np.median(summary["latency"])) * 1e3, 2),
        "command_to_motion_p90_ms": round(float(np.percentile(summary["latency"], 90)) * 1e3, 2),
        "cpu_percent": round(float(np.median(summary["cpu"])), 1),
        "plan_ms_while_servoing": round(busy_ms, 2),
        "plan_ms_idle": round(idle_ms, 2),
        "plan_ratio": round(busy_ms / idle_ms, 3),
        **spread([round(v, 2) for v in summary["loop_hz"]]),
        **machine(),
    })


SERVO_SCENARIOS = {"servo": bench_servo}
