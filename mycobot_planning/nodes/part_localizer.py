"""part_localizer: the executable (``ros2 run mycobot_planning part_localizer``). The node and its documentation:
mycobot_planning.ros.demos.part_localizer."""
from __future__ import annotations

import sys

from mycobot_planning.ros.demos.part_localizer import PartLocalizer
from mycobot_planning.ros.node_runtime import run_node


def main(args: list[str] | None = None) -> None:
    sys.exit(run_node(PartLocalizer, args, threads=2))


if __name__ == "__main__":
    main()
