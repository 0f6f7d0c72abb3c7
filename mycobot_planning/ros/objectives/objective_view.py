"""The viewer's Objectives panel fed from the objective_server's interfaces: its status, tree
state and operator prompt topics in, /do_objective, /cancel_objective and the prompt answers
out, the library polled from ~/get_objectives. Nothing here waits: the panel's buttons send
requests and their outcomes come back on the topics."""
from __future__ import annotations

import json
from typing import Any

from mycobot_objective_msgs.action import DoObjectiveSequence
from mycobot_objective_msgs.msg import ObjectiveServerStatus, OperatorPrompt
from mycobot_objective_msgs.srv import AnswerOperatorPrompt, CancelObjective
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from std_msgs.msg import String
from std_srvs.srv import Trigger

from interfaces_py.action_client import ActionClient
from mycobot_planning.visualization.objective_panel import ObjectiveActions, ObjectivePanel

from .ros_context import LATCHED

ANSWERS = {"continue": AnswerOperatorPrompt.Request.CONTINUE, "fail": AnswerOperatorPrompt.Request.FAIL,
           "waypoint": AnswerOperatorPrompt.Request.MOVE_TO_WAYPOINT}


class ObjectiveView:
    """Connects a viewer's ObjectivePanel to the objective_server ``server`` (e.g. /objective_server)."""

    def __init__(self, node: Node, server: str, poll_period: float = 2.0) -> None:
        self.node = node
        self.server = server.rstrip("/")
        self.panel: ObjectivePanel | None = None
        group = MutuallyExclusiveCallbackGroup()
        self._action = ActionClient(node, DoObjectiveSequence, "/do_objective", callback_group=group)
        self._cancel = node.create_client(CancelObjective, "/cancel_objective", callback_group=group)
        self._answer = node.create_client(AnswerOperatorPrompt, f"{self.server}/answer_operator_prompt",
                                          callback_group=group)
        self._library = node.create_client(Trigger, f"{self.server}/get_objectives", callback_group=group)
        node.create_subscription(ObjectiveServerStatus, f"{self.server}/status", self._on_status, LATCHED,
                                 callback_group=group)
        node.create_subscription(String, f"{self.server}/tree_state", self._on_tree_state, LATCHED,
                                 callback_group=group)
        node.create_subscription(OperatorPrompt, f"{self.server}/operator_prompt", self._on_prompt, LATCHED,
                                 callback_group=group)
        node.create_timer(poll_period, self._poll_library, callback_group=group)

    def actions(self) -> ObjectiveActions:
        return ObjectiveActions(run=self.run, stop=self.stop, answer=self.answer)

    def attach(self, panel: ObjectivePanel) -> None:
        self.panel = panel
        self._poll_library()

    # -- out --------------------------------------------------------------------------------
    def run(self, name: str) -> None:
        if not self._action.server_is_ready():
            self.node.get_logger().warning(f"cannot run '{name}': /do_objective is not available")
            return
        self._action.send_goal_async(DoObjectiveSequence.Goal(objective_name=name))
        self.node.get_logger().info(f"viewer: run objective '{name}'")

    def stop(self) -> None:
        if self._cancel.service_is_ready():
            self._cancel.call_async(CancelObjective.Request())

    def answer(self, prompt_id: int, answer: str, waypoint: str) -> None:
        if answer not in ANSWERS or not self._answer.service_is_ready():
            return
        request = AnswerOperatorPrompt.Request(prompt_id=prompt_id, answer=ANSWERS[answer], waypoint_name=waypoint)
        self._answer.call_async(request)

    # -- in ---------------------------------------------------------------------------------
    def _poll_library(self) -> None:
        if self.panel is None or not self._library.service_is_ready():
            return
        future = self._library.call_async(Trigger.Request())
        future.add_done_callback(self._on_library)

    def _on_library(self, future: Any) -> None:
        try:
            library = json.loads(future.result().message)
        except Exception:  # a server answering something else: keep the last library
            return
        if self.panel is not None:
            self.panel.on_library([o["name"] for o in library.get("objectives", [])], library.get("waypoints", []))

    def _on_status(self, msg: ObjectiveServerStatus) -> None:
        if self.panel is not None:
            self.panel.on_status(msg.objective_name, msg.objective_status, msg.message)

    def _on_tree_state(self, msg: String) -> None:
        if self.panel is not None:
            try:
                self.panel.on_tree_state(json.loads(msg.data))
            except ValueError:
                return

    def _on_prompt(self, msg: OperatorPrompt) -> None:
        if self.panel is not None:
            self.panel.on_prompt({"prompt_id": msg.prompt_id, "active": msg.active, "prompt": msg.prompt,
                                  "node_path": msg.node_path, "objective_name": msg.objective_name,
                                  "waypoint_names": list(msg.waypoint_names)})
