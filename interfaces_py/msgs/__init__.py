"""MoveIt-style messages as plain, validated dataclasses with an exact JSON wire form.

One module per message family (base machinery, geometry, scene, trajectory, task constructor);
everything is importable from here. The full story: docs/interfaces.md, section interfaces_py.msgs.
"""
from .base import (MAX_MESH_TRIANGLES, MAX_MESH_VERTICES, MAX_NAME_LENGTH, MAX_OBJECT_EXTENT,  # noqa: F401
                   WORKSPACE_BOUND, MessageError, _convert, _describe, _Message, _require_len, printable)
from .geometry import Mesh, Pose, SolidPrimitive
from .scene import (AllowedCollisionMatrix, AttachedCollisionObject, CollisionObject, PlanningScene,
                    PlanningSceneWorld, RobotState)
from .task import (SolutionInfo, StageDescription, StageStatistics, SubTrajectory, TaskDescription,  # noqa: F401
                   TaskSolution, TaskStatistics, TrajectoryExecutionInfo)
from .trajectory import JointTrajectory, JointTrajectoryPoint, MoveItErrorCode, RobotTrajectory

__all__ = [
    "MessageError",
    "Pose",
    "SolidPrimitive",
    "Mesh",
    "CollisionObject",
    "AttachedCollisionObject",
    "AllowedCollisionMatrix",
    "RobotState",
    "PlanningSceneWorld",
    "PlanningScene",
    "JointTrajectoryPoint",
    "JointTrajectory",
    "RobotTrajectory",
    "MoveItErrorCode",
]
# The task-constructor messages (defined at the end of this module) are listed separately until
# interfaces_py/__init__.py and the generic message tests include them; import them by name.
TASK_MESSAGES = (
    "TrajectoryExecutionInfo",
    "SolutionInfo",
    "SubTrajectory",
    "TaskSolution",
    "StageDescription",
    "TaskDescription",
    "StageStatistics",
    "TaskStatistics",
)

