"""``ros2 run mycobot_planning run_objective NAME|FILE.xml``: run an objective (a behavior tree)
and print one JSON line with its final status and the root blackboard.

A tree made of BehaviorTree.CPP's built-in nodes runs right here, without ROS (rclpy is not
even imported). Behaviors (motion, perception, operator prompts) run in the objective server.
Exit status: 0 SUCCESS, 1 FAILURE (or SKIPPED, or an error while running), 2 refused before
running (bad XML, unknown node, missing port, ...), 130 interrupted (the tree is halted).
"""
from __future__ import annotations

import argparse
import json
import logging
import signal
import sys
import threading
from typing import Any

from mycobot_planning.behavior_tree import BehaviorTreeFactory, Blackboard, NodeStatus, TreeLoadError
from mycobot_planning.behavior_tree.exceptions import BehaviorTreeException
from mycobot_planning.behavior_tree.objectives import blackboard_json, default_library_paths, load_objective

EXIT_SUCCESS, EXIT_FAILURE, EXIT_REFUSED, EXIT_INTERRUPTED = 0, 1, 2, 130


def _arguments(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="run_objective",
        description="Run an objective (BehaviorTree.CPP v4 XML) and print one JSON line: "
                    '{"objective", "status", "blackboard"[, "error"]}.')
    parser.add_argument("objective", nargs="?", help="objective name (a BehaviorTree ID in the objective "
                                                     "library) or an XML file")
    parser.add_argument("--library", action="append", default=[], metavar="DIR",
                        help="objective library folder (repeatable; config/objectives is always searched)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="overrides",
                        help="root blackboard entry set before the tree runs (a string, converted by the "
                             "ports that read it; repeatable)")
    parser.add_argument("--tick-period", type=float, default=0.01, metavar="S",
                        help="longest sleep between ticks while the tree is RUNNING (default 0.01 s)")
    parser.add_argument("--tree-nodes-model", action="store_true",
                        help="print the TreeNodesModel XML of the nodes this command can run (for Groot2) and exit")
    args = parser.parse_args(argv)
    if not args.tree_nodes_model and not args.objective:
        parser.error("an objective name or file is required")
    if not args.tick_period > 0.0:
        parser.error("--tick-period must be > 0")
    for item in args.overrides:
        if "=" not in item or not item.split("=", 1)[0]:
            parser.error(f"--set expects KEY=VALUE, got {item!r}")
    return args


def _emit(record: dict[str, Any]) -> None:
    print(json.dumps(record), flush=True)


def _refusal(exc: TreeLoadError, factory: BehaviorTreeFactory) -> str:
    node_id = exc.unknown_node_id
    if node_id is None:
        return str(exc)
    declared = node_id in factory.parser.declared_models
    where = f"{exc.file}:{exc.line}" if exc.file else "the objective"
    if declared:
        return (f"{where}: node '{node_id}' is not a built-in node of BehaviorTree.CPP: a tree with behaviors "
                "needs the objective server (ros2 run mycobot_planning objective_server); "
                "run_objective runs built-in nodes only")
    return f"{exc} (run_objective runs BehaviorTree.CPP's built-in nodes; behaviors need the objective server)"


def main(argv: list[str] | None = None) -> int:
    args = _arguments(argv)
    logging.basicConfig(level=logging.WARNING, stream=sys.stderr, format="[run_objective] %(message)s")
    factory = BehaviorTreeFactory()
    if args.tree_nodes_model:
        print(factory.write_tree_nodes_model_xml(include_builtin=True))
        return EXIT_SUCCESS
    name = args.objective
    blackboard = Blackboard.create()
    try:
        tree_id = load_objective(factory, args.objective, [*default_library_paths(), *args.library])
        name = tree_id
        for item in args.overrides:
            key, value = item.split("=", 1)
            blackboard.set(key, value)
        tree = factory.create_tree(tree_id, blackboard)
    except TreeLoadError as exc:
        message = _refusal(exc, factory)
        print(f"run_objective: refused: {message}", file=sys.stderr)
        _emit({"objective": name, "status": "REFUSED", "error": message, "blackboard": {}})
        return EXIT_REFUSED

    cancel = threading.Event()

    def on_signal(signum: int, frame: Any) -> None:
        cancel.set()
        tree.emit_wake_up_signal()

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    print(f"run_objective: running objective '{name}'", file=sys.stderr, flush=True)
    try:
        while True:
            status = tree.tick_once()
            if status is not NodeStatus.RUNNING:
                break
            if cancel.is_set():
                tree.halt_tree()
                print("run_objective: interrupted, the tree was halted", file=sys.stderr)
                _emit({"objective": name, "status": "CANCELLED", "blackboard": blackboard_json(blackboard)})
                return EXIT_INTERRUPTED
            tree.sleep(args.tick_period)
    except BehaviorTreeException as exc:
        print(f"run_objective: error while running (the tree was halted): {exc}", file=sys.stderr)
        _emit({"objective": name, "status": "FAILURE", "error": str(exc), "blackboard": blackboard_json(blackboard)})
        return EXIT_FAILURE
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    _emit({"objective": name, "status": status.name, "blackboard": blackboard_json(blackboard)})
    return EXIT_SUCCESS if status is NodeStatus.SUCCESS else EXIT_FAILURE


if __name__ == "__main__":
    sys.exit(main())
