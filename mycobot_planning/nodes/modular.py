"""modular: the executable (``ros2 run mycobot_planning modular``). The node and its documentation:
mycobot_planning.ros.demos.modular."""
from __future__ import annotations

from mycobot_planning.ros.demos.modular import ModularDemo
from mycobot_planning.ros.task.task_node import main_for

main = main_for(ModularDemo)

if __name__ == "__main__":
    main()
