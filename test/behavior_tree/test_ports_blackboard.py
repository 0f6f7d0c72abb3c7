"""Ports (typed values from XML strings and from the blackboard) and the blackboard's typing
and scoping rules."""
from __future__ import annotations

import pytest

from mycobot_planning.behavior_tree import (
    ANY,
    BOOL,
    DOUBLE,
    INT,
    NODE_STATUS,
    POSE,
    POSE_STAMPED,
    STRING,
    UINT,
    VECTOR_BOOL,
    VECTOR_DOUBLE,
    VECTOR_INT,
    VECTOR_STRING,
    BehaviorTreeFactory,
    Blackboard,
    LogicError,
    NodeStatus,
    PortError,
    PoseStamped,
    SyncActionNode,
    input_port,
    output_port,
)
from mycobot_planning.behavior_tree.ports import ConversionError


@pytest.mark.parametrize("port_type, text, value", [
    (INT, "42", 42), (INT, "-7", -7), (UINT, "7", 7), (DOUBLE, "1.5", 1.5), (DOUBLE, "1e3", 1000.0),
    (DOUBLE, "-.5", -0.5), (BOOL, "true", True), (BOOL, "False", False), (BOOL, "1", True), (BOOL, "0", False),
    (STRING, " keep spaces ", " keep spaces "), (NODE_STATUS, "SKIPPED", NodeStatus.SKIPPED),
    (VECTOR_DOUBLE, "1;2.5;3", [1.0, 2.5, 3.0]), (VECTOR_INT, "1;2", [1, 2]), (VECTOR_INT, "", []),
    (VECTOR_BOOL, "true;0", [True, False]), (VECTOR_STRING, "a;b c;", ["a", "b c"]),
    (VECTOR_STRING, "a;;b", ["a", "", "b"]), (VECTOR_DOUBLE, "json:[1, 2.5]", [1.0, 2.5]),
    (INT, "json:12", 12), (ANY, "anything", "anything"),
])
def test_strings_convert_to_port_types(port_type, text, value):
    converted = port_type.from_string(text)
    assert converted == value and type(converted) is type(value)


@pytest.mark.parametrize("port_type, text", [
    (INT, "12abc"), (INT, "1.5"), (INT, ""), (INT, "0x10"), (INT, "99999999999"), (UINT, "-1"), (DOUBLE, "abc"),
    (DOUBLE, "1_000"), (BOOL, "yes"), (BOOL, "TRUE "), (NODE_STATUS, "success"), (VECTOR_DOUBLE, "1;x;3"),
    (VECTOR_INT, "1,2"), (POSE, "1;2;3"), (POSE, "0;0;0;0;0;0;0"), (POSE_STAMPED, "world;1;2"),
    (INT, "json:{"),
])
def test_strings_that_do_not_convert_are_refused(port_type, text):
    with pytest.raises(ConversionError):
        port_type.from_string(text)


def test_poses_from_strings():
    pose = POSE.from_string("0.1;0.2;0.3;0;0;0;1")
    assert pose.position == [0.1, 0.2, 0.3] and pose.orientation == [0.0, 0.0, 0.0, 1.0]
    turned = POSE.from_string("0;0;0.5;0;0;1.5707963267948966")  # x;y;z;roll;pitch;yaw
    assert turned.orientation == pytest.approx([0.0, 0.0, 0.7071067811865476, 0.7071067811865476])
    stamped = POSE_STAMPED.from_string("world;0.2;0;0.5;0;0;0;1")
    assert stamped.frame_id == "world" and stamped.pose.position == [0.2, 0.0, 0.5]
    assert POSE_STAMPED.from_string("0.2;0;0.5;0;0;0;1").frame_id == ""
    assert POSE_STAMPED.convert({"header": {"frame_id": "base"}, "pose": {"position": [1, 2, 3],
                                                                         "orientation": [0, 0, 0, 1]}}).frame_id == "base"
    assert POSE.convert(stamped) is stamped.pose


class Probe(SyncActionNode):
    seen: list = []

    @classmethod
    def provided_ports(cls):
        return (input_port("count", INT), input_port("ratio", DOUBLE, 0.5, "a default"),
                input_port("flag", BOOL, required=False), output_port("out", VECTOR_DOUBLE),
                output_port("unused", INT))

    def tick(self):
        Probe.seen.append((self.get_input("count"), self.get_input("ratio"), self.get_input("flag", None)))
        self.set_output("out", [self.get_input("count"), 0.5])
        assert self.set_output("unused", 1) is False  # not connected in the XML: nothing written
        return NodeStatus.SUCCESS


def probe_tree(attrs: str, bb: Blackboard | None = None):
    factory = BehaviorTreeFactory()
    factory.register_node_type(Probe, "Probe")
    Probe.seen = []
    return factory.create_tree_from_text(f'<root BTCPP_format="4"><BehaviorTree ID="M"><Probe {attrs}/>'
                                         "</BehaviorTree></root>", bb)


def test_ports_read_literals_defaults_and_blackboard_entries():
    tree = probe_tree('count="3" out="{v}"')
    assert tree.tick_once() is NodeStatus.SUCCESS
    assert Probe.seen == [(3, 0.5, None)] and tree.root_blackboard().get("v") == [3.0, 0.5]
    bb = Blackboard.create()
    tree = probe_tree('count="{n}" ratio="{r}" flag="{f}" out="{@v}"', bb)
    bb.set("n", "7")  # a string entry is converted by the port that reads it
    bb.set("r", 2)  # an integer read as a double
    bb.set("f", 1.0)
    tree.tick_once()
    assert Probe.seen == [(7, 2.0, True)] and bb.get("v") == [7.0, 0.5]


def test_port_errors_name_the_node_the_port_and_the_entry():
    tree = probe_tree('count="{n}"')
    with pytest.raises(PortError) as caught:
        tree.tick_once()
    assert caught.value.node_path == "Probe::1" and "[count] remapped to [n]" in str(caught.value)
    tree = probe_tree('count="{n}"')
    with pytest.raises(PortError, match="type of an entry shall not change"):
        tree.root_blackboard().set("n", 2.5)  # the entry took the port's type when the tree was loaded
    bb = Blackboard.create()
    bb.set("n", "2.5")  # an untyped entry given before loading: the port finds out when it reads it
    tree = probe_tree('count="{n}"', bb)
    with pytest.raises(PortError, match=r"entry \[n\] = '2.5', which is not a int"):
        tree.tick_once()


def test_blackboard_entries_keep_their_type():
    bb = Blackboard.create()
    bb.set("n", 3)
    bb.set("n", "4")  # strings are converted
    bb.set("n", 5.0)  # doubles that are whole numbers are cast
    assert bb.get("n") == 5 and isinstance(bb.get("n"), int)
    for bad in (5.5, "five", [1]):
        with pytest.raises(PortError, match="type of an entry shall not change"):
            bb.set("n", bad)
    bb.set("s", "text")
    bb.set("s", 3)  # a string entry is not typed until it holds a number
    with pytest.raises(PortError):
        bb.set("s", "x")
    bb.create_entry("typed", INT)
    with pytest.raises(LogicError, match="Previously declared type \\[int\\]"):
        bb.create_entry("typed", DOUBLE)
    bb.create_entry("typed", ANY)  # an untyped port may share it


def test_blackboard_scoping_remapping_and_root_access():
    root = Blackboard.create()
    child = Blackboard.create(root)
    child.add_subtree_remapping("inner", "outer")
    child.set("inner", 1)
    child.set("local", 2)
    child.set("@global", 3)
    assert root.get("outer") == 1 and root.get("global") == 3 and "local" not in root
    assert child.get("@global") == 3 and child.get("inner") == 1
    assert child.get("missing", "default") == "default"
    child.unset("inner")  # BT.CPP: unset does not follow a remapping
    assert root.get("outer") == 1
    child.unset("local")
    assert "local" not in child
    auto = Blackboard.create(root)
    auto.enable_auto_remapping(True)
    auto.set("shared", 4)
    auto.set("_private", 5)
    assert root.get("shared") == 4 and "_private" not in root


def test_pose_stamped_values_go_through_the_blackboard():
    bb = Blackboard.create()
    bb.create_entry("goal", POSE_STAMPED)
    bb.set("goal", "world;1;2;3;0;0;0;1")
    assert isinstance(bb.get("goal"), PoseStamped) and bb.get("goal").pose.position == [1.0, 2.0, 3.0]


def test_defaults_that_are_objects_reach_the_node():
    from interfaces_py.msgs import Pose

    seen = []

    class Offset(SyncActionNode):
        @classmethod
        def provided_ports(cls):
            return (input_port("offset", POSE, Pose(position=[0.0, 0.0, 0.1])),
                    input_port("options", ANY, {"mode": "fast"}), input_port("axes", VECTOR_INT, [1, 2]))

        def tick(self):
            seen.append((self.get_input("offset"), self.get_input("options"), self.get_input("axes")))
            return NodeStatus.SUCCESS

    factory = BehaviorTreeFactory()
    factory.register_node_type(Offset, "Offset")
    tree = factory.create_tree_from_text('<root BTCPP_format="4"><BehaviorTree ID="M"><Offset/></BehaviorTree></root>')
    assert tree.tick_once() is NodeStatus.SUCCESS
    offset, options, axes = seen[0]
    assert offset.position == [0.0, 0.0, 0.1] and options == {"mode": "fast"} and axes == [1, 2]
    model = factory.write_tree_nodes_model_xml()
    assert 'name="offset" type="geometry_msgs::msg::Pose" default="0.0;0.0;0.1;0.0;0.0;0.0;1.0"' in model
    assert 'name="axes" type="std::vector&lt;int&gt;" default="1;2"' in model
