"""The global planner component (MoveIt's GlobalPlannerComponent, node
``global_planner_component``): action server ``global_planning_action``
(moveit_msgs/action/GlobalPlanner).

It plans the goal's motion sequence item through move_group's ``/plan_kinematic_path``
(moveit_msgs/srv/GetMotionPlan, answered by the planning_server: one planning implementation)
from the current state (the request's start state is replaced by an empty diff, "the current
state", as MoveIt's MoveItPlanningPipeline plans from its monitored scene's current state),
publishes the solution as moveit_msgs/MotionPlanResponse on ``global_trajectory`` (depth 1, as
MoveIt) and returns it as the action's result. A failed plan aborts the goal with the planner's
error code; a canceled goal publishes nothing.
"""
from __future__ import annotations

import threading
import time
from typing import Any

from moveit_msgs.action import GlobalPlanner
from moveit_msgs.msg import MotionPlanResponse, MoveItErrorCodes, RobotState
from moveit_msgs.srv import GetMotionPlan
from rclpy.callback_groups import ReentrantCallbackGroup

from interfaces_py import names
from mycobot_planning.ros.action_servers import ABORTED, CANCELED
from mycobot_planning.ros.hybrid_planning.component import HybridPlanningComponent
from mycobot_planning.ros.hybrid_planning.goal_checks import GoalError, motion_plan_request
from mycobot_planning.ros.node_runtime import ParameterSpec, Parameters

__all__ = ["GLOBAL_PLANNER_NAMES", "GlobalPlannerComponent"]

#: global_planner_name values accepted (MoveIt's plugin, which plans with move_group's pipelines)
GLOBAL_PLANNER_NAMES = ("moveit_hybrid_planning/MoveItPlanningPipeline", "moveit::hybrid_planning/MoveItPlanningPipeline")
#: s between two checks for a cancel while the plan service works
CANCEL_POLL = 0.02
#: s added to the request's allowed_planning_time before the plan service counts as not answering
ANSWER_MARGIN = 10.0


def _global_planner_name(value: Any) -> str | None:
    return None if value in GLOBAL_PLANNER_NAMES else \
        f"global_planner_name must be one of {', '.join(GLOBAL_PLANNER_NAMES)} (got '{value}')"


class GlobalPlannerComponent(HybridPlanningComponent):
    def __init__(self, node_name: str = "global_planner_component", **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self._params = Parameters(self, [
            ParameterSpec("global_planner_name", GLOBAL_PLANNER_NAMES[0],
                          "the global planner plugin: MoveIt's MoveItPlanningPipeline, here move_group's "
                          "plan_kinematic_path service", read_only=True, validator=_global_planner_name),
            ParameterSpec("global_planning_action_name", "global_planning_action",
                          "the GlobalPlanner action this component serves", non_empty=True, read_only=True),
            ParameterSpec("global_solution_topic", "global_trajectory",
                          "where each solution is published (moveit_msgs/MotionPlanResponse, depth 1)",
                          non_empty=True, read_only=True),
            ParameterSpec("plan_service", names.PLAN_SERVICE,
                          "move_group's GetMotionPlan service that plans", non_empty=True, read_only=True),
        ])
        group = ReentrantCallbackGroup()
        self._publisher = self.create_publisher(MotionPlanResponse, self._params.get("global_solution_topic"), 1)
        self._plan_client = self.create_client(GetMotionPlan, self._params.get("plan_service"), callback_group=group)
        self.serve(GlobalPlanner, self._params.get("global_planning_action_name"), self._execute, group)
        self.get_logger().info(f"global planner ready: {self._params.get('global_planning_action_name')} plans "
                               f"through {self._params.get('plan_service')}")

    def _answer(self, goal_handle: Any, code: int, message: str, group: str = "") -> GlobalPlanner.Result:
        result = GlobalPlanner.Result()
        result.response.group_name = group
        result.response.error_code = MoveItErrorCodes(val=code, message=message, source="global_planner_component")
        outcome = CANCELED if goal_handle.is_cancel_requested else ABORTED
        return self.end(goal_handle, result, outcome, f"global planning failed: {message}")

    def _execute(self, goal_handle: Any) -> GlobalPlanner.Result:
        return self.answer_always(
            goal_handle, self._plan, GlobalPlanner.Result, "global planning",
            lambda exc: self._answer(goal_handle, MoveItErrorCodes.FAILURE,
                                     f"internal error ({type(exc).__name__}); the log has the details"))

    def _plan(self, goal_handle: Any) -> GlobalPlanner.Result:
        goal = goal_handle.request
        try:
            request = motion_plan_request(goal.planning_group, goal.motion_sequence)
        except GoalError as exc:
            return self._answer(goal_handle, exc.code, exc.message, goal.planning_group)
        request.start_state = RobotState(is_diff=True)  # plan from the current state
        service = self._params.get("plan_service")
        if not self._plan_client.wait_for_service(timeout_sec=5.0):
            return self._answer(goal_handle, MoveItErrorCodes.COMMUNICATION_FAILURE,
                                f"no {service} service (is the planning_server running?)", request.group_name)
        future = self._plan_client.call_async(GetMotionPlan.Request(motion_plan_request=request))
        done = threading.Event()
        future.add_done_callback(lambda _f: done.set())
        deadline = time.monotonic() + max(request.allowed_planning_time, 5.0) + ANSWER_MARGIN
        while not done.wait(CANCEL_POLL):
            if self.going_down():
                return GlobalPlanner.Result()
            if goal_handle.is_cancel_requested:
                return self._answer(goal_handle, MoveItErrorCodes.PREEMPTED, "global planning canceled",
                                    request.group_name)
            if time.monotonic() > deadline:
                future.cancel()
                return self._answer(goal_handle, MoveItErrorCodes.TIMED_OUT, f"{service} did not answer",
                                    request.group_name)
        response = future.result().motion_plan_response
        result = GlobalPlanner.Result(response=response)
        if self.going_down():
            return result
        if goal_handle.is_cancel_requested:
            goal_handle.canceled()
            return result
        if response.error_code.val != MoveItErrorCodes.SUCCESS:
            self.get_logger().warning(f"global planning failed ({response.error_code.val}): "
                                      f"{response.error_code.message}")
            goal_handle.abort()
            return result
        self._publisher.publish(response)
        self.get_logger().info(f"global solution: {len(response.trajectory.joint_trajectory.points)} points, "
                               f"planned in {response.planning_time:.2f} s")
        goal_handle.succeed()
        return result
