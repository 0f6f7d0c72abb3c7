"""pick_place_demo: the seed's Example 1 (``ros2 run mycobot_planning pick_place_demo``).

    ros2 run mycobot_planning pick_place_demo --ros-args --params-file config/pick_place_demo_params.yaml

The same pick and place as mtc_node (ros/demos/mtc_node.py, task: mycobot_planning.demos.pick_place)
under the node name ``pick_place_demo`` and with Example 1's parameter file. Example 1 names the
end effector (``eef_name``) and the support surface (``surface_link``, used by the "allow
collision (object,support)" and "forbid collision (object,surface)" stages) itself; mtc_node
uses the gripper group's name and the table's. The parameters Example 1 lacks keep mtc_node's
defaults and are declared too, so they can be set the same way.
"""
from __future__ import annotations

from mycobot_planning.ros.demos.mtc_node import PickPlaceTaskNode
from mycobot_planning.demos.pick_place import MTC_NODE_PARAMETER_NAMES, PICK_PLACE_DEMO_PARAMETERS

NODE_NAME = "pick_place_demo"
#: Example 1's parameters first (its file's order), then mtc_node's others.
NAMES = tuple(PICK_PLACE_DEMO_PARAMETERS) + tuple(n for n in MTC_NODE_PARAMETER_NAMES
                                                  if n not in PICK_PLACE_DEMO_PARAMETERS)


class PickPlaceDemo(PickPlaceTaskNode):
    # Example 1's log lines (pick_place_demo.cpp)
    PLANNED, NOT_PLANNED = "Planning succeeded", "Planning failed"
    EXECUTED, NOT_EXECUTED = "Execution complete", "Execution failed with error code: {val}"

    def __init__(self) -> None:
        super().__init__(NODE_NAME, NAMES, title="pick and place demo")
