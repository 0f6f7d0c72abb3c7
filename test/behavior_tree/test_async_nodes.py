"""Asynchronous nodes: StatefulActionNode (on_start/on_running/on_halted) and ThreadedAction,
how they are halted, how they wake the tree, and errors from them."""
from __future__ import annotations

import threading
from concurrent.futures import Future

import pytest

from mycobot_planning.behavior_tree import (
    FAILURE,
    IDLE,
    RUNNING,
    SUCCESS,
    BehaviorTreeFactory,
    BehaviorTreeRuntimeError,
    FakeClock,
    NodeStatus,
    StatefulActionNode,
    ThreadedAction,
)


class Journal:
    def __init__(self):
        self.events: list[str] = []
        self.futures: list[Future] = []


class Motion(StatefulActionNode):
    """Stands for a behavior waiting on a ROS action: on_start sends a goal (a Future), on_running
    polls it, on_halted cancels it. The future's completion wakes the tree up."""

    def __init__(self, name, config, journal: Journal):
        super().__init__(name, config)
        self.journal = journal
        self.future: Future | None = None

    def on_start(self):
        self.journal.events.append(f"{self.name}:start")
        self.future = Future()
        self.future.add_done_callback(lambda _: self.emit_wake_up_signal())
        self.journal.futures.append(self.future)
        return RUNNING

    def on_running(self):
        self.journal.events.append(f"{self.name}:running")
        if not self.future.done():
            return RUNNING
        return SUCCESS if self.future.result() else FAILURE

    def on_halted(self):
        self.journal.events.append(f"{self.name}:halted")
        self.future.cancel()


def factory(journal: Journal) -> BehaviorTreeFactory:
    f = BehaviorTreeFactory()
    f.register_node_type(Motion, "Motion", journal)
    return f


def tree_of(body: str, journal: Journal, clock=None):
    return factory(journal).create_tree_from_text(
        f'<root BTCPP_format="4"><BehaviorTree ID="M">{body}</BehaviorTree></root>', clock=clock)


def test_stateful_action_lifecycle():
    journal = Journal()
    tree = tree_of('<Motion name="move"/>', journal)
    assert tree.tick_once() is RUNNING and tree.tick_once() is RUNNING
    journal.futures[0].set_result(True)
    assert tree.tick_once() is SUCCESS
    assert journal.events == ["move:start", "move:running", "move:running"]
    assert tree.root_node.status is IDLE  # a completed root is reset: the tree can run again
    assert tree.tick_once() is RUNNING and journal.events[-1] == "move:start"


def test_a_completed_future_wakes_the_tree_up():
    journal = Journal()
    tree = tree_of('<Motion name="move"/>', journal)
    assert tree.tick_once() is RUNNING
    threading.Thread(target=journal.futures[0].set_result, args=(True,)).start()
    assert tree.sleep(60.0) is True  # returns at the wake-up, not after 60 s
    assert tree.tick_once() is SUCCESS


@pytest.mark.parametrize("body, halt", [
    ('<Timeout msec="100"><Motion name="move"/></Timeout>', "timeout"),
    ('<ReactiveSequence><ScriptCondition code="ok"/><Motion name="move"/></ReactiveSequence>', "condition"),
    ('<Motion name="move"/>', "halt_tree"),
])
def test_a_running_stateful_action_is_halted_cleanly(body, halt):
    journal, clock = Journal(), FakeClock()
    tree = tree_of(body, journal, clock)
    tree.root_blackboard().set("ok", 1)
    assert tree.tick_once() is RUNNING
    if halt == "timeout":
        clock.advance(0.1)
        assert tree.tick_once() is FAILURE
    elif halt == "condition":
        tree.root_blackboard().set("ok", 0)
        assert tree.tick_once() is FAILURE
    else:
        tree.halt_tree()
    assert journal.events == ["move:start", "move:halted"]
    assert journal.futures[0].cancelled()
    assert all(node.status is IDLE for node in tree.nodes())


def test_a_completed_action_is_not_halted():
    journal = Journal()
    tree = tree_of('<Sequence><Motion name="a"/><Motion name="b"/></Sequence>', journal)
    tree.tick_once()
    journal.futures[0].set_result(True)
    tree.tick_once()
    tree.halt_tree()
    assert journal.events == ["a:start", "a:running", "b:start", "b:halted"]


class Worker(ThreadedAction):
    """Blocking code in a thread: waits for ``go`` (or a halt), then answers ``answer``."""

    def __init__(self, name, config, control: dict):
        super().__init__(name, config)
        self.control = control

    def tick(self):
        control = self.control
        control["thread"] = threading.current_thread().name
        control["started"].set()
        while not control["go"].wait(0.005):
            if self.is_halt_requested():
                control["halted"] = True
                return FAILURE
        if control.get("raise"):
            raise ValueError("the driver said no")
        return control.get("answer", SUCCESS)


def worker_tree(control: dict):
    f = BehaviorTreeFactory()
    f.register_node_type(Worker, "Worker", control)
    return f.create_tree_from_text('<root BTCPP_format="4"><BehaviorTree ID="M"><Sequence>'
                                   '<Worker name="work"/><Script code="after := 1"/></Sequence></BehaviorTree></root>')


def control() -> dict:
    return {"go": threading.Event(), "started": threading.Event()}


def test_threaded_action_runs_in_its_own_thread_and_wakes_the_tree():
    c = control()
    tree = worker_tree(c)
    assert tree.tick_once() is RUNNING
    assert c["started"].wait(10)
    assert c["thread"] == "bt:work" and c["thread"] != threading.current_thread().name
    c["go"].set()
    assert tree.sleep(60.0) is True  # the thread's end wakes the tree up
    assert tree.tick_once() is SUCCESS and tree.root_blackboard().get("after") == 1


def test_halting_a_threaded_action_waits_for_its_thread():
    c = control()
    tree = worker_tree(c)
    tree.tick_once()
    assert c["started"].wait(10)
    tree.halt_tree()
    assert c["halted"] is True  # halt returned only after the thread saw the request and ended
    assert all(node.status is IDLE for node in tree.nodes())


def test_an_exception_in_the_thread_is_raised_in_the_tree_naming_the_node():
    c = control()
    c["raise"] = True
    tree = worker_tree(c)
    tree.tick_once()
    c["go"].set()
    tree.sleep(60.0)
    with pytest.raises(BehaviorTreeRuntimeError) as caught:
        tree.tick_once()
    assert caught.value.node_path == "work" and "the driver said no" in str(caught.value)
    assert all(node.status is IDLE for node in tree.nodes())


def test_an_error_mid_tree_halts_the_running_siblings():
    journal = Journal()
    tree = tree_of('<Parallel><Motion name="arm"/><Sequence><Sleep msec="{missing}"/></Sequence></Parallel>',
                   journal)
    with pytest.raises(BehaviorTreeRuntimeError, match=r"remapped to \[missing\]"):
        tree.tick_once()
    assert journal.events == ["arm:start", "arm:halted"]
    assert all(node.status is NodeStatus.IDLE for node in tree.nodes())
