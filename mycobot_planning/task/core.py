"""MTC's ``core`` namespace: Task, containers, solvers, cost terms and geometry in one place
(``from mycobot_planning.task import core; core.CartesianPath()``)."""
from .containers import Alternatives, ContainerBase, Fallbacks, Merger, ParallelContainerBase, SerialContainer, WrapperBase
from .cost_terms import (Clearance, Constant, CostTerm, DistanceToReference, LambdaCostTerm, LinkMotion, PathLength,
                         TrajectoryCostTerm, TrajectoryDuration)
from .errors import InitStageException, TaskError
from .geometry import PointStamped, PoseStamped, TwistStamped, Vector3Stamped
from .properties import Property, PropertyInitializerSource, PropertyMap
from .solvers import CartesianPath, JointInterpolationPlanner, MultiPlanner, PipelinePlanner, PlannerInterface
from .stage import Connecting, Generator, MonitoringGenerator, PropagatingEitherWay, Stage
from .storage import InterfaceState, SolutionBase, SolutionSequence, SubTrajectory, WrappedSolution
from .task import Task

__all__ = [
    "Alternatives", "CartesianPath", "Clearance", "Connecting", "Constant", "ContainerBase", "CostTerm",
    "DistanceToReference", "Fallbacks", "Generator", "InitStageException", "InterfaceState", "JointInterpolationPlanner",
    "LambdaCostTerm", "LinkMotion", "Merger", "MultiPlanner", "MonitoringGenerator", "ParallelContainerBase", "PathLength",
    "PipelinePlanner", "PlannerInterface", "PointStamped", "PoseStamped", "PropagatingEitherWay", "Property",
    "PropertyInitializerSource", "PropertyMap", "SerialContainer", "SolutionBase", "SolutionSequence", "Stage",
    "SubTrajectory", "Task", "TaskError", "TrajectoryCostTerm", "TrajectoryDuration", "TwistStamped", "Vector3Stamped",
    "WrappedSolution", "WrapperBase",
]
