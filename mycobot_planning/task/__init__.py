"""ROS-free task constructor: MoveIt Task Constructor's stages, containers, solvers, cost terms
and introspection on the mycobot_planning core.

MTC's Python bindings are split into ``core`` and ``stages``; so is this package::

    from mycobot_planning.task import Task, core, stages

    task = Task("demo", model, scene)
    task.add(stages.CurrentState("current"))
    move = stages.MoveRelative("x +0.05", core.CartesianPath())
    move.group = "arm"
    move.setDirection(core.Vector3Stamped("base_link", [0.05, 0, 0]))
    task.add(move)
    task.plan()
    task.printState()

Nothing here imports rclpy.
"""
from . import cost_terms, stages
from .containers import Alternatives, ContainerBase, Fallbacks, Merger, ParallelContainerBase, SerialContainer, WrapperBase
from .cost_terms import (
    Clearance,
    Constant,
    CostTerm,
    DistanceToReference,
    LambdaCostTerm,
    LinkMotion,
    PathLength,
    TrajectoryCostTerm,
    TrajectoryDuration,
)
from .errors import InitStageException, PropertyError, PropertyTypeError, PropertyUndeclared, PropertyUndefined, TaskError
from .geometry import PointStamped, PoseStamped, TwistStamped, Vector3Stamped
from .properties import Property, PropertyInitializerSource, PropertyMap
from .solvers import CartesianPath, JointInterpolationPlanner, PipelinePlanner, PlannerInterface, PlanResult
from .stage import Connecting, Generator, MonitoringGenerator, PropagatingBackward, PropagatingEitherWay, PropagatingForward, Stage
from .storage import InterfaceState, SolutionBase, SolutionSequence, SubTrajectory, WrappedSolution
from .task import Task
from . import core  # noqa: E402  (MTC-style namespace, imports the names above)

__all__ = [
    "Alternatives",
    "CartesianPath",
    "Clearance",
    "Connecting",
    "Constant",
    "ContainerBase",
    "CostTerm",
    "DistanceToReference",
    "Fallbacks",
    "Generator",
    "InitStageException",
    "InterfaceState",
    "JointInterpolationPlanner",
    "LambdaCostTerm",
    "LinkMotion",
    "Merger",
    "MonitoringGenerator",
    "ParallelContainerBase",
    "PathLength",
    "PipelinePlanner",
    "PlanResult",
    "PlannerInterface",
    "PointStamped",
    "PoseStamped",
    "PropagatingBackward",
    "PropagatingEitherWay",
    "PropagatingForward",
    "Property",
    "PropertyError",
    "PropertyInitializerSource",
    "PropertyMap",
    "PropertyTypeError",
    "PropertyUndeclared",
    "PropertyUndefined",
    "SerialContainer",
    "SolutionBase",
    "SolutionSequence",
    "Stage",
    "SubTrajectory",
    "Task",
    "TaskError",
    "TrajectoryCostTerm",
    "TrajectoryDuration",
    "TwistStamped",
    "Vector3Stamped",
    "WrappedSolution",
    "WrapperBase",
    "core",
    "cost_terms",
    "stages",
]
