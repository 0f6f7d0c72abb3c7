"""Objectives benchmark: what the behavior-tree engine itself costs per node and tick.

A 1,000-node tree of built-in nodes in which every node is ticked on every tick: a Sequence of
111 groups, each a Sequence of Inverter(AlwaysFailure), Fallback(AlwaysFailure, AlwaysSuccess),
ForceSuccess(AlwaysSuccess) and AlwaysSuccess (9 nodes). One tick of the whole tree is timed
(``tick_exactly_once``, perf_counter) and divided by the number of nodes ticked, which is checked
to be 1,000 before timing. Loading (XML parse, checks, instantiation) is timed too.

Summary keys (a contract, keep them stable): ``tick_overhead_us`` (median µs per node per tick),
plus its p90, ``tree_nodes``, ``tick_ms`` (median whole-tree tick), ``load_ms`` (median load and
instantiation), the spread of per-repeat medians and the machine. The objectives' other keys
(``my_pick_and_place_s``, ``cancel_to_rest_ms``) need the behaviors over ROS and come with them.

Register in scenarios.SCENARIOS as "objectives".
"""
from __future__ import annotations

import time

from mycobot_planning.behavior_tree import BehaviorTreeFactory, NodeStatus

from .common import emit, machine, spread, stats

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


def bench_objectives(repeat: int, seed: int) -> None:
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
    emit({**summary, **spread(per_node_medians), **machine()})


OBJECTIVES_SCENARIOS = {"objectives": bench_objectives}
