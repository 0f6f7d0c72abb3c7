"""SubTrees: their own blackboards, port remapping, literal ports, _autoremap, {@key},
TreeNodesModel port defaults, names and paths, recursion, halting; and <include>."""
from __future__ import annotations

import pytest
from bt_test_nodes import F, R, S, Script, factory_with, trace

from mycobot_planning.behavior_tree import BehaviorTreeFactory, BehaviorTreeRuntimeError, NodeStatus, TreeLoadError


def make(main: str, *subtrees: tuple[str, str], models: str = "", factory=None, script=None):
    body = "".join(f'<BehaviorTree ID="{i}">{b}</BehaviorTree>' for i, b in subtrees)
    xml = (f'<root BTCPP_format="4" main_tree_to_execute="Main"><BehaviorTree ID="Main">{main}</BehaviorTree>'
           f'{body}{models}</root>')
    factory = factory or factory_with(script or Script())
    return factory.create_tree_from_text(xml)


def test_ports_remap_subtree_entries_to_the_parent():
    tree = make('<Sequence><Script code="x := 5"/><SubTree ID="Double" input="{x}" output="{y}"/></Sequence>',
                ("Double", '<Script code="output := input * 2"/>'))
    assert tree.tick_once() is S
    root, sub = tree.subtrees[0].blackboard, tree.subtrees[1].blackboard
    assert root.get("y") == 10.0
    assert sub.keys() == []  # input and output live in the parent
    assert sub.remappings == {"input": "x", "output": "y"}


def test_literal_ports_are_constants_of_the_subtree():
    tree = make('<SubTree ID="Greet" who="World"/>', ("Greet", "<Script code=\"msg := 'Hello ' .. who\"/>"))
    assert tree.tick_once() is S
    assert tree.subtrees[1].blackboard.get("msg") == "Hello World"
    assert tree.root_blackboard().keys() == []


def test_a_subtree_without_remapping_does_not_see_the_parent():
    tree = make('<Sequence><Script code="x := 1"/><SubTree ID="Sub"/></Sequence>', ("Sub", '<Script code="y := x"/>'))
    with pytest.raises(BehaviorTreeRuntimeError, match="Variable not found: x"):
        tree.tick_once()


def test_autoremap_shares_every_name_but_private_ones():
    tree = make('<Sequence><Script code="x := 1"/><SubTree ID="Sub" _autoremap="true"/></Sequence>',
                ("Sub", '<Script code="y := x + 1; _tmp := 3"/>'))
    assert tree.tick_once() is S
    assert tree.root_blackboard().get("y") == 2.0 and "_tmp" not in tree.root_blackboard().keys()
    assert tree.subtrees[1].blackboard.keys() == ["_tmp"]


def test_autoremap_with_an_explicit_literal_port():
    tree = make('<Sequence><Script code="x := 1"/><SubTree ID="Sub" _autoremap="true" k="7"/></Sequence>',
                ("Sub", '<Script code="y := x .. k; same := k == 7"/>'))
    assert tree.tick_once() is S
    assert tree.root_blackboard().get("y") == "17"  # a literal port is a string, as in BT.CPP
    assert tree.root_blackboard().get("same") == 1.0
    assert "k" not in tree.root_blackboard().keys()


def test_equals_sign_remaps_a_port_to_the_same_name():
    tree = make('<Sequence><Script code="x := 4"/><SubTree ID="Sub" x="{=}"/></Sequence>',
                ("Sub", '<Script code="x = x + 1"/>'))
    assert tree.tick_once() is S and tree.root_blackboard().get("x") == 5


def test_at_keys_reach_the_root_blackboard_from_any_depth():
    tree = make('<Sequence><Script code="count := 0"/><SubTree ID="Outer"/></Sequence>',
                ("Outer", '<SubTree ID="Inner"/>'),
                ("Inner", '<Sequence><Script code="@count += 1"/><SetBlackboard value="{@count}" output_key="@copy"/>'
                          '</Sequence>'))
    assert tree.tick_once() is S
    assert tree.root_blackboard().get("count") == 1 and tree.root_blackboard().get("copy") == 1


def test_subtree_model_defaults_and_mandatory_ports():
    models = ('<TreeNodesModel><SubTree ID="Move" editable="true"><input_port name="speed" default="0.5"/>'
              '<input_port name="target"/></SubTree></TreeNodesModel>')
    sub = ("Move", '<Script code="used := speed .. target"/>')
    with pytest.raises(TreeLoadError, match=r"mandatory port called \[target\]"):
        make('<SubTree ID="Move"/>', sub, models=models)
    tree = make('<SubTree ID="Move" target="home"/>', sub, models=models)
    assert tree.tick_once() is S and tree.subtrees[1].blackboard.get("used") == "0.5home"
    make('<SubTree ID="Move" _autoremap="true"/>', sub, models=models)  # autoremap satisfies the model


def test_names_paths_and_uids():
    script = Script()
    tree = make('<Sequence><SubTree ID="Sub" name="first"/><SubTree ID="Sub"/></Sequence>',
                ("Sub", '<Sequence><Act name="A"/><Cond/></Sequence>'), script=script)
    paths = [(node.uid, node.full_path) for node in tree.nodes()]
    assert paths == [(1, "Sequence::1"), (2, "first"), (3, "first/Sequence::3"), (4, "first/A"),
                     (5, "first/Cond::5"), (6, "Sub::6"), (7, "Sub::6/Sequence::7"), (8, "Sub::6/A"),
                     (9, "Sub::6/Cond::9")]
    assert [(s.tree_id, s.instance_name) for s in tree.subtrees] == [("Main", ""), ("Sub", "first"), ("Sub", "Sub::6")]
    assert tree.subtrees[1].blackboard is not tree.subtrees[2].blackboard


@pytest.mark.parametrize("subtrees, chain", [
    ((("A", '<SubTree ID="B"/>'), ("B", '<Sequence><AlwaysSuccess/><SubTree ID="A"/></Sequence>')), "A -> B -> A"),
    ((("A", '<SubTree ID="A"/>'),), "A -> A"),
])
def test_subtrees_that_include_each_other_are_refused(subtrees, chain):
    with pytest.raises(TreeLoadError) as caught:
        make('<SubTree ID="A"/>', *subtrees)
    assert "recursion" in str(caught.value) and chain in str(caught.value)
    assert caught.value.line == 1 and caught.value.node.startswith("<SubTree")


def test_halting_reaches_nodes_inside_subtrees():
    script = Script()
    script.set("A", R)
    script.set("C", S, F)
    tree = make('<ReactiveSequence><Cond name="C"/><SubTree ID="Sub"/></ReactiveSequence>',
                ("Sub", '<Sequence><SubTree ID="Leaf"/></Sequence>'), ("Leaf", '<Act name="A"/>'), script=script)
    assert trace(tree, script, 2) == [(R, ["C", "A"]), (F, ["C"])]
    assert script.halts["A"] == 1
    assert all(node.status is NodeStatus.IDLE for node in tree.nodes())


# ---------------------------------------------------------------- <include>

def write(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def test_includes_resolve_relative_to_the_including_file(tmp_path):
    write(tmp_path / "common.xml", '<root BTCPP_format="4"><BehaviorTree ID="Leaf">'
                                   '<Script code="@leaf := 1"/></BehaviorTree></root>')
    write(tmp_path / "sub" / "sub.xml", '<root BTCPP_format="4"><include path="../common.xml"/>'
                                        '<BehaviorTree ID="Sub"><SubTree ID="Leaf"/></BehaviorTree></root>')
    main = write(tmp_path / "main.xml", '<root BTCPP_format="4" main_tree_to_execute="Main">'
                                        '<include path="sub/sub.xml"/><include path="common.xml"/>'
                                        '<BehaviorTree ID="Main"><SubTree ID="Sub"/></BehaviorTree></root>')
    tree = BehaviorTreeFactory().create_tree_from_file(main)
    assert tree.tick_once() is S and tree.root_blackboard().get("leaf") == 1


def test_include_cycles_and_missing_includes_are_refused(tmp_path):
    write(tmp_path / "a.xml", '<root BTCPP_format="4">\n<include path="b.xml"/>\n'
                              '<BehaviorTree ID="A"><AlwaysSuccess/></BehaviorTree></root>')
    write(tmp_path / "b.xml", '<root BTCPP_format="4">\n\n<include path="a.xml"/></root>')
    with pytest.raises(TreeLoadError) as caught:
        BehaviorTreeFactory().create_tree_from_file(tmp_path / "a.xml")
    assert "include cycle: a.xml -> b.xml -> a.xml" in str(caught.value)
    assert caught.value.file.endswith("b.xml") and caught.value.line == 3
    write(tmp_path / "c.xml", '<root BTCPP_format="4">\n<include path="nowhere.xml"/></root>')
    with pytest.raises(TreeLoadError, match="no such file") as caught:
        BehaviorTreeFactory().create_tree_from_file(tmp_path / "c.xml")
    assert caught.value.line == 2
