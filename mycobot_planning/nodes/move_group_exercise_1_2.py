"""move_group_exercise_1_2: the executable (``ros2 run mycobot_planning move_group_exercise_1_2``). The node and its documentation:
mycobot_planning.ros.demos.move_group_exercise_1_2."""
from __future__ import annotations

import sys

from mycobot_planning.ros.demos.move_group_exercise_1_2 import Exercise12
from mycobot_planning.ros.workflow_runtime import run_workflow


def main(args: list[str] | None = None) -> None:
    sys.exit(run_workflow(Exercise12, args))


if __name__ == "__main__":
    main()
