"""Built-in actions and conditions: AlwaysSuccess/Failure, Script, ScriptCondition, SetBlackboard,
UnsetBlackboard (Sleep and WasEntryUpdated are with the time and update decorators)."""
from __future__ import annotations

import pytest

from mycobot_planning.behavior_tree import (
    BehaviorTreeFactory,
    BehaviorTreeRuntimeError,
    Blackboard,
    NodeStatus,
)


def run(body: str, bb: Blackboard | None = None) -> tuple[NodeStatus, Blackboard]:
    bb = bb if bb is not None else Blackboard.create()
    tree = BehaviorTreeFactory().create_tree_from_text(
        f'<root BTCPP_format="4"><BehaviorTree ID="M">{body}</BehaviorTree></root>', bb)
    return tree.tick_once(), bb


def test_always_success_and_failure():
    assert run("<AlwaysSuccess/>")[0] is NodeStatus.SUCCESS
    assert run("<AlwaysFailure/>")[0] is NodeStatus.FAILURE


def test_script_and_script_condition():
    status, bb = run('<Sequence><Script code="a := 2; b := a * 3"/><ScriptCondition code="b == 6"/></Sequence>')
    assert status is NodeStatus.SUCCESS and bb.get("b") == 6.0
    assert run('<ScriptCondition code="1 &gt; 2"/>')[0] is NodeStatus.FAILURE
    # the code may come from the blackboard
    bb = Blackboard.create()
    bb.set("program", "x := 41 + 1")
    assert run('<Script code="{program}"/>', bb)[1].get("x") == 42.0


def test_a_script_error_is_an_error_of_the_tree_naming_the_node():
    with pytest.raises(BehaviorTreeRuntimeError) as caught:
        run('<Sequence><Script name="compute" code="y := missing + 1"/></Sequence>')
    assert caught.value.node_path == "compute" and "Variable not found: missing" in str(caught.value)
    with pytest.raises(BehaviorTreeRuntimeError, match="not a boolean"):
        run("<ScriptCondition code=\"'text'\"/>")


def test_set_blackboard_writes_literals_and_copies_entries():
    status, bb = run('<Sequence><SetBlackboard value="42" output_key="answer"/>'
                     '<Script code="n := 1"/><SetBlackboard value="{n}" output_key="copy"/>'
                     '<SetBlackboard value="7" output_key="n"/>'
                     '<SetBlackboard value="root" output_key="@where"/></Sequence>')
    assert status is NodeStatus.SUCCESS
    assert bb.get("answer") == "42"  # a literal is a string (ports convert it when they read it)
    assert bb.get("copy") == 1
    assert bb.get("n") == 7  # a string written to a number entry is converted
    assert bb.get("where") == "root"


def test_set_blackboard_refuses_a_value_that_does_not_fit_and_fails_on_an_empty_source():
    with pytest.raises(BehaviorTreeRuntimeError, match="can't convert"):
        run('<Sequence><Script code="n := 1"/><SetBlackboard value="one" output_key="n"/></Sequence>')
    bb = Blackboard.create()
    bb.create_entry("empty")
    assert run('<SetBlackboard value="{empty}" output_key="x"/>', bb)[0] is NodeStatus.FAILURE


def test_unset_blackboard():
    status, bb = run('<Sequence><Script code="a := 1; b := 2"/><UnsetBlackboard key="a"/></Sequence>')
    assert status is NodeStatus.SUCCESS and bb.keys() == ["b"]
