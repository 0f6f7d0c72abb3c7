"""Data behaviors of MoveIt Pro's core set: log, wait, loop over a vector, and the saved
waypoints and robot states an objective moves between."""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ..action_node import StatefulActionNode
from ..basic_types import FAILURE, IDLE, RUNNING, SKIPPED, SUCCESS, NodeStatus, is_status_completed
from ..decorator_node import DecoratorNode
from ..ports import ANY, DOUBLE, INT, STRING, input_port, output_port
from .context import JOINT_STATE, BehaviorContext, JointStateValue
from .pose_behaviors import _ContextAction
from .waypoints import Waypoint, WaypointError

LOG_LEVELS = ("debug", "info", "warn", "error")


class LogMessage(_ContextAction):
    DESCRIPTION = "Writes a message to the objective's log (and the objective server's ROS log)."

    @classmethod
    def provided_ports(cls):
        return (input_port("message", STRING, description="the text to log"),
                input_port("log_level", STRING, "info", "debug, info, warn or error"))

    def tick(self) -> NodeStatus:
        level = self.get_input("log_level").lower()
        if level not in LOG_LEVELS:
            return self.fail(f"log_level must be one of {', '.join(LOG_LEVELS)}, got '{level}'")
        self.context.log(level, self.get_input("message"))
        return SUCCESS


class WaitForDuration(StatefulActionNode):
    DESCRIPTION = "RUNNING for delay_duration seconds of the tree's clock, then SUCCESS."

    def __init__(self, name: str, config: Any, context: BehaviorContext | None = None):
        super().__init__(name, config)
        self._deadline = 0.0

    @classmethod
    def provided_ports(cls):
        return (input_port("delay_duration", DOUBLE, 1.0, "how long to wait (s)"),)

    def on_start(self) -> NodeStatus:
        delay = self.get_input("delay_duration")
        if delay < 0.0:
            raise ValueError(f"delay_duration must be >= 0, got {delay}")
        self._deadline = self.now() + delay
        self.wake_up_at(self._deadline)
        return RUNNING if delay > 0.0 else SUCCESS

    def on_running(self) -> NodeStatus:
        return SUCCESS if self.now() >= self._deadline else RUNNING


class ForEach(DecoratorNode):
    """Ticks its child once per element of ``vector_in`` (written to ``out``, its position to
    ``index``), one element per tick; FAILURE as soon as the child fails, SUCCESS after the
    last element (also for an empty vector)."""

    DESCRIPTION = "Runs its child once for each element of a vector, writing the element to out."

    @classmethod
    def provided_ports(cls):
        return (input_port("vector_in", ANY, description="the vector to loop over (a blackboard entry or a;b;c)"),
                output_port("out", ANY, description="the current element"),
                output_port("index", INT, description="the current element's position, from 0"))

    def __init__(self, name: str, config: Any, context: BehaviorContext | None = None):
        super().__init__(name, config)
        self._items: list = []
        self._index = 0
        self._child_running = False

    def tick(self) -> NodeStatus:
        if self._status is IDLE:
            value = self.get_input("vector_in")
            if isinstance(value, str):
                value = value.split(";") if value else []
            if not isinstance(value, Sequence):
                raise ValueError(f"vector_in must be a vector, got {type(value).__name__}")
            self._items, self._index, self._child_running = list(value), 0, False
            self.set_status(RUNNING)
        if self._index >= len(self._items):
            return SUCCESS
        if not self._child_running:
            self.set_output("out", self._items[self._index])
            self.set_output("index", self._index)
        status = self.child.execute_tick()
        self._child_running = status is RUNNING
        if status is FAILURE:
            self.reset_child()
            return FAILURE
        if is_status_completed(status) or status is SKIPPED:
            self.reset_child()
            self._index += 1
            if self._index >= len(self._items):
                return SUCCESS
            self.emit_wake_up_signal()
        return RUNNING

    def halt(self) -> None:
        self._child_running = False
        super().halt()


class RetrieveWaypoint(_ContextAction):
    DESCRIPTION = "Reads a saved waypoint's joint state (for the joints of joint_group_name) from the waypoints file."

    @classmethod
    def provided_ports(cls):
        return (input_port("waypoint_name", STRING, description="the saved waypoint"),
                input_port("joint_group_name", STRING, "arm", "the planning group whose joints are kept; "
                           "empty: every joint of the waypoint"),
                output_port("waypoint_joint_state", JOINT_STATE, description="the waypoint's joint state"))

    def tick(self) -> NodeStatus:
        try:
            waypoint = self.context.waypoints.get(self.get_input("waypoint_name"))
        except WaypointError as exc:
            return self.fail(str(exc))
        self.set_output("waypoint_joint_state", JointStateValue(list(waypoint.joint_names), list(waypoint.positions)))
        return SUCCESS


class SaveCurrentState(_ContextAction):
    DESCRIPTION = "Writes the robot's current joint state to the blackboard."

    @classmethod
    def provided_ports(cls):
        return (output_port("saved_robot_state", JOINT_STATE, description="the joint state now"),)

    def tick(self) -> NodeStatus:
        try:
            state = self.context.current_joint_state()
        except LookupError as exc:
            return self.fail(str(exc))
        self.set_output("saved_robot_state", state)
        return SUCCESS


class SaveWaypoint(_ContextAction):
    DESCRIPTION = "Saves the robot's current joint state as a named waypoint (in the waypoints file)."

    @classmethod
    def provided_ports(cls):
        return (input_port("waypoint_name", STRING, description="the name to save it under (replaces one)"),
                input_port("description", STRING, "", "what the waypoint is for"))

    def tick(self) -> NodeStatus:
        try:
            state = self.context.current_joint_state()
        except LookupError as exc:
            return self.fail(str(exc))
        try:
            self.context.waypoints.save(Waypoint(self.get_input("waypoint_name"), list(state.name),
                                                 list(state.position), self.get_input("description")), overwrite=True)
        except WaypointError as exc:
            return self.fail(str(exc))
        return SUCCESS


DATA_BEHAVIORS = (LogMessage, WaitForDuration, ForEach, RetrieveWaypoint, SaveCurrentState, SaveWaypoint)
