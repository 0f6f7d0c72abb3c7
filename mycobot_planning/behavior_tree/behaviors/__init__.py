"""MoveIt Pro's core behaviors that need no ROS (poses, data, waypoints, the operator prompt),
registered on a factory with the context they run in. The ROS ones (motion, scene, perception)
are in mycobot_planning.ros.objectives. See docs/objectives.md."""
from __future__ import annotations

from ..bt_factory import BehaviorTreeFactory
from .context import JOINT_STATE, VECTOR_POSE_STAMPED, BehaviorContext, JointStateValue
from .data_behaviors import DATA_BEHAVIORS
from .operator import OperatorPrompt, OperatorPrompts, RequestTeleoperation, WaitForUserTrajectoryApproval
from .pose_behaviors import POSE_BEHAVIORS
from .waypoints import Waypoint, WaypointError, WaypointStore

#: (class, registration ID, subcategory) of every ROS-free behavior
CORE_BEHAVIORS = (
    *[(cls, cls.__name__, "Poses") for cls in POSE_BEHAVIORS],
    *[(cls, cls.__name__, "Data") for cls in DATA_BEHAVIORS],
    (RequestTeleoperation, "RequestTeleoperation", "Operator"),
    (WaitForUserTrajectoryApproval, "WaitForUserTrajectoryApproval", "Operator"),
)


def register_core_behaviors(factory: BehaviorTreeFactory, context: BehaviorContext) -> None:
    """Register every ROS-free behavior on ``factory``, bound to ``context``."""
    for cls, registration_id, subcategory in CORE_BEHAVIORS:
        factory.register_node_type(cls, registration_id, context, metadata={"subcategory": subcategory})


__all__ = ["BehaviorContext", "CORE_BEHAVIORS", "JOINT_STATE", "JointStateValue", "OperatorPrompt",
           "OperatorPrompts", "RequestTeleoperation", "VECTOR_POSE_STAMPED", "WaitForUserTrajectoryApproval",
           "Waypoint", "WaypointError", "WaypointStore", "register_core_behaviors"]
