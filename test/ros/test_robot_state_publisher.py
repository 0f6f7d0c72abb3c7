"""robot_state_publisher: /robot_description, /tf_static and /tf as RViz reads them, checked
against the URDF and our forward kinematics, with the mock controllers publishing /joint_states."""
from __future__ import annotations

import numpy as np
import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from scipy.spatial.transform import Rotation
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.paths import config_file
from ros_testing import NodeProcess, use_session_domain, wait_until

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


@pytest.fixture(scope="module")
def received():
    use_session_domain()
    mock = NodeProcess("mycobot_planning.nodes.mock_controllers",
                       ["--ros-args", "-p", "initial_positions.link2_to_link3:=0.4",
                        "-p", "initial_positions.gripper_controller:=-0.3"])
    rsp = NodeProcess("mycobot_planning.nodes.robot_state_publisher")
    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node("tf_listener_test", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    got: dict = {"tf": {}, "static": {}, "description": None, "joints": None}

    def on_tf(msg: TFMessage, key: str) -> None:
        for t in msg.transforms:
            got[key][(t.header.frame_id, t.child_frame_id)] = t.transform

    node.create_subscription(TFMessage, "/tf", lambda m: on_tf(m, "tf"), 100)
    node.create_subscription(TFMessage, "/tf_static", lambda m: on_tf(m, "static"), LATCHED)
    node.create_subscription(String, "/robot_description", lambda m: got.__setitem__("description", m.data), LATCHED)
    node.create_subscription(JointState, "/joint_states", lambda m: got.__setitem__("joints", m), 10)
    try:
        assert mock.wait_for_output("controller_manager ready", 30), mock.output()
        assert rsp.wait_for_output("robot_state_publisher ready", 30), rsp.output()

        def spin_until(predicate) -> bool:
            return wait_until(lambda: (executor.spin_once(timeout_sec=0.05), predicate())[1], 15.0)

        assert spin_until(lambda: got["description"] and got["static"] and len(got["tf"]) >= 12
                          and got["joints"] is not None)
        yield got
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        rsp.stop()
        mock.stop()


def _matrix(transform) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = [transform.translation.x, transform.translation.y, transform.translation.z]
    r = transform.rotation
    m[:3, :3] = Rotation.from_quat([r.x, r.y, r.z, r.w]).as_matrix()
    return m


def test_robot_description_is_the_urdf(received):
    assert received["description"] == config_file("mycobot_280.urdf").read_text()


def test_static_and_moving_transforms_cover_every_joint(received):
    model = RobotModel.mycobot()
    fixed = {(model.joint(j).parent_link, model.joint(j).child_link) for j in model.joint_names
             if model.joint(j).type == "fixed"}
    moving = {(model.joint(j).parent_link, model.joint(j).child_link) for j in model.joint_names
              if model.joint(j).type != "fixed"}
    assert set(received["static"]) == fixed
    assert set(received["tf"]) == moving  # the five mimic finger joints included


def test_transforms_match_our_kinematics_at_the_joint_states(received):
    model = RobotModel.mycobot()
    state = RobotState(model)
    js = received["joints"]
    active = set(model.variable_names)
    state.set_joint_positions({n: p for n, p in zip(js.name, js.position) if n in active})
    assert state.joint_position("link2_to_link3") == pytest.approx(0.4)
    for (parent, child), transform in {**received["static"], **received["tf"]}.items():
        expected = np.linalg.inv(state.frame_pose(parent)) @ state.frame_pose(child)
        assert np.allclose(_matrix(transform), expected, atol=1e-9), (parent, child)
