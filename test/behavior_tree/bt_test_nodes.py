"""Test doubles for the behavior-tree tests: BT.CPP-like nodes whose answers are scripted.

``Act`` and ``Cond`` nodes (told apart by their ``name``) return, tick after tick, the statuses
a test gave for their name (the last one repeats), and count their ticks and halts, like
BT.CPP's own test nodes (AsyncActionTest, ConditionTestNode). ``trace`` ticks a tree and
records, per tick, the root's status and which nodes were ticked.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

from mycobot_planning.behavior_tree import (
    FAILURE,
    RUNNING,
    SKIPPED,
    SUCCESS,
    BehaviorTreeFactory,
    ConditionNode,
    FakeClock,
    NodeStatus,
)
from mycobot_planning.behavior_tree.action_node import ActionNodeBase

S, F, R, K = SUCCESS, FAILURE, RUNNING, SKIPPED


@dataclass
class Script:
    """What each scripted node answers, and what happened to it."""

    answers: dict[str, list[NodeStatus]] = field(default_factory=dict)
    ticks: Counter = field(default_factory=Counter)
    halts: Counter = field(default_factory=Counter)
    log: list[str] = field(default_factory=list)

    def next(self, name: str) -> NodeStatus:
        self.ticks[name] += 1
        self.log.append(name)
        queue = self.answers.setdefault(name, [SUCCESS])
        return queue.pop(0) if len(queue) > 1 else queue[0]

    def set(self, name: str, *statuses: NodeStatus) -> None:
        self.answers[name] = list(statuses)


class _Scripted:
    """A node answering what the script says for its name."""

    def __init__(self, name, config, script: Script):
        super().__init__(name, config)
        self.script = script

    def tick(self) -> NodeStatus:
        return self.script.next(self.name)


class ScriptedAction(_Scripted, ActionNodeBase):
    """An action answering what the script says; RUNNING allowed; records halts."""

    def halt(self) -> None:
        self.script.halts[self.name] += 1
        self.reset_status()


class ScriptedCondition(_Scripted, ConditionNode):
    """A condition answering what the script says."""


def factory_with(script: Script) -> BehaviorTreeFactory:
    factory = BehaviorTreeFactory()
    factory.register_node_type(ScriptedAction, "Act", script)
    factory.register_node_type(ScriptedCondition, "Cond", script)
    return factory


def tree_of(body: str, script: Script, clock=None, factory: BehaviorTreeFactory | None = None):
    """A tree whose main BehaviorTree is ``body`` (one node, XML)."""
    xml = f'<root BTCPP_format="4"><BehaviorTree ID="Main">{body}</BehaviorTree></root>'
    return (factory or factory_with(script)).create_tree_from_text(xml, clock=clock)


def trace(tree, script: Script, ticks: int, clock: FakeClock | None = None, step: float = 0.0,
          exactly_once: bool = False) -> list[tuple[NodeStatus, list[str]]]:
    """Tick ``ticks`` times; per tick the root's status and the scripted nodes ticked (in order).
    With a clock, time advances by ``step`` before each tick after the first."""
    out = []
    for index in range(ticks):
        if clock is not None and index:
            clock.advance(step)
        script.log.clear()
        status = tree.tick_exactly_once() if exactly_once else tree.tick_once()
        out.append((status, list(script.log)))
    return out
