"""A blocking client of the objective_server: send /do_objective, wait for the result, and read
the final root blackboard from ~/tree_state (``run_objective --server`` and tests use it)."""
from __future__ import annotations

import json
import threading
import time
import uuid
from typing import Any

import rclpy
from action_msgs.msg import GoalStatus
from mycobot_objective_msgs.action import DoObjectiveSequence
from mycobot_objective_msgs.msg import BehaviorParameter, BehaviorParameterDescription
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import String

from interfaces_py.action_client import ActionClient
from interfaces_py.background_spin import BackgroundSpin
from mycobot_planning.paths import use_fast_discovery

from .ros_context import LATCHED

SERVER = "/objective_server"


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
        self._action = ActionClient(self.node, DoObjectiveSequence, "/do_objective")
        executor = SingleThreadedExecutor(context=self._context)
        executor.add_node(self.node)
        self._spin = BackgroundSpin(executor, name="objective client executor")

    def _on_state(self, msg: String) -> None:
        with self._lock:
            self._state = json.loads(msg.data)

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
        sent = self._action.send_goal_async(goal)
        deadline = time.monotonic() + timeout
        while not sent.done():
            if time.monotonic() > deadline:
                return GoalStatus.STATUS_UNKNOWN, None
            time.sleep(0.01)
        self.handle = sent.result()
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
