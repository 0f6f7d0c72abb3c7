"""Execution through ros2_control's controller actions, as moveit_simple_controller_manager does:
the ControllerBus of core/trajectory_execution/ over control_msgs FollowJointTrajectory and GripperCommand
action clients, one per controller of moveit_controllers.yaml.

The execution monitor reads controller states (status, goal id, when last heard); here they come
from the action's goal response, feedback and result:

* goal rejected -> ``aborted``; accepted or feedback -> ``executing`` (feedback doubles as the
  heartbeat that tells a lost controller from a slow one);
* result SUCCEEDED with error_code 0 (GripperCommand: reached_goal) -> ``succeeded``;
  ABORTED, or SUCCEEDED with an error code -> ``failed`` with the controller's error_string;
  CANCELED -> ``stopped``.
"""
from __future__ import annotations

import dataclasses
import threading
import time
import uuid
from collections import OrderedDict
from typing import Any, Callable

from action_msgs.msg import GoalStatus
from control_msgs.action import FollowJointTrajectory, GripperCommand
from control_msgs.msg import JointTrajectoryControllerState
from rclpy.node import Node

from interfaces_py.action_client import ActionClient
from interfaces_py.msgs import JointTrajectory
from interfaces_py.ros_conversions import joint_trajectory_to_msg
from mycobot_planning.ros.topic_reader import TopicReader
from mycobot_planning.core.trajectory_execution import GRIPPER_COMMAND, ControllerInfo, ControllerState

#: N: GripperCommand max_effort when the trajectory gives none (the mock has no dynamics; a real
#: gripper controller clamps it to its own limit)
DEFAULT_MAX_EFFORT = 10.0
HEARTBEAT_QOS = 1  # the newest heartbeat is all that counts
#: s to wait for a controller to confirm a cancel
CANCEL_CONFIRM_TIMEOUT = 1.0
FJT_ERRORS = {
    FollowJointTrajectory.Result.INVALID_GOAL: "INVALID_GOAL",
    FollowJointTrajectory.Result.INVALID_JOINTS: "INVALID_JOINTS",
    FollowJointTrajectory.Result.OLD_HEADER_TIMESTAMP: "OLD_HEADER_TIMESTAMP",
    FollowJointTrajectory.Result.PATH_TOLERANCE_VIOLATED: "PATH_TOLERANCE_VIOLATED",
    FollowJointTrajectory.Result.GOAL_TOLERANCE_VIOLATED: "GOAL_TOLERANCE_VIOLATED",
}


class ActionControllerBus:
    """ControllerBus over control_msgs actions. The action clients live on ``monitor`` (a node on
    a single-threaded executor of its own, which also carries /joint_states), so feedback at the
    controllers' rate never queues behind planning requests."""

    MAX_GOALS = 32  # goal states remembered per controller

    def __init__(self, node: Node, monitor: Node, controllers: list[ControllerInfo],
                 on_feedback: Callable[[], None]) -> None:
        self._node = node
        self._on_feedback = on_feedback
        self._lock = threading.Lock()
        self._controllers = {c.name: c for c in controllers}
        self._clients: dict[str, ActionClient] = {}
        self._latest: dict[str, ControllerState] = {}
        self._by_goal: dict[str, OrderedDict[str, ControllerState]] = {}
        self._handles: dict[str, Any] = {}  # controller -> goal handle of the goal it runs for us
        self._alive: dict[str, float] = {}  # controller -> when its controller_state last arrived
        self._heartbeats: dict[str, TopicReader] = {}
        for c in controllers:
            action = GripperCommand if c.action_type == GRIPPER_COMMAND else FollowJointTrajectory
            self._clients[c.name] = ActionClient(monitor, action, c.action_name)
            self._by_goal[c.name] = OrderedDict()
            # JTC publishes its state at every update: the heartbeat that tells a busy controller
            # (a goal not yet answered, feedback delayed on a loaded machine) from a lost one. It
            # is read when asked for (controller_state), not at each of its 100 messages a second
            # (liveness only: raw, never deserialized).
            self._heartbeats[c.name] = TopicReader(monitor, JointTrajectoryControllerState,
                                                   f"/{c.name}/controller_state", HEARTBEAT_QOS, raw=True)

    # ------------------------------------------------------------------ ControllerBus
    def is_available(self, controller: str) -> bool:
        return self._clients[controller].server_is_ready()

    def send(self, controller: str, trajectory: JointTrajectory) -> None:
        info = self._controllers[controller]
        goal_id = trajectory.frame_id or f"{controller}#{uuid.uuid4().hex[:8]}"
        if info.action_type == GRIPPER_COMMAND:
            goal = GripperCommand.Goal()
            last = trajectory.points[-1]
            index = list(trajectory.joint_names).index(info.joints[0])
            goal.command.position = float(last.positions[index])
            efforts = getattr(last, "effort", None) or []
            goal.command.max_effort = float(efforts[index]) if len(efforts) > index else DEFAULT_MAX_EFFORT
        else:
            goal = FollowJointTrajectory.Goal()
            goal.trajectory = joint_trajectory_to_msg(trajectory)
            goal.trajectory.header.frame_id = ""
        self._record(controller, ControllerState("executing", True, "goal sent", goal_id, tuple(info.joints),
                                                 time.monotonic()))
        future = self._clients[controller].send_goal_async(
            goal, feedback_callback=lambda msg, c=controller, g=goal_id: self._on_action_feedback(c, g, msg))
        future.add_done_callback(lambda f, c=controller, g=goal_id: self._on_goal_response(c, g, f))

    def stop(self, controller: str) -> None:
        """Cancel the controller's goal and wait (briefly) for the controller to confirm, so the
        joints are at rest when the execution reports PREEMPTED."""
        with self._lock:
            handle = self._handles.get(controller)
        if handle is None:
            return
        done = threading.Event()
        handle.cancel_goal_async().add_done_callback(lambda _: done.set())
        if not done.wait(CANCEL_CONFIRM_TIMEOUT):
            self._node.get_logger().warning(f"controller '{controller}' did not confirm the cancel within "
                                            f"{CANCEL_CONFIRM_TIMEOUT:g} s")

    def controller_state(self, controller: str, goal_id: str | None = None) -> ControllerState | None:
        """The goal's state, or (no ``goal_id``) the latest one, heard as recently as the last
        controller_state heartbeat."""
        if goal_id is None:
            self._read_heartbeat(controller)
        with self._lock:
            if goal_id is not None:
                return self._by_goal.get(controller, {}).get(goal_id)
            latest = self._latest.get(controller)
            alive = self._alive.get(controller)
        if latest is None or alive is None or alive <= latest.received:
            return latest
        return dataclasses.replace(latest, received=alive)

    def _read_heartbeat(self, controller: str) -> None:
        """Take the newest controller_state of ``controller`` (if one came since the last read)
        and note when it arrived."""
        reader = self._heartbeats.get(controller)
        if reader is None or reader.take_latest() is None:
            return
        age = max(0.0, (time.time_ns() - reader.last_received_ns) * 1e-9) if reader.last_received_ns else 0.0
        with self._lock:
            self._alive[controller] = time.monotonic() - age

    def close(self) -> None:
        """Destroy the heartbeat subscriptions (before their node)."""
        for reader in self._heartbeats.values():
            reader.destroy()

    def summary(self) -> dict[str, Any]:
        now = time.monotonic()
        with self._lock:
            return {
                name: {"status": s.status, "goal_id": s.goal_id, "message": s.message, "age": now - s.received}
                for name, s in self._latest.items()
            }

    # ------------------------------------------------------------------ action callbacks
    def _record(self, controller: str, state: ControllerState) -> None:
        with self._lock:
            goals = self._by_goal[controller]
            known = goals.get(state.goal_id)
            if known is not None and not known.active and state.active:
                # a goal's end is final: a feedback message handled after its result (the executor's
                # threads may run them out of order; a gripper goal that ends in one control cycle
                # made this happen) must not turn it back into "executing"
                return
            self._latest[controller] = state
            goals[state.goal_id] = state
            goals.move_to_end(state.goal_id)
            while len(goals) > self.MAX_GOALS:
                goals.popitem(last=False)
        self._on_feedback()

    def _state(self, controller: str, goal_id: str, status: str, message: str) -> ControllerState:
        return ControllerState(status, status == "executing", message, goal_id,
                               tuple(self._controllers[controller].joints), time.monotonic())

    def _on_goal_response(self, controller: str, goal_id: str, future: Any) -> None:
        try:
            handle = future.result()
        except Exception as exc:  # transport failure
            self._record(controller, self._state(controller, goal_id, "aborted", f"sending the goal failed: {exc}"))
            return
        if not handle.accepted:
            self._record(controller, self._state(
                controller, goal_id, "aborted",
                "rejected: the controller refused the goal (its log says why)"))
            return
        with self._lock:
            self._handles[controller] = handle
        self._record(controller, self._state(controller, goal_id, "executing", "goal accepted"))
        handle.get_result_async().add_done_callback(
            lambda f, c=controller, g=goal_id, h=handle: self._on_result(c, g, h, f))

    def _on_action_feedback(self, controller: str, goal_id: str, msg: Any) -> None:
        self._record(controller, self._state(controller, goal_id, "executing", "executing"))

    def _on_result(self, controller: str, goal_id: str, handle: Any, future: Any) -> None:
        with self._lock:
            if self._handles.get(controller) is handle:
                del self._handles[controller]
        try:
            response = future.result()
        except Exception as exc:
            self._record(controller, self._state(controller, goal_id, "failed", f"no result: {exc}"))
            return
        status, result = response.status, response.result
        if isinstance(result, GripperCommand.Result):
            detail = (f"position {result.position:.4f}, effort {result.effort:g}, stalled {result.stalled}, "
                      f"reached_goal {result.reached_goal}")
            ok = status == GoalStatus.STATUS_SUCCEEDED and result.reached_goal
        else:
            code = FJT_ERRORS.get(result.error_code, str(result.error_code))
            detail = f"{code}: {result.error_string}" if result.error_code else result.error_string
            ok = status == GoalStatus.STATUS_SUCCEEDED and result.error_code == 0
        if ok:
            self._record(controller, self._state(controller, goal_id, "succeeded", "goal succeeded"))
        elif status == GoalStatus.STATUS_CANCELED:
            self._record(controller, self._state(controller, goal_id, "stopped", f"goal canceled ({detail})"))
        else:
            self._record(controller, self._state(controller, goal_id, "failed", detail or "goal aborted"))
