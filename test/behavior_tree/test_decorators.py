"""Decorator nodes, tick by tick, against BehaviorTree.CPP 4.6-4.8 (src/decorators); time-based
ones on a FakeClock, so no test sleeps."""
from __future__ import annotations

import pytest
from bt_test_nodes import F, K, R, S, Script, factory_with, trace, tree_of

from mycobot_planning.behavior_tree import INT, FakeClock, NodeStatus, input_port

A = '<Act name="A"/>'


def run(body: str, script: Script, ticks: int, **kwargs):
    return trace(tree_of(body, script), script, ticks, **kwargs)


@pytest.mark.parametrize("decorator, child, expected", [
    ("Inverter", S, F), ("Inverter", F, S), ("Inverter", R, R), ("Inverter", K, K),
    ("ForceSuccess", F, S), ("ForceSuccess", S, S), ("ForceSuccess", R, R),
    ("ForceFailure", S, F), ("ForceFailure", F, F), ("ForceFailure", R, R),
])
def test_status_changing_decorators(decorator, child, expected):
    script = Script()
    script.set("A", child)
    assert run(f"<{decorator}>{A}</{decorator}>", script, 1)[0][0] is expected


# ---------------------------------------------------------------- Repeat / RetryUntilSuccessful

def test_repeat_counts_successes_within_one_tick_once():
    script = Script()
    assert run(f'<Repeat num_cycles="3">{A}</Repeat>', script, 1) == [(S, ["A", "A", "A"])]
    # tick_exactly_once sees the yield after each success that came at once
    script = Script()
    assert run(f'<Repeat num_cycles="3">{A}</Repeat>', script, 3, exactly_once=True) == [
        (R, ["A"]), (R, ["A"]), (S, ["A"])]


def test_repeat_with_a_running_child_and_a_failure():
    script = Script()
    script.set("A", R, S)
    assert run(f'<Repeat num_cycles="3">{A}</Repeat>', script, 2) == [(R, ["A"]), (S, ["A", "A", "A"])]
    script = Script()
    script.set("A", S, F, S)
    # a failure ends the loop and resets the count: the next run needs 3 successes again
    assert run(f'<Repeat num_cycles="3">{A}</Repeat>', script, 2) == [(F, ["A", "A"]), (S, ["A", "A", "A"])]


def test_repeat_zero_cycles_succeeds_without_ticking_and_minus_one_is_forever():
    script = Script()
    assert run(f'<Repeat num_cycles="0">{A}</Repeat>', script, 1) == [(S, [])]
    script = Script()
    result = run(f'<Repeat num_cycles="-1">{A}</Repeat>', script, 50, exactly_once=True)
    assert {status for status, _ in result} == {R} and script.ticks["A"] == 50


def test_retry_counts_attempts():
    script = Script()
    script.set("A", F, F, S)
    assert run(f'<RetryUntilSuccessful num_attempts="3">{A}</RetryUntilSuccessful>', script, 1) == [
        (S, ["A", "A", "A"])]
    script = Script()
    script.set("A", F)
    assert run(f'<RetryUntilSuccessful num_attempts="3">{A}</RetryUntilSuccessful>', script, 1) == [
        (F, ["A", "A", "A"])]
    script = Script()
    script.set("A", F)
    assert run(f'<RetryUntilSuccessful num_attempts="3">{A}</RetryUntilSuccessful>', script, 3,
               exactly_once=True) == [(R, ["A"]), (R, ["A"]), (F, ["A"])]


def test_retry_with_a_running_child_and_forever():
    script = Script()
    script.set("A", R, F, S)
    assert run(f'<RetryUntilSuccessful num_attempts="2">{A}</RetryUntilSuccessful>', script, 2) == [
        (R, ["A"]), (S, ["A", "A"])]
    script = Script()
    script.set("A", F)
    result = run(f'<RetryUntilSuccessful num_attempts="-1">{A}</RetryUntilSuccessful>', script, 20,
                 exactly_once=True)
    assert {status for status, _ in result} == {R}


def test_keep_running_until_failure():
    script = Script()
    script.set("A", S, S, F)
    assert run(f"<KeepRunningUntilFailure>{A}</KeepRunningUntilFailure>", script, 3) == [
        (R, ["A"]), (R, ["A"]), (F, ["A"])]


# ---------------------------------------------------------------- Delay / Timeout / Sleep

def test_delay_ticks_the_child_when_the_time_is_up():
    script, clock = Script(), FakeClock()
    tree = tree_of(f'<Delay delay_msec="100">{A}</Delay>', script, clock)
    assert trace(tree, script, 3, clock=clock, step=0.05) == [(R, []), (R, []), (S, ["A"])]
    # a new execution waits again
    assert trace(tree, script, 2, clock=clock, step=0.05) == [(R, []), (R, [])]


def test_delay_passes_a_running_child_through_and_restarts_after_a_halt():
    script, clock = Script(), FakeClock()
    script.set("A", R, S)
    tree = tree_of(f'<Delay delay_msec="10">{A}</Delay>', script, clock)
    assert trace(tree, script, 3, clock=clock, step=0.01, exactly_once=True) == [(R, []), (R, ["A"]), (S, ["A"])]
    tree.tick_once()
    tree.halt_tree()
    clock.advance(1.0)
    assert trace(tree, script, 1) == [(R, [])]  # the delay starts over


def test_tick_while_running_wakes_up_at_the_delay_deadline():
    script, clock = Script(), FakeClock()
    tree = tree_of(f'<Delay delay_msec="250">{A}</Delay>', script, clock)
    assert tree.tick_while_running(sleep_time=10.0) is S
    assert clock.now() == pytest.approx(0.25)


def test_timeout_halts_a_child_still_running_at_the_deadline():
    script, clock = Script(), FakeClock()
    script.set("A", R)
    tree = tree_of(f'<Timeout msec="100">{A}</Timeout>', script, clock)
    assert trace(tree, script, 3, clock=clock, step=0.05) == [(R, ["A"]), (R, ["A"]), (F, [])]
    assert script.halts["A"] == 1
    assert tree.root_node.child.status is NodeStatus.IDLE


def test_timeout_passes_the_status_of_a_child_that_completes_in_time():
    script, clock = Script(), FakeClock()
    script.set("A", R, S)
    tree = tree_of(f'<Timeout msec="100">{A}</Timeout>', script, clock)
    assert trace(tree, script, 2, clock=clock, step=0.099) == [(R, ["A"]), (S, ["A"])]
    assert script.halts["A"] == 0


def test_timeout_zero_means_no_limit_and_the_tick_loop_wakes_at_the_deadline():
    script, clock = Script(), FakeClock()
    script.set("A", R)
    tree = tree_of(f'<Timeout msec="0">{A}</Timeout>', script, clock)
    assert trace(tree, script, 3, clock=clock, step=1000.0) == [(R, ["A"])] * 3
    script, clock = Script(), FakeClock()
    script.set("A", R)
    tree = tree_of(f'<Timeout msec="300">{A}</Timeout>', script, clock)
    assert tree.tick_while_running(sleep_time=0.1) is F
    assert clock.now() == pytest.approx(0.3)


def test_sleep_runs_for_its_time():
    script, clock = Script(), FakeClock()
    tree = tree_of('<Sequence><Sleep msec="30"/><Act name="A"/></Sequence>', script, clock)
    assert trace(tree, script, 3, clock=clock, step=0.015) == [(R, []), (R, []), (S, ["A"])]
    tree = tree_of('<Sleep msec="0"/>', script, clock)
    assert tree.tick_exactly_once() is S


# ---------------------------------------------------------------- RunOnce / Precondition

def test_run_once_then_skips():
    script = Script()
    body = f'<Sequence><RunOnce>{A}</RunOnce><Act name="B"/></Sequence>'
    assert run(body, script, 2) == [(S, ["A", "B"]), (S, ["B"])]


def test_run_once_without_skip_repeats_the_first_status_and_waits_for_a_running_child():
    script = Script()
    script.set("A", R, F)
    body = f'<RunOnce then_skip="false">{A}</RunOnce>'
    assert run(body, script, 4) == [(R, ["A"]), (F, ["A"]), (F, []), (F, [])]


def precondition_tree(script: Script, **attrs: str):
    extra = "".join(f' {k}="{v}"' for k, v in attrs.items())
    return tree_of(f'<Precondition if="x &gt; 1"{extra}>{A}</Precondition>', script)


@pytest.mark.parametrize("x, otherwise, expected, ticked", [
    (2, None, S, ["A"]), (0, None, F, []), (0, "SKIPPED", K, []), (0, "SUCCESS", S, []), (0, "RUNNING", R, [])])
def test_precondition(x, otherwise, expected, ticked):
    script = Script()
    tree = precondition_tree(script, **({"else": otherwise} if otherwise else {}))
    tree.root_blackboard().set("x", x)
    assert trace(tree, script, 1) == [(expected, ticked)]


def test_precondition_is_not_evaluated_again_while_the_child_runs():
    script = Script()
    script.set("A", R, R, S)
    tree = precondition_tree(script)
    bb = tree.root_blackboard()
    bb.set("x", 5)
    assert trace(tree, script, 1) == [(R, ["A"])]
    bb.set("x", 0)
    assert trace(tree, script, 3) == [(R, ["A"]), (S, ["A"]), (F, [])]


# ---------------------------------------------------------------- Loop nodes

def loop_factory(script: Script, record: list):
    factory = factory_with(script)
    factory.register_simple_action("Record", lambda node: record.append(node.get_input("v")) or S,
                                   [input_port("v")])
    return factory


@pytest.mark.parametrize("loop, queue, values", [
    ("LoopInt", "1;2;3", [1, 2, 3]), ("LoopDouble", "0.5;1.5", [0.5, 1.5]),
    ("LoopBool", "true;0;1", [True, False, True]), ("LoopString", "a;b c;", ["a", "b c"])])
def test_loops_pop_one_element_per_tick(loop, queue, values):
    script, record = Script(), []
    body = f'<{loop} queue="{queue}" value="{{v}}"><Record v="{{v}}"/></{loop}>'
    tree = tree_of(body, script, factory=loop_factory(script, record))
    statuses = [tree.tick_exactly_once() for _ in range(len(values) + 1)]
    assert statuses == [R] * len(values) + [S]
    assert record == values
    assert tree.tick_while_running() is S and record == values * 2  # a literal queue starts over


def test_loop_consumes_a_queue_in_the_blackboard_and_answers_if_empty():
    script, record = Script(), []
    body = ('<LoopString queue="{names}" value="{v}" if_empty="{empty}"><Record v="{v}"/></LoopString>')
    tree = tree_of(body, script, factory=loop_factory(script, record))
    bb = tree.root_blackboard()
    bb.set("empty", "SUCCESS")
    bb.set("names", ["left", "right"])
    assert tree.tick_while_running() is S and record == ["left", "right"]
    assert list(bb.get("names")) == []
    bb.set("empty", "SKIPPED")
    assert tree.tick_while_running() is K  # the queue was consumed: if_empty at once
    bb.set("names", "a;b")  # a string is parsed into the queue
    bb.set("empty", "FAILURE")
    assert [tree.tick_exactly_once() for _ in range(3)] == [R, R, F]  # if_empty also ends a loop
    assert record[-2:] == ["a", "b"]


def test_loop_fails_when_the_child_fails():
    script = Script()
    script.set("A", S, F)
    assert run(f'<LoopInt queue="1;2;3">{A}</LoopInt>', script, 2) == [(R, ["A"]), (F, ["A"])]


# ---------------------------------------------------------------- entry updates

def test_skip_unless_updated_and_was_entry_updated():
    script = Script()
    tree = tree_of('<Sequence><SkipUnlessUpdated entry="{x}"><Act name="A"/></SkipUnlessUpdated>'
                   '<WasEntryUpdated entry="x"/></Sequence>', script)
    bb = tree.root_blackboard()
    assert trace(tree, script, 1) == [(F, [])]  # never written: A skipped, WasEntryUpdated fails
    bb.set("x", 1)
    assert trace(tree, script, 1) == [(S, ["A"])]
    assert trace(tree, script, 1) == [(F, [])]


def test_wait_value_update_runs_until_the_entry_is_written():
    script = Script()
    tree = tree_of('<WaitValueUpdate entry="{x}"><Act name="A"/></WaitValueUpdate>', script)
    tree.root_blackboard().create_entry("x", INT)
    assert trace(tree, script, 2) == [(R, []), (R, [])]
    tree.root_blackboard().set("x", 3)
    assert trace(tree, script, 1) == [(S, ["A"])]
