"""camera_simulator: the executable (``ros2 run mycobot_planning camera_simulator``). The node and its documentation:
mycobot_planning.ros.perception.camera_simulator."""
from __future__ import annotations

import sys

from mycobot_planning.ros.node_runtime import run_node
from mycobot_planning.ros.perception.camera_simulator import CameraSimulator


def main(args: list[str] | None = None) -> None:
    sys.exit(run_node(CameraSimulator, args, threads=2))


if __name__ == "__main__":
    main()
