"""The behaviors the objective_server offers, without starting nodes: every one described with
described ports, the shipped Groot2 TreeNodesModel current, every shipped objective loadable."""
from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from mycobot_planning.behavior_tree import BehaviorTreeFactory
from mycobot_planning.behavior_tree.behaviors import CORE_BEHAVIORS
from mycobot_planning.behavior_tree.objectives import library_files, load_objective, tree_ids_of
from mycobot_planning.paths import config_dir
from mycobot_planning.ros.objectives.objective_server import register_behaviors, tree_nodes_model_xml
from mycobot_planning.ros.objectives.mtc_behaviors import MTC_BEHAVIORS
from mycobot_planning.ros.objectives.ros_behaviors import ROS_BEHAVIORS

MODEL_FILE = config_dir() / "groot" / "tree_nodes_model.xml"
LIBRARY = config_dir() / "objectives"
WORKSHOP = ["Open Gripper", "Close Gripper", "Look at Table", "Take Snapshot", "Pick Object", "Place Object",
            "3 Waypoints Pick and Place", "My Pick and Place", "My Transform Pose", "Pick with Recovery", "Request Teleoperation"]


def factory() -> BehaviorTreeFactory:
    f = BehaviorTreeFactory()
    register_behaviors(f, None)
    return f


def test_every_behavior_is_described_and_so_is_every_port():
    f = factory()
    for _, registration_id, _ in (*CORE_BEHAVIORS, *ROS_BEHAVIORS, *MTC_BEHAVIORS):
        manifest = f.manifests[registration_id]
        assert manifest.description, registration_id
        assert all(p.description for p in manifest.ports.values()), registration_id
        assert dict(manifest.metadata).get("subcategory"), registration_id


def test_the_issue_s_behaviors_are_all_there():
    ids = set(factory().manifests)
    assert {"CreatePoseStamped", "CreateStampedPose", "TransformPose", "TransformPoseFrame", "VisualizePose",
            "MoveToWaypoint", "MoveToJointState", "MoveToPose", "PlanCartesianPath", "PlanToJointGoal",
            "ExecuteTrajectory", "ValidateTrajectory", "MoveGripperAction", "Stop", "GetCurrentPlanningScene",
            "AddCollisionBox", "ResetPlanningSceneObjects", "AttachObject", "DetachObject", "GetPointCloud",
            "ClearSnapshot", "DetectObjects", "RetrieveWaypoint", "SaveCurrentState", "LogMessage",
            "WaitForDuration", "ForEach", "WaitForUserTrajectoryApproval", "RequestTeleoperation",
            "PlanAndExecuteTaskNode", "InitializeMTCTask", "SetupMTCCurrentState", "SetupMTCPlanToPose",
            "SetupMTCPlanToRobotState", "SetupMTCMoveAlongFrameAxis", "SetupMTCSetCollisionRule", "PlanMTCTask",
            "ExecuteMTCSolution"} <= ids


def test_the_shipped_groot2_model_is_the_current_one():
    assert MODEL_FILE.read_text() == tree_nodes_model_xml() + "\n", (
        "regenerate: python -m mycobot_planning.nodes.objective_server --tree-nodes-model "
        "> config/groot/tree_nodes_model.xml")


def test_the_model_is_groot2_s_format_and_loads_back():
    root = ET.fromstring(MODEL_FILE.read_text())
    assert root.tag == "root" and root.get("BTCPP_format") == "4"
    models = root.find("TreeNodesModel")
    move = models.find("Action[@ID='MoveToWaypoint']")
    port = move.find("input_port[@name='waypoint_name']")
    assert port.get("type") == "std::string" and port.text
    assert models.find("Decorator[@ID='ForEach']") is not None
    BehaviorTreeFactory().register_behavior_tree_from_text(MODEL_FILE.read_text())


@pytest.mark.parametrize("path", library_files([LIBRARY]), ids=lambda p: p.name)
def test_every_shipped_objective_loads_with_the_behaviors(path):
    f = factory()
    tree_id = load_objective(f, str(path), [LIBRARY])
    tree = f.create_tree(tree_id)
    assert tree.root_node is not None


def test_the_workshop_s_objectives_are_shipped():
    names = [name for path in library_files([LIBRARY]) for name in tree_ids_of(path)]
    assert sorted(names) == sorted(WORKSHOP)


def test_parameter_overrides_become_typed_blackboard_values():
    from geometry_msgs.msg import PoseStamped as PoseStampedMsg
    from mycobot_objective_msgs.msg import BehaviorParameter, BehaviorParameterDescription as D
    from sensor_msgs.msg import JointState

    from mycobot_planning.behavior_tree import PoseStamped
    from mycobot_planning.behavior_tree.behaviors import JointStateValue
    from mycobot_planning.ros.objectives.objective_server import _override_value

    def parameter(kind, **values):
        p = BehaviorParameter(**values)
        p.description.name, p.description.type = "x", kind
        return p

    assert _override_value(parameter(D.TYPE_STRING, string_value="hi")) == "hi"
    assert _override_value(parameter(D.TYPE_DOUBLE, double_value=0.5)) == 0.5
    assert _override_value(parameter(D.TYPE_INT, int_value=7)) == 7
    assert _override_value(parameter(D.TYPE_BOOL, bool_value=True)) is True
    pose = PoseStampedMsg()
    pose.header.frame_id = "base_link"
    pose.pose.position.z, pose.pose.orientation.w = 0.3, 1.0
    value = _override_value(parameter(D.TYPE_POSE, pose_value=pose))
    assert isinstance(value, PoseStamped) and value.frame_id == "base_link" and value.pose.position == [0, 0, 0.3]
    joints = _override_value(parameter(D.TYPE_JOINT_STATE, joint_state_value=JointState(name=["a"], position=[0.2])))
    assert isinstance(joints, JointStateValue) and joints.as_dict() == {"a": 0.2}
    with pytest.raises(ValueError, match="unknown type 9"):
        _override_value(parameter(9))
