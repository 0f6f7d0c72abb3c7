"""fallbacks_move_to: the executable (``ros2 run mycobot_planning fallbacks_move_to``). The node and its documentation:
mycobot_planning.ros.demos.fallbacks_move_to."""
from __future__ import annotations

from mycobot_planning.ros.demos.fallbacks_move_to import FallbacksMoveToDemo
from mycobot_planning.ros.task.task_node import main_for

main = main_for(FallbacksMoveToDemo)

if __name__ == "__main__":
    main()
