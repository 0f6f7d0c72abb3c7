"""objective_server: the executable (``ros2 run mycobot_planning objective_server``). The node and its
documentation: mycobot_planning.ros.objectives.objective_server."""
from __future__ import annotations

import sys

from mycobot_planning.ros.node_runtime import run_node
from mycobot_planning.ros.objectives.objective_server import ObjectiveServer, tree_nodes_model_xml


def main(args: list[str] | None = None) -> None:
    argv = sys.argv if args is None else args
    if "--tree-nodes-model" in argv:  # the behaviors' TreeNodesModel for Groot2, then exit
        print(tree_nodes_model_xml())
        sys.exit(0)
    sys.exit(run_node(ObjectiveServer, args, threads=8))


if __name__ == "__main__":
    main()
