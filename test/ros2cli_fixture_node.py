"""Test-only node for test_ros2cli.py: a bit of everything the `ros2` verbs talk to.

Run as `python test/ros2cli_fixture_node.py` (test/ is not a package). Node `/ros2cli_fixture`:
- publishes std_msgs/String 'hello <n>' on /fixture/chatter at 20 Hz, and a latched
  (transient local) trajectory_msgs/JointTrajectory on /fixture/trajectory;
- subscribes to /fixture/command (std_msgs/String) and prints "heard: <data>" for each message;
- serves /fixture/trigger (std_srvs/Trigger) and /fixture/set_flag (std_srvs/SetBool);
- declares parameters through node_runtime (described, ranged, validated: refusals have reasons).
"""
from __future__ import annotations

import sys

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String
from std_srvs.srv import SetBool, Trigger
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from mycobot_planning.ros.node_runtime import ParameterSpec, Parameters, run_node

SPECS = [
    ParameterSpec("gain", 1.5, "Scaling of the fixture's output", range=(0.0, 10.0)),
    ParameterSpec("execute", False, "Execute after planning"),
    ParameterSpec("planner_id", "RRTConnectkConfigDefault", "Planner to use", non_empty=True),
    ParameterSpec("joint_names", ["joint1", "joint2"], "Joints of the group", non_empty=True),
    ParameterSpec("attempts", 3, "Planning attempts", range=(1, 100)),
]


class FixtureNode(Node):
    def __init__(self) -> None:
        super().__init__("ros2cli_fixture")
        self.parameters = Parameters(self, SPECS)
        self.count = 0
        self.flag = False
        self.chatter = self.create_publisher(String, "/fixture/chatter", 10)
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.trajectory = self.create_publisher(JointTrajectory, "/fixture/trajectory", latched)
        self.trajectory.publish(JointTrajectory(
            joint_names=["joint1", "joint2"],
            points=[JointTrajectoryPoint(positions=[0.0, 0.5]), JointTrajectoryPoint(positions=[0.25, 1.0])],
        ))
        self.create_subscription(String, "/fixture/command", self._on_command, 10)
        self.create_service(Trigger, "/fixture/trigger", self._on_trigger)
        self.create_service(SetBool, "/fixture/set_flag", self._on_set_flag)
        self.create_timer(0.05, self._tick)
        print("fixture ready", flush=True)

    def _tick(self) -> None:
        self.count += 1
        self.chatter.publish(String(data=f"hello {self.count}"))

    def _on_command(self, msg: String) -> None:
        print(f"heard: {msg.data}", flush=True)

    def _on_trigger(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        response.success = True
        response.message = f"triggered with gain {self.parameters.get('gain')}"
        return response

    def _on_set_flag(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        self.flag = request.data
        response.success = True
        response.message = f"flag is {self.flag}"
        return response


if __name__ == "__main__":
    sys.exit(run_node(FixtureNode))
