"""Objectives benchmark: what the behavior-tree engine itself costs per node and tick.

A 1,000-node tree of built-in nodes in which every node is ticked on every tick: a Sequence of
111 groups, each a Sequence of Inverter(AlwaysFailure), Fallback(AlwaysFailure, AlwaysSuccess),
ForceSuccess(AlwaysSuccess) and AlwaysSuccess (9 nodes). One tick of the whole tree is timed
(``tick_exactly_once``, perf_counter) and divided by the number of nodes ticked, which is checked
to be 1,000 before timing. Loading (XML parse, checks, instantiation) is timed too.

Then the objectives over ROS, with real processes (mock controllers, planning_server, camera
simulator, perception_server, objective_server) on a domain of the bench's own:
``my_pick_and_place_s`` is the wall time of the shipped "My Pick and Place" objective (look at
the table, snapshot into perception, open, pick, close, move away, place, open: seven motions and
a detection) from the /do_objective goal to its result; ``cancel_to_rest_ms`` is the time from a
/cancel_objective request sent 0.3 s into a motion of "3 Waypoints Pick and Place" to the first
/joint_states message after which the arm's positions stay unchanged (< 1e-6 rad) for two more
messages (the controllers publish at 100 Hz, so the figure is at most 20 ms too late).

Summary keys (a contract, keep them stable): ``tick_overhead_us`` (median µs per node per tick),
plus its p90, ``tree_nodes``, ``tick_ms`` (median whole-tree tick), ``load_ms`` (median load and
instantiation), ``my_pick_and_place_s`` and ``cancel_to_rest_ms`` (medians over the repeats), the
spread of per-repeat medians and the machine.

Register in scenarios.SCENARIOS as "objectives".
"""
from __future__ import annotations

import threading
import time

import numpy as np

from mycobot_planning.behavior_tree import BehaviorTreeFactory, NodeStatus

from .common import emit, machine, rest_time, spread, stats

GROUPS = 111
TICKS = 300
WARMUP_TICKS = 30

_GROUP = ("<Sequence><Inverter><AlwaysFailure/></Inverter><Fallback><AlwaysFailure/><AlwaysSuccess/></Fallback>"
          "<ForceSuccess><AlwaysSuccess/></ForceSuccess><AlwaysSuccess/></Sequence>")


def thousand_node_tree_xml(groups: int = GROUPS) -> str:
    """1 + 9 x groups nodes, every one ticked on every tick (1,000 for 111 groups)."""
    return (f'<root BTCPP_format="4"><BehaviorTree ID="Bench"><Sequence>{_GROUP * groups}</Sequence>'
            "</BehaviorTree></root>")


def nodes_ticked_per_tick(tree) -> int:  # type: ignore[no-untyped-def]
    """Nodes that left IDLE during one tick (observers are removed again before timing)."""
    ticked = set()
    unsubscribe = tree.subscribe_to_status_changes(lambda t, node, prev, new: ticked.add(node.uid))
    try:
        tree.tick_exactly_once()
    finally:
        unsubscribe()
    return len(ticked)


def bench_objectives(repeat: int, seed: int, over_ros: bool = True) -> None:
    """The engine's cost, then (``over_ros``, the command's default) the objectives over ROS."""
    factory = BehaviorTreeFactory()
    xml = thousand_node_tree_xml()
    per_node_medians: list[float] = []
    pooled: list[float] = []
    tick_times: list[float] = []
    load_times: list[float] = []
    for index in range(repeat):
        start = time.perf_counter()
        tree = factory.create_tree_from_text(xml)
        load_times.append(time.perf_counter() - start)
        nodes = sum(1 for _ in tree.nodes())
        ticked = nodes_ticked_per_tick(tree)
        if ticked != nodes:
            raise RuntimeError(f"the benchmark tree ticked {ticked} of its {nodes} nodes")
        for _ in range(WARMUP_TICKS):
            tree.tick_exactly_once()
        samples = []
        for _ in range(TICKS):
            start = time.perf_counter()
            status = tree.tick_exactly_once()
            samples.append(time.perf_counter() - start)
            if status is not NodeStatus.SUCCESS:
                raise RuntimeError(f"the benchmark tree answered {status.name}")
        per_node = [s / nodes for s in samples]
        record = {"scenario": "objectives", "repeat": index, "tree_nodes": nodes, "ticks": TICKS,
                  "load_ms": round(load_times[-1] * 1e3, 3)}
        record.update(stats(per_node, 1e6, "us"))
        emit(record)
        per_node_medians.append(record["median_us"])
        pooled += per_node
        tick_times += samples
    summary = {"scenario": "objectives", "summary": True, "tree_nodes": nodes}
    overhead = stats(pooled, 1e6, "us")
    summary["tick_overhead_us"] = overhead["median_us"]
    summary["tick_overhead_p90_us"] = overhead["p90_us"]
    summary["tick_ms"] = stats(tick_times, 1e3, "ms")["median_ms"]
    summary["load_ms"] = stats(load_times, 1e3, "ms")["median_ms"]
    if over_ros:
        pick_place, cancel_to_rest = objectives_over_ros(repeat)
        summary["my_pick_and_place_s"] = stats(pick_place, 1.0, "s")["median_s"]
        summary["cancel_to_rest_ms"] = stats(cancel_to_rest, 1e3, "ms")["median_ms"]
    emit({**summary, **spread(per_node_medians), **machine()})


REST_THRESHOLD = 1e-6  # rad
CANCEL_AFTER = 0.3  # s into the motion


def objectives_over_ros(repeat: int) -> tuple[list[float], list[float]]:
    """My Pick and Place's wall time and cancel-to-rest, ``repeat`` times each (module docstring)."""
    from mycobot_objective_msgs.srv import CancelObjective

    from mycobot_planning.ros.objectives.objective_client import ObjectiveClient

    from .ros_scenarios import RobotProcesses, _JointWatcher, _wait, bench_domain_id

    small = ["--ros-args", "-p", "width:=320", "-p", "height:=240", "-p", "rate:=2.0"]
    extra = {"camera_simulator": (small, "camera_simulator ready"),
             "perception_server": (["--ros-args", "--params-file", _config("perception_server.yaml")],
                                   "perception_server ready"),
             "objective_server": ([], "objective_server ready")}
    pick_place: list[float] = []
    cancel_to_rest: list[float] = []
    with RobotProcesses(bench_domain_id(), ["--params-file", _config("planning_server.yaml")],
                        extra_nodes=extra):
        watcher = _JointWatcher()
        client = ObjectiveClient()
        history: list[tuple[float, np.ndarray]] = []
        recording = threading.Event()
        watcher.listeners.append(lambda t, p: history.append((t, p.copy())) if recording.is_set() else None)
        cancel = watcher.node.create_client(CancelObjective, "/cancel_objective")
        try:
            if not client.wait_for_server(30.0):
                raise RuntimeError("the objective_server does not answer")
            _wait(lambda: watcher.latest is not None, 30.0, "/joint_states")
            _wait(cancel.service_is_ready, 30.0, "/cancel_objective")
            for index in range(repeat):
                _check(client.run("Look at Table"), "Look at Table")
                started = time.perf_counter()
                _check(client.run("My Pick and Place"), "My Pick and Place")
                pick_place.append(time.perf_counter() - started)
                _check(client.run("Look at Table"), "Look at Table")
                watcher.arm()
                outcome: dict = {}
                runner = threading.Thread(target=lambda: outcome.update(
                    answer=client.run("3 Waypoints Pick and Place")))
                runner.start()
                _wait(lambda: watcher.moved_at is not None, 60.0, "the arm to move")
                time.sleep(CANCEL_AFTER)
                history.clear()
                recording.set()
                asked = time.perf_counter()
                future = cancel.call_async(CancelObjective.Request())
                runner.join(60.0)
                # the objective answers once its tree has halted; the arm may still be finishing
                # its smooth stop: keep recording until it rests (or 5 s)
                settle = time.monotonic() + 5.0
                while rest_time(list(history), asked, REST_THRESHOLD) is None and time.monotonic() < settle:
                    time.sleep(0.02)
                recording.clear()
                if not future.done() or not future.result().status.success:
                    raise RuntimeError("/cancel_objective did not cancel the running objective")
                _, result = outcome["answer"]
                if result is None or result.error_code.val != -7:
                    raise RuntimeError(f"the canceled objective did not report PREEMPTED: {result}")
                rest = _rest_time(history, asked)
                cancel_to_rest.append(rest - asked)
                emit({"scenario": "objectives", "repeat": index, "my_pick_and_place_s": round(pick_place[-1], 3),
                      "cancel_to_rest_ms": round(cancel_to_rest[-1] * 1e3, 1)})
        finally:
            client.close()
            watcher.close()
    return pick_place, cancel_to_rest


def _config(name: str) -> str:
    from mycobot_planning.paths import config_file

    return str(config_file(name))


def _check(answer: tuple, name: str) -> None:
    _, result = answer
    if result is None or result.error_code.val != 1:
        raise RuntimeError(f"objective '{name}' failed: {getattr(result, 'error_message', 'no result')}")


def _rest_time(history: list, asked: float) -> float:
    """The first sample after ``asked`` followed by two unchanged ones."""
    found = rest_time(history, asked, REST_THRESHOLD)
    if found is None:
        raise RuntimeError("the arm never came to rest after the cancel")
    return found


OBJECTIVES_SCENARIOS = {"objectives": bench_objectives}
