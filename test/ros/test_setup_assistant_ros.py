"""The nodes on a setup-assistant config: planning_server + mock_controllers brought up on the UR5
(example-robot-data's URDF and shipped SRDF through `python -m mycobot_planning.setup_assistant`),
and pymoveit2 5.0.0, unmodified, planning and executing a pose goal on it."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from scipy.spatial.transform import Rotation

from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.paths import example_robot_data_dir
from ros_testing import ProbeNode, pymoveit2_joints, robot_processes

pymoveit2 = pytest.importorskip("pymoveit2", reason="pymoveit2 is installed by scripts/setup.sh")

ROBOTS = example_robot_data_dir()
ARM = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
TIP = "tool0"


@pytest.fixture(scope="module")
def ur5_config(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("ur5") / "ur5_config"
    done = subprocess.run([sys.executable, "-m", "mycobot_planning.setup_assistant",
                           str(ROBOTS / "ur_description/urdf/ur5_robot.urdf"),
                           "--srdf", str(ROBOTS / "ur_description/srdf/ur5.srdf"),
                           "--group", f"arm:base_link:{TIP}", "--samples", "2000", "-o", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return out


class Client(ProbeNode):
    def __init__(self) -> None:
        super().__init__("ur5_pymoveit2_user",
                         executor=lambda context: MultiThreadedExecutor(num_threads=4, context=context))
        self.moveit2 = pymoveit2.MoveIt2(node=self.node, joint_names=ARM, base_link_name="base_link",
                                         end_effector_name=TIP, group_name="arm",
                                         callback_group=ReentrantCallbackGroup())
        self.spin_in_background()

    def joints(self) -> np.ndarray:
        return pymoveit2_joints(self.moveit2, ARM)


@pytest.fixture(scope="module")
def ur5_system(ur5_config: Path, tmp_path_factory: pytest.TempPathFactory):
    params = tmp_path_factory.mktemp("ur5_params") / "params.yaml"
    params.write_text(yaml.safe_dump({"/**": {"ros__parameters": {"robot_config": str(ur5_config)}}}))
    with robot_processes(params_file=params, controllers_file=params) as (controllers, server):
        yield controllers, server


def test_nodes_load_the_config(ur5_system) -> None:
    controllers, server = ur5_system
    assert "arm_controller (6 joints" in controllers.output()
    assert "planning_server ready: robot 'ur5', groups ['arm']" in server.output()
    assert "arm_controller" in server.output()


def test_pymoveit2_plans_and_executes_a_pose_goal(ur5_system, ur5_config: Path) -> None:
    model = RobotModel.from_config(ur5_config)
    target = np.array([0.4, -1.2, 1.3, -1.6, -1.5, 0.3])
    state = RobotState(model)
    state.set_joint_positions(dict(zip(ARM, target)))
    goal = state.frame_pose(TIP)
    client = Client()
    try:
        assert client.moveit2.wait_for_joint_state(10.0)
        assert client.wait_for_move_group(), "move_group's services and actions were not discovered"
        quat = Rotation.from_matrix(goal[:3, :3]).as_quat()
        assert client.moveit2.move_to_pose(position=goal[:3, 3].tolist(), quat_xyzw=quat.tolist())
        assert client.moveit2.wait_until_executed()
        assert client.moveit2.get_last_execution_error_code().val == 1
        reached = RobotState(model)
        reached.set_joint_positions(dict(zip(ARM, client.joints())))
        pose = reached.frame_pose(TIP)
        assert np.linalg.norm(pose[:3, 3] - goal[:3, 3]) < 2e-3
        assert np.degrees(Rotation.from_matrix(pose[:3, :3].T @ goal[:3, :3]).magnitude()) < 1.0
    finally:
        client.close()
