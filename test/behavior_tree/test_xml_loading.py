"""Loading BT.CPP v4 XML: both node forms, main tree selection, Groot2's files and a running
tree's XML unchanged, and bad input refused before anything runs, naming file, line and node."""
from __future__ import annotations

import textwrap

import pytest
from bt_test_nodes import F, R, S, Script, factory_with, trace

from mycobot_planning.behavior_tree import (
    BehaviorTreeFactory,
    Blackboard,
    NodeStatus,
    TreeLoadError,
    write_tree_to_xml,
)

COMPACT = """
<root BTCPP_format="4">
  <BehaviorTree ID="Main">
    <Sequence name="root">
      <AlwaysSuccess/>
      <ScriptCondition code="true"/>
      <Inverter><AlwaysFailure/></Inverter>
      <SubTree ID="Sub" value="{v}"/>
    </Sequence>
  </BehaviorTree>
  <BehaviorTree ID="Sub"><Script code="value := 3"/></BehaviorTree>
</root>"""

GENERIC = """
<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main">
    <Control ID="Sequence" name="root">
      <Action ID="AlwaysSuccess"/>
      <Condition ID="ScriptCondition" code="true"/>
      <Decorator ID="Inverter"><Action ID="AlwaysFailure"/></Decorator>
      <SubTree ID="Sub" value="{v}"/>
    </Control>
  </BehaviorTree>
  <BehaviorTree ID="Sub"><Action ID="Script" code="value := 3"/></BehaviorTree>
</root>"""


def shape(tree):
    return [(node.registration_id, node.name, node.type.value) for node in tree.nodes()]


def test_compact_and_generic_forms_build_the_same_tree():
    factory = BehaviorTreeFactory()
    compact = factory.create_tree_from_text(COMPACT, main_tree_id="Main")
    generic = factory.create_tree_from_text(GENERIC)
    assert shape(compact) == shape(generic)
    assert [n.registration_id for n in generic.nodes()] == [
        "Sequence", "AlwaysSuccess", "ScriptCondition", "Inverter", "AlwaysFailure", "SubTree", "Script"]
    assert generic.tick_once() is S and generic.root_blackboard().get("v") == 3


def test_main_tree_selection():
    factory = BehaviorTreeFactory()
    with pytest.raises(TreeLoadError, match="main_tree_to_execute"):
        factory.create_tree_from_text(COMPACT)
    one = '<root BTCPP_format="4"><BehaviorTree ID="Only"><AlwaysSuccess/></BehaviorTree></root>'
    assert factory.create_tree_from_text(one).subtrees[0].tree_id == "Only"
    factory.register_behavior_tree_from_text(GENERIC)
    assert sorted(factory.registered_behavior_trees()) == ["Main", "Sub"]
    assert factory.create_tree().subtrees[0].tree_id == "Main"
    assert factory.create_tree("Sub").subtrees[0].tree_id == "Sub"
    with pytest.raises(TreeLoadError, match="can't find a tree with name 'Nope'"):
        factory.create_tree("Nope")


GROOT2_FILE = """<?xml version="1.0" encoding="UTF-8"?>
<root BTCPP_format="4">
  <BehaviorTree ID="Main" _description="made in Groot2">
    <Sequence>
      <SaySomething message="hello"/>
      <SubTree ID="Sub" target="{goal}" _autoremap="false"/>
    </Sequence>
  </BehaviorTree>

  <BehaviorTree ID="Sub">
    <Sleep msec="10"/>
  </BehaviorTree>

  <!-- Description of Node Models (used by Groot) -->
  <TreeNodesModel>
    <Action ID="SaySomething" editable="true">
      <input_port name="message"/>
    </Action>
    <Action ID="Sleep" editable="true">
      <input_port name="msec"/>
    </Action>
    <SubTree ID="Sub" editable="true">
      <input_port name="target" default="home"/>
      <MetadataFields><Metadata subcategory="Motion"/></MetadataFields>
    </SubTree>
  </TreeNodesModel>
</root>
"""


def groot_factory(said: list):
    from mycobot_planning.behavior_tree import STRING, input_port
    factory = BehaviorTreeFactory()
    factory.register_simple_action("SaySomething", lambda node: said.append(node.get_input("message")) or S,
                                   [input_port("message", STRING)])
    return factory


def test_a_file_as_groot2_saves_it_loads_unchanged():
    said: list = []
    factory = groot_factory(said)
    with pytest.raises(TreeLoadError, match="main_tree_to_execute"):
        factory.create_tree_from_text(GROOT2_FILE)  # Groot2 does not write it: name the tree, as in BT.CPP
    tree = factory.create_tree_from_text(GROOT2_FILE, main_tree_id="Main")
    assert tree.tick_while_running() is S and said == ["hello"]
    assert tree.subtrees[1].blackboard.remappings == {"target": "goal"}


def test_a_running_trees_xml_with_uids_and_fullpaths_loads_unchanged_and_runs_the_same():
    script = Script()
    script.set("A", R, S)
    script.set("C", F)
    xml = textwrap.dedent("""
        <root BTCPP_format="4" main_tree_to_execute="Main">
          <BehaviorTree ID="Main">
            <Sequence>
              <Script code="n := 0"/>
              <SubTree ID="Work" name="first" count="{n}"/>
              <SubTree ID="Work" count="{n}"/>
              <RunOnce then_skip="false"><Act name="A" _onSuccess="@done := true"/></RunOnce>
            </Sequence>
          </BehaviorTree>
          <BehaviorTree ID="Work"><Fallback><Cond name="C"/><Script code="count += 1"/></Fallback></BehaviorTree>
        </root>""")
    factory = factory_with(script)
    original = factory.create_tree_from_text(xml)
    written = write_tree_to_xml(original, add_metadata=True)
    # BT.CPP's layout: one BehaviorTree per SubTree instance, _fullpath on it and on the SubTree, _uid everywhere
    assert '<BehaviorTree ID="Work" _fullpath="first">' in written
    assert '<BehaviorTree ID="Work" _fullpath="Work::7">' in written
    assert '<SubTree ID="Work" _fullpath="Work::7" _uid="7" count="{n}" />' in written
    assert '<SubTree ID="Work" name="first" _fullpath="first" _uid="3" count="{n}" />' in written
    assert '<Act name="A" _uid="12" _onSuccess="@done := true" />' in written
    assert '<RunOnce name="RunOnce" _uid="11" then_skip="false">' in written

    script2 = Script()
    script2.set("A", R, S)
    script2.set("C", F)
    reloaded = factory_with(script2).create_tree_from_text(written, main_tree_id="Main")
    assert [(n.registration_id, n.name) for n in reloaded.nodes()] == [
        (n.registration_id, n.name) for n in original.nodes()]
    assert [n.full_path for n in reloaded.nodes()] == [n.full_path for n in original.nodes()]
    assert trace(original, script, 3) == trace(reloaded, script2, 3)
    assert original.root_blackboard().get("n") == reloaded.root_blackboard().get("n") == 2
    assert reloaded.root_blackboard().get("done") == 1
    # and once more: writing the reloaded tree gives the same XML
    assert write_tree_to_xml(reloaded, add_metadata=True) == written


# ---------------------------------------------------------------- bad input


def refused(xml: str, factory=None, match: str | None = None) -> TreeLoadError:
    factory = factory or factory_with(Script())
    with pytest.raises(TreeLoadError) as caught:
        factory.create_tree_from_text(textwrap.dedent(xml).strip(), source="objective.xml")
    error = caught.value
    assert error.file == "objective.xml"
    if match:
        assert match in str(error), str(error)
    return error


def tree_xml(body: str) -> str:
    return f'<root BTCPP_format="4">\n<BehaviorTree ID="Main">\n{body}\n</BehaviorTree>\n</root>'


@pytest.mark.parametrize("body, line, node, message", [
    ("<Sequence>\n<AlwaysSuccess/>\n<Sequense/>\n</Sequence>", 5, "<Sequense>",
     "node 'Sequense' is not a registered node (did you mean 'Sequence'"),
    ('<Action ID="MoveToPose"/>', 3, '<Action ID="MoveToPose">', "<Action> ID 'MoveToPose' is not a registered node"),
    ("<Sleep/>", 3, "<Sleep>", "missing required input port [msec] (unsigned int)"),
    ('<Sleep msec="ten"/>', 3, "<Sleep>", 'value "ten" can not be converted to unsigned int'),
    ('<Sleep msec="-5"/>', 3, "<Sleep>", "can not be converted to unsigned int"),
    ('<Repeat num_cycles="1.5"><AlwaysSuccess/></Repeat>', 3, "<Repeat>", "can not be converted to int"),
    ('<RunOnce then_skip="maybe"><AlwaysSuccess/></RunOnce>', 3, "<RunOnce>", "can not be converted to bool"),
    ('<Precondition if="true" else="MAYBE"><AlwaysSuccess/></Precondition>', 3, "<Precondition>",
     "can not be converted to BT::NodeStatus"),
    ('<Sleep msec="10" speed="2"/>', 3, "<Sleep>", "a port with name [speed] is found in the XML but not"),
    ('<LoopInt queue="1;2" value="3"><AlwaysSuccess/></LoopInt>', 3, "<LoopInt>",
     "output port [value] must name a blackboard entry"),
    ('<Script code="x := := 1"/>', 3, "<Script>", "script error"),
    ('<AlwaysSuccess _skipIf="x = = 1"/>', 3, "<AlwaysSuccess>", "script error in _skipIf"),
    ('<Inverter>\n<AlwaysSuccess/>\n<AlwaysSuccess/>\n</Inverter>', 3, "<Inverter>", "must have exactly 1 child"),
    ("<Sequence/>", 3, "<Sequence>", "must have 1 or more children"),
    ("<AlwaysSuccess><AlwaysFailure/></AlwaysSuccess>", 3, "<AlwaysSuccess>", "must not have any child"),
    ('<SubTree ID="Nowhere"/>', 3, '<SubTree ID="Nowhere">', "no <BehaviorTree ID=\"Nowhere\"> was loaded"),
    ('<Sequence ID="Sequence"><AlwaysSuccess/></Sequence>', 3, '<Sequence ID="Sequence">',
     "attribute [ID] is not allowed"),
    ("<Control><AlwaysSuccess/></Control>", 3, "<Control>", "must have the attribute [ID]"),
    ('<Sequence>\n<Sleep msec="{t}"/>\n<Repeat num_cycles="{t}"><AlwaysSuccess/></Repeat>\n</Sequence>', 5,
     "<Repeat>", "uses the blackboard entry [t] as int, but it was created with type unsigned int"),
    ('<Parallel success_count="3"><AlwaysSuccess/></Parallel>', 3, "<Parallel>", "can never succeed"),
])
def test_bad_trees_are_refused_naming_file_line_and_node(body, line, node, message):
    error = refused(tree_xml(body), match=message)
    assert (error.line, error.node) == (line, node)
    assert str(error).startswith(f"objective.xml:{line}: {node}: ")


@pytest.mark.parametrize("xml, line, message", [
    ('<root BTCPP_format="4">\n<BehaviorTree ID="Main">\n<Sequence>\n</BehaviorTree>\n</root>', 4,
     "malformed XML: mismatched tag"),
    ('<root BTCPP_format="4">\n<BehaviorTree ID="Main" ID="x"><AlwaysSuccess/></BehaviorTree></root>', 2,
     "duplicate attribute"),
    ("", 1, "malformed XML"),
    ('<tree BTCPP_format="4"/>', 1, "root node called <root>"),
    ('<root BTCPP_format="3"><BehaviorTree ID="M"><AlwaysSuccess/></BehaviorTree></root>', 1,
     "only BehaviorTree.CPP's version 4"),
    ('<root BTCPP_format="4">\n<BehaviorTree ID="Main"><AlwaysSuccess/><AlwaysSuccess/></BehaviorTree></root>', 2,
     "must have exactly 1 child"),
    ('<root BTCPP_format="4">\n<BehaviorTree ID="Sequence"><AlwaysSuccess/></BehaviorTree></root>', 2,
     "must not use the name of a registered node"),
    ('<root BTCPP_format="4"><BehaviorTree ID="M"><AlwaysSuccess/></BehaviorTree>\n'
     '<BehaviorTree ID="M"><AlwaysFailure/></BehaviorTree></root>', 2, "defined twice"),
    ('<root BTCPP_format="4"><BehaviorTree ID="M"><AlwaysSuccess/></BehaviorTree>\n<BehaviorTree>'
     '<AlwaysSuccess/></BehaviorTree></root>', 2, "must have the attribute [ID]"),
    ('<root BTCPP_format="4"><TreeNodesModel/>\n<TreeNodesModel/><BehaviorTree ID="M"><AlwaysSuccess/>'
     '</BehaviorTree></root>', 2, "only a single node <TreeNodesModel>"),
    ('<!DOCTYPE root [<!ENTITY a "b">]><root BTCPP_format="4"/>', 1, "DOCTYPE is not allowed"),
])
def test_bad_documents_are_refused_with_the_line(xml, line, message):
    error = refused(xml, match=message)
    assert error.line == line


def test_nothing_runs_and_the_blackboard_is_left_as_it_was_when_a_tree_is_refused():
    script = Script()
    bb = Blackboard.create()
    bb.set("kept", 1)
    xml = ('<root BTCPP_format="4" main_tree_to_execute="Main"><BehaviorTree ID="Main"><Sequence><Act name="A"/>'
           '<Script code="y := 1"/><Sleep msec="{t}"/><SetBlackboard value="1" output_key="{k}"/>'
           '<SubTree ID="Sub" _autoremap="true"/><Nope/></Sequence></BehaviorTree>'
           '<BehaviorTree ID="Sub"><Sleep msec="{u}"/></BehaviorTree></root>')
    with pytest.raises(TreeLoadError, match="'Nope'"):
        factory_with(script).create_tree_from_text(xml, bb)
    assert script.ticks == {} and bb.keys() == ["kept"]


def test_duplicate_trees_across_files_are_refused_unless_kept(tmp_path):
    a = tmp_path / "a.xml"
    a.write_text('<root BTCPP_format="4"><BehaviorTree ID="T"><AlwaysSuccess/></BehaviorTree></root>')
    b = tmp_path / "b.xml"
    b.write_text('<root BTCPP_format="4">\n<BehaviorTree ID="T"><AlwaysFailure/></BehaviorTree></root>')
    factory = BehaviorTreeFactory()
    factory.register_behavior_tree_from_file(a)
    with pytest.raises(TreeLoadError, match=r"'T' is already defined in .*a\.xml:1") as caught:
        factory.register_behavior_tree_from_file(b)
    assert caught.value.line == 2
    factory.register_behavior_tree_from_file(b, skip_existing=True)
    assert factory.create_tree("T").tick_once() is NodeStatus.SUCCESS


def test_missing_format_is_read_as_version_4_with_a_warning(caplog):
    tree = BehaviorTreeFactory().create_tree_from_text('<root><BehaviorTree ID="M"><AlwaysSuccess/></BehaviorTree></root>')
    assert tree.tick_once() is S
    assert "BTCPP_format" in caplog.text
