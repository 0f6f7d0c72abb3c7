"""move_group_exercise_1_1: the executable (``ros2 run mycobot_planning move_group_exercise_1_1``). The node and its documentation:
mycobot_planning.ros.demos.move_group_exercise_1_1."""
from __future__ import annotations

import sys

from mycobot_planning.ros.demos.move_group_exercise_1_1 import Exercise11
from mycobot_planning.ros.workflow_runtime import run_workflow


def main(args: list[str] | None = None) -> None:
    sys.exit(run_workflow(Exercise11, args))


if __name__ == "__main__":
    main()
