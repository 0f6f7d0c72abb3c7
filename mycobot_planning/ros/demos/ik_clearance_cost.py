"""ik_clearance_cost: the seed's "clearance IK" demo as a node (``ros2 run mycobot_planning
ik_clearance_cost --ros-args --params-file config/ik_clearance_cost_parameters.yaml``).

ComputeIK "IK" around FixedState "initial state" (arm 'ready' beside a sphere 'obstacle', built
inside the task as the seed does) finds the IK solutions for a pose next to the obstacle and
ranks them by a Clearance cost; each solution's comment names the closest pair of bodies.
Node ``ik_clearance_cost_demo`` (as in the seed). Parameters ``cumulative`` and ``with_world``
(defaults from config/ik_clearance_cost_parameters.yaml) configure the cost term; changing them
takes effect at the next plan (``ros2 service call /ik_clearance_cost_demo/plan
std_srvs/srv/Trigger``). The other parameters, topics and services: ros/task/task_node.py.
"""
from __future__ import annotations

from mycobot_planning.ros.node_runtime import ParameterSpec
from mycobot_planning.ros.task.task_node import TaskNode
from mycobot_planning.task import Task
from mycobot_planning.demos.mtc_demos import build_ik_clearance_cost_task, load_ik_clearance_cost_parameters

NODE_NAME = "ik_clearance_cost_demo"


class IkClearanceCostDemo(TaskNode):
    def __init__(self) -> None:
        defaults = load_ik_clearance_cost_parameters()
        super().__init__(NODE_NAME, title="IK Clearance Cost Demo", parameters=[
            ParameterSpec("cumulative", defaults["cumulative"], "Clearance cost: true adds up every link's closest "
                          "distance, false uses the single closest distance"),
            ParameterSpec("with_world", defaults["with_world"], "Clearance cost: true measures distances to the world "
                          "objects, false only the robot's distances to itself"),
        ])
        self.info(f"Parameters loaded: cumulative={str(self.params.get('cumulative')).lower()}, "
                  f"with_world={str(self.params.get('with_world')).lower()}")

    def build_task(self) -> Task:
        return build_ik_clearance_cost_task(self.model, cumulative=bool(self.params.get("cumulative")),
                                            with_world=bool(self.params.get("with_world")), seed=self.seed)
