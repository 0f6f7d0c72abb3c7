"""hybrid_planning: the executable (``ros2 run mycobot_planning hybrid_planning``): MoveIt's hybrid
planning manager, global planner and local planner components in one process. The nodes and
their documentation: mycobot_planning.ros.hybrid_planning; docs/hybrid_planning.md."""
from __future__ import annotations

import sys

from mycobot_planning.ros.hybrid_planning.container import HybridPlanningContainer
from mycobot_planning.ros.node_runtime import run_node


def main(args: list[str] | None = None) -> None:
    sys.exit(run_node(HybridPlanningContainer, args, threads=6))


if __name__ == "__main__":
    main()
