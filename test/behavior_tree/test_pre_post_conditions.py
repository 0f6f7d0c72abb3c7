"""Pre-conditions (_failureIf, _successIf, _skipIf, _while) and post-conditions (_onSuccess,
_onFailure, _post, _onHalted) on any node, as BT.CPP's TreeNode::executeTick runs them."""
from __future__ import annotations

import pytest
from bt_test_nodes import F, K, R, S, Script, trace, tree_of

from mycobot_planning.behavior_tree import BehaviorTreeRuntimeError, NodeStatus


def tree_with(body: str, script: Script, **entries):
    tree = tree_of(body, script)
    for key, value in entries.items():
        tree.root_blackboard().set(key, value)
    return tree


@pytest.mark.parametrize("attribute, expected", [("_skipIf", K), ("_failureIf", F), ("_successIf", S)])
def test_a_true_precondition_answers_instead_of_the_node(attribute, expected):
    script = Script()
    tree = tree_with(f'<Act name="A" {attribute}="flag == 1"/>', script, flag=1)
    assert trace(tree, script, 1) == [(expected, [])]
    assert tree.root_node.status is NodeStatus.IDLE
    tree.root_blackboard().set("flag", 0)
    assert trace(tree, script, 1) == [(S, ["A"])]


def test_preconditions_are_checked_in_bt_cpp_order():
    script = Script()
    tree = tree_with('<Act name="A" _skipIf="true" _successIf="true" _failureIf="true"/>', script)
    assert trace(tree, script, 1) == [(F, [])]
    tree = tree_with('<Act name="A" _skipIf="true" _successIf="true"/>', script)
    assert trace(tree, script, 1) == [(S, [])]


def test_a_skipped_child_lets_the_sequence_continue():
    script = Script()
    tree = tree_with('<Sequence><Act name="A" _skipIf="x &gt; 0"/><Act name="B"/></Sequence>', script, x=3)
    assert trace(tree, script, 1) == [(S, ["B"])]


def test_preconditions_are_not_checked_again_while_the_node_runs():
    script = Script()
    script.set("A", R, R, S)
    tree = tree_with('<Act name="A" _failureIf="stop"/>', script, stop=0)
    assert trace(tree, script, 1) == [(R, ["A"])]
    tree.root_blackboard().set("stop", 1)
    assert trace(tree, script, 2) == [(R, ["A"]), (S, ["A"])]


def test_while_skips_a_node_and_halts_it_when_it_turns_false():
    script = Script()
    script.set("A", R)
    tree = tree_with('<Sequence><Act name="A" _while="go" _onHalted="halted := true"/><Act name="B"/></Sequence>',
                     script, go=0)
    assert trace(tree, script, 1) == [(S, ["B"])]  # false from the start: skipped
    tree.root_blackboard().set("go", 1)
    assert trace(tree, script, 2) == [(R, ["A"]), (R, ["A"])]
    tree.root_blackboard().set("go", 0)
    assert trace(tree, script, 1) == [(S, ["B"])]
    assert script.halts["A"] == 1 and tree.root_blackboard().get("halted") == 1


@pytest.mark.parametrize("answer, ran", [(S, ["success", "post"]), (F, ["failure", "post"])])
def test_post_conditions_run_after_a_completed_status(answer, ran):
    script = Script()
    script.set("A", R, answer)
    tree = tree_with('<Act name="A" _onSuccess="success := 1" _onFailure="failure := 1" _post="post := 1"/>',
                     script)
    tree.tick_once()
    assert tree.root_blackboard().keys() == []  # RUNNING runs none of them
    tree.tick_once()
    assert sorted(tree.root_blackboard().keys()) == sorted(ran)


def test_post_conditions_follow_a_status_set_by_a_precondition():
    script = Script()
    tree = tree_with('<Act name="A" _successIf="true" _onSuccess="done := 1" _post="n := 2"/>', script)
    assert trace(tree, script, 1) == [(S, [])]
    assert dict(tree.root_blackboard().items()) == {"done": 1, "n": 2}


def test_on_halted_runs_when_a_running_node_is_halted():
    script = Script()
    script.set("C", S, F)
    script.set("A", R)
    tree = tree_with('<ReactiveSequence><Cond name="C"/><Act name="A" _onHalted="halted := halted + 1"/>'
                     '</ReactiveSequence>', script, halted=0)
    assert trace(tree, script, 2) == [(R, ["C", "A"]), (F, ["C"])]
    assert tree.root_blackboard().get("halted") == 1
    script.set("C", S)
    tree.tick_once()
    tree.halt_tree()
    assert tree.root_blackboard().get("halted") == 2
    tree.halt_tree()  # nothing runs: nothing more to halt
    assert tree.root_blackboard().get("halted") == 2


def test_a_failing_precondition_script_names_the_node_and_halts_the_tree():
    script = Script()
    script.set("A", R)
    tree = tree_with('<Parallel><Act name="A"/><Act name="B" _skipIf="missing == 1"/></Parallel>', script)
    with pytest.raises(BehaviorTreeRuntimeError) as caught:
        tree.tick_once()
    assert "Variable not found: missing" in str(caught.value)
    assert caught.value.node_path == "B"
    assert script.halts["A"] == 1 and all(n.status is NodeStatus.IDLE for n in tree.nodes())


def test_conditions_on_a_subtree_read_the_parent_blackboard():
    script = Script()
    xml = ('<root BTCPP_format="4" main_tree_to_execute="Main">'
           '<BehaviorTree ID="Main"><Sequence><Script code="x := 1"/>'
           '<SubTree ID="Sub" _skipIf="x == 1"/><SubTree ID="Sub" _onSuccess="ok := true"/></Sequence></BehaviorTree>'
           '<BehaviorTree ID="Sub"><Act name="A"/></BehaviorTree></root>')
    from bt_test_nodes import factory_with
    tree = factory_with(script).create_tree_from_text(xml)
    assert tree.tick_once() is S
    assert script.ticks["A"] == 1 and tree.root_blackboard().get("ok") == 1
