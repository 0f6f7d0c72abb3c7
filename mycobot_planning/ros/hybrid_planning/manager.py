"""The hybrid planning manager (MoveIt's HybridPlanningManager, node ``hybrid_planning_manager``):
action server ``run_hybrid_planning`` (moveit_msgs/action/HybridPlanner).

A run feeds every event (the request, the global and local planners' results, the local
planner's feedback) to the planner logic (``planner_logic_plugin_name``: MoveIt's
SinglePlanExecution or ReplanInvalidatedTrajectory, mycobot_planning.core.hybrid_planning) and
does what it answers: send the goal to the global planner (``global_planning_action``), start
the local planner (``local_planning_action``), or answer the run. A cancel cancels both planners
(the local planner brings the arm to rest) and answers canceled (PREEMPTED). A goal the planners
cannot take (no or several motion sequence items, a group mismatch, NaN values) is aborted at
once with the reason.
"""
from __future__ import annotations

import queue
import threading
import time
from typing import Any, Callable

from action_msgs.msg import GoalStatus
from moveit_msgs.action import GlobalPlanner, HybridPlanner, LocalPlanner
from moveit_msgs.msg import MotionPlanResponse, MoveItErrorCodes
from rclpy.callback_groups import ReentrantCallbackGroup

from interfaces_py.action_client import ActionClient
from mycobot_planning.core.hybrid_planning import (
    PLANNER_LOGIC_PLUGINS,
    HybridPlanningAction,
    HybridPlanningEvent,
    planner_logic,
)
from mycobot_planning.ros.action_servers import ABORTED, CANCELED, SUCCEEDED
from mycobot_planning.ros.hybrid_planning.component import HybridPlanningComponent
from mycobot_planning.ros.hybrid_planning.goal_checks import GoalError, motion_plan_request
from mycobot_planning.ros.node_runtime import ParameterSpec, Parameters

__all__ = ["HybridPlanningManager"]

#: s between two checks for a cancel while a run waits for events
POLL = 0.02
#: s the manager waits for the planners' action servers
SERVER_TIMEOUT = 5.0
#: s a cancel waits for the planners to confirm (the local planner's stop is under way by then)
CANCEL_TIMEOUT = 5.0
_E = HybridPlanningEvent


def _logic_name(value: Any) -> str | None:
    if value in PLANNER_LOGIC_PLUGINS:
        return None
    known = ", ".join(n for n in PLANNER_LOGIC_PLUGINS if n.startswith("moveit::"))
    return f"planner_logic_plugin_name '{value}' is not a known planner logic (known: {known})"


class _Run:
    """One hybrid planning run: its events and the planners' goals in flight."""

    def __init__(self) -> None:
        self.events: queue.Queue[tuple[Any, str]] = queue.Queue()
        self.global_goal: Any = None
        self.global_pending = False
        self.local_goal: Any = None
        self.local_pending = False
        self.closed = False  # the run is over: a goal accepted from now on is canceled at once
        self.lock = threading.Lock()

    def adopt(self, kind: str, handle: Any) -> bool:
        """Keep an accepted planner goal; False (and the goal canceled) when the run is over."""
        with self.lock:
            if not self.closed:
                setattr(self, f"{kind}_goal", handle)
                return True
        handle.cancel_goal_async()
        return False

    def idle(self) -> bool:
        with self.lock:
            return not (self.global_pending or self.local_pending or self.global_goal or self.local_goal)


def _goal_answer(run: _Run, kind: str, rejected: Any, finished: Callable[[Any], None],
                 pending_until_result: bool) -> Callable[[Any], None]:
    """The callback of the global or local planner's (``kind``) goal request: an accepted goal
    is followed to its result, which goes to ``finished``; the event ``rejected`` when the planner
    did not accept it. The run's ``<kind>_pending`` ends there, unless ``pending_until_result``
    and the goal was accepted (then ``finished`` ends it)."""

    def answered(future: Any) -> None:
        handle = future.result()
        refused = handle is None or not handle.accepted
        if refused or not pending_until_result:
            with run.lock:
                setattr(run, f"{kind}_pending", False)
        if refused:
            run.events.put((rejected, f"the {kind} planner rejected the goal"))
            return
        if run.adopt(kind, handle):
            handle.get_result_async().add_done_callback(lambda r: finished(r.result()))

    return answered


def _status_event(status: int, succeeded: Any, canceled: Any, aborted: Any) -> Any:
    """The event a planner goal's final status raises."""
    return {GoalStatus.STATUS_SUCCEEDED: succeeded, GoalStatus.STATUS_CANCELED: canceled}.get(status, aborted)


class HybridPlanningManager(HybridPlanningComponent):
    def __init__(self, node_name: str = "hybrid_planning_manager", **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self._params = Parameters(self, [
            ParameterSpec("planner_logic_plugin_name", "moveit::hybrid_planning/ReplanInvalidatedTrajectory",
                          "planner logic: MoveIt's ReplanInvalidatedTrajectory (replan on 'Collision ahead' or "
                          "'Local planner is stuck') or SinglePlanExecution (plan once); either plugin name "
                          "spelling MoveIt uses, or the bare class name", validator=_logic_name),
            ParameterSpec("hybrid_planning_action_name", "run_hybrid_planning",
                          "the HybridPlanner action this manager serves", non_empty=True, read_only=True),
            ParameterSpec("global_planning_action_name", "global_planning_action",
                          "the global planner's GlobalPlanner action", non_empty=True, read_only=True),
            ParameterSpec("local_planning_action_name", "local_planning_action",
                          "the local planner's LocalPlanner action", non_empty=True, read_only=True),
            ParameterSpec("global_solution_topic", "global_trajectory",
                          "the global planner's solutions (GLOBAL_SOLUTION_AVAILABLE events)", non_empty=True,
                          read_only=True),
        ])
        group = ReentrantCallbackGroup()
        self._run: _Run | None = None
        self._run_lock = threading.Lock()
        self._global = ActionClient(self, GlobalPlanner, self._params.get("global_planning_action_name"),
                                    callback_group=group)
        self._local = ActionClient(self, LocalPlanner, self._params.get("local_planning_action_name"),
                                   callback_group=group)
        self.create_subscription(MotionPlanResponse, self._params.get("global_solution_topic"),
                                 self._on_global_solution, 1, callback_group=group)
        self.serve(HybridPlanner, self._params.get("hybrid_planning_action_name"), self._execute, group)
        self.get_logger().info(f"hybrid planning manager ready: {self._params.get('hybrid_planning_action_name')} "
                               f"with {self._params.get('planner_logic_plugin_name')}")

    # ------------------------------------------------------------------ events
    def _on_global_solution(self, msg: MotionPlanResponse) -> None:
        run = self._run
        if run is not None and msg.error_code.val == MoveItErrorCodes.SUCCESS:
            run.events.put((_E.GLOBAL_SOLUTION_AVAILABLE, ""))

    def _send_global(self, run: _Run, goal: Any) -> str | None:
        """Send the global planning goal (one at a time: a replan asked for while one is under way
        is that one); None, or why it cannot be sent."""
        with run.lock:
            if run.global_pending:
                return None
            run.global_pending = True
        if not self._global.wait_for_server(timeout_sec=SERVER_TIMEOUT):
            with run.lock:
                run.global_pending = False
            return f"no {self._params.get('global_planning_action_name')} action server"
        future = self._global.send_goal_async(GlobalPlanner.Goal(planning_group=goal.planning_group,
                                                                 motion_sequence=goal.motion_sequence))

        def finished(answer: Any) -> None:
            with run.lock:
                run.global_pending = False
                run.global_goal = None
            code = answer.result.response.error_code
            detail = f"{code.message or 'error code'} ({code.val})" if code.val != MoveItErrorCodes.SUCCESS else ""
            run.events.put((_status_event(answer.status, _E.GLOBAL_PLANNING_ACTION_SUCCESSFUL,
                                          _E.GLOBAL_PLANNING_ACTION_CANCELED, _E.GLOBAL_PLANNING_ACTION_ABORTED),
                            detail))

        future.add_done_callback(_goal_answer(run, "global", _E.GLOBAL_PLANNING_ACTION_REJECTED, finished, True))
        return None

    def _send_local(self, run: _Run) -> str | None:
        if not self._local.wait_for_server(timeout_sec=SERVER_TIMEOUT):
            return f"no {self._params.get('local_planning_action_name')} action server"

        def feedback(msg: Any) -> None:
            run.events.put(("feedback", msg.feedback.feedback))

        with run.lock:
            run.local_pending = True
        future = self._local.send_goal_async(LocalPlanner.Goal(), feedback_callback=feedback)

        def finished(answer: Any) -> None:
            with run.lock:
                run.local_goal = None
            message = answer.result.error_message or answer.result.error_code.message
            run.events.put((_status_event(answer.status, _E.LOCAL_PLANNING_ACTION_SUCCESSFUL,
                                          _E.LOCAL_PLANNING_ACTION_CANCELED, _E.LOCAL_PLANNING_ACTION_ABORTED),
                            message))

        future.add_done_callback(_goal_answer(run, "local", _E.LOCAL_PLANNING_ACTION_REJECTED, finished, False))
        return None

    # ------------------------------------------------------------------ the run
    def _answer(self, goal_handle: Any, code: int, message: str) -> HybridPlanner.Result:
        result = HybridPlanner.Result(error_message=message)
        result.error_code = MoveItErrorCodes(val=code, message=message, source="hybrid_planning_manager")
        if code == MoveItErrorCodes.SUCCESS:
            outcome = SUCCEEDED
        elif goal_handle.is_cancel_requested:
            result.error_code.val = MoveItErrorCodes.PREEMPTED
            outcome = CANCELED
        else:
            outcome = ABORTED
        return self.end(goal_handle, result, outcome, f"hybrid planning failed: {message}")

    def _execute(self, goal_handle: Any) -> HybridPlanner.Result:
        goal = goal_handle.request
        try:
            motion_plan_request(goal.planning_group, goal.motion_sequence)
        except GoalError as exc:
            return self._answer(goal_handle, exc.code, f"refused: {exc.message}")
        try:
            logic = planner_logic(self._params.get("planner_logic_plugin_name"))
        except ValueError as exc:
            return self._answer(goal_handle, MoveItErrorCodes.FAILURE, str(exc))
        run = _Run()
        with self._run_lock:
            if self._run is not None:
                busy = True
            else:
                busy, self._run = False, run
        if busy:
            return self._answer(goal_handle, MoveItErrorCodes.FAILURE, "another hybrid planning run is active")
        try:
            return self._loop(goal_handle, goal, logic, run)
        except Exception as exc:  # never leave a run without an answer, nor the planners running
            if self.going_down():
                return HybridPlanner.Result()
            self.get_logger().error(f"hybrid planning failed: {type(exc).__name__}: {exc}")
            self._cancel_planners(run)
            return self._answer(goal_handle, MoveItErrorCodes.FAILURE,
                                f"internal error ({type(exc).__name__}); the log has the details")
        finally:
            with self._run_lock:
                self._run = None

    def _loop(self, goal_handle: Any, goal: Any, logic: Any, run: _Run) -> HybridPlanner.Result:
        run.events.put((_E.HYBRID_PLANNING_REQUEST_RECEIVED, ""))
        A = HybridPlanningAction
        while True:
            try:
                event, detail = run.events.get(timeout=POLL)
            except queue.Empty:
                if self.going_down():
                    return HybridPlanner.Result()
                if goal_handle.is_cancel_requested:
                    return self._cancel(goal_handle, run)
                continue
            if goal_handle.is_cancel_requested:
                return self._cancel(goal_handle, run)
            if event == "feedback":
                goal_handle.publish_feedback(HybridPlanner.Feedback(feedback=detail))
                reaction = logic.react_to_feedback(detail)
                self.get_logger().info(f"local planner: {detail} -> {reaction.action.value}")
            else:
                reaction = logic.react(event)
            if reaction.action is A.SEND_GLOBAL_SOLVER_REQUEST:
                problem = self._send_global(run, goal)
            elif reaction.action is A.SEND_LOCAL_SOLVER_REQUEST:
                problem = self._send_local(run)
            elif reaction.action is A.RETURN_HP_SUCCESS:
                self._cancel_planners(run)
                return self._answer(goal_handle, MoveItErrorCodes.SUCCESS, "")
            elif reaction.action is A.RETURN_HP_FAILURE:
                self._cancel_planners(run)
                message = reaction.message + (f": {detail}" if detail else "")
                return self._answer(goal_handle, reaction.error_code, message)
            else:
                problem = None
            if problem:
                self._cancel_planners(run)
                return self._answer(goal_handle, MoveItErrorCodes.COMMUNICATION_FAILURE, problem)

    def _cancel_planners(self, run: _Run) -> None:
        """Close the run and cancel the planners' goals (accepted ones now, pending ones on acceptance)."""
        with run.lock:
            run.closed = True
            handles = [h for h in (run.global_goal, run.local_goal) if h is not None]
        for handle in handles:
            handle.cancel_goal_async()

    def _cancel(self, goal_handle: Any, run: _Run) -> HybridPlanner.Result:
        """Cancel both planners, wait until they have answered (the local planner answers once it
        has sent the arm's stop), answer canceled."""
        self._cancel_planners(run)
        deadline = time.monotonic() + CANCEL_TIMEOUT
        while not run.idle() and time.monotonic() < deadline:
            time.sleep(POLL)
        return self._answer(goal_handle, MoveItErrorCodes.PREEMPTED, "hybrid planning canceled")
