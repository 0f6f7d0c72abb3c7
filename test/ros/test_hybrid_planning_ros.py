"""Hybrid planning on MoveIt's names and types, in real processes: mock_controllers, the
planning_server (move_group) and the hybrid_planning process (manager, global and local planner)
on this session's ROS domain; a client sends moveit_msgs/action/HybridPlanner goals to
/run_hybrid_planning as MoveIt's hybrid planning test does.

What a user sees: a joint goal reached (checked on /joint_states); a box dropped on the path
ahead mid-motion answered with "Collision ahead", a replan and the goal reached without touching
the box (every recorded /joint_states sample checked against the final scene); a cancel that
leaves the arm at rest; bad goals refused with a reason. One bring-up serves the module.
"""
from __future__ import annotations

import math
import signal
import time

import numpy as np
import pytest
from action_msgs.msg import GoalStatus
from moveit_msgs.action import HybridPlanner
from moveit_msgs.msg import (
    CollisionObject as CollisionObjectRos,
    Constraints,
    JointConstraint,
    MotionPlanRequest,
    MotionPlanResponse,
    MotionSequenceItem,
    MoveItErrorCodes,
)
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from shape_msgs.msg import SolidPrimitive

from interfaces_py.action_client import ActionClient
from interfaces_py.msgs import CollisionObject, Pose
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.paths import config_file
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.core.trajectory_execution.path_ahead import PathAhead
from mycobot_planning.ros.bringup import robot as bringup
from mycobot_planning.ros.move_group.moveit_translation import joint_trajectory_from_ros
from mycobot_arm import ARM, tip_pose
from ros_testing import ProbeNode, robot_processes, wait_until

START = [0.0, -0.8, -0.8, 0.0, 0.0, 0.0]
GOAL = [1.2, -0.8, -0.8, 0.0, 0.0, 0.0]
BOX_SIZE = 0.04


class Client(ProbeNode):
    """A HybridPlanner client, /joint_states recorded, the global solutions collected, and a
    /collision_object publisher."""

    def __init__(self) -> None:
        # single-threaded: once the spin thread stops no callback can still be running when the
        # node goes (a multi-threaded executor's workers may: InvalidHandle "never retrieved")
        super().__init__("hybrid_planning_user")
        self.action = ActionClient(self.node, HybridPlanner, "/run_hybrid_planning")
        self.states = self.collect(JointState, "/joint_states", 1000)
        self.solutions = self.collect(MotionPlanResponse, "/global_trajectory", 1)
        self.objects = self.node.create_publisher(CollisionObjectRos, "/collision_object", 10)
        self.listen_to_joint_states()
        self.spin_in_background()

    def close(self) -> None:
        if self.spinner is not None:  # no executor waits on the action client while it goes
            self.spinner.stop()
            self.spinner = None
        self.action.destroy()
        super().close()

    def arm(self) -> np.ndarray:
        joints = self.joints()
        return np.array([joints[n] for n in ARM])

    def send(self, goal: HybridPlanner.Goal) -> tuple[object, list[str]]:
        feedback: list[str] = []
        assert self.action.wait_for_server(timeout_sec=10.0)
        future = self.action.send_goal_async(goal, feedback_callback=lambda m: feedback.append(m.feedback.feedback))
        assert wait_until(future.done, 10.0), "the goal was not answered"
        handle = future.result()
        assert handle.accepted
        return handle, feedback

    def result(self, handle, timeout: float = 30.0):
        future = handle.get_result_async()
        assert wait_until(future.done, timeout), "no result"
        return future.result()

    def run(self, goal: HybridPlanner.Goal, timeout: float = 30.0):
        handle, feedback = self.send(goal)
        return self.result(handle, timeout), feedback


def joint_goal(values, group: str = "arm", scaling: float = 0.3, names=ARM) -> HybridPlanner.Goal:
    request = MotionPlanRequest(group_name=group, num_planning_attempts=1, allowed_planning_time=5.0,
                                max_velocity_scaling_factor=scaling, max_acceleration_scaling_factor=scaling)
    request.goal_constraints = [Constraints(joint_constraints=[
        JointConstraint(joint_name=n, position=float(v), tolerance_above=1e-3, tolerance_below=1e-3, weight=1.0)
        for n, v in zip(names, values)])]
    goal = HybridPlanner.Goal(planning_group=group)
    goal.motion_sequence.items = [MotionSequenceItem(req=request, blend_radius=0.0)]
    return goal


@pytest.fixture(scope="module")
def processes():
    hybrid = bringup.hybrid_planning(["--params-file", str(config_file("hybrid_planning.yaml"))])
    with robot_processes(extra_nodes=[hybrid]) as started:
        yield started


@pytest.fixture(scope="module")
def client(processes):
    user = Client()
    try:
        assert wait_until(lambda: bool(user.joints()), 10.0)
        yield user
    finally:
        user.close()


def move_to(client: Client, values) -> None:
    answer, _ = client.run(joint_goal(values))
    assert answer.status == GoalStatus.STATUS_SUCCEEDED, answer.result.error_message
    assert answer.result.error_code.val == MoveItErrorCodes.SUCCESS


def test_a_joint_goal_is_reached(client: Client) -> None:
    move_to(client, START)
    assert wait_until(lambda: np.max(np.abs(client.arm() - START)) <= 0.01, 2.0), client.arm()


def box_at_flange(mycobot: RobotModel, arm: np.ndarray) -> CollisionObject:
    pose = np.eye(4)
    pose[:3, 3] = tip_pose(mycobot, arm)[:3, 3]
    return CollisionObject.box("box", [BOX_SIZE] * 3, Pose.from_matrix(pose))


def box_msg(box: CollisionObject) -> CollisionObjectRos:
    msg = CollisionObjectRos(id=box.id, operation=CollisionObjectRos.ADD)
    msg.header.frame_id = "world"
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = (float(v) for v in box.pose.position)
    msg.pose.orientation.w = 1.0
    msg.primitives = [SolidPrimitive(type=SolidPrimitive.BOX, dimensions=[BOX_SIZE] * 3)]
    msg.primitive_poses = [msg.pose.__class__()]
    msg.primitive_poses[0].orientation.w = 1.0
    return msg


def test_a_box_on_the_path_ahead_is_avoided_by_replanning(client: Client, mycobot: RobotModel) -> None:
    move_to(client, START)
    with client.lock:
        client.solutions.clear()
        first_state = len(client.states)
    handle, feedback = client.send(joint_goal(GOAL, scaling=0.2))
    assert wait_until(lambda: len(client.solutions) >= 1, 15.0), "no global solution published"
    first, _ = joint_trajectory_from_ros(client.solutions[0].trajectory)
    halfway = first.points[len(first.points) // 2].positions
    box = box_at_flange(mycobot, np.array(halfway))
    blocked = PlanningScene(mycobot)
    blocked.add_object(box)
    assert PathAhead(mycobot, first).first_collision(blocked, 0.0) is not None  # the box is on the first plan
    assert wait_until(lambda: np.max(np.abs(client.arm() - START)) > 0.02, 5.0), "the arm did not start"
    client.objects.publish(box_msg(box))  # mid-motion, ahead of the arm

    answer = client.result(handle, 40.0)
    assert answer.status == GoalStatus.STATUS_SUCCEEDED, answer.result.error_message
    assert "Collision ahead" in feedback
    assert len(client.solutions) >= 2  # replanned
    assert wait_until(lambda: np.max(np.abs(client.arm() - GOAL)) <= 0.01, 2.0), client.arm()
    with client.lock:
        recorded = [(dict(zip(m.name, m.position)), m.header.stamp.sec + m.header.stamp.nanosec * 1e-9)
                    for m in client.states[first_state:]]
    samples = np.array([[s[n] for n in ARM] for s, _ in recorded])
    stamps = np.array([t for _, t in recorded])
    assert len(samples) > 50 and np.max(np.abs(np.diff(samples, axis=0))) < 0.2  # a recording of the motion
    for k in range(len(samples) - 1):  # every sample, and the straight line to the next at 0.01 rad steps
        a, b = samples[k], samples[k + 1]
        # ... when the two are consecutive controller cycles: across a gap in the recording (a loaded
        # machine drops /joint_states from this subscriber's queue) the straight line is not the path
        # the arm took, and may cut a corner of the detour around the box
        steps = 1 if stamps[k + 1] - stamps[k] > 0.025 else max(1, int(np.ceil(np.max(np.abs(b - a)) / 0.01)))
        for s in np.linspace(0.0, 1.0, steps + 1):
            state = RobotState(mycobot)
            state.set_joint_positions(dict(zip(ARM, a + s * (b - a))))
            assert not blocked.is_state_colliding(state), f"the executed motion touches the box at sample {k}"
    client.objects.publish(CollisionObjectRos(id="box", operation=CollisionObjectRos.REMOVE))


def test_a_cancel_stops_the_arm(client: Client) -> None:
    before = client.arm()
    target = START if np.max(np.abs(before - START)) > 0.5 else GOAL
    handle, _ = client.send(joint_goal(target, scaling=0.2))
    assert wait_until(lambda: np.max(np.abs(client.arm() - before)) > 0.1, 10.0), "the arm did not move"
    cancel = handle.cancel_goal_async()
    assert wait_until(cancel.done, 5.0)
    answer = client.result(handle, 10.0)
    assert answer.status == GoalStatus.STATUS_CANCELED
    assert answer.result.error_code.val == MoveItErrorCodes.PREEMPTED
    time.sleep(0.5)  # the stop along the path takes a moment
    rest = client.arm()
    time.sleep(0.3)
    assert np.max(np.abs(client.arm() - rest)) < 1e-4, "the arm still moves after the cancel"
    assert np.max(np.abs(rest - np.array(target))) > 0.05  # stopped on the way, not at the goal


def nan_goal() -> HybridPlanner.Goal:
    goal = joint_goal(START)
    goal.motion_sequence.items[0].req.goal_constraints[0].joint_constraints[2].position = math.nan
    return goal


def two_items() -> HybridPlanner.Goal:
    goal = joint_goal(START)
    goal.motion_sequence.items = [goal.motion_sequence.items[0]] * 2
    return goal


def other_group() -> HybridPlanner.Goal:
    goal = joint_goal(START)
    goal.planning_group = "gripper"
    return goal


@pytest.mark.parametrize("goal, code, words", [
    (HybridPlanner.Goal(planning_group="arm"), MoveItErrorCodes.INVALID_MOTION_PLAN, "no items"),
    (two_items(), MoveItErrorCodes.INVALID_MOTION_PLAN, "2 items"),
    (nan_goal(), MoveItErrorCodes.INVALID_MOTION_PLAN, "not a finite number"),
    (other_group(), MoveItErrorCodes.INVALID_GROUP_NAME, "differs from the request's group_name 'arm'"),
    (joint_goal(START, group="nope"), MoveItErrorCodes.PLANNING_FAILED, "nope"),
], ids=["empty motion_sequence", "two items", "NaN joint value", "group mismatch", "unknown group"])
def test_a_bad_goal_is_aborted_with_the_reason(client: Client, goal, code: int, words: str) -> None:
    answer, _ = client.run(goal, 20.0)
    assert answer.status == GoalStatus.STATUS_ABORTED
    assert answer.result.error_code.val == code
    assert words in answer.result.error_message


def test_single_plan_execution_holds_the_arm_without_replanning(client: Client, mycobot: RobotModel) -> None:
    """planner_logic_plugin_name set at run time (MoveIt's plugin name; a bad one is refused):
    "Collision ahead" then leaves the arm held, with no new global plan, until the cancel."""
    refused = client.set_param("hybrid_planning_manager",
                               Parameter("planner_logic_plugin_name", value="moveit::hybrid_planning/Nope"))
    assert not refused.successful and "ReplanInvalidatedTrajectory" in refused.reason
    name = "moveit::hybrid_planning/SinglePlanExecution"
    assert client.set_param("hybrid_planning_manager", Parameter("planner_logic_plugin_name", value=name)).successful
    try:
        move_to(client, START)
        with client.lock:
            client.solutions.clear()
        handle, feedback = client.send(joint_goal(GOAL, scaling=0.2))
        assert wait_until(lambda: len(client.solutions) >= 1, 15.0), "no global solution published"
        first, _ = joint_trajectory_from_ros(client.solutions[0].trajectory)
        box = box_at_flange(mycobot, np.array(first.points[len(first.points) // 2].positions))
        client.objects.publish(box_msg(box))
        assert wait_until(lambda: "Collision ahead" in feedback, 10.0)
        time.sleep(1.0)
        held = client.arm()
        time.sleep(0.3)
        assert np.max(np.abs(client.arm() - held)) < 1e-4 and np.max(np.abs(held - GOAL)) > 0.1
        assert len(client.solutions) == 1  # no replan
        assert wait_until(handle.cancel_goal_async().done, 5.0)
        assert client.result(handle, 10.0).status == GoalStatus.STATUS_CANCELED
    finally:
        client.objects.publish(CollisionObjectRos(id="box", operation=CollisionObjectRos.REMOVE))
        client.set_param("hybrid_planning_manager", Parameter(
            "planner_logic_plugin_name", value="moveit::hybrid_planning/ReplanInvalidatedTrajectory"))


def test_sigint_mid_motion_ends_the_process_cleanly(client: Client, processes) -> None:
    """Last: Ctrl-C while the local planner drives the arm ends the process with 0, no traceback."""
    hybrid = processes[2]
    before = client.arm()
    client.send(joint_goal(START if np.max(np.abs(before - START)) > 0.5 else GOAL, scaling=0.2))
    assert wait_until(lambda: np.max(np.abs(client.arm() - before)) > 0.05, 10.0), "the arm did not move"
    hybrid.signal(signal.SIGINT)
    assert wait_until(lambda: not hybrid.alive(), 10.0), "hybrid_planning did not exit on SIGINT"
    assert hybrid.returncode() == 0
    assert "Traceback" not in hybrid.log_path.read_text()
