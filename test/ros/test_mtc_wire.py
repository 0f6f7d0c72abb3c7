"""MTC on the wire: mtc_node's task on MoveIt Task Constructor's own introspection interface
(moveit_task_constructor_msgs TaskDescription / TaskStatistics / Solution on /description,
/statistics, /solution, and the /get_solution service), and the published solution executed by
move_group's execute_task_solution action, as MTC's Task::execute and RViz's panel send it."""
from __future__ import annotations

import contextlib


import numpy as np
import pytest
import rclpy
from moveit_msgs.msg import MoveItErrorCodes, PlanningSceneComponents
from moveit_msgs.srv import GetPlanningScene
from moveit_task_constructor_msgs.action import ExecuteTaskSolution
from moveit_task_constructor_msgs.msg import Solution, TaskDescription, TaskStatistics
from moveit_task_constructor_msgs.srv import GetSolution
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_srvs.srv import Trigger

from interfaces_py.action_client import ActionClient
from interfaces_py.background_spin import BackgroundSpin
from mycobot_planning.paths import config_file
from mycobot_planning.demos.pick_place import PickPlaceParameters, expected_place_pose
from ros_testing import NodeProcess, robot_processes, use_session_domain, wait_until

LATCHED = QoSProfile(depth=2, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


@pytest.fixture(scope="module")
def wire():
    use_session_domain()
    robot = contextlib.ExitStack()
    mtc = None
    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node("mtc_wire_test", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    got: dict = {"description": None, "statistics": None, "solution": None}
    statistics_count = [0]

    def on_message(key: str, msg) -> None:
        got[key] = msg
        if key == "statistics":
            statistics_count[0] += 1

    for topic, cls in (("/description", TaskDescription), ("/statistics", TaskStatistics), ("/solution", Solution)):
        # deep enough to keep every progress message until the executor takes it
        qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
        node.create_subscription(cls, topic, lambda m, k=topic[1:]: on_message(k, m), qos)
    spinner = BackgroundSpin(executor, name="mtc wire probe executor")

    def spin_until(predicate, timeout: float = 120.0) -> bool:
        return wait_until(predicate, timeout)

    try:
        robot.enter_context(robot_processes(params_file=True))
        mtc = NodeProcess("mycobot_planning.nodes.mtc_node",
                          ["--ros-args", "--params-file", str(config_file("mtc_node_params.yaml")),
                           "-p", "execute:=false"])
        assert mtc.wait_for_output("MTC pick and place completed", 120), mtc.output()
        assert spin_until(lambda: all(got.values())), got
        yield {"node": node, "executor": executor, "got": got, "spin_until": spin_until,
               "statistics_count": lambda: statistics_count[0]}
    finally:
        spinner.stop()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        if mtc is not None:
            mtc.stop()
        robot.close()


def test_description_and_statistics_on_mtc_topics(wire):
    description, statistics = wire["got"]["description"], wire["got"]["statistics"]
    names = [s.name for s in description.stages]
    assert names[0] and {"current state", "pick object", "place object", "move to place"} <= set(names)
    ids = {s.id for s in description.stages}
    assert all(s.parent_id == 0 or s.parent_id in ids for s in description.stages)
    assert statistics.task_id == description.task_id
    root = next(s for s in statistics.stages if s.id == description.stages[0].id)
    assert len(root.solved) == 10


def test_statistics_are_published_while_planning(wire):
    """MTC publishes introspection as the task plans; so do our task nodes (every 0.1 s at most).
    Re-planned through the node's ~/plan service once discovery is done (at start-up the node's
    first messages can go out before this subscriber is matched), the 10 solutions take longer
    than that, so progress messages come before the final one."""
    before = wire["statistics_count"]()
    client = wire["node"].create_client(Trigger, "/mtc_node/plan")
    assert client.wait_for_service(timeout_sec=10.0)
    future = client.call_async(Trigger.Request())
    assert wire["spin_until"](future.done, 120.0) and future.result().success, future.result()
    assert wire["spin_until"](lambda: wire["statistics_count"]() - before >= 2, 5.0), \
        wire["statistics_count"]() - before


def test_get_solution_answers_the_published_solution(wire):
    solution = wire["got"]["solution"]
    root = solution.sub_solution[0]
    statistics = wire["got"]["statistics"]
    assert root.info.id in {i for s in statistics.stages for i in s.solved}
    assert list(root.sub_solution_id) == [s.info.id for s in solution.sub_trajectory]
    client = wire["node"].create_client(GetSolution, "/get_solution")
    assert client.wait_for_service(timeout_sec=10.0)
    future = client.call_async(GetSolution.Request(solution_id=root.info.id))
    assert wire["spin_until"](future.done, 10.0)
    answered = future.result().solution
    assert answered.task_id == solution.task_id
    assert [s.info.id for s in answered.sub_trajectory] == [s.info.id for s in solution.sub_trajectory]
    assert sum(len(s.trajectory.joint_trajectory.points) > 0 for s in answered.sub_trajectory) >= 10


def test_execute_task_solution_action_places_the_object(wire):
    action = ActionClient(wire["node"], ExecuteTaskSolution, "/execute_task_solution")
    assert action.wait_for_server(timeout_sec=10.0)
    goal_future = action.send_goal_async(ExecuteTaskSolution.Goal(solution=wire["got"]["solution"]))
    assert wire["spin_until"](goal_future.done, 10.0) and goal_future.result().accepted
    result_future = goal_future.result().get_result_async()
    assert wire["spin_until"](result_future.done, 120.0)
    code = result_future.result().result.error_code
    assert code.val == MoveItErrorCodes.SUCCESS, code.message
    client = wire["node"].create_client(GetPlanningScene, "/get_planning_scene")
    request = GetPlanningScene.Request()
    request.components.components = (PlanningSceneComponents.WORLD_OBJECT_GEOMETRY
                                      | PlanningSceneComponents.ROBOT_STATE_ATTACHED_OBJECTS)
    future = client.call_async(request)
    assert wire["spin_until"](future.done, 10.0)
    scene = future.result().scene
    assert not len(scene.robot_state.attached_collision_objects)
    obj = next(o for o in scene.world.collision_objects if o.id == "object")
    placed = np.array([obj.pose.position.x, obj.pose.position.y, obj.pose.position.z])
    assert np.linalg.norm(placed - expected_place_pose(PickPlaceParameters())[:3, 3]) < 0.01
