"""Asking the operator (MoveIt Pro's Request Teleoperation and WaitForUserTrajectoryApproval),
without ROS: a behavior opens a prompt and waits RUNNING until the operator answers Continue
(SUCCESS) or Fail (FAILURE); a halt withdraws the prompt. Whoever shows prompts (the objective
server's topic and service, a test) subscribes to the open prompt and answers it.
"""
from __future__ import annotations

import itertools
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..action_node import StatefulActionNode
from ..basic_types import FAILURE, RUNNING, SUCCESS, NodeStatus
from ..ports import ANY, BOOL, INT, STRING, input_port, output_port

if TYPE_CHECKING:
    from .context import BehaviorContext


@dataclass
class OperatorPrompt:
    prompt_id: int
    text: str
    node_path: str
    objective_name: str
    kind: str  # "teleoperation" or "approval"
    decision: bool | None = None
    active: bool = True


PromptListener = Callable[[OperatorPrompt], None]


class OperatorPrompts:
    """The open prompt (at most one: one objective runs at a time) and who listens to it."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._ids = itertools.count(1)
        self._current: OperatorPrompt | None = None
        self._wakers: dict[int, Callable[[], None]] = {}
        self._listeners: list[PromptListener] = []

    def subscribe(self, listener: PromptListener) -> None:
        """``listener(prompt)`` on every prompt opened or withdrawn (``prompt.active``)."""
        with self._lock:
            self._listeners.append(listener)

    def _notify(self, prompt: OperatorPrompt) -> None:
        for listener in list(self._listeners):
            listener(prompt)

    def open(self, text: str, node_path: str, objective_name: str, kind: str,
             on_answer: Callable[[], None]) -> OperatorPrompt:
        with self._lock:
            previous = self._current
            prompt = OperatorPrompt(next(self._ids), text, node_path, objective_name, kind)
            self._current = prompt
            self._wakers[prompt.prompt_id] = on_answer
        if previous is not None and previous.active:
            previous.active = False
        self._notify(prompt)
        return prompt

    def close(self, prompt: OperatorPrompt) -> None:
        """Withdraw a prompt (answered, or its behavior halted)."""
        with self._lock:
            self._wakers.pop(prompt.prompt_id, None)
            was_active, prompt.active = prompt.active, False
            if self._current is prompt:
                self._current = None
        if was_active:
            self._notify(prompt)

    def current(self) -> OperatorPrompt | None:
        with self._lock:
            return self._current

    def answer(self, prompt_id: int, proceed: bool) -> tuple[bool, str]:
        """The operator's word on prompt ``prompt_id`` (0: the open one): (accepted, why not)."""
        with self._lock:
            prompt = self._current
            if prompt is None or not prompt.active:
                return False, "no operator prompt is open"
            if prompt_id and prompt_id != prompt.prompt_id:
                return False, f"prompt {prompt_id} is not open (the open prompt is {prompt.prompt_id})"
            if prompt.decision is not None:
                return False, f"prompt {prompt.prompt_id} was already answered"
            prompt.decision = bool(proceed)
            waker = self._wakers.get(prompt.prompt_id)
        if waker is not None:
            waker()
        return True, "continue" if proceed else "fail"


class _PromptBehavior(StatefulActionNode):
    KIND = "teleoperation"

    def __init__(self, name: str, config: Any, context: BehaviorContext):
        super().__init__(name, config)
        self.context = context
        self._prompt: OperatorPrompt | None = None

    def prompt_text(self) -> str:  # pragma: no cover - abstract
        raise NotImplementedError

    def on_start(self) -> NodeStatus:
        text = self.prompt_text()
        self.context.log("info", f"{self.config.path or self.name}: waiting for the operator: {text or '(no prompt)'}")
        self._prompt = self.context.operator.open(text, self.config.path or self.name,
                                                  self.context.objective_name, self.KIND, self.emit_wake_up_signal)
        return RUNNING

    def on_running(self) -> NodeStatus:
        prompt = self._prompt
        if prompt is None or prompt.decision is None:
            return RUNNING
        self.context.operator.close(prompt)
        self._prompt = None
        self.context.log("info", f"{self.config.path or self.name}: the operator answered "
                                 f"{'Continue' if prompt.decision else 'Fail'}")
        return SUCCESS if prompt.decision else FAILURE

    def on_halted(self) -> None:
        if self._prompt is not None:
            self.context.operator.close(self._prompt)
            self._prompt = None


class RequestTeleoperation(_PromptBehavior):
    DESCRIPTION = ("Asks the operator to take over: the tree waits while they move the arm (to a waypoint or a "
                   "joint state, through the objective server's operator prompt or the browser viewer), then "
                   "SUCCESS on Continue, FAILURE on Fail.")

    @classmethod
    def provided_ports(cls):
        return (input_port("enable_user_interaction", BOOL, False, "show user_interaction_prompt to the operator"),
                input_port("user_interaction_prompt", STRING, "", "what the operator is asked to do"),
                input_port("initial_teleop_mode", INT, 3, "MoveIt Pro's TeleoperationMode the prompt opens in "
                           "(3: move to waypoint, the only mode until jogging exists)"))

    def prompt_text(self) -> str:
        if self.get_input("enable_user_interaction"):
            return self.get_input("user_interaction_prompt")
        return "Teleoperate the robot, then press Continue (or Fail)"


class WaitForUserTrajectoryApproval(_PromptBehavior):
    DESCRIPTION = "Shows a planned trajectory to the operator and waits: SUCCESS if approved, FAILURE if rejected."
    KIND = "approval"

    @classmethod
    def provided_ports(cls):
        return (input_port("trajectory", ANY, description="the planned trajectory to approve (shown to the operator)", required=False),
                input_port("user_interaction_prompt", STRING, "Approve the planned trajectory?",
                           "what the operator is asked"),
                output_port("approved", BOOL, description="the operator's answer"))

    def prompt_text(self) -> str:
        return self.get_input("user_interaction_prompt")

    def on_running(self) -> NodeStatus:
        prompt = self._prompt
        status = super().on_running()
        if status is not RUNNING and prompt is not None:
            self.set_output("approved", bool(prompt.decision))
        return status
