"""mujoco_sim: the executable (``ros2 run mycobot_planning mujoco_sim``). The node and its documentation:
mycobot_planning.ros.controllers.mujoco_sim."""
from __future__ import annotations

import sys

from mycobot_planning.ros.controllers.mujoco_sim import mujoco_sim
from mycobot_planning.ros.node_runtime import run_node


def main(args: list[str] | None = None) -> None:
    # Each running action goal holds an executor thread while it follows its trajectory.
    sys.exit(run_node(mujoco_sim, args, threads=6))


if __name__ == "__main__":
    main()
