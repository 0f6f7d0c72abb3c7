"""mtc_node: the executable (``ros2 run mycobot_planning mtc_node``). The node and its documentation:
mycobot_planning.ros.demos.mtc_node."""
from __future__ import annotations

from mycobot_planning.ros.demos.mtc_node import PickPlaceTaskNode
from mycobot_planning.ros.task.task_node import main_for

main = main_for(PickPlaceTaskNode)

if __name__ == "__main__":
    main()
