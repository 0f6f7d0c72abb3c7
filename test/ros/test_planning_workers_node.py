"""The planning_server with planning_processes: 2 (plans in worker processes): concurrent
/plan_kinematic_path requests each get their own answer, a scene change reaches the workers,
planner parameters set over ROS apply there, the move action's cancel stops a worker's plan."""
from __future__ import annotations

import numpy as np
import pytest
from action_msgs.msg import GoalStatus
from moveit_msgs.action import MoveGroup
from moveit_msgs.msg import CollisionObject
from moveit_msgs.srv import GetMotionPlan, SetPlannerParams
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from trajectory_msgs.msg import JointTrajectory as JointTrajectoryMsg

from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.robot_state.robot_state import RobotState
from ros_testing import wait_until
from test_move_group_api import ARM, FAR, C, Client, apply, box, joint_goal, move_group_client

pytestmark = pytest.mark.ros

#: different goals behind the box the tests put up (FAR moved a little)
GOALS = [list(np.asarray(FAR) + d) for d in (0.0, 0.05, -0.05, 0.08, -0.08, 0.03)]


@pytest.fixture(scope="module")
def client():
    with move_group_client("planning_processes:=2", ready="planning on 2 worker processes") as user:
        yield user


def _end(response) -> list[float]:
    trajectory = response.trajectory.joint_trajectory
    names = list(trajectory.joint_names)
    return [trajectory.points[-1].positions[names.index(j)] for j in ARM]


def test_concurrent_plans_each_get_their_own_answer(client: Client) -> None:
    assert apply(client, box("wall_box", (0.0, 0.15, 0.25), size=(0.05, 0.05, 0.05)))
    plan = client.node.create_client(GetMotionPlan, "/plan_kinematic_path")
    try:
        assert plan.wait_for_service(10.0)
        requests = []
        for goal in GOALS:
            request = joint_goal(goal)
            request.motion_plan_request.num_planning_attempts = 3
            requests.append(request)
        futures = [plan.call_async(r) for r in requests]
        assert wait_until(lambda: (client.executor.spin_once(timeout_sec=0.05), all(f.done() for f in futures))[1],
                          120.0)
        for goal, future in zip(GOALS, futures):
            response = future.result().motion_plan_response
            assert response.error_code.val == C.SUCCESS, response.error_code.message
            np.testing.assert_allclose(_end(response), goal, atol=2e-3)
    finally:
        client.node.destroy_client(plan)
        assert apply(client, box("wall_box", (0.0, 0.15, 0.25), operation=CollisionObject.REMOVE))


def test_a_new_object_on_the_way_reaches_the_workers(client: Client) -> None:
    """The straight joint motion through an object is refused once the object is in the scene."""
    straight = joint_goal(FAR)
    straight.motion_plan_request.pipeline_id = "joint_interpolation"
    before = client.call(GetMotionPlan, "/plan_kinematic_path", straight).motion_plan_response
    assert before.error_code.val == C.SUCCESS, before.error_code.message
    middle = np.asarray(before.trajectory.joint_trajectory.points[len(before.trajectory.joint_trajectory.points) // 2]
                        .positions)
    model = RobotModel.mycobot()
    state = RobotState(model)
    state.set_joint_positions(dict(zip(before.trajectory.joint_trajectory.joint_names, middle)))
    position = state.frame_pose(model.group("arm").tip_link)[:3, 3]
    assert apply(client, box("in_the_way", position))
    try:
        after = client.call(GetMotionPlan, "/plan_kinematic_path", straight).motion_plan_response
        assert after.error_code.val != C.SUCCESS
        assert "in_the_way" in after.error_code.message or "collision" in after.error_code.message.lower()
    finally:
        assert apply(client, box("in_the_way", position, operation=CollisionObject.REMOVE))


def test_planner_parameters_set_over_ros_apply_in_the_workers(client: Client) -> None:
    """/set_planner_params with workers: applied (the server logs the new parameters) and plans
    still succeed (test_planning_workers shows the workers plan with the changed parameters)."""
    request = SetPlannerParams.Request(pipeline_id="ompl", planner_config="RRTConnectkConfigDefault", group="arm")
    request.params.keys, request.params.values = ["range"], ["0.3"]
    client.call(SetPlannerParams, "/set_planner_params", request)
    # the log line may be written after the response is sent (seen late once on a loaded machine)
    assert wait_until(lambda: "parameters now" in client.server.output() and "range" in client.server.output(), 5.0)
    response = client.call(GetMotionPlan, "/plan_kinematic_path", joint_goal(FAR)).motion_plan_response
    assert response.error_code.val == C.SUCCESS, response.error_code.message


def test_cancelling_the_move_action_stops_the_workers_plan(client: Client) -> None:
    goal = MoveGroup.Goal()
    goal.request = joint_goal(FAR).motion_plan_request
    goal.request.num_planning_attempts = 1000  # planning would take its whole allowed time
    goal.request.allowed_planning_time = 60.0
    goal.planning_options.plan_only = True
    states: list[str] = []
    handle = client.send(client.move, goal, feedback=lambda m: states.append(m.feedback.state))
    assert wait_until(lambda: (client.executor.spin_once(timeout_sec=0.01), "PLANNING" in states)[1], 20.0,
                      period=0.0)
    client.spin_until(handle.cancel_goal_async())
    response = client.spin_until(handle.get_result_async(), timeout=20.0)
    assert response.status == GoalStatus.STATUS_CANCELED
    assert response.result.error_code.val == C.PREEMPTED


def test_a_late_subscriber_to_planned_path_gets_the_last_plan(client: Client) -> None:
    """Nobody listens to /planned_path here, so the server builds no message per plan; a
    subscriber that comes afterwards still gets the last plan, as the latched topic promises."""
    goal = [0.4, -0.3, 0.2, 0.1, 0.3, -0.2]
    response = client.call(GetMotionPlan, "/plan_kinematic_path", joint_goal(goal)).motion_plan_response
    assert response.error_code.val == C.SUCCESS, response.error_code.message
    received: list = []
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    subscription = client.node.create_subscription(JointTrajectoryMsg, "/planned_path", received.append, latched)
    try:
        assert wait_until(lambda: (client.executor.spin_once(timeout_sec=0.05), bool(received))[1], 20.0)
        names = list(received[-1].joint_names)
        end = [received[-1].points[-1].positions[names.index(j)] for j in ARM]
        np.testing.assert_allclose(end, goal, atol=2e-3)
    finally:
        client.node.destroy_subscription(subscription)


def test_ctrl_c_stops_the_server_and_its_workers_without_a_traceback(client: Client) -> None:
    """Last in the module: it ends the planning_server. Ctrl-C in a terminal signals the whole
    process group, worker processes included; the server shuts them down, and none of them
    prints a KeyboardInterrupt traceback (they did, from their idle queue wait)."""
    import os
    import signal

    pid = client.server.proc.pid
    os.killpg(os.getpgid(pid), signal.SIGINT)
    assert client.server.proc.wait(timeout=20.0) == 0
    output = client.server.output()
    assert "Traceback" not in output and "KeyboardInterrupt" not in output, \
        output[max(0, output.find("Traceback") - 500):]
