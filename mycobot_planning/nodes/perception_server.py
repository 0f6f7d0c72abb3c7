"""perception_server: the executable (``ros2 run mycobot_planning perception_server``). The node and its documentation:
mycobot_planning.ros.perception.perception_server."""
from __future__ import annotations

import sys

from mycobot_planning.ros.node_runtime import run_node
from mycobot_planning.ros.perception.perception_server import PerceptionServer


def main(args: list[str] | None = None) -> None:
    sys.exit(run_node(PerceptionServer, args, threads=4))


if __name__ == "__main__":
    main()
