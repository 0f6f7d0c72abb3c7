"""What a behavior may ask of the application that runs it, without ROS: a log, a place to show
poses, frame transforms, the robot's current joints, the saved waypoints and the operator.

The objective server (mycobot_planning.ros.objectives) gives the ROS answers; tests and
``run_objective`` use this base, which knows one frame and no robot. Behaviors receive the
context as their constructor argument (``factory.register_node_type(cls, ID, context)``).
"""
from __future__ import annotations

import json
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..ports import ConversionError, PortType, PoseStamped, _cast_pose_stamped, _parse_pose_stamped, split_string
from .operator import OperatorPrompts
from .waypoints import WaypointStore

_LOG = logging.getLogger("mycobot_planning.objectives")


@dataclass
class JointStateValue:
    """sensor_msgs/JointState's names and positions (what waypoints and SaveCurrentState hold)."""

    name: list[str] = field(default_factory=list)
    position: list[float] = field(default_factory=list)

    def __post_init__(self) -> None:
        if len(self.name) != len(self.position):
            raise ConversionError(f"a joint state needs as many positions as names, got {len(self.name)} names "
                                  f"and {len(self.position)} positions")

    def as_dict(self) -> dict[str, float]:
        return dict(zip(self.name, self.position))

    def to_dict(self) -> dict[str, Any]:
        return {"name": list(self.name), "position": list(self.position)}


def _parse_joint_state(text: str) -> JointStateValue:
    """``joint:value;joint:value`` (or ``json:{"name": [...], "position": [...]}``)."""
    names, positions = [], []
    for part in split_string(text):
        joint, sep, value = part.partition(":")
        if not sep or not joint.strip():
            raise ConversionError(f"a joint state is written joint:value;joint:value, got [{text}]")
        try:
            positions.append(float(value))
        except ValueError:
            raise ConversionError(f"joint '{joint.strip()}': [{value}] is not a number") from None
        names.append(joint.strip())
    return JointStateValue(names, positions)


def _cast_joint_state(value: Any) -> JointStateValue:
    if isinstance(value, JointStateValue):
        return value
    if isinstance(value, Mapping):
        if "name" in value and "position" in value:
            return JointStateValue([str(n) for n in value["name"]], [float(p) for p in value["position"]])
        return JointStateValue([str(k) for k in value], [float(v) for v in value.values()])
    names, positions = getattr(value, "name", None), getattr(value, "position", None)
    if names is not None and positions is not None:  # a sensor_msgs/JointState
        return JointStateValue([str(n) for n in names], [float(p) for p in positions])
    raise ConversionError(f"expected a joint state, got {type(value).__name__}")


#: sensor_msgs/JointState (names and positions)
JOINT_STATE = PortType("sensor_msgs::msg::JointState", parse=_parse_joint_state, cast=_cast_joint_state)


def _parse_pose_vector(text: str) -> list[PoseStamped]:
    if text.startswith("json:"):
        return [_cast_pose_stamped(v) for v in json.loads(text[5:])]
    raise ConversionError("a vector of poses is given as a blackboard entry or json:[...]")


def _cast_pose_vector(value: Any) -> list[PoseStamped]:
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
        raise ConversionError(f"expected a vector of poses, got {type(value).__name__}")
    return [_cast_pose_stamped(v) for v in value]


#: std::vector<geometry_msgs::msg::PoseStamped>
VECTOR_POSE_STAMPED = PortType("std::vector<geometry_msgs::msg::PoseStamped>", parse=_parse_pose_vector,
                               cast=_cast_pose_vector)


class BehaviorContext:
    """The application behind the behaviors. This base runs without ROS: it logs through
    ``logging``, knows only identical frames, has no robot, and keeps waypoints and operator
    prompts in memory (the objective server publishes both)."""

    def __init__(self, waypoints: WaypointStore | None = None, operator: OperatorPrompts | None = None,
                 logger: logging.Logger | None = None) -> None:
        self.waypoints = waypoints if waypoints is not None else WaypointStore()
        self.operator = operator if operator is not None else OperatorPrompts()
        self.logger = logger or _LOG
        self.objective_name = ""

    def log(self, level: str, text: str) -> None:
        getattr(self.logger, {"warn": "warning"}.get(level, level), self.logger.info)(text)

    def visualize_pose(self, marker_name: str, pose: PoseStamped, size: float, lifetime: float, text: str) -> None:
        self.log("info", f"pose '{marker_name}': {pose.to_dict()}")

    def lookup_transform(self, target_frame: str, source_frame: str) -> np.ndarray:
        """The 4x4 pose of ``source_frame`` in ``target_frame``; LookupError if unknown."""
        if target_frame == source_frame:
            return np.eye(4)
        raise LookupError(f"no transform from '{source_frame}' to '{target_frame}' (no robot connected)")

    def current_joint_state(self) -> JointStateValue:
        raise LookupError("the robot's joint states are not available (no robot connected)")


__all__ = ["BehaviorContext", "JOINT_STATE", "JointStateValue", "VECTOR_POSE_STAMPED",
           "_parse_pose_stamped"]
