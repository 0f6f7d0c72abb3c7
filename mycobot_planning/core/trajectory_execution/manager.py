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

import numpy as np

from interfaces_py.msgs import JointTrajectory, JointTrajectoryPoint, MoveItErrorCode, PlanningScene as PlanningSceneMsg

from ..planning_scene.planning_scene import PlanningScene
from ..robot_model.robot_model import RobotModel
from ..robot_trajectory.robot_trajectory import TimedTrajectory, joint_trajectory_to_timed
from .controller_manager import (
    FOLLOW_JOINT_TRAJECTORY,
    ControllerBus,
    ControllerInfo,
    check_controllers,
    select_controllers,
    split_trajectory,
)
from .monitor import ExecutionMonitor, ExecutionResult
from .path_ahead import PathAhead, PathCollision, stop_command, stopping_trajectory
from .settings import ExecutionError, ExecutionSettings, error_code as _code
from .task_solution import SolutionResult, SolutionStep, check_solution, execute_solution
from .trajectory_preparation import check_start_state, prepare_trajectory, trajectory_duration

#: s: the least time a stop command's first point may lie ahead of its sending
MIN_STOP_LEAD = 0.008
#: s before the clock's time searched for the arm's place on the path when a stop begins (a
#: window, not the whole past: a path that passes a state twice must not send the stop back)
STOP_LOCATE_WINDOW = 1.0
#: s after the clock's time searched likewise (as before the window grew: an arm is not ahead of it)
STOP_LOCATE_AHEAD = 0.05
#: s: how soon a halt (no room to decelerate) holds the joints where they were last seen
HALT_TIME = 0.02
#: s: how long a new execution waits for one that is stopping (decelerating to rest) to end
STOPPING_WAIT = 3.0
#: s a trajectory's start waits at most for joints still settling from the previous motion
#: (MoveIt's waitForRobotToStop wait_time), polled every SETTLE_POLL s; joints that moved less
#: than SETTLE_MOTION (rad or m) in one poll are at rest
SETTLE_WAIT = 1.0
SETTLE_POLL = 0.02
SETTLE_MOTION = 1e-4


class TrajectoryExecutionManager:
    """Executes trajectories and task solutions, one at a time, through a ControllerBus.

    ``current_positions()`` returns the current joint positions by name (mimic joints may be
    included) and their age in seconds, or (None, None) when no joint state arrived yet.
    ``clock`` and ``wait`` are injectable so tests can run on simulated time; by default ``wait``
    sleeps until ``notify()`` is called (a controller state or joint state arrived) or the poll
    period passes.

    ``scene_source`` (a copy of the monitored scene) enables watching the path ahead: every
    ``scene_changed()`` during an execution re-checks what remains of the trajectory, off the
    execution loop; a collision ahead stops the arm along its path before it (see path_ahead)
    and the execution fails with MOTION_PLAN_INVALIDATED_BY_ENVIRONMENT_CHANGE. A stop request
    decelerates the same way. ``stop_lead`` (s): how far ahead of now a stop command begins, the
    time it takes to reach the controllers.
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
        scene_source: Callable[[], PlanningScene] | None = None,
        stop_lead: float = 0.015,
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
        self._shut_down = False  # shut_down(): every execution refused from then on
        self._started_at: float | None = None
        self._description = ""
        self.last_result: dict[str, Any] | None = None
        # Goal ids "<prefix><n>/<controller>": unique per manager, readable in controller logs.
        self.goal_prefix = f"exec-{uuid.uuid4().hex[:6]}-"
        self._goal_counter = 0
        self._scene_source = scene_source
        self.stop_lead = stop_lead
        self._watch: _PathWatch | None = None
        self._reaction_ms: float | None = None
        self.invalidations = 0
        self.last_reaction_ms: float | None = None
        #: what the last path watch saw: checks made, and ms from a scene change to its verdict
        self.watch_stats: dict[str, Any] = {"checks": 0, "reaction_ms": [], "changes": 0, "changes_checked": 0}

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
                # executions stopped by a scene change so far, and the last one's reaction (ms from
                # the change's arrival to the stop command)
                "invalidations": self.invalidations,
                "last_reaction_ms": self.last_reaction_ms,
            }

    def notify(self) -> None:
        """New feedback arrived: wake the monitoring loop."""
        self._wake.set()

    def scene_changed(self) -> None:
        """The monitored scene changed: re-check the path ahead of a running execution (the
        check runs on the watch thread; bursts of changes are coalesced into one check of the
        newest scene)."""
        watch = self._watch
        if watch is not None:
            watch.changed()

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

    def _settled_positions(self, prepared: JointTrajectory, needed: Iterable[str]) -> Mapping[str, float]:
        """The robot's positions for the start check. When the trajectory's first point is not
        yet within allowed_start_tolerance and the joints still move (a real arm settling after the
        previous step, which succeeded within goal_tolerance), wait for them to stop, as MoveIt's
        waitForRobotToStop does after each part: up to SETTLE_WAIT s, until they are at rest (no
        joint moved SETTLE_MOTION in SETTLE_POLL s). Nothing is sent meanwhile, and never while
        they still move; the caller's check then decides with the latest positions."""
        current = self._require_positions(needed)
        tolerance = self.settings.allowed_start_tolerance
        if tolerance <= 0 or not prepared.points:
            return current
        first = dict(zip(prepared.joint_names, prepared.points[0].positions))

        def within(positions: Mapping[str, float]) -> bool:
            return all(abs(float(v) - float(positions[n])) <= tolerance for n, v in first.items() if n in positions)

        if within(current):
            return current
        deadline = self._clock() + SETTLE_WAIT
        while self._clock() < deadline and not self._stop_requested:
            self._wait(SETTLE_POLL)
            previous, current = current, self._require_positions(needed)
            if max((abs(float(current[n]) - float(previous[n])) for n in first if n in current), default=0.0) \
                    < SETTLE_MOTION:
                break  # at rest (never sent while the joints still move): the caller's check decides
        return current

    # ------------------------------------------------------------------ single trajectories
    def stopping(self) -> bool:
        """An execution runs and has been asked to stop: it ends as soon as the arm is at rest."""
        with self._state_lock:
            return self._started_at is not None and self._stop_requested

    def executing_after_stop(self, timeout: float = STOPPING_WAIT) -> bool:
        """Whether an execution is still running once a stopping one has had ``timeout`` s to
        bring the arm to rest: a request that arrives while the previous motion decelerates
        (a cancel followed at once by a new goal) waits for it instead of being refused."""
        deadline = time.monotonic() + timeout
        while self.executing and self.stopping() and time.monotonic() < deadline:
            time.sleep(0.005)
        return self.executing

    def shut_down(self) -> None:
        """Refuse every execution from now on (PREEMPTED): the process is going down, and a
        motion started now would outlive its supervision (stop() ends the running one)."""
        with self._state_lock:
            self._shut_down = True

    def _begin(self, description: str) -> MoveItErrorCode | None:
        with self._state_lock:
            if self._shut_down:
                return _code(MoveItErrorCode.PREEMPTED, f"refused: {description}: move_group is shutting down")
        if self.stopping():
            self.executing_after_stop()
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
        prepared = prepare_trajectory(self.model, trajectory, limit_tolerance=self.settings.limit_tolerance,
                                      max_waypoint_distance=self.settings.max_waypoint_distance)
        chosen = select_controllers(prepared.joint_names, self.controllers, controllers)
        needed = sorted({j for c in chosen for j in c.joints} | set(prepared.joint_names))
        current = self._settled_positions(prepared, needed)
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
        watch = None
        if self._scene_source is not None:
            ahead = PathAhead(self.model, prepared)
            path = ahead.trajectory
            watch = _PathWatch(ahead, self._scene_source, lambda: self._arm_time(ahead, started), self._wake,
                               self.watch_stats, self._log)
        else:
            path = joint_trajectory_to_timed(prepared)
        try:
            for controller, command in commands:
                self.bus.send(controller.name, command)
        except Exception as exc:
            self._stop_all(commands)
            raise ExecutionError(MoveItErrorCode.CONTROL_FAILED, f"sending the trajectory failed: {exc}") from None
        if watch is not None:
            self._watch = watch
            watch.start()
        self._reaction_ms = None
        try:
            outcome = self._follow(path, commands, monitor, started, watch)
        finally:
            self._watch = None
            if watch is not None:
                watch.close()
        elapsed = self._clock() - started
        limit = monitor.deadline - started if math.isfinite(monitor.deadline) else None
        level = "info" if outcome else ("warning" if outcome.val in (
            MoveItErrorCode.PREEMPTED, MoveItErrorCode.MOTION_PLAN_INVALIDATED_BY_ENVIRONMENT_CHANGE) else "error")
        self._log(level, f"execution of {description}: {outcome}")
        return ExecutionResult(outcome, monitor.controller_names, elapsed, monitor.duration, limit, self._reaction_ms)

    def _follow(self, path: TimedTrajectory, commands: Sequence[tuple[ControllerInfo, JointTrajectory]],
                monitor: ExecutionMonitor, started: float, watch: "_PathWatch | None") -> MoveItErrorCode:
        """Watch the running commands until they end; a collision ahead or a stop request ends
        them with a stop along the path."""
        while True:
            hit = watch.collision if watch is not None else None
            if hit is not None:
                return self._controlled_stop(path, commands, started, _code(
                    MoveItErrorCode.MOTION_PLAN_INVALIDATED_BY_ENVIRONMENT_CHANGE, hit.message()), hit)
            for controller, _ in commands:
                latest = self.bus.controller_state(controller.name)
                if latest is not None:
                    monitor.heard(controller.name, latest.received)
                monitor.update(controller.name,
                               self.bus.controller_state(controller.name, monitor.expected_goal(controller.name)))
            now = self._clock()
            outcome = monitor.poll(now, self._fresh_positions())
            if outcome is not None and outcome.val == MoveItErrorCode.PREEMPTED:
                return self._controlled_stop(path, commands, started, outcome, None)
            if outcome is not None:
                if not outcome:
                    self._stop_all(commands)
                return outcome
            self._wait(self._poll_period)

    def _arm_time(self, ahead: PathAhead, started: float) -> float:
        """Where on ``ahead`` the arm is (s from its start): the clock's time, or earlier where
        fresh joint states place the arm behind it (a controller that accepted the goal late or
        runs behind), so a check of the path ahead never skips what the arm has still to pass."""
        t_clock = self._clock() - started
        fresh = self._fresh_positions()
        if fresh is None or not all(n in fresh for n in ahead.joint_names):
            return t_clock
        # the whole past is searched: a state matching an earlier part of the path only widens the check
        return min(t_clock, ahead.locate(np.array([fresh[n] for n in ahead.joint_names]), t_clock,
                                         window=max(t_clock, 0.3)))

    def _record_reaction(self, hit: PathCollision | None) -> None:
        """For a stop caused by ``hit``: ms from the scene change's arrival to now (the stop sent)."""
        watch = self._watch
        if hit is None or watch is None or watch.hit_since is None:
            return
        self._reaction_ms = (time.monotonic() - watch.hit_since) * 1e3
        with self._state_lock:
            self.invalidations += 1
            self.last_reaction_ms = self._reaction_ms

    def _controlled_stop(self, path: TimedTrajectory, commands: Sequence[tuple[ControllerInfo, JointTrajectory]],
                         started: float, outcome: MoveItErrorCode, hit: PathCollision | None) -> MoveItErrorCode:
        """Bring the arm to rest along its path within the acceleration limits (before ``hit``
        when given) and answer ``outcome`` once the controllers report it at rest. Where no such
        stop exists (the obstacle too close, the stop refused), the controllers' goals are
        cancelled: they hold where they are at once."""
        names = path.joint_names
        limits = np.array([self.model.acceleration_limits[self.model.variable_index(n)] for n in names])
        before = hit.free_until if hit is not None else None
        lead, plan, spent = self.stop_lead, None, 0.0
        for _ in range(3):
            mark = time.monotonic()
            t_arm = self._clock() - started
            ahead = self._watch.path if self._watch is not None else None
            fresh, age = self._current_positions()
            if (ahead is not None and fresh is not None and age is not None
                    and age <= self.settings.joint_state_timeout and all(n in fresh for n in ahead.joint_names)):
                # where the arm really is (a controller that accepted the goal late runs behind
                # the clock, on a loaded machine by half a second), plus how old that joint state is
                t_arm = ahead.locate(np.array([fresh[n] for n in ahead.joint_names]), t_arm,
                                     window=STOP_LOCATE_WINDOW, ahead=STOP_LOCATE_AHEAD) + age
            if hit is not None and before is None:
                break
            plan = stopping_trajectory(path, t_arm + lead, limits, before)
            spent = time.monotonic() - mark
            if plan is None or lead - spent >= MIN_STOP_LEAD:
                break
            lead = self.stop_lead + 2.0 * spent  # the computation was slow: begin the stop further ahead
        text = outcome.message
        if plan is None:
            self._halt(commands)
            self._record_reaction(hit)
            return _code(outcome.val, f"{text}; too close to stop along the path within the acceleration "
                                      "limits: halted at once")
        self._goal_counter += 1
        goal_id = f"{self.goal_prefix}{self._goal_counter}"
        current = self._fresh_positions() or {}
        try:
            command = stop_command(plan, lead, goal_id, elapsed=time.monotonic() - mark, min_lead=MIN_STOP_LEAD)
            stops = split_trajectory(command, self.controllers, current,
                                     [c.name for c, _ in commands], goal_id)
            baseline = {c.name: self.bus.controller_state(c.name) for c, _ in stops}
            for controller, command in stops:
                self.bus.send(controller.name, command)
            self._record_reaction(hit)
        except Exception as exc:  # a stop that cannot be sent: hold at once
            self._stop_all(commands)
            return _code(outcome.val, f"{text}; the stop along the path could not be sent ({exc}): halted at once")
        now = self._clock()
        monitor = ExecutionMonitor(stops, self.settings, now, baseline)
        while True:
            for controller, _ in stops:
                latest = self.bus.controller_state(controller.name)
                if latest is not None:
                    monitor.heard(controller.name, latest.received)
                monitor.update(controller.name, self.bus.controller_state(controller.name,
                                                                          monitor.expected_goal(controller.name)))
            done = monitor.poll(self._clock(), self._fresh_positions())
            if done is not None:
                break
            self._wait(self._poll_period)
        where = f"at rest at {plan.rest_at:.2f} s of the trajectory after a {plan.duration:.2f} s stop"
        if not done:
            self._stop_all(stops)
            return _code(outcome.val, f"{text}; the stop along the path failed ({done.message}): halted")
        return _code(outcome.val, f"{text}; {where}")

    def _already_there(self, trajectory: JointTrajectory, current: Mapping[str, float]) -> bool:
        """A zero-duration trajectory whose point is where the robot is (a plan from a state to
        itself) needs no controller: sending it would only risk a spurious timeout."""
        if trajectory_duration(trajectory) > 0.0 or any(
            p.positions != trajectory.points[0].positions for p in trajectory.points
        ):
            return False
        tolerance = self.settings.goal_tolerance or 1e-6
        return all(abs(v - current[n]) <= tolerance for n, v in zip(trajectory.joint_names, trajectory.points[0].positions))

    def _halt(self, commands: Sequence[tuple[ControllerInfo, JointTrajectory]]) -> None:
        """Hold every joint where /joint_states last put it, at once (a one-point goal reached
        in HALT_TIME s, preempting the running one): no room is left to decelerate along the path.
        A controller without a fresh joint state for all its joints, or a gripper, is cancelled."""
        current = self._fresh_positions()
        self._goal_counter += 1
        goal_id = f"{self.goal_prefix}{self._goal_counter}"
        for controller, _ in commands:
            if (current is None or controller.action_type != FOLLOW_JOINT_TRAJECTORY
                    or not all(j in current for j in controller.joints)):
                self._stop_all([(controller, _)])
                continue
            hold = JointTrajectory(joint_names=list(controller.joints), frame_id=f"{goal_id}/{controller.name}",
                                   points=[JointTrajectoryPoint(positions=[float(current[j]) for j in controller.joints],
                                                                velocities=[0.0] * len(controller.joints),
                                                                time_from_start=HALT_TIME)])
            try:
                self.bus.send(controller.name, hold)
            except Exception as exc:
                self._log("error", f"holding controller '{controller.name}' failed ({exc}); cancelling its goal")
                self._stop_all([(controller, _)])

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


class _PathWatch:
    """The thread that re-checks the path ahead after scene changes (see scene_changed): it
    sleeps until a change arrives, checks the newest scene, and records the first collision
    ahead, which the execution loop then acts on (woken through ``wake``)."""

    def __init__(self, path: PathAhead, scene_source: Callable[[], PlanningScene], arm_time: Callable[[], float],
                 wake: threading.Event, stats: dict[str, Any], log: Callable[[str, str], None]) -> None:
        self.path = path
        self._log = log
        self._scene_source = scene_source
        self._arm_time = arm_time  # where on the path the arm is now (s from its start)
        self._wake = wake
        self._changed = threading.Event()
        self._closed = False
        self._since: float | None = None  # when the oldest unchecked change arrived
        self.collision: PathCollision | None = None
        #: when the scene change behind the collision found arrived (time.monotonic)
        self.hit_since: float | None = None
        stats["checks"] = 0
        stats["reaction_ms"] = []
        #: scene changes announced, and how many of them the newest finished check covered
        stats["changes"] = 0
        stats["changes_checked"] = 0
        self._stats = stats
        self._thread = threading.Thread(target=self._run, name="path ahead watch", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def changed(self) -> None:
        if self._since is None:
            self._since = time.monotonic()
        self._stats["changes"] += 1
        self._changed.set()

    def close(self) -> None:
        self._closed = True
        self._changed.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout=5.0)

    def _run(self) -> None:
        while True:
            self._changed.wait()
            if self._closed:
                return
            self._changed.clear()
            covered = self._stats["changes"]  # read after the clear: a later change sets the event again
            since, self._since = self._since, None
            t_from = self._arm_time()
            woke = time.monotonic()
            try:
                scene = self._scene_source()
                copied = time.monotonic()
                hit = self.path.first_collision(scene, t_from)
            except Exception as exc:  # a failed check must not end the watch: the next change checks again
                self._log("error", f"checking the path ahead failed: {type(exc).__name__}: {exc}")
                continue
            self._stats["changes_checked"] = covered
            self._stats["checks"] += 1
            if since is not None:
                self._stats["reaction_ms"].append((time.monotonic() - since) * 1e3)
            if hit is not None:
                done = time.monotonic()
                self._log("info", f"path ahead re-checked after a scene change: collision found "
                                  f"{(woke - since) * 1e3 if since else 0.0:.1f} ms after the change arrived, scene "
                                  f"copied in {(copied - woke) * 1e3:.1f} ms, path checked in {(done - copied) * 1e3:.1f} ms")
                self.hit_since = since
                self.collision = hit
                self._wake.set()
                return
