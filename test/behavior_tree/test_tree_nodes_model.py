"""TreeNodesModel export (what Groot2 loads to edit our trees) and its way back into the loader."""
from __future__ import annotations

import xml.etree.ElementTree as ET

from mycobot_planning.behavior_tree import (
    ANY,
    BUILTIN_NODES,
    DOUBLE,
    INT,
    POSE_STAMPED,
    BehaviorTreeFactory,
    NodeStatus,
    StatefulActionNode,
    bidirectional_port,
    input_port,
    output_port,
)


class MoveToPose(StatefulActionNode):
    DESCRIPTION = "Plans and executes a motion of the tool to a pose"

    @classmethod
    def provided_ports(cls):
        return (input_port("target_pose", POSE_STAMPED, description="where the tool goes"),
                input_port("velocity_scale_factor", DOUBLE, 1.0, "fraction of the joint velocity limits"),
                output_port("trajectory", ANY, description="the executed trajectory"),
                bidirectional_port("attempts", INT, 0, "attempts so far"))

    def on_start(self):
        return NodeStatus.SUCCESS

    def on_running(self):
        return NodeStatus.SUCCESS


def factory_with_behavior() -> BehaviorTreeFactory:
    factory = BehaviorTreeFactory()
    factory.register_node_type(MoveToPose, "MoveToPose", metadata={"subcategory": "Motion"})
    factory.register_simple_condition("IsGripperOpen", lambda node: True, description="the gripper is open")
    return factory


def models(xml: str) -> dict[str, ET.Element]:
    root = ET.fromstring(xml)
    assert root.tag == "root" and root.get("BTCPP_format") == "4"
    (model_root,) = root
    assert model_root.tag == "TreeNodesModel"
    return {element.get("ID"): element for element in model_root}


def ports(element: ET.Element) -> dict[str, dict]:
    return {p.get("name"): {"direction": p.tag, "type": p.get("type"), "default": p.get("default"),
                            "description": (p.text or "")} for p in element if p.tag.endswith("_port")}


def test_registered_behaviors_are_exported_with_ports_descriptions_and_metadata():
    exported = models(factory_with_behavior().write_tree_nodes_model_xml())
    assert sorted(exported) == ["IsGripperOpen", "MoveToPose"]
    move = exported["MoveToPose"]
    assert move.tag == "Action"
    assert ports(move) == {
        "target_pose": {"direction": "input_port", "type": "geometry_msgs::msg::PoseStamped", "default": None,
                        "description": "where the tool goes"},
        "velocity_scale_factor": {"direction": "input_port", "type": "double", "default": "1.0",
                                  "description": "fraction of the joint velocity limits"},
        "trajectory": {"direction": "output_port", "type": "BT::AnyTypeAllowed", "default": None,
                       "description": "the executed trajectory"},
        "attempts": {"direction": "inout_port", "type": "int", "default": "0", "description": "attempts so far"},
    }
    assert [m.attrib for m in move.find("MetadataFields")] == [{"subcategory": "Motion"}]
    assert move.find("description").text == "Plans and executes a motion of the tool to a pose"
    assert exported["IsGripperOpen"].tag == "Condition"


def test_builtin_models_carry_bt_cpp_names_types_and_defaults():
    exported = models(BehaviorTreeFactory().write_tree_nodes_model_xml(include_builtin=True))
    assert set(exported) == set(BUILTIN_NODES)
    assert models(BehaviorTreeFactory().write_tree_nodes_model_xml()) == {}
    expected = {
        ("Sleep", "msec"): ("input_port", "unsigned int", None),
        ("Delay", "delay_msec"): ("input_port", "unsigned int", None),
        ("Timeout", "msec"): ("input_port", "unsigned int", None),
        ("Repeat", "num_cycles"): ("input_port", "int", None),
        ("RetryUntilSuccessful", "num_attempts"): ("input_port", "int", None),
        ("Parallel", "success_count"): ("input_port", "int", "-1"),
        ("Parallel", "failure_count"): ("input_port", "int", "1"),
        ("ParallelAll", "max_failures"): ("input_port", "int", "1"),
        ("RunOnce", "then_skip"): ("input_port", "bool", "true"),
        ("Precondition", "if"): ("input_port", "std::string", None),
        ("Precondition", "else"): ("input_port", "BT::NodeStatus", "FAILURE"),
        ("Script", "code"): ("input_port", "std::string", None),
        ("ScriptCondition", "code"): ("input_port", "BT::AnyTypeAllowed", None),
        ("SetBlackboard", "value"): ("input_port", "BT::AnyTypeAllowed", None),
        ("SetBlackboard", "output_key"): ("inout_port", "BT::AnyTypeAllowed", None),
        ("UnsetBlackboard", "key"): ("input_port", "std::string", None),
        ("Switch3", "variable"): ("input_port", "std::string", None),
        ("Switch3", "case_3"): ("input_port", "std::string", None),
        ("LoopInt", "if_empty"): ("input_port", "BT::NodeStatus", "SUCCESS"),
        ("LoopDouble", "value"): ("output_port", "double", None),
        ("WasEntryUpdated", "entry"): ("input_port", "BT::Any", None),
        ("SubTree", "_autoremap"): ("input_port", "bool", "false"),
    }
    for (node_id, port), (direction, type_name, default) in expected.items():
        found = ports(exported[node_id])[port]
        assert (found["direction"], found["type"], found["default"]) == (direction, type_name, default), node_id
    kinds = {node_id: element.tag for node_id, element in exported.items()}
    assert kinds["Sequence"] == "Control" and kinds["Inverter"] == "Decorator" and kinds["Sleep"] == "Action"
    assert kinds["ScriptCondition"] == "Condition" and kinds["SubTree"] == "SubTree"


def test_a_tree_file_carrying_the_exported_model_loads():
    factory = factory_with_behavior()
    model = factory.write_tree_nodes_model_xml()
    body = model.replace('<root BTCPP_format="4">', "").replace("</root>", "")
    xml = ('<root BTCPP_format="4"><BehaviorTree ID="Main"><Sequence><IsGripperOpen/>'
           '<MoveToPose target_pose="world;0.2;0;0.3;0;0;0;1" trajectory="{traj}"/></Sequence></BehaviorTree>'
           f"{body}</root>")
    tree = factory.create_tree_from_text(xml)
    assert tree.tick_once() is NodeStatus.SUCCESS
    assert sorted(factory.parser.declared_models) == []  # create_tree_from_text used its own parser
    factory.register_behavior_tree_from_text(xml)
    assert sorted(factory.parser.declared_models) == ["IsGripperOpen", "MoveToPose"]
