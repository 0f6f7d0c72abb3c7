"""MoveIt's TrajectoryExecutionManager without ROS: one execution at a time through a ControllerBus.

docs/trajectory_execution.md describes preparation, start tolerance, monitoring and task
solutions; the nodes implement the ControllerBus with rclpy.
"""
from __future__ import annotations

import math
import threading
import time
import uuid
from typing import Any, Callable, Iterable, Mapping, Sequence

from interfaces_py.msgs import JointTrajectory, MoveItErrorCode, PlanningScene as PlanningSceneMsg

from ..planning_scene.planning_scene import PlanningScene
from ..robot_model.robot_model import RobotModel
from .controller_manager import ControllerBus, ControllerInfo, check_controllers, select_controllers, split_trajectory
from .monitor import ExecutionMonitor, ExecutionResult
from .settings import ExecutionError, ExecutionSettings, error_code as _code
from .task_solution import SolutionResult, SolutionStep, check_solution, execute_solution
from .trajectory_preparation import check_start_state, prepare_trajectory, trajectory_duration

class TrajectoryExecutionManager:
    """Executes trajectories and task solutions, one at a time, through a ControllerBus.

    ``current_positions()`` returns the current joint positions by name (mimic joints may be
    included) and their age in seconds, or (None, None) when no joint state arrived yet.
    ``clock`` and ``wait`` are injectable so tests can run on simulated time; by default ``wait``
    sleeps until ``notify()`` is called (a controller state or joint state arrived) or the poll
    period passes.
    """

    def __init__(
        self,
        model: RobotModel,
        controllers: Sequence[ControllerInfo],
        bus: ControllerBus,
        current_positions: Callable[[], tuple[Mapping[str, float] | None, float | None]],
        settings: ExecutionSettings | None = None,
        clock: Callable[[], float] = time.monotonic,
        wait: Callable[[float], None] | None = None,
        poll_period: float = 0.01,
        log: Callable[[str, str], None] | None = None,
    ) -> None:
        check_controllers(model, controllers)
        self.model = model
        self.controllers = list(controllers)
        self.bus = bus
        self.settings = settings or ExecutionSettings()
        self._current_positions = current_positions
        self._clock = clock
        self._wake = threading.Event()
        self._wait = wait or self._default_wait
        self._poll_period = poll_period
        self._log = log or (lambda level, text: None)
        self._busy = threading.Lock()
        self._state_lock = threading.Lock()
        self._monitor: ExecutionMonitor | None = None
        self._stop_requested = False
        self._started_at: float | None = None
        self._description = ""
        self.last_result: dict[str, Any] | None = None
        # Goal ids "<prefix><n>/<controller>": unique per manager, readable in controller logs.
        self.goal_prefix = f"exec-{uuid.uuid4().hex[:6]}-"
        self._goal_counter = 0

    # ------------------------------------------------------------------ status
    @property
    def executing(self) -> bool:
        return self._busy.locked()

    def status(self) -> dict[str, Any]:
        with self._state_lock:
            running = self._started_at is not None
            return {
                "executing": running,
                "description": self._description if running else "",
                "elapsed": (self._clock() - self._started_at) if running else 0.0,
                "last_result": self.last_result,
            }

    def notify(self) -> None:
        """New feedback arrived: wake the monitoring loop."""
        self._wake.set()

    def _default_wait(self, timeout: float) -> None:
        self._wake.wait(timeout)
        self._wake.clear()

    def stop(self) -> bool:
        """Stop the running execution (reported PREEMPTED). False when nothing was executing."""
        with self._state_lock:
            if self._started_at is None:
                return False
            self._stop_requested = True
            if self._monitor is not None:
                self._monitor.request_stop()
        self._wake.set()
        return True

    def _fresh_positions(self) -> Mapping[str, float] | None:
        positions, age = self._current_positions()
        if positions is None or age is None or age > self.settings.joint_state_timeout:
            return None
        return positions

    def _require_positions(self, joints: Iterable[str]) -> Mapping[str, float]:
        positions, age = self._current_positions()
        if positions is None:
            raise ExecutionError(MoveItErrorCode.ROBOT_STATE_STALE,
                                 "no joint state received on /joint_states yet: are the controllers running?")
        if age is None or age > self.settings.joint_state_timeout:
            raise ExecutionError(
                MoveItErrorCode.ROBOT_STATE_STALE,
                f"the last joint state is {age:.2f} s old (joint_state_timeout {self.settings.joint_state_timeout} s): "
                "is the joint state broadcaster running?",
            )
        missing = [j for j in joints if j not in positions]
        if missing:
            raise ExecutionError(MoveItErrorCode.ROBOT_STATE_STALE, f"/joint_states lacks joints {missing}")
        return positions

    # ------------------------------------------------------------------ single trajectories
    def _begin(self, description: str) -> MoveItErrorCode | None:
        if not self._busy.acquire(blocking=False):
            with self._state_lock:
                what, since = self._description, (self._clock() - self._started_at) if self._started_at else 0.0
            return _code(MoveItErrorCode.FAILURE,
                         f"refused: another execution ({what}) is in progress for {since:.2f} s; "
                         "stop it first or wait for it to finish")
        with self._state_lock:
            self._started_at = self._clock()
            self._description = description
            self._stop_requested = False
            self._monitor = None
        return None

    def _end(self, result: dict[str, Any]) -> None:
        with self._state_lock:
            self._started_at = None
            self._monitor = None
            self.last_result = result
        self._busy.release()

    def execute(self, trajectory: JointTrajectory, controllers: Sequence[str] | None = None,
                description: str = "trajectory") -> ExecutionResult:
        """Execute one trajectory (blocking). Never raises for bad input: the result says why."""
        refused = self._begin(description)
        if refused is not None:
            return ExecutionResult(refused)
        result = ExecutionResult(_code(MoveItErrorCode.FAILURE, "not executed"))
        try:
            result = self._execute(trajectory, controllers, description)
        except ExecutionError as exc:
            self._log("warning", f"execution of {description} refused: {exc.message}")
            result = ExecutionResult(exc.error_code())
        except Exception as exc:  # a bug or transport failure must still end the execution cleanly
            result = ExecutionResult(_code(MoveItErrorCode.FAILURE, f"execution failed: {type(exc).__name__}: {exc}"))
        finally:
            self._end(result.to_dict())
        return result

    def _execute(self, trajectory: JointTrajectory, controllers: Sequence[str] | None, description: str) -> ExecutionResult:
        with self._state_lock:
            if self._stop_requested:
                return ExecutionResult(_code(MoveItErrorCode.PREEMPTED, "execution stopped on request before it started"))
        prepared = prepare_trajectory(self.model, trajectory, limit_tolerance=self.settings.limit_tolerance)
        chosen = select_controllers(prepared.joint_names, self.controllers, controllers)
        needed = sorted({j for c in chosen for j in c.joints} | set(prepared.joint_names))
        current = self._require_positions(needed)
        check_start_state(prepared, current, self.settings.allowed_start_tolerance)
        if self._already_there(prepared, current):
            return ExecutionResult(_code(MoveItErrorCode.SUCCESS, "nothing to execute: the robot is already at the "
                                         "trajectory's only point"), [c.name for c in chosen])
        self._goal_counter += 1
        goal_id = f"{self.goal_prefix}{self._goal_counter}"
        commands = split_trajectory(prepared, self.controllers, current, controllers, goal_id)
        for controller, _ in commands:
            if not self.bus.is_available(controller.name):
                raise ExecutionError(
                    MoveItErrorCode.CONTROL_FAILED,
                    f"controller '{controller.name}' is not running (no action server on {controller.action_name})",
                )
        baseline = {c.name: self.bus.controller_state(c.name) for c, _ in commands}
        started = self._clock()
        monitor = ExecutionMonitor(commands, self.settings, started, baseline)
        with self._state_lock:
            if self._stop_requested:
                return ExecutionResult(_code(MoveItErrorCode.PREEMPTED, "execution stopped on request before it started"))
            self._monitor = monitor
        self._log("info", f"executing {description}: {monitor.duration:.3f} s on {', '.join(monitor.controller_names)}")
        try:
            for controller, command in commands:
                self.bus.send(controller.name, command)
        except Exception as exc:
            self._stop_all(commands)
            raise ExecutionError(MoveItErrorCode.CONTROL_FAILED, f"sending the trajectory failed: {exc}") from None
        while True:
            for controller, _ in commands:
                latest = self.bus.controller_state(controller.name)
                if latest is not None:
                    monitor.heard(controller.name, latest.received)
                monitor.update(controller.name,
                               self.bus.controller_state(controller.name, monitor.expected_goal(controller.name)))
            now = self._clock()
            outcome = monitor.poll(now, self._fresh_positions())
            if outcome is not None:
                break
            self._wait(self._poll_period)
        if not outcome:
            self._stop_all(commands)
        elapsed = self._clock() - started
        limit = monitor.deadline - started if math.isfinite(monitor.deadline) else None
        level = "info" if outcome else ("warning" if outcome.val == MoveItErrorCode.PREEMPTED else "error")
        self._log(level, f"execution of {description}: {outcome}")
        return ExecutionResult(outcome, monitor.controller_names, elapsed, monitor.duration, limit)

    def _already_there(self, trajectory: JointTrajectory, current: Mapping[str, float]) -> bool:
        """A zero-duration trajectory whose point is where the robot is (a plan from a state to
        itself) needs no controller: sending it would only risk a spurious timeout."""
        if trajectory_duration(trajectory) > 0.0 or any(
            p.positions != trajectory.points[0].positions for p in trajectory.points
        ):
            return False
        tolerance = self.settings.goal_tolerance or 1e-6
        return all(abs(v - current[n]) <= tolerance for n, v in zip(trajectory.joint_names, trajectory.points[0].positions))

    def _stop_all(self, commands: Sequence[tuple[ControllerInfo, JointTrajectory]]) -> None:
        for controller, _ in commands:
            try:
                self.bus.stop(controller.name)
            except Exception as exc:  # keep stopping the others
                self._log("error", f"stopping controller '{controller.name}' failed: {exc}")

    # ------------------------------------------------------------------ task solutions
    def check_solution(self, steps: Sequence[SolutionStep], scene: PlanningScene,
                       current: Mapping[str, float] | None = None) -> None:
        """Validate a whole task solution before the first motion (see task_solution)."""
        check_solution(self, steps, scene, current)

    def execute_solution(self, steps: Sequence[SolutionStep], apply_diff: Callable[[PlanningSceneMsg], None],
                         scene: PlanningScene | None = None) -> SolutionResult:
        """Execute a task solution step by step (see task_solution.execute_solution)."""
        return execute_solution(self, steps, apply_diff, scene)

