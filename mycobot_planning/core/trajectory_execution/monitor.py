"""Watching one execution: controller states and joint states until success, failure, stop or timeout."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

from interfaces_py.msgs import JointTrajectory, MoveItErrorCode

from ..moveit_error_code import ErrorCodeResult
from .controller_manager import (
    TERMINAL_FAILURE,
    TERMINAL_INTERRUPTED,
    TERMINAL_SUCCESS,
    ControllerInfo,
    ControllerState,
)
from .settings import ExecutionSettings
from .settings import error_code as _code
from .trajectory_preparation import trajectory_duration


@dataclass
class ExecutionResult(ErrorCodeResult):
    """The outcome of one trajectory execution."""

    error_code: MoveItErrorCode
    controllers: list[str] = field(default_factory=list)
    duration: float = 0.0  # measured, s
    expected_duration: float = 0.0
    allowed_duration: float | None = None
    #: ms from the scene change that invalidated the path (its arrival) to the stop command sent
    reaction_ms: float | None = None

    def to_dict(self) -> dict[str, Any]:
        return {
            "error_code": self.error_code.to_dict(),
            "controllers": list(self.controllers),
            "duration": self.duration,
            "expected_duration": self.expected_duration,
            "allowed_duration": self.allowed_duration,
            "reaction_ms": self.reaction_ms,
        }


class ExecutionMonitor:
    """Decides the outcome of a running execution from controller states, joint states and time.

    Pure bookkeeping, no threads and no clock of its own: the caller feeds it and asks ``poll``.
    A controller state counts for this execution only if it names the goal id sent with the
    command (the command's frame_id); for commands sent without an id, only if its goal_id differs
    from the one the controller reported before sending. Either way a stale "succeeded" from the
    previous goal is never mistaken for this one's.
    """

    def __init__(
        self,
        commands: Sequence[tuple[ControllerInfo, JointTrajectory]],
        settings: ExecutionSettings,
        started: float,
        baseline: Mapping[str, ControllerState | None],
    ) -> None:
        self.commands = list(commands)
        self.settings = settings
        self.started = started
        self.duration = max((trajectory_duration(t) for _, t in commands), default=0.0)
        self.deadline = (
            started + settings.allowed_duration(self.duration) if settings.execution_duration_monitoring else math.inf
        )
        self._baseline = {name: (state.goal_id if state is not None else None) for name, state in baseline.items()}
        self._baseline_received = {name: (state.received if state is not None else -math.inf)
                                   for name, state in baseline.items()}
        self._expected = {c.name: t.frame_id for c, t in commands}
        self._latest: dict[str, ControllerState] = {}
        self._heard: dict[str, float] = {}  # when each controller last reported anything
        self._succeeded: set[str] = set()
        self._stop_requested = False
        self._goal: dict[str, float] = {}
        for _, trajectory in commands:
            self._goal.update(zip(trajectory.joint_names, trajectory.points[-1].positions))

    @property
    def controller_names(self) -> list[str]:
        return [c.name for c, _ in self.commands]

    def expected_goal(self, controller: str) -> str | None:
        """The goal id the command to ``controller`` carries (None if sent without one)."""
        return self._expected.get(controller) or None

    def belongs_to_us(self, controller: str, state: ControllerState) -> bool:
        """Whether a state reports on the goal this execution sent."""
        expected = self._expected.get(controller)
        if expected:
            return state.goal_id == expected
        baseline = self._baseline.get(controller)
        if state.received < self._baseline_received.get(controller, -math.inf):
            return False
        if state.received <= self.started:
            return False
        if baseline is None:
            return True
        return state.goal_id != baseline

    def update(self, controller: str, state: ControllerState | None) -> None:
        if state is None or not self.belongs_to_us(controller, state):
            return
        self._latest[controller] = state
        if state.status == TERMINAL_SUCCESS:
            self._succeeded.add(controller)

    def heard(self, controller: str, received: float) -> None:
        """The controller reported (any state, any goal) at ``received``: it is alive."""
        self._heard[controller] = max(received, self._heard.get(controller, -math.inf))

    def request_stop(self) -> None:
        self._stop_requested = True

    def _lost(self, now: float, positions: Mapping[str, float] | None) -> MoveItErrorCode | None:
        """CONTROL_FAILED for a controller that stopped reporting while its goal runs: it is
        declared lost after ``joint_state_timeout`` of silence, not at the duration deadline."""
        timeout = self.settings.joint_state_timeout
        for name in self.controller_names:
            if name in self._succeeded:
                continue
            silence = now - max(self._heard.get(name, -math.inf), self.started)
            if silence > timeout:
                joints = ("and /joint_states stopped too" if positions is None
                          else "while /joint_states still arrive")
                return _code(MoveItErrorCode.CONTROL_FAILED,
                             f"controller '{name}' stopped reporting: no state for {silence:.2f} s (state timeout "
                             f"{timeout:g} s, the joint_state_timeout) {joints}; is its process still running?")
        return None

    def goal_deviation(self, positions: Mapping[str, float]) -> tuple[str, float] | None:
        """(joint, deviation) of the joint farthest from the last point; None if a joint is unknown."""
        worst = ("", 0.0)
        for name, target in self._goal.items():
            if name not in positions:
                return None
            deviation = abs(float(positions[name]) - target)
            if deviation > worst[1]:
                worst = (name, deviation)
        return worst

    def poll(self, now: float, positions: Mapping[str, float] | None) -> MoveItErrorCode | None:
        """The outcome once it is decided, else None. ``positions``: current joint states (None if stale)."""
        if self._stop_requested:
            return _code(MoveItErrorCode.PREEMPTED, "execution stopped on request")
        for name in self.controller_names:
            state = self._latest.get(name)
            if state is None:
                continue
            if state.status in TERMINAL_FAILURE:
                detail = f": {state.message}" if state.message else ""
                return _code(MoveItErrorCode.CONTROL_FAILED, f"controller '{name}' {state.status} the trajectory{detail}")
            if state.status in TERMINAL_INTERRUPTED:
                detail = f": {state.message}" if state.message else ""
                return _code(MoveItErrorCode.CONTROL_FAILED,
                             f"controller '{name}' was {state.status} by something else than this execution{detail}")
        lost = self._lost(now, positions)
        if lost is not None:
            return lost
        all_done = len(self._succeeded) == len(self.commands)
        if all_done:
            tolerance = self.settings.goal_tolerance
            if tolerance <= 0:
                return _code(MoveItErrorCode.SUCCESS, self._success_message(now))
            deviation = self.goal_deviation(positions) if positions is not None else None
            if deviation is not None and deviation[1] <= tolerance:
                return _code(MoveItErrorCode.SUCCESS, self._success_message(now))
        if now > self.deadline:
            return self._timeout(now, positions, all_done)
        return None

    def _success_message(self, now: float) -> str:
        return (f"trajectory of {self.duration:.3f} s executed in {now - self.started:.3f} s by "
                f"{', '.join(self.controller_names)}")

    def _timeout(self, now: float, positions: Mapping[str, float] | None, all_done: bool) -> MoveItErrorCode:
        s = self.settings
        limit = (f"{self.deadline - self.started:.3f} s (duration {self.duration:.3f} s x "
                 f"{s.allowed_execution_duration_scaling} + {s.allowed_goal_duration_margin} s)")
        if all_done:
            if positions is None:
                return _code(MoveItErrorCode.CONTROL_FAILED,
                             f"controllers reported success but no current joint states arrived within {limit}")
            name, deviation = self.goal_deviation(positions) or ("?", math.nan)
            return _code(MoveItErrorCode.CONTROL_FAILED,
                         f"controllers reported success but joint '{name}' is still {deviation:.4f} from the goal "
                         f"(goal_tolerance {s.goal_tolerance}) after {limit}")
        pending = []
        for name in self.controller_names:
            if name in self._succeeded:
                continue
            state = self._latest.get(name)
            if state is None:
                pending.append(f"'{name}' never reported this goal")
            else:
                detail = f" ({state.message})" if state.message else ""
                pending.append(f"'{name}' is {state.status}{detail}")
        return _code(MoveItErrorCode.TIMED_OUT, f"execution exceeded the allowed {limit}: " + "; ".join(pending))

