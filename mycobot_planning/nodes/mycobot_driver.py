"""mycobot_driver: the executable (``ros2 run mycobot_planning mycobot_driver``). The node and its documentation:
mycobot_planning.ros.controllers.mycobot_driver."""
from __future__ import annotations

import sys

from mycobot_planning.ros.controllers.mycobot_driver import MyCobotDriver
from mycobot_planning.ros.node_runtime import run_node


def main(args: list[str] | None = None) -> None:
    sys.exit(run_node(MyCobotDriver, args, threads=6))


if __name__ == "__main__":
    main()
