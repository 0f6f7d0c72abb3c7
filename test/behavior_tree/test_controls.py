"""Control nodes, tick by tick, against BehaviorTree.CPP 4.6-4.8's semantics (src/controls)."""
from __future__ import annotations

import pytest
from bt_test_nodes import F, K, R, S, Script, factory_with, trace, tree_of

from mycobot_planning.behavior_tree import NodeStatus, TreeLoadError

THREE = '<Act name="A"/><Act name="B"/><Act name="C"/>'


def run(control: str, script: Script, ticks: int, children: str = THREE, **attrs: str):
    extra = "".join(f' {k}="{v}"' for k, v in attrs.items())
    return trace(tree_of(f"<{control}{extra}>{children}</{control}>", script), script, ticks)


# ---------------------------------------------------------------- a child that runs

@pytest.mark.parametrize("control, expected", [
    # Sequence and SequenceWithMemory resume at the running child; ReactiveSequence re-ticks from the first
    ("Sequence", [(R, ["A", "B"]), (R, ["B"]), (S, ["B", "C"])]),
    ("SequenceWithMemory", [(R, ["A", "B"]), (R, ["B"]), (S, ["B", "C"])]),
    ("ReactiveSequence", [(R, ["A", "B"]), (R, ["A", "B"]), (S, ["A", "B", "C"])]),
])
def test_sequences_when_a_child_runs(control, expected):
    script = Script()
    script.set("B", R, R, S)
    assert run(control, script, 3) == expected


@pytest.mark.parametrize("control, expected", [
    # after B fails: Sequence starts over at A, SequenceWithMemory resumes at B
    ("Sequence", [(F, ["A", "B"]), (S, ["A", "B", "C"])]),
    ("SequenceWithMemory", [(F, ["A", "B"]), (S, ["B", "C"])]),
    ("ReactiveSequence", [(F, ["A", "B"]), (S, ["A", "B", "C"])]),
])
def test_sequences_after_a_child_fails(control, expected):
    script = Script()
    script.set("B", F, S)
    assert run(control, script, 2) == expected


def test_reactive_sequence_halts_the_running_child_when_a_condition_fails():
    script = Script()
    script.set("A", S, S, F)
    script.set("B", R)
    result = run("ReactiveSequence", script, 3, '<Cond name="A"/><Act name="B"/>')
    assert result == [(R, ["A", "B"]), (R, ["A", "B"]), (F, ["A"])]
    assert script.halts["B"] == 1


def test_plain_sequence_does_not_recheck_a_condition_while_a_child_runs():
    script = Script()
    script.set("A", S, F)
    script.set("B", R)
    assert run("Sequence", script, 3, '<Cond name="A"/><Act name="B"/>') == [
        (R, ["A", "B"]), (R, ["B"]), (R, ["B"])]
    assert script.halts["B"] == 0


def test_reactive_sequence_halts_an_earlier_running_child_when_a_later_one_runs():
    script = Script()
    script.set("A", R, S)
    script.set("B", R)
    result = run("ReactiveSequence", script, 2, '<Act name="A"/><Act name="B"/>')
    assert result == [(R, ["A"]), (R, ["A", "B"])]


@pytest.mark.parametrize("control, expected", [
    ("Fallback", [(R, ["A", "B"]), (R, ["B"]), (S, ["B"])]),
    ("ReactiveFallback", [(R, ["A", "B"]), (R, ["A", "B"]), (S, ["A", "B"])]),
])
def test_fallbacks_when_a_child_runs(control, expected):
    script = Script()
    script.set("A", F)
    script.set("B", R, R, S)
    assert run(control, script, 3) == expected


def test_reactive_fallback_halts_the_running_child_when_an_earlier_child_succeeds():
    script = Script()
    script.set("A", F, F, S)
    script.set("B", R)
    assert run("ReactiveFallback", script, 3, '<Cond name="A"/><Act name="B"/>') == [
        (R, ["A", "B"]), (R, ["A", "B"]), (S, ["A"])]
    assert script.halts["B"] == 1


@pytest.mark.parametrize("control", ["Fallback", "ReactiveFallback"])
def test_fallbacks_fail_when_every_child_fails_and_stop_at_the_first_success(control):
    script = Script()
    for name in "ABC":
        script.set(name, F)
    assert run(control, script, 1) == [(F, ["A", "B", "C"])]
    script = Script()
    script.set("A", F)
    assert run(control, script, 1) == [(S, ["A", "B"])]


@pytest.mark.parametrize("control, success", [("Sequence", S), ("Fallback", F), ("ReactiveSequence", S),
                                              ("ReactiveFallback", F), ("SequenceWithMemory", S)])
def test_all_children_skipped_is_skipped_one_skipped_is_not(control, success):
    script = Script()
    script.set("A", K)
    script.set("B", K)
    script.set("C", K)
    assert run(control, script, 1)[0][0] is K
    script = Script()
    script.set("A", K)
    script.set("B", success)
    script.set("C", success)
    assert run(control, script, 1)[0][0] is success


# ---------------------------------------------------------------- async variants

@pytest.mark.parametrize("control, answer", [("AsyncSequence", S), ("AsyncFallback", F)])
def test_async_sequence_and_fallback_yield_between_children(control, answer):
    script = Script()
    for name in "ABC":
        script.set(name, answer)
    tree = tree_of(f"<{control}>{THREE}</{control}>", script)
    assert trace(tree, script, 3, exactly_once=True) == [(R, ["A"]), (R, ["B"]), (answer, ["C"])]
    # tick_once ticks again at once when a node asked to be woken up
    script.ticks.clear()
    assert trace(tree, script, 1) == [(answer, ["A", "B", "C"])]


def test_plain_sequence_does_not_yield():
    script = Script()
    assert run("Sequence", script, 1) == [(S, ["A", "B", "C"])]
    tree = tree_of(f"<Sequence>{THREE}</Sequence>", script)
    assert trace(tree, script, 1, exactly_once=True) == [(S, ["A", "B", "C"])]


def test_sequence_with_memory_yields_after_each_child_that_succeeded_at_once():
    """BT.CPP's SequenceWithMemory returns the flow (with a wake-up) after an IDLE child succeeds."""
    script = Script()
    tree = tree_of(f"<SequenceWithMemory>{THREE}</SequenceWithMemory>", script)
    assert trace(tree, script, 3, exactly_once=True) == [(R, ["A"]), (R, ["B"]), (S, ["C"])]


# ---------------------------------------------------------------- Parallel

def test_parallel_succeeds_at_the_success_count_and_halts_the_others():
    script = Script()
    script.set("A", R, S)
    script.set("B", R, R, S)
    script.set("C", R)
    result = run("Parallel", script, 3, success_count="2", failure_count="1")
    assert result == [(R, ["A", "B", "C"]), (R, ["A", "B", "C"]), (S, ["B"])]
    assert script.halts["C"] == 1
    assert script.ticks["A"] == 2  # a completed child is not ticked again


def test_parallel_fails_at_the_failure_count():
    script = Script()
    script.set("A", F)
    script.set("B", F)
    script.set("C", R)
    assert run("Parallel", script, 1, success_count="1", failure_count="2") == [(F, ["A", "B"])]
    script = Script()
    script.set("A", F)
    script.set("B", R, S)
    script.set("C", R)
    assert run("Parallel", script, 2, success_count="1", failure_count="2") == [
        (R, ["A", "B", "C"]), (S, ["B"])]


def test_parallel_fails_as_soon_as_success_is_impossible():
    script = Script()
    script.set("A", F)
    script.set("B", R)
    script.set("C", R)
    # 3 successes needed, one child already failed: FAILURE even though failure_count is 3
    assert run("Parallel", script, 1, success_count="3", failure_count="3") == [(F, ["A"])]


def test_parallel_defaults_need_every_child_and_fail_at_the_first_failure():
    script = Script()
    script.set("A", R, S)
    assert run("Parallel", script, 2) == [(R, ["A", "B", "C"]), (S, ["A"])]
    script = Script()
    script.set("A", R)
    script.set("B", F)
    assert run("Parallel", script, 1) == [(F, ["A", "B"])]
    assert script.halts["A"] == 1


@pytest.mark.parametrize("success_count, failure_count, answers, expected", [
    # -1: all children; -2: all but one (Python-style counting from the number of children)
    ("-1", "1", {"A": S, "B": S, "C": S}, S),
    ("-2", "1", {"A": S, "B": S, "C": R}, S),
    ("-2", "-1", {"A": F, "B": F, "C": S}, F),    # -1 failures: all three must fail... but success is impossible
    ("1", "-1", {"A": F, "B": F, "C": F}, F),
    ("1", "-2", {"A": F, "B": F, "C": R}, F),
    ("1", "-1", {"A": F, "B": F, "C": R}, R),
    # below -(children): the threshold is 0, so the Parallel succeeds after its first child
    ("-4", "1", {"A": R, "B": R, "C": R}, S),
])
def test_parallel_negative_thresholds(success_count, failure_count, answers, expected):
    script = Script()
    for name, status in answers.items():
        script.set(name, status)
    assert run("Parallel", script, 1, success_count=success_count, failure_count=failure_count)[0][0] is expected


def test_parallel_counts_skipped_children_as_successes_only_with_a_negative_success_count():
    script = Script()
    script.set("A", K)
    assert run("Parallel", script, 1, success_count="-1")[0][0] is S
    script = Script()
    script.set("A", K)
    assert run("Parallel", script, 1, success_count="3")[0][0] is R
    script = Script()
    for name in "ABC":
        script.set(name, K)
    assert run("Parallel", script, 1, success_count="3")[0][0] is K


@pytest.mark.parametrize("attrs", [{"success_count": "4"}, {"failure_count": "4"}, {"failure_count": "5"}])
def test_parallel_thresholds_beyond_the_children_are_refused_at_load(attrs):
    script = Script()
    with pytest.raises(TreeLoadError, match="can never"):
        run("Parallel", script, 1, **attrs)


def test_parallel_all_waits_for_every_child_and_counts_failures():
    script = Script()
    script.set("B", R, F)
    assert run("ParallelAll", script, 2, max_failures="1") == [(R, ["A", "B", "C"]), (F, ["B"])]
    script = Script()
    script.set("B", R, F)
    assert run("ParallelAll", script, 2, max_failures="2") == [(R, ["A", "B", "C"]), (S, ["B"])]
    script = Script()
    for name in "ABC":
        script.set(name, F)
    assert run("ParallelAll", script, 1, max_failures="-1")[0][0] is F  # -1: all three


# ---------------------------------------------------------------- IfThenElse / WhileDoElse

def test_if_then_else_does_not_recheck_the_condition_while_a_branch_runs():
    script = Script()
    script.set("C", S, F)
    script.set("A", R, S)
    children = '<Cond name="C"/><Act name="A"/><Act name="B"/>'
    assert run("IfThenElse", script, 2, children) == [(R, ["C", "A"]), (S, ["A"])]
    script = Script()
    script.set("C", F)
    assert run("IfThenElse", script, 1, children) == [(S, ["C", "B"])]
    script = Script()
    script.set("C", F)
    assert run("IfThenElse", script, 1, '<Cond name="C"/><Act name="A"/>') == [(F, ["C"])]


def test_while_do_else_rechecks_the_condition_and_halts_the_other_branch():
    script = Script()
    script.set("C", S, F, S)
    script.set("A", R)
    script.set("B", R)
    children = '<Cond name="C"/><Act name="A"/><Act name="B"/>'
    assert run("WhileDoElse", script, 3, children) == [(R, ["C", "A"]), (R, ["C", "B"]), (R, ["C", "A"])]
    assert script.halts == {"A": 1, "B": 1}
    script = Script()
    script.set("C", F)
    assert run("WhileDoElse", script, 1, '<Cond name="C"/><Act name="A"/>') == [(F, ["C"])]


@pytest.mark.parametrize("control, children", [("IfThenElse", 1), ("IfThenElse", 4), ("WhileDoElse", 4)])
def test_if_then_else_and_while_do_else_need_two_or_three_children(control, children):
    body = "".join(f'<Act name="X{i}"/>' for i in range(children))
    with pytest.raises(TreeLoadError, match="2 to 3 children"):
        tree_of(f"<{control}>{body}</{control}>", Script())


# ---------------------------------------------------------------- Switch

def switch_tree(script: Script, cases: str = 'case_1="1" case_2="2" case_3="red"'):
    factory = factory_with(script)
    factory.register_scripting_enum("RED", 7)
    body = ('<ReactiveSequence><Cond name="gate"/>'
            f'<Switch3 variable="{{mode}}" {cases}>'
            '<Act name="A"/><Act name="B"/><Act name="C"/><Act name="D"/></Switch3></ReactiveSequence>')
    return tree_of(body, script, factory=factory)


@pytest.mark.parametrize("mode, chosen", [("1", "A"), ("2", "B"), ("2.0", "B"), (" 2", "D"), ("red", "C"),
                                          ("0x2", "D"), ("3", "D"), ("", "D")])
def test_switch_picks_the_first_matching_case_or_the_default(mode, chosen):
    script = Script()
    tree = switch_tree(script)
    tree.root_blackboard().set("mode", mode)
    assert trace(tree, script, 1) == [(S, ["gate", chosen])]


def test_switch_matches_integers_enum_names_and_reals():
    script = Script()
    tree = switch_tree(script, 'case_1="RED" case_2="2.5" case_3="x"')
    tree.root_blackboard().set("mode", "7")
    assert trace(tree, script, 1) == [(S, ["gate", "A"])]
    tree.root_blackboard().set("mode", "2.50000001")
    assert trace(tree, script, 1) == [(S, ["gate", "B"])]


def test_switch_without_the_variable_entry_takes_the_default():
    script = Script()
    tree = switch_tree(script)
    assert trace(tree, script, 1) == [(S, ["gate", "D"])]


def test_switch_halts_the_running_case_when_the_variable_changes():
    script = Script()
    script.set("A", R)
    script.set("B", R)
    tree = switch_tree(script)
    tree.root_blackboard().set("mode", "1")
    assert trace(tree, script, 1) == [(R, ["gate", "A"])]
    tree.root_blackboard().set("mode", "2")
    assert trace(tree, script, 1) == [(R, ["gate", "B"])]
    assert script.halts["A"] == 1


@pytest.mark.parametrize("switch, children", [("Switch2", 2), ("Switch2", 4), ("Switch6", 6)])
def test_switch_needs_one_child_per_case_plus_the_default(switch, children):
    body = "".join(f'<Act name="X{i}"/>' for i in range(children))
    with pytest.raises(TreeLoadError, match="children"):
        tree_of(f'<{switch} variable="x">{body}</{switch}>', Script())


def test_every_switch_size_is_registered():
    script = Script()
    for cases in range(2, 7):
        body = "".join(f'<Act name="X{i}"/>' for i in range(cases + 1))
        attrs = " ".join(f'case_{i}="{i}"' for i in range(1, cases + 1))
        tree = tree_of(f'<Switch{cases} variable="{cases}" {attrs}>{body}</Switch{cases}>', script)
        script.log.clear()
        assert tree.tick_once() is NodeStatus.SUCCESS
        assert script.log == [f"X{cases - 1}"]
