"""fallbacks_move_to: the seed's "fallback strategies in MoveTo" demo as a node
(``ros2 run mycobot_planning fallbacks_move_to``).

Three initial states (an Alternatives of FixedStates, the third with a thin box in its scene,
all built inside the task as the seed does) and a Fallbacks "move to other side" trying a
Cartesian path, the industrial PTP and OMPL RRTConnect to 'ready' with link1_to_link2 = +tau/8.
Expected: Cartesian fails for all three, PTP succeeds for two, OMPL for the one with the box.
Node ``fallbacks_move_to_demo`` (as in the seed); parameters, topics and services:
ros/task/task_node.py. The solutions start from the fixed initial states, not from the robot's
current state, so executing one only works when the robot stands at that initial state (the
planning_server refuses it otherwise, naming the joint that is off).
"""
from __future__ import annotations

from mycobot_planning.ros.task.task_node import TaskNode
from mycobot_planning.task import Task
from mycobot_planning.demos.mtc_demos import build_fallbacks_move_to_task

NODE_NAME = "fallbacks_move_to_demo"


class FallbacksMoveToDemo(TaskNode):
    def __init__(self) -> None:
        super().__init__(NODE_NAME, title="fallbacks_move_to demo")

    def build_task(self) -> Task:
        return build_fallbacks_move_to_task(self.model, seed=self.seed)
