"""A blocking client of the objective_server: send /do_objective, wait for the result, and read
the final root blackboard from ~/tree_state (``run_objective --server`` and tests use it).

A goal's response can be lost on a loaded machine: when the server has not yet matched this
client's response reader, Fast DDS drops it ("failed to send response (timeout): client will not
receive response") although the goal was accepted and runs. rclpy's future then never completes.
So the client names its goal itself and also reads the action's status topic: a goal the status
lists as accepted is followed to its result without the lost response."""
from __future__ import annotations

import json
import threading
import time
import uuid
from typing import Any

import rclpy
from action_msgs.msg import GoalStatus, GoalStatusArray
from mycobot_objective_msgs.action import DoObjectiveSequence
from mycobot_objective_msgs.msg import BehaviorParameter, BehaviorParameterDescription
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.action.client import ClientGoalHandle
from rclpy.node import Node
from rclpy.qos import qos_profile_action_status_default
from std_msgs.msg import String
from unique_identifier_msgs.msg import UUID

from interfaces_py.action_client import ActionClient
from interfaces_py.background_spin import BackgroundSpin
from mycobot_planning.paths import use_fast_discovery

from .ros_context import LATCHED

SERVER = "/objective_server"
ACTION = "/do_objective"
#: s: how long a goal's response is awaited before the status topic is asked whether it was accepted
GOAL_RESPONSE_WAIT = 3.0


def string_override(name: str, value: str) -> BehaviorParameter:
    parameter = BehaviorParameter()
    parameter.description.name = name
    parameter.description.type = BehaviorParameterDescription.TYPE_STRING
    parameter.string_value = value
    return parameter


class ObjectiveClient:
    """Runs objectives on the objective_server from a private node (its own context and spin)."""

    def __init__(self, server: str = SERVER) -> None:
        use_fast_discovery()
        self._context = Context()
        rclpy.init(context=self._context)
        self.node = Node(f"objective_client_{uuid.uuid4().hex[:8]}", context=self._context)
        self._lock = threading.Lock()
        self._state: dict[str, Any] | None = None
        self.node.create_subscription(String, f"{server}/tree_state", self._on_state, LATCHED)
        self._action = ActionClient(self.node, DoObjectiveSequence, ACTION)
        self._listed: set[bytes] = set()  # goal ids the action's status topic has listed
        self.node.create_subscription(GoalStatusArray, f"{ACTION}/_action/status", self._on_status,
                                      qos_profile_action_status_default)
        executor = SingleThreadedExecutor(context=self._context)
        executor.add_node(self.node)
        self._spin = BackgroundSpin(executor, name="objective client executor")

    def _on_state(self, msg: String) -> None:
        with self._lock:
            self._state = json.loads(msg.data)

    def _on_status(self, msg: GoalStatusArray) -> None:
        with self._lock:
            self._listed.update(bytes(s.goal_info.goal_id.uuid) for s in msg.status_list)

    def _accepted_without_response(self, goal_id: UUID) -> ClientGoalHandle | None:
        """A handle for a goal whose response was lost but that the status topic lists (the server
        lists only goals it accepted); None while it does not."""
        with self._lock:
            listed = bytes(goal_id.uuid) in self._listed
        if not listed:
            return None
        self.node.get_logger().warning(
            f"{ACTION}: the goal's response never came, but the server lists the goal as accepted: "
            "following it to its result")
        return ClientGoalHandle(self._action, goal_id, DoObjectiveSequence.Impl.SendGoalService.Response(accepted=True))

    def tree_state(self) -> dict[str, Any] | None:
        with self._lock:
            return self._state

    def wait_for_server(self, timeout: float = 10.0) -> bool:
        return self._action.wait_for_server(timeout_sec=timeout)

    def run(self, objective_name: str = "", objective_xml_string: str = "",
            overrides: dict[str, str] | None = None, timeout: float = 600.0) -> tuple[int, Any]:
        """Send a goal and wait: (GoalStatus, DoObjectiveSequence.Result or None)."""
        goal = DoObjectiveSequence.Goal(objective_name=objective_name, objective_xml_string=objective_xml_string,
                                        parameter_overrides=[string_override(k, v) for k, v in
                                                             (overrides or {}).items()])
        self.handle = None
        with self._lock:
            self._state = None
        goal_id = UUID(uuid=list(uuid.uuid4().bytes))
        sent = self._action.send_goal_async(goal, goal_uuid=goal_id)
        started = time.monotonic()
        deadline = started + timeout
        handle = None
        while not sent.done():
            now = time.monotonic()
            if now > deadline:
                return GoalStatus.STATUS_UNKNOWN, None
            if now - started > GOAL_RESPONSE_WAIT and (handle := self._accepted_without_response(goal_id)):
                break
            time.sleep(0.01)
        self.handle = handle or sent.result()
        if not self.handle.accepted:
            return GoalStatus.STATUS_UNKNOWN, None
        result = self.handle.get_result_async()
        while not result.done():
            if time.monotonic() > deadline:
                return GoalStatus.STATUS_UNKNOWN, None
            time.sleep(0.01)
        answer = result.result()
        # the final ~/tree_state is published just before the result; wait for it to arrive
        final = {"Success", "Failure", "Cancelled"}
        end = time.monotonic() + 2.0
        while time.monotonic() < end and (self.tree_state() or {}).get("status") not in final:
            time.sleep(0.01)
        return answer.status, answer.result

    def cancel(self) -> None:
        if getattr(self, "handle", None) is not None:
            self.handle.cancel_goal_async()

    def close(self) -> None:
        self._spin.stop()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self._context)
