"""planning_server: the executable (``ros2 run mycobot_planning planning_server``). The node and its documentation:
mycobot_planning.ros.move_group.planning_server."""
from __future__ import annotations

import sys

from mycobot_planning.ros.move_group.planning_server import PlanningServer
from mycobot_planning.ros.node_runtime import run_node


def main(args: list[str] | None = None) -> None:
    sys.exit(run_node(PlanningServer, args, threads=8))


if __name__ == "__main__":
    main()
