"""MoveItPy's API (moveit.planning, moveit.core.*) on the core, in this process, without a bring-up.

MoveItPy is configured as its tutorial configures it (plan request namespaces, pipeline names),
here through ``config_dict`` with the Panda's robot_description, so it needs no move_group; plans
start from named states (no joint states needed). The answers are checked against the core:
poses by forward kinematics, plans by the trajectory validator, collisions by the scene.
"""
from __future__ import annotations

import copy
import importlib
import sys
from pathlib import Path
from typing import Iterator

import numpy as np
import pytest
import rclpy
import yaml
from geometry_msgs.msg import Pose, PoseStamped
from moveit_msgs.msg import CollisionObject
from shape_msgs.msg import SolidPrimitive

from interfaces_py.msgs import MoveItErrorCode
from mycobot_planning.core.robot_model.robot_model import RobotModel as CoreRobotModel
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory
from mycobot_planning.paths import config_file, example_robot_data_dir
from mycobot_planning.ros import drop_in
from mycobot_planning.ros.drop_in.moveit.core import robot_state as robot_state_module
from mycobot_planning.ros.drop_in.moveit.core.kinematic_constraints import (
    construct_joint_constraint,
    construct_link_constraint,
)
from mycobot_planning.ros.drop_in.moveit.core.planning_scene import PlanningScene
from mycobot_planning.ros.drop_in.moveit.core.robot_model import RobotModel
from mycobot_planning.ros.drop_in.moveit.core.robot_state import RobotState
from mycobot_planning.ros.drop_in.moveit.planning import (
    MoveItPy,
    MultiPipelinePlanRequestParameters,
    PlanRequestParameters,
)
from mycobot_planning.ros.drop_in.moveit.utils import (
    create_params_file_from_dict,
    get_launch_params_filepaths,
    ros_arguments,
    ros_params_file,
)
from mycobot_planning.ros.drop_in import rclcpp
from mycobot_planning.ros.drop_in.moveit.task_constructor import stages as mtc_stages
from ros_testing import REPO, use_session_domain

TUTORIAL_CONFIG = REPO / "test" / "third_party" / "moveit_py_tutorial" / "config" / "motion_planning_python_api_tutorial.yaml"
#: the tutorial's collision objects (motion_planning_python_api_planning_scene.py)
BOXES = [((0.15, 0.1, 0.5), (0.1, 0.4, 0.1)), ((0.25, 0.0, 1.0), (0.1, 0.4, 0.1)),
         ((-0.25, -0.3, 0.8), (0.2, 0.2, 0.2)), ((0.25, 0.3, 0.75), (0.15, 0.15, 0.15))]


def panda_urdf_srdf() -> tuple[str, str]:
    urdf = (example_robot_data_dir() / "panda_description" / "urdf" / "panda.urdf").read_text()
    return urdf, config_file("panda/panda.srdf").read_text()


@pytest.fixture(scope="module")
def moveit() -> Iterator[MoveItPy]:
    use_session_domain()
    urdf, srdf = panda_urdf_srdf()
    config = yaml.safe_load(TUTORIAL_CONFIG.read_text())
    config.update(robot_description=urdf, robot_description_semantic=srdf)
    config["planning_scene_monitor_options"]["wait_for_initial_state_timeout"] = 0.0  # no joint states here
    initialized = rclpy.ok()
    robot = MoveItPy(node_name="moveit_py_api_test", config_dict=config)
    try:
        yield robot
    finally:
        robot.shutdown()
        assert rclpy.ok() == initialized  # MoveItPy shuts down only what it initialized


@pytest.fixture(scope="module")
def model(moveit: MoveItPy) -> RobotModel:
    return moveit.get_robot_model()


def boxes_msg(frame: str = "panda_link0") -> CollisionObject:
    msg = CollisionObject()
    msg.header.frame_id = frame
    msg.id = "boxes"
    for position, dimensions in BOXES:
        pose = Pose()
        pose.position.x, pose.position.y, pose.position.z = position
        msg.primitives.append(SolidPrimitive(type=SolidPrimitive.BOX, dimensions=list(dimensions)))
        msg.primitive_poses.append(pose)
    msg.operation = CollisionObject.ADD
    return msg


# ---------------------------------------------------------------------------- robot model and state
def test_robot_model_and_groups(model: RobotModel) -> None:
    assert model.name == "panda" and model.has_joint_model_group("panda_arm")
    assert set(model.joint_model_group_names) >= {"panda_arm", "hand", "panda_arm_hand"}
    arm = model.get_joint_model_group("panda_arm")
    assert arm.active_joint_model_names == [f"panda_joint{i}" for i in range(1, 8)]
    assert model.get_joint_model_group("nope") is None
    bounds = arm.active_joint_model_bounds
    assert len(bounds) == 7 and bounds[3][0].max_position < 0 and bounds[0][0].velocity_bounded
    assert arm.satisfies_position_bounds(np.zeros(7)) is False  # joint 4 must stay below -0.07
    with pytest.raises(ValueError, match="7 variables"):
        arm.satisfies_position_bounds([0.0])


def test_robot_state_values_kinematics_and_ik(model: RobotModel) -> None:
    state = RobotState(model)
    assert state.set_to_default_values("panda_arm", "ready") and not state.set_to_default_values("panda_arm", "nope")
    ready = state.get_joint_group_positions("panda_arm")
    assert ready[3] == pytest.approx(-2.356)
    state.joint_positions = {"panda_joint1": 0.3}
    assert state.joint_positions["panda_joint1"] == 0.3 and state.joint_positions["panda_joint4"] == pytest.approx(-2.356)
    with pytest.raises(KeyError, match="not variables"):
        state.joint_positions = {"nope": 1.0}
    pose = state.get_pose("panda_hand")
    matrix = state.get_global_link_transform("panda_hand")
    assert [pose.position.x, pose.position.y, pose.position.z] == pytest.approx(matrix[:3, 3].tolist())
    clone = copy.copy(state)
    clone.set_joint_group_positions("panda_arm", ready)  # back to ready: the copy is its own state
    assert state.joint_positions["panda_joint1"] == 0.3
    # IK back to the pose the first state had
    assert clone.set_from_ik("panda_arm", pose, "panda_hand")
    np.testing.assert_allclose(clone.get_global_link_transform("panda_hand"), matrix, atol=1e-4)
    far = Pose()
    far.position.x, far.orientation.w = 5.0, 1.0
    assert not clone.set_from_ik("panda_arm", far, "panda_hand", 0.05)
    clone.update()
    with pytest.raises(ValueError, match="Invalid category"):
        clone.update(type="everything")


def test_random_positions_stay_inside_the_limits_and_can_be_repeated(model: RobotModel) -> None:
    core = robot_state_module.core_state(RobotState(model)).model
    draws = []
    for _ in range(2):
        robot_state_module.seed(7)
        state = RobotState(model)
        state.set_to_random_positions()
        values = np.array(list(state.joint_positions.values()))
        assert np.all(values >= core.lower_limits) and np.all(values <= core.upper_limits)
        draws.append(values)
    np.testing.assert_array_equal(*draws)
    robot_state_module.seed(None)


def test_jacobian_at_a_point_on_the_link(model: RobotModel) -> None:
    state = RobotState(model)
    state.set_to_default_values("panda_arm", "ready")
    offset = np.array([0.0, 0.0, 0.1])
    jacobian = state.get_jacobian("panda_arm", "panda_link8", offset)
    step = 1e-6
    base = (state.get_global_link_transform("panda_link8") @ np.append(offset, 1.0))[:3]
    for k, name in enumerate(model.get_joint_model_group("panda_arm").active_joint_model_names):
        moved = copy.copy(state)
        moved.joint_positions = {name: state.joint_positions[name] + step}
        point = (moved.get_global_link_transform("panda_link8") @ np.append(offset, 1.0))[:3]
        np.testing.assert_allclose(jacobian[:3, k], (point - base) / step, atol=1e-4)


# ---------------------------------------------------------------------------- planning scene
def test_planning_scene_collisions_as_the_tutorial_checks_them(model: RobotModel) -> None:
    scene = PlanningScene(model)
    scene.current_state.set_to_default_values("panda_arm", "ready")
    assert not scene.is_state_colliding("panda_arm")
    scene.apply_collision_object(boxes_msg())
    assert scene.knows_frame_transform("boxes") and not scene.knows_frame_transform("nope")
    # the tutorial's check: the hand at (0.25, 0.25, 0.5), IK from 'ready'
    state = scene.current_state
    original = state.get_joint_group_positions("panda_arm")
    goal = Pose()
    goal.position.x, goal.position.y, goal.position.z, goal.orientation.w = 0.25, 0.25, 0.5, 1.0
    robot_state_module.seed(1)
    assert state.set_from_ik("panda_arm", goal, "panda_hand")
    colliding = scene.is_state_colliding(robot_state=state, joint_model_group_name="panda_arm", verbose=True)
    core = scene._scene
    report = core.check_collision(robot_state_module.core_state(state))
    assert colliding == any("boxes" in c.bodies for c in report.contacts)
    # the scene's current_state is the scene's own state: changing it changed the scene
    assert not np.allclose(robot_state_module.core_state(scene.current_state).group_positions("panda_arm"), original)
    state.set_joint_group_positions("panda_arm", original)
    assert not scene.is_state_colliding("panda_arm")
    # a block where the hand is at 'ready': in collision, also as the positional overload
    ready = RobotState(model)
    ready.set_to_default_values("panda_arm", "ready")
    hand = ready.get_pose("panda_hand")
    block = CollisionObject()
    block.header.frame_id = "panda_link0"
    block.id = "block"
    block.primitives.append(SolidPrimitive(type=SolidPrimitive.BOX, dimensions=[0.05, 0.05, 0.05]))
    block.primitive_poses.append(hand)
    block.operation = CollisionObject.ADD
    scene.apply_collision_object(block)
    assert scene.is_state_colliding(ready, "panda_arm") and not scene.is_state_valid(ready, "panda_arm")
    inside = ready
    scene.remove_all_collision_objects()
    assert not scene.is_state_colliding(inside, "panda_arm")
    with pytest.raises(ValueError, match="collision object"):
        scene.apply_collision_object("not a message")


def test_constraints_are_built_as_moveit_builds_them(model: RobotModel) -> None:
    state = RobotState(model)
    state.set_to_default_values("panda_arm", "extended")
    constraints = construct_joint_constraint(robot_state=state, joint_model_group=model.get_joint_model_group("panda_arm"))
    assert [c.joint_name for c in constraints.joint_constraints] == [f"panda_joint{i}" for i in range(1, 8)]
    assert all(c.tolerance_above == c.tolerance_below == 0.01 and c.weight == 1.0 for c in constraints.joint_constraints)
    scene = PlanningScene(model)
    assert scene.is_state_constrained(state, constraints)
    ready = RobotState(model)
    ready.set_to_default_values("panda_arm", "ready")
    assert not scene.is_state_constrained(ready, constraints)
    link = construct_link_constraint("panda_link8", "panda_link0", [0.3, 0.0, 0.5], 0.01, [1.0, 0.0, 0.0, 0.0], 0.1)
    assert link.position_constraints[0].constraint_region.primitives[0].dimensions[0] == 0.01
    assert link.orientation_constraints[0].absolute_z_axis_tolerance == 0.1
    with pytest.raises(ValueError, match="No link cartesian or orientation"):
        construct_link_constraint("panda_link8", "panda_link0")


def test_fixed_state_takes_a_moveit_py_planning_scene(model: RobotModel) -> None:
    """MTC's fixed_state.py: PlanningScene(task.getRobotModel()) handed to FixedState.setState."""
    core_model = CoreRobotModel.panda()
    scene = PlanningScene(core_model)  # a Task's core model works as well as MoveItPy's
    stage = mtc_stages.FixedState("fixed state")
    stage.setState(scene)
    assert stage._scene is scene._scene


# ---------------------------------------------------------------------------- MoveItPy planning
def test_plan_request_parameters_come_from_the_tutorial_namespaces(moveit: MoveItPy) -> None:
    default = PlanRequestParameters(moveit)
    assert (default.planning_pipeline, default.planning_attempts, default.planning_time) == ("ompl", 1, 1.0)
    multi = MultiPipelinePlanRequestParameters(moveit, ["ompl_rrtc", "pilz_lin", "chomp_planner"])
    pipelines = [p.planning_pipeline for p in multi.multi_plan_request_parameters]
    assert pipelines == ["ompl", "pilz_industrial_motion_planner", "chomp"]
    assert multi.multi_plan_request_parameters[1].planner_id == "PTP"
    assert sorted(moveit.planning_pipelines) == ["chomp", "ompl", "pilz_industrial_motion_planner"]


def valid_plan(moveit: MoveItPy, result, start_named: str = "ready") -> None:
    assert result, result.error_code
    timed = result.trajectory.timed_trajectory
    gaps = np.max(np.abs(np.diff(timed.positions, axis=0)))
    assert gaps <= 0.1 + 1e-9
    scene = moveit.get_planning_scene_monitor().core.scene_copy()
    start = result.trajectory.start_state
    scene.set_current_state(start)
    report = validate_trajectory(scene, timed, "panda_arm", start)
    assert report.valid, report.problems


def test_plans_to_each_kind_of_goal(moveit: MoveItPy) -> None:
    arm = moveit.get_planning_component("panda_arm")
    assert arm.planning_group_name == "panda_arm" and "extended" in arm.named_target_states
    arm.set_start_state(configuration_name="ready")
    arm.set_goal_state(configuration_name="extended")
    valid_plan(moveit, arm.plan())
    # a PoseStamped goal, the tutorial's
    goal = PoseStamped()
    goal.header.frame_id = "panda_link0"
    goal.pose.orientation.w = 1.0
    goal.pose.position.x, goal.pose.position.y, goal.pose.position.z = 0.28, -0.2, 0.5
    arm.set_goal_state(pose_stamped_msg=goal, pose_link="panda_link8")
    result = arm.plan()
    valid_plan(moveit, result)
    reached = result.trajectory[len(result.trajectory) - 1].get_pose("panda_link8")
    assert [reached.position.x, reached.position.y, reached.position.z] == pytest.approx([0.28, -0.2, 0.5], abs=2e-3)
    # joint constraints
    target = RobotState(moveit.get_robot_model())
    target.joint_positions = {"panda_joint1": -1.0, "panda_joint2": 0.7, "panda_joint3": 0.7, "panda_joint4": -1.5,
                              "panda_joint5": -0.7, "panda_joint6": 2.0, "panda_joint7": 0.0}
    arm.set_goal_state(motion_plan_constraints=[construct_joint_constraint(
        robot_state=target, joint_model_group=moveit.get_robot_model().get_joint_model_group("panda_arm"))])
    result = arm.plan(single_plan_parameters=PlanRequestParameters(moveit, "ompl_rrtc"))
    valid_plan(moveit, result)
    end = result.trajectory[len(result.trajectory) - 1].get_joint_group_positions("panda_arm")
    np.testing.assert_allclose(end, [-1.0, 0.7, 0.7, -1.5, -0.7, 2.0, 0.0], atol=0.0101)


def test_multi_pipeline_plan_takes_the_shortest_of_ompl_pilz_and_chomp(moveit: MoveItPy) -> None:
    arm = moveit.get_planning_component("panda_arm")
    arm.set_start_state(configuration_name="extended")
    arm.set_goal_state(configuration_name="ready")
    chosen = []
    result = arm.plan(multi_plan_parameters=MultiPipelinePlanRequestParameters(
        moveit, ["ompl_rrtc", "pilz_lin", "chomp_planner"]), solution_selection_function=lambda r: chosen.extend(r) or r[1])
    assert len(chosen) == 3 and all(chosen), [c.error_code for c in chosen]
    assert result is chosen[1]
    best = arm.plan(multi_plan_parameters=MultiPipelinePlanRequestParameters(
        moveit, ["ompl_rrtc", "pilz_lin", "chomp_planner"]))
    valid_plan(moveit, best)
    only = arm.plan(multi_plan_parameters=MultiPipelinePlanRequestParameters(moveit, ["chomp_planner"]))
    valid_plan(moveit, only)


def test_plans_around_what_read_write_adds(moveit: MoveItPy) -> None:
    monitor = moveit.get_planning_scene_monitor()
    with monitor.read_write() as scene:
        scene.apply_collision_object(boxes_msg())
        scene.current_state.update()
    try:
        with monitor.read_only() as scene:
            assert "boxes" in scene._scene.world_object_ids()
        arm = moveit.get_planning_component("panda_arm")
        arm.set_start_state(configuration_name="ready")
        arm.set_goal_state(configuration_name="extended")
        valid_plan(moveit, arm.plan())  # validated in the monitored scene, boxes included
    finally:
        with monitor.read_write() as scene:
            scene.remove_all_collision_objects()


def test_no_joint_states_within_the_wait_is_moveits_error(moveit: MoveItPy) -> None:
    urdf, srdf = panda_urdf_srdf()
    config = {"robot_description": urdf, "robot_description_semantic": srdf,
              "planning_scene_monitor_options": {"wait_for_initial_state_timeout": 0.2}}
    with pytest.raises(RuntimeError, match="Unable to configure planning scene monitor"):
        MoveItPy(node_name="moveit_py_waiting", config_dict=config)
    assert rclpy.ok()  # not MoveItPy's to shut down: the fixture's MoveItPy initialized it


def test_bad_calls_are_refused_as_moveit_refuses_them(moveit: MoveItPy) -> None:
    with pytest.raises(RuntimeError, match="Could not find joint model group 'nope'"):
        moveit.get_planning_component("nope")
    arm = moveit.get_planning_component("panda_arm")
    no_goal = arm.plan()
    assert not no_goal and no_goal.error_code.val == MoveItErrorCode.INVALID_GOAL_CONSTRAINTS
    with pytest.raises(ValueError, match="at least one"):
        arm.set_goal_state()
    with pytest.raises(ValueError, match="Cannot specify both"):
        arm.set_goal_state(configuration_name="ready", robot_state=RobotState(moveit.get_robot_model()))
    with pytest.raises(ValueError, match="both message and corresponding link"):
        arm.set_goal_state(pose_stamped_msg=PoseStamped())
    with pytest.raises(ValueError, match="single and multi"):
        arm.plan(single_plan_parameters=PlanRequestParameters(moveit),
                 multi_plan_parameters=MultiPipelinePlanRequestParameters(moveit, ["ompl_rrtc"]))
    assert arm.set_goal_state(configuration_name="nope") is False
    assert arm.set_start_state(configuration_name="nope") is False
    # from the current state with no joint states at all: MoveIt's "did not receive robot state"
    arm.set_start_state_to_current_state()
    arm.set_goal_state(configuration_name="ready")
    stale = arm.plan()
    assert not stale and stale.error_code.val == MoveItErrorCode.ROBOT_STATE_STALE


# ---------------------------------------------------------------------------- rclcpp
def test_rclcpp_nodes_take_node_options_and_are_spun_in_the_background(moveit: MoveItPy) -> None:
    """py_binding_tools' rclcpp on rclpy: init() reuses a context rclpy already has (here
    MoveItPy's), NodeOptions work as keywords and attributes, nodes are spun by rclcpp's executor
    (a script never spins), shutdown() leaves a context it did not make alone."""
    rclcpp.init()
    try:
        options = rclcpp.NodeOptions(automatically_declare_parameters_from_overrides=True)
        options.arguments = ["--ros-args", "-p", "answer:=42"]
        node = rclcpp.Node("rclcpp_options_test", options)
        assert node.name == "rclcpp_options_test" and node.get_parameter("answer").value == 42
        assert node.executor is not None  # added to rclcpp's background executor
        plain = rclcpp.Node("rclcpp_plain_test")
        assert not plain.has_parameter("answer")
        with pytest.raises(AttributeError):
            rclcpp.NodeOptions(no_such_option=True)
        with pytest.raises(TypeError, match="NodeOptions"):
            rclcpp.Node("bad", {"automatically_declare_parameters_from_overrides": True})  # type: ignore[arg-type]
    finally:
        rclcpp.shutdown()
    assert rclpy.ok()


# ---------------------------------------------------------------------------- parameters and the hook
def test_a_moveit_config_yaml_becomes_a_parameters_file_for_every_node(tmp_path: Path) -> None:
    converted = ros_params_file(TUTORIAL_CONFIG)
    data = yaml.safe_load(Path(converted).read_text())
    assert data["/**"]["ros__parameters"]["pilz_lin"]["plan_request_params"]["planner_id"] == "PTP"
    ros_file = create_params_file_from_dict({"a": 1}, "node")
    assert ros_params_file(ros_file) == ros_file and yaml.safe_load(Path(ros_file).read_text()) == \
        {"node": {"ros__parameters": {"a": 1}}}
    args = ros_arguments(["x", "--ros-args", "--params-file", str(TUTORIAL_CONFIG), "-p", "a:=1"])
    assert args[3] != str(TUTORIAL_CONFIG) and args[:3] == ["x", "--ros-args", "--params-file"]
    assert get_launch_params_filepaths(["s.py", "--ros-args", "--params-file", "a.yaml", "--params-file", "b.yaml"]) \
        == ["a.yaml", "b.yaml"]
    assert ros_params_file(tmp_path / "missing.yaml") == str(tmp_path / "missing.yaml")


def test_the_import_hook_serves_moveit_only_while_installed() -> None:
    aliases = ("moveit", "moveit.planning", "moveit.core", "moveit.core.robot_state", "rclcpp", "moveit_commander")
    assert not drop_in.installed()
    drop_in.install()
    try:
        planning = importlib.import_module("moveit.planning")
        assert planning is importlib.import_module("mycobot_planning.ros.drop_in.moveit.planning")
        assert importlib.import_module("moveit.core.robot_state").RobotState is RobotState
        assert importlib.import_module("rclcpp").NodeOptions().automatically_declare_parameters_from_overrides is False
        with pytest.raises(ModuleNotFoundError, match="moveit.nope"):
            importlib.import_module("moveit.nope")
    finally:
        drop_in.uninstall()
        for name in aliases:
            sys.modules.pop(name, None)
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("moveit")
