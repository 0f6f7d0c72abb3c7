"""pick_place_demo: the executable (``ros2 run mycobot_planning pick_place_demo``). The node and its documentation:
mycobot_planning.ros.demos.pick_place_demo."""
from __future__ import annotations

from mycobot_planning.ros.demos.pick_place_demo import PickPlaceDemo
from mycobot_planning.ros.task.task_node import main_for

main = main_for(PickPlaceDemo)

if __name__ == "__main__":
    main()
