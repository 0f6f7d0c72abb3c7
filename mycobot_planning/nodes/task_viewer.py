"""task_viewer: the executable (``ros2 run mycobot_planning task_viewer``). The node and its documentation:
mycobot_planning.ros.task.task_viewer."""
from __future__ import annotations

import sys

from mycobot_planning.ros.node_runtime import run_node
from mycobot_planning.ros.task.task_viewer import TaskViewerNode


def main(args: list[str] | None = None) -> int:
    return run_node(TaskViewerNode, args)


if __name__ == "__main__":
    sys.exit(main())
