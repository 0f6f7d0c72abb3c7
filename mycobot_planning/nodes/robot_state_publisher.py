"""robot_state_publisher: the executable (``ros2 run mycobot_planning robot_state_publisher``). The node and its documentation:
mycobot_planning.ros.robot_state_publisher."""
from __future__ import annotations

import sys

from mycobot_planning.ros.node_runtime import run_node
from mycobot_planning.ros.robot_state_publisher import RobotStatePublisher


def main(args: list[str] | None = None) -> None:
    sys.exit(run_node(RobotStatePublisher, args, threads=1))


if __name__ == "__main__":
    main()
