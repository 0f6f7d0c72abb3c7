"""modular: the seed's "Reusable Containers" demo as a node (``ros2 run mycobot_planning modular``).

From the planning_server's current state: move to 'ready', five "Cartesian Path" modules
(x +0.05, y -0.02, rz -18° with a Cartesian solver, then moveTo 'ready'), move to 'home'.
Node ``modular_demo`` (as in the seed); parameters, topics and services: ros/task/task_node.py.
With ``execute:=true`` the robot runs the solution; the task is built by
mycobot_planning.demos.mtc_demos.build_modular_task.
"""
from __future__ import annotations

from mycobot_planning.ros.node_runtime import ParameterSpec
from mycobot_planning.ros.task.task_node import TaskNode
from mycobot_planning.task import Task
from mycobot_planning.demos.mtc_demos import build_modular_task

NODE_NAME = "modular_demo"


class ModularDemo(TaskNode):
    def __init__(self) -> None:
        super().__init__(NODE_NAME, title="modular demo", parameters=[
            ParameterSpec("group", "arm", "planning group the modules move", non_empty=True, read_only=True),
            ParameterSpec("modules", 5, "number of reusable 'Cartesian Path' modules", range=(1, 50)),
        ])
        group = self.params.get("group")
        if group not in self.model.group_names:
            raise ValueError(f"group '{group}' is not a planning group of '{self.model.name}'; "
                             f"known: {', '.join(self.model.group_names)}")

    def build_task(self) -> Task:
        return build_modular_task(self.model, group=self.params.get("group"), modules=int(self.params.get("modules")),
                                  seed=self.seed)
