"""ik_clearance_cost: the executable (``ros2 run mycobot_planning ik_clearance_cost``). The node and its documentation:
mycobot_planning.ros.demos.ik_clearance_cost."""
from __future__ import annotations

from mycobot_planning.ros.demos.ik_clearance_cost import IkClearanceCostDemo
from mycobot_planning.ros.task.task_node import main_for

main = main_for(IkClearanceCostDemo)

if __name__ == "__main__":
    main()
