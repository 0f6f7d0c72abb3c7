"""Acceptance: pymoveit2 5.0.0 from PyPI, a MoveIt client nobody here wrote, used unmodified as its
users use it, against planning_server + mock_controllers in real processes.

Every motion is checked on /joint_states afterwards (pymoveit2's own joint state subscription),
poses against our own forward kinematics, scene changes by reading the scene back through
get_planning_scene.
"""
from __future__ import annotations


import numpy as np
import pytest
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from scipy.spatial.transform import Rotation

from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_arm import ARM, READY, TIP, tip_pose
from ros_testing import ProbeNode, pymoveit2_joints, wait_until, robot_processes

pymoveit2 = pytest.importorskip("pymoveit2", reason="pymoveit2 is installed by scripts/setup.sh")



class Client(ProbeNode):
    """What a pymoveit2 user writes: a node, MoveIt2 (services + execute_trajectory, and a second
    one on move_action), GripperInterface, a multi-threaded executor spinning in the background."""

    def __init__(self) -> None:
        super().__init__("pymoveit2_user", executor=lambda context: MultiThreadedExecutor(num_threads=4, context=context))
        group = ReentrantCallbackGroup()
        self.moveit2 = pymoveit2.MoveIt2(node=self.node, joint_names=ARM, base_link_name="base_link",
                                         end_effector_name=TIP, group_name="arm", callback_group=group)
        self.moveit2_action = pymoveit2.MoveIt2(node=self.node, joint_names=ARM, base_link_name="base_link",
                                                end_effector_name=TIP, group_name="arm", callback_group=group,
                                                use_move_group_action=True)
        self.gripper = pymoveit2.GripperInterface(
            node=self.node, gripper_joint_names=["gripper_controller"], open_gripper_joint_positions=0.0,
            closed_gripper_joint_positions=-0.6, gripper_group_name="gripper", callback_group=group,
            gripper_command_action_name="grip_action_controller/gripper_cmd",
            # it picks its backend once, at construction, from the action servers discovered by
            # then: its 1 s default was once too short for this new node on a loaded machine
            discovery_timeout_sec=10.0)
        self.spin_in_background()

    def joints(self, names: list[str]) -> np.ndarray:
        """Positions from the newest /joint_states message received after this call."""
        return pymoveit2_joints(self.moveit2, names)


@pytest.fixture(scope="module")
def client():
    with robot_processes():
        user = Client()
        try:
            assert user.moveit2.wait_for_joint_state(10.0)
            assert user.wait_for_move_group(), "move_group's services and actions were not discovered"
            yield user
        finally:
            user.close()


def move_to(client: Client, target: list[float], action: bool = False) -> None:
    moveit2 = client.moveit2_action if action else client.moveit2
    assert moveit2.move_to_configuration(target)
    assert moveit2.wait_until_executed()
    assert moveit2.get_last_execution_error_code().val == 1


def test_move_to_configuration_reaches_the_joints(client: Client) -> None:
    target = [0.3, -0.2, 0.4, 0.1, 0.2, 0.0]
    move_to(client, target)
    assert np.allclose(client.joints(ARM), target, atol=0.01)


def test_move_to_configuration_through_move_action(client: Client) -> None:
    target = [-0.4, 0.1, 0.3, -0.2, 0.1, 0.3]
    move_to(client, target, action=True)
    assert np.allclose(client.joints(ARM), target, atol=0.01)


@pytest.mark.parametrize("action", [False, True], ids=["plan+execute", "move_action"])
def test_move_to_pose_reaches_the_pose(client: Client, mycobot: RobotModel, action: bool) -> None:
    move_to(client, READY)
    goal = tip_pose(mycobot, np.array([0.5, -0.4, 0.8, 0.1, 0.3, 0.2]))
    quat = Rotation.from_matrix(goal[:3, :3]).as_quat()
    moveit2 = client.moveit2_action if action else client.moveit2
    assert moveit2.move_to_pose(position=goal[:3, 3].tolist(), quat_xyzw=quat.tolist())
    assert moveit2.wait_until_executed()
    reached = tip_pose(mycobot, client.joints(ARM))
    assert np.linalg.norm(reached[:3, 3] - goal[:3, 3]) < 2e-3
    assert np.degrees(Rotation.from_matrix(reached[:3, :3].T @ goal[:3, :3]).magnitude()) < 1.0


def test_compute_fk_and_ik_agree_with_our_kinematics(client: Client, mycobot: RobotModel) -> None:
    arm = np.array([0.2, -0.5, 0.7, 0.3, -0.2, 0.4])
    from sensor_msgs.msg import JointState

    fk = client.moveit2.compute_fk(joint_state=JointState(name=ARM, position=arm.tolist()))
    ours = tip_pose(mycobot, arm)
    got = fk[0] if isinstance(fk, list) else fk
    assert got.header.frame_id == "base_link"
    p, q = got.pose.position, got.pose.orientation
    assert np.allclose([p.x, p.y, p.z], ours[:3, 3], atol=1e-9)  # base_link coincides with world
    assert Rotation.from_quat([q.x, q.y, q.z, q.w]).approx_equal(Rotation.from_matrix(ours[:3, :3]), atol=1e-9)
    solution = client.moveit2.compute_ik(position=[p.x, p.y, p.z], quat_xyzw=[q.x, q.y, q.z, q.w])
    assert solution is not None
    values = dict(zip(solution.name, solution.position))
    solved = tip_pose(mycobot, np.array([values[j] for j in ARM]))
    assert np.linalg.norm(solved[:3, 3] - ours[:3, 3]) < 1e-4
    assert Rotation.from_matrix(solved[:3, :3].T @ ours[:3, :3]).magnitude() < 1e-3


def _scene(client: Client):
    assert client.moveit2.update_planning_scene(timeout_sec=10.0)
    return client.moveit2.planning_scene


def test_collision_box_add_attach_detach_remove(client: Client) -> None:
    moveit2 = client.moveit2
    moveit2.add_collision_box(id="pm2_box", size=(0.04, 0.05, 0.06), position=(0.2, -0.15, 0.05),
                              quat_xyzw=(0.0, 0.0, 0.0, 1.0))
    assert wait_until(lambda: "pm2_box" in [o.id for o in _scene(client).world.collision_objects], 5.0)
    box = next(o for o in _scene(client).world.collision_objects if o.id == "pm2_box")
    assert list(box.primitives[0].dimensions) == pytest.approx([0.04, 0.05, 0.06])
    world_position = np.array([box.pose.position.x, box.pose.position.y, box.pose.position.z])
    world_position += [box.primitive_poses[0].position.x, box.primitive_poses[0].position.y,
                       box.primitive_poses[0].position.z]
    assert np.allclose(world_position, [0.2, -0.15, 0.05], atol=1e-9)

    moveit2.attach_collision_object(id="pm2_box", link_name=TIP, touch_links=[TIP])
    assert wait_until(lambda: [a.object.id for a in _scene(client).robot_state.attached_collision_objects]
                      == ["pm2_box"], 5.0)
    attached = _scene(client).robot_state.attached_collision_objects[0]
    assert attached.link_name == TIP
    assert "pm2_box" not in [o.id for o in _scene(client).world.collision_objects]

    moveit2.detach_collision_object(id="pm2_box")
    assert wait_until(lambda: not len(_scene(client).robot_state.attached_collision_objects)
                      and "pm2_box" in [o.id for o in _scene(client).world.collision_objects], 5.0)

    moveit2.remove_collision_object(id="pm2_box")
    assert wait_until(lambda: "pm2_box" not in [o.id for o in _scene(client).world.collision_objects], 5.0)


def test_cartesian_move_goes_straight_down(client: Client, mycobot: RobotModel) -> None:
    move_to(client, READY)
    start = tip_pose(mycobot, client.joints(ARM))
    goal = start.copy()
    goal[2, 3] -= 0.04
    quat = Rotation.from_matrix(goal[:3, :3]).as_quat()
    assert client.moveit2.move_to_pose(position=goal[:3, 3].tolist(), quat_xyzw=quat.tolist(), cartesian=True)
    assert client.moveit2.wait_until_executed()
    reached = tip_pose(mycobot, client.joints(ARM))
    assert np.linalg.norm(reached[:3, 3] - goal[:3, 3]) < 2e-3
    assert Rotation.from_matrix(reached[:3, :3].T @ goal[:3, :3]).magnitude() < 0.02


def test_gripper_closes_and_opens_through_gripper_command(client: Client) -> None:
    client.gripper.close()
    assert client.gripper.wait_until_executed()
    assert client.joints(["gripper_controller"])[0] == pytest.approx(-0.6, abs=0.01)
    client.gripper.open()
    assert client.gripper.wait_until_executed()
    assert client.joints(["gripper_controller"])[0] == pytest.approx(0.0, abs=0.01)
