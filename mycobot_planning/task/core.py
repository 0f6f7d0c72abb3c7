"""MTC's ``core`` namespace: Task, containers, solvers, cost terms and geometry in one place
(``from mycobot_planning.task import core; core.CartesianPath()``)."""
from .containers import Alternatives, ContainerBase, Fallbacks, Merger, ParallelContainerBase, SerialContainer, WrapperBase
from interfaces_py.msgs import MoveItErrorCode

from ..core.planners.cartesian.cartesian_precision import CartesianPrecision
from .cost_terms import (Clearance, Constant, CostTerm, DistanceToReference, LambdaCostTerm, LinkMotion, LinkRotation,
                         PathLength, TrajectoryCostTerm, TrajectoryDuration)
from .errors import InitStageException, TaskError
from .geometry import PointStamped, PoseStamped, TwistStamped, Vector3Stamped
from .properties import Property, PropertyInitializerSource, PropertyMap
from .solvers import CartesianPath, JointInterpolationPlanner, MultiPlanner, PipelinePlanner, PlannerInterface
from .stage import (Connecting, Generator, MonitoringGenerator, PropagatingBackward, PropagatingEitherWay,
                    PropagatingForward, Stage)
from .storage import InterfaceState, SolutionBase, SolutionSequence, SubTrajectory, WrappedSolution
from .task import Task

#: MTC's Python names for two of ours: the exception a stage's init raises, and the base class of
#: every solution
InitStageError = InitStageException
Solution = SolutionBase

__all__ = [
    "Alternatives", "CartesianPath", "CartesianPrecision", "Clearance", "Connecting", "Constant", "ContainerBase", "CostTerm",
    "DistanceToReference", "Fallbacks", "Generator", "InitStageError", "InitStageException", "InterfaceState",
    "JointInterpolationPlanner", "LambdaCostTerm", "LinkMotion", "LinkRotation", "Merger", "MoveItErrorCode",
    "MultiPlanner", "MonitoringGenerator", "ParallelContainerBase", "PathLength", "PipelinePlanner", "PlannerInterface",
    "PointStamped", "PoseStamped", "PropagatingBackward", "PropagatingEitherWay", "PropagatingForward", "Property",
    "PropertyInitializerSource", "PropertyMap", "SerialContainer", "Solution", "SolutionBase", "SolutionSequence", "Stage",
    "SubTrajectory", "Task", "TaskError", "TrajectoryCostTerm", "TrajectoryDuration", "TwistStamped", "Vector3Stamped",
    "WrappedSolution", "WrapperBase",
]
