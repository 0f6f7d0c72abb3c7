"""MTC's PlannerInterface: the solvers' base (typed properties, the two planning questions,
memoized answers), their result (PlanResult), the process-wide planning pipeline, and the path
constraints every solver resolves in the scene it plans from."""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from ...core.kinematic_constraints.kinematic_constraints import ConstraintError, PathConstraints, dense_violation
from ...core.planning_interface.planning_pipeline import PlanningPipeline
from ...core.planning_scene.planning_scene import PlanningScene
from ...core.robot_trajectory.robot_trajectory import DEFAULT_MAX_WAYPOINT_DISTANCE, TimedTrajectory, limit_waypoint_distance
from ..errors import PropertyError
from ..path_constraints import PathConstraintsSpec, as_path_constraints
from ..properties import PropertyAttributes, PropertyMap, PropertySetter

if TYPE_CHECKING:  # pragma: no cover
    from ...core.robot_model.robot_model import RobotModel
    from ..task import TaskContext

__all__ = ["PlanResult", "PlannerInterface", "check_path", "collision_identity", "constraint_failure", "constraints_key",
           "default_pipeline", "plan_seed"]

_PIPELINE_LOCK = threading.Lock()
_DEFAULT_PIPELINE: PlanningPipeline | None = None


def default_pipeline() -> PlanningPipeline:
    """The process-wide planning pipeline (built on first use, then reused)."""
    global _DEFAULT_PIPELINE
    with _PIPELINE_LOCK:
        if _DEFAULT_PIPELINE is None:
            _DEFAULT_PIPELINE = PlanningPipeline()
        return _DEFAULT_PIPELINE


@dataclass
class PlanResult:
    """A planner's answer: success, the group trajectory (possibly partial), and why."""

    success: bool
    trajectory: TimedTrajectory | None = None
    message: str = ""
    planner_id: str = ""

    def __bool__(self) -> bool:
        return self.success


class PlannerInterface(PropertyAttributes):
    """Base of the solvers: typed properties and the two planning questions."""

    def __init__(self) -> None:
        object.__setattr__(self, "_properties", PropertyMap(lambda: type(self).__name__))
        p = self._properties
        p.declare("max_velocity_scaling_factor", 1.0, "scale down max velocity by this factor", type=float)
        p.declare("max_acceleration_scaling_factor", 1.0, "scale down max acceleration by this factor", type=float)
        p.declare("timeout", math.inf, "upper bound of the planning time (s); the stage's timeout applies too",
                  type=float)
        p.declare("max_waypoint_distance", DEFAULT_MAX_WAYPOINT_DISTANCE,
                  "largest joint motion (rad, or m) between consecutive waypoints of the trajectories this planner "
                  "gives a stage (MTC's JointInterpolationPlanner max_step, 0.1): sparser ones get exact samples "
                  "of their own timing in between", type=float)

    setMaxVelocityScalingFactor = PropertySetter("max_velocity_scaling_factor", float)
    setMaxAccelerationScalingFactor = PropertySetter("max_acceleration_scaling_factor", float)

    def _scaling(self) -> tuple[float, float]:
        values = []
        for name in ("max_velocity_scaling_factor", "max_acceleration_scaling_factor"):
            value = float(self._properties[name])
            if not 0.0 < value <= 1.0:
                raise PropertyError(name, f"must be in (0, 1], got {value}", type(self).__name__)
            values.append(value)
        return values[0], values[1]

    def _timeout(self, timeout: float) -> float:
        limit = float(self._properties["timeout"])
        return min(timeout, limit) if math.isfinite(limit) else timeout

    def init(self, robot_model: "RobotModel") -> None:
        """Check the configuration (ValueError naming the property); the owning stage reports it."""
        self._scaling()
        if not float(self._properties["max_waypoint_distance"]) > 0.0:
            raise ValueError(f"max_waypoint_distance must be > 0, got {self._properties['max_waypoint_distance']}")

    def dense(self, trajectory: TimedTrajectory | None) -> TimedTrajectory | None:
        """``trajectory`` with waypoints at most ``max_waypoint_distance`` apart per joint, its
        timing unchanged (what the stages publish, execute and validate; see
        core.robot_trajectory.limit_waypoint_distance)."""
        if trajectory is None:
            return None
        return limit_waypoint_distance(trajectory, float(self._properties["max_waypoint_distance"]))

    def _memoized(self, context: "TaskContext | None", scene: PlanningScene, parts: tuple,
                  compute: Callable[[], PlanResult]) -> PlanResult:
        """Reuse the result of an identical earlier query of this planning run.

        Only for deterministic planners (Cartesian, joint interpolation): the same planner
        settings, group, start state, target and collision scene give the same answer, so a
        task repeating a module from the same state (the modular demo) plans it once. The scene
        is identified by its compiled collision content, shared by scene copies until one of
        them changes; scenes without it are never reused. The result is kept dense (see
        :meth:`dense`), so a reused answer is not made dense again.
        """
        identity = collision_identity(scene)
        if context is None or identity is None or not context.reuse_plans:
            return compute()
        key = (type(self), tuple(sorted((k, repr(v)) for k, v in self._properties.items())), identity,
               scene.current_state.positions.tobytes()) + parts
        cache = context.plan_cache
        result = cache.get(key)
        if result is None:
            result = compute()
            result.trajectory = self.dense(result.trajectory)
            if len(cache) < context.plan_cache_size:
                cache[key] = result
        return result

    @property
    def planner_id(self) -> str:
        return type(self).__name__

    def getPlannerId(self) -> str:
        return self.planner_id

    def plan(self, from_scene: PlanningScene, to_scene: PlanningScene, group: str, timeout: float,
             context: "TaskContext | None" = None, path_constraints: Any = None) -> PlanResult:
        raise NotImplementedError

    def plan_pose(self, from_scene: PlanningScene, link: str, offset: np.ndarray, target: np.ndarray, group: str,
                  timeout: float, context: "TaskContext | None" = None, path_constraints: Any = None) -> PlanResult:
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"{type(self).__name__}({dict(self._properties.defined())})"


def collision_identity(scene: PlanningScene) -> object | None:
    """What identifies a scene's collision content (world, attached objects, ACM): the compiled
    collision model holder the core shares between copies until one changes. None if the
    scene does not expose one (then nothing is reused)."""
    return getattr(scene, "_slot", None)


def plan_seed(context: "TaskContext | None") -> int | None:
    """The next planner seed of the task's run (None without a context: unseeded)."""
    return None if context is None else context.next_seed()


class _ConstraintProblem(Exception):
    """Path constraints that cannot be used in the scene planned from (the message says why)."""


def _spec(path_constraints: Any) -> PathConstraintsSpec | None:
    """The path constraints a planner was given, as a PathConstraintsSpec (None: none)."""
    if path_constraints is None:
        return None
    try:
        spec = as_path_constraints(path_constraints)
    except (TypeError, ValueError) as exc:
        raise _ConstraintProblem(f"invalid path constraints: {exc}") from None
    return spec or None


def _resolve(path_constraints: Any, scene: PlanningScene) -> PathConstraints | None:
    """The core constraints in ``scene`` (frames and attached objects at its current state)."""
    spec = _spec(path_constraints)
    if spec is None:
        return None
    try:
        return spec.resolve(scene)
    except (ConstraintError, ValueError, KeyError) as exc:
        raise _ConstraintProblem(f"path constraints: {exc}") from None


def constraints_key(path_constraints: Any) -> str:
    """The constraints' part of a memoized query's key ("" without constraints)."""
    spec = _spec(path_constraints)
    return "" if spec is None else spec.key()


def constraint_failure(planner: "PlannerInterface", path_constraints: Any, scene: PlanningScene
                        ) -> tuple[PathConstraints | None, PlanResult | None]:
    """(resolved constraints, None), or (None, the failure to answer with)."""
    try:
        return _resolve(path_constraints, scene), None
    except _ConstraintProblem as exc:
        return None, PlanResult(False, None, str(exc), planner.planner_id)


def check_path(constraints: PathConstraints | None, start, joint_names, path: np.ndarray,
                what: str) -> str | None:
    """Why ``path`` (checked densely along its straight segments) leaves the constraints, or None."""
    if not constraints:
        return None
    found = dense_violation(constraints, start, joint_names, path)
    if found is None:
        return None
    index, fraction, problem = found
    if index == 0 and fraction == 0.0:
        where = "the start state"
    elif index == len(path) - 1:
        where = "the goal state"
    else:
        where = f"the {what}, {100.0 * (index + fraction) / max(1, len(path) - 1):.0f}% of the way,"
    return f"{where} violates the path constraints: {problem}"


