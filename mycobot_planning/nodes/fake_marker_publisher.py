"""fake_marker_publisher: the executable (``ros2 run mycobot_planning fake_marker_publisher``). The node and its documentation:
mycobot_planning.ros.demos.fake_marker_publisher."""
from __future__ import annotations

import sys

from mycobot_planning.ros.demos.fake_marker_publisher import FakeMarkerPublisher
from mycobot_planning.ros.node_runtime import run_node


def main(args: list[str] | None = None) -> None:
    sys.exit(run_node(FakeMarkerPublisher, args, threads=2))


if __name__ == "__main__":
    main()
