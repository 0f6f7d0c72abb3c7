"""Planners for MoveTo / MoveRelative / Connect (MTC's solvers), wrapping the planning core.

* :class:`PipelinePlanner`: the planning pipelines by id and planner id, as move_group offers
  them: OMPL (``{"ompl": "arm[RRTConnectkConfigDefault]"}``) and the industrial PTP / LIN / CIRC
  (``{"pilz_industrial_motion_planner": "PTP"}``). One :class:`PlanningPipeline` is shared by
  every PipelinePlanner of the process unless one is given, so OMPL configurations load once.
* :class:`CartesianPath`: a straight line of the ik frame (step size, jump threshold, minimum
  fraction, velocity/acceleration scaling), MTC's defaults (step 0.01 m, jump threshold 1.5).
* :class:`JointInterpolationPlanner`: a straight line in joint space, checked every
  ``max_step`` (the core's 0.01 rad; MTC's 0.1 rad lets a link sweep through thin objects, see
  core/joint_interpolation.py).

Each planner answers two questions: plan to a goal *state* (the joints of a group in the goal
scene) and plan the link ``link`` (with the rigid ``offset`` of the ik frame) to a world pose.
Both return a :class:`PlanResult` with the trajectory of the group, which may be partial when
planning failed (MoveRelative measures how far a partial Cartesian path got).

Planner properties are MTC's: set them as attributes (``cartesian.step_size = 0.005``), through
``properties``, or with MTC's setters (``setStepSize``).

Both questions take MTC's ``path_constraints`` (the stage's property: a moveit_msgs/Constraints,
its dict or JSON form, or a core PathConstraints; see task/path_constraints.py), resolved in the
scene planned from, so a constraint may name an object attached there. PipelinePlanner hands them
to the planning pipeline (OMPL plans on the constraint manifold; the industrial planner's paths
are checked); CartesianPath stops where its line would leave them (its fraction then falls short);
JointInterpolationPlanner checks its straight line densely and fails naming the broken
constraint (MTC's ignores them on joint-space goals; it only keeps them at IK for pose goals,
which it does here too).
"""
from __future__ import annotations

import math
import time
import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, Mapping

import numpy as np

from ..core.cartesian_path import compute_cartesian_path
from ..core.cartesian_precision import CartesianPrecision
from ..core.errors import PlanningError
from ..core.joint_interpolation import DEFAULT_MAX_STEP, interpolate_joint_path
from ..core.kinematic_constraints import ConstraintError, PathConstraints, dense_violation
from ..core.trajectory_validator import validate_trajectory
from ..core.planning_interface import JointGoal, MotionPlanRequest, PlanningFailure, PoseGoal, goal_states
from ..core.planning_pipeline import PlanningPipeline
from ..core.planning_scene import PlanningScene
from ..core.robot_trajectory import DEFAULT_MAX_WAYPOINT_DISTANCE, TimedTrajectory, limit_waypoint_distance
from ..core.trajectory_processing.cartesian_speed_limit import limit_cartesian_link_speed
from ..core.transforms import inverse
from .errors import PropertyError, TaskError
from .geometry import PoseStamped, as_pose_stamped, robot_tip_for_frame
from .path_constraints import PathConstraintsSpec, as_path_constraints
from .properties import PropertyMap
from .trajectories import time_path

if TYPE_CHECKING:  # pragma: no cover
    from ..core.robot_model import RobotModel
    from .task import TaskContext

__all__ = ["CartesianPath", "JointInterpolationPlanner", "MultiPlanner", "PipelinePlanner", "PlanResult", "PlannerInterface",
           "default_pipeline"]

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


class PlannerInterface:
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

    @property
    def properties(self) -> PropertyMap:
        return self._properties

    def setProperty(self, name: str, value: Any) -> None:
        self._properties.set(name, value)

    def setMaxVelocityScalingFactor(self, factor: float) -> None:
        self._properties.set("max_velocity_scaling_factor", factor)

    def setMaxAccelerationScalingFactor(self, factor: float) -> None:
        self._properties.set("max_acceleration_scaling_factor", factor)

    def setTimeout(self, timeout: float) -> None:
        self._properties.set("timeout", timeout)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        props = self.__dict__.get("_properties")
        if props is not None and name in props:
            return props[name]
        raise AttributeError(f"{type(self).__name__} has no attribute or property '{name}'")

    def __setattr__(self, name: str, value: Any) -> None:
        if name.startswith("_") or hasattr(type(self), name):
            object.__setattr__(self, name, value)
            return
        props = self.__dict__.get("_properties")
        if props is not None and name in props:
            props.set(name, value)
            return
        raise AttributeError(f"{type(self).__name__} has no property '{name}' (declared: {', '.join(sorted(props or []))})")

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


def _seed(context: "TaskContext | None") -> int | None:
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


def _constraints_key(path_constraints: Any) -> str:
    spec = _spec(path_constraints)
    return "" if spec is None else spec.key()


def _constraint_failure(planner: "PlannerInterface", path_constraints: Any, scene: PlanningScene
                        ) -> tuple[PathConstraints | None, PlanResult | None]:
    """(resolved constraints, None), or (None, the failure to answer with)."""
    try:
        return _resolve(path_constraints, scene), None
    except _ConstraintProblem as exc:
        return None, PlanResult(False, None, str(exc), planner.planner_id)


def _check_path(constraints: PathConstraints | None, start, joint_names, path: np.ndarray,
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


class PipelinePlanner(PlannerInterface):
    """Plans with the planning pipelines (OMPL, industrial), as MTC's PipelinePlanner.

    ``PipelinePlanner("ompl")``, ``PipelinePlanner("ompl", "RRTConnectkConfigDefault")`` or
    MTC's map form ``PipelinePlanner({"pilz_industrial_motion_planner": "PTP"})``. With several
    pipelines in the map they are tried in order and the first success is used.
    """

    def __init__(self, pipeline_id_planner_id_map: Any = "ompl", planner_id: str = "", *args: str,
                 pipeline: PlanningPipeline | None = None) -> None:
        super().__init__()
        node = None if isinstance(pipeline_id_planner_id_map, (str, Mapping)) else pipeline_id_planner_id_map
        if not isinstance(pipeline_id_planner_id_map, (str, Mapping)):
            # MTC's ros2 form PipelinePlanner(node, "ompl", "RRTConnectkConfigDefault"): planning
            # runs here, on the task's robot; the node only lets a task load that robot.
            if len(args) > 1:
                raise TaskError("PipelinePlanner(node, pipeline, planner_id) takes at most three arguments")
            pipeline_id_planner_id_map, planner_id = planner_id or "ompl", (args[0] if args else "")
        elif args:
            raise TaskError("PipelinePlanner: too many arguments; expected (pipeline, planner_id), "
                            "(node, pipeline, planner_id) or ({pipeline: planner_id})")
        if isinstance(pipeline_id_planner_id_map, str):
            mapping = {pipeline_id_planner_id_map: planner_id}
        elif isinstance(pipeline_id_planner_id_map, Mapping):
            if planner_id:
                raise TaskError("give the planner id inside the pipeline map, not as a second argument")
            mapping = {str(k): str(v) for k, v in pipeline_id_planner_id_map.items()}
        else:
            raise TaskError(f"PipelinePlanner: expected a pipeline id or a {{pipeline: planner_id}} map, "
                            f"got {type(pipeline_id_planner_id_map).__name__}")
        if not mapping:
            raise TaskError("PipelinePlanner: the pipeline map is empty")
        p = self._properties
        p.declare("pipeline_id_planner_id_map", mapping, "pipelines and their planner ids, tried in order", type=dict)
        p.declare("num_planning_attempts", 1, "number of planning attempts", type=int)
        p.declare("goal_joint_tolerance", 1e-4, "tolerance for reaching joint goals", type=float)
        p.declare("goal_position_tolerance", 1e-4, "tolerance for reaching position goals", type=float)
        p.declare("goal_orientation_tolerance", 1e-3, "tolerance for reaching orientation goals", type=float)
        p.declare("validate_solution", True, "check every planned trajectory with the trajectory validator and "
                  "re-plan (new seed) when it fails (skipped when the pipeline already validated it, as "
                  "the OMPL pipeline does)", type=bool)
        p.declare("max_validation_retries", 2, "re-plans after a trajectory failed validation", type=int)
        object.__setattr__(self, "_pipeline", pipeline)
        object.__setattr__(self, "_last_planner", "")
        #: the ROS node of MTC's PipelinePlanner(node, ...) form: a Task without a robot model
        #: loads its model through it (see Task.init)
        object.__setattr__(self, "node", node)

    def setPlannerId(self, pipeline_id: str, planner_id: str) -> bool:
        mapping = dict(self._properties["pipeline_id_planner_id_map"])
        if pipeline_id not in mapping:
            return False
        mapping[pipeline_id] = planner_id
        self._properties.set("pipeline_id_planner_id_map", mapping)
        return True

    @property
    def pipeline(self) -> str:
        """The (first) planning pipeline's id, MTC's ``pipeline`` property."""
        return next(iter(self._properties["pipeline_id_planner_id_map"]))

    @pipeline.setter
    def pipeline(self, pipeline_id: str) -> None:
        self._properties.set("pipeline_id_planner_id_map", {str(pipeline_id): self.planner})

    @property
    def planner(self) -> str:
        """The (first) pipeline's planner id, MTC's ``planner`` property ("" means its default)."""
        return next(iter(self._properties["pipeline_id_planner_id_map"].values()))

    @planner.setter
    def planner(self, planner_id: str) -> None:
        mapping = dict(self._properties["pipeline_id_planner_id_map"])
        mapping[next(iter(mapping))] = str(planner_id)
        self._properties.set("pipeline_id_planner_id_map", mapping)

    @property
    def planner_id(self) -> str:
        if self._last_planner:
            return self._last_planner
        return ", ".join(f"{k}:{v}" if v else k for k, v in self._properties["pipeline_id_planner_id_map"].items())

    def init(self, robot_model: "RobotModel") -> None:
        super().init(robot_model)
        pipeline = self._pipeline or default_pipeline()
        for pipeline_id in self._properties["pipeline_id_planner_id_map"]:
            if pipeline_id not in pipeline.pipeline_ids:
                raise ValueError(f"unknown planning pipeline '{pipeline_id}'; known: {', '.join(pipeline.pipeline_ids)}")
        attempts = self._properties["num_planning_attempts"]
        if attempts < 1:
            raise ValueError(f"num_planning_attempts must be >= 1, got {attempts}")

    def _plan(self, scene: PlanningScene, group: str, goal, timeout: float, context,
              path_constraints: Any = None) -> PlanResult:
        constraints, failed = _constraint_failure(self, path_constraints, scene)
        if failed is not None:
            return failed
        pipeline = self._pipeline
        if pipeline is None:
            pipeline = context.pipeline if context is not None else default_pipeline()
        velocity, acceleration = self._scaling()
        timeout = self._timeout(timeout)
        messages = []
        for pipeline_id, planner_id in self._properties["pipeline_id_planner_id_map"].items():
            request = MotionPlanRequest(
                group,
                goal,
                start_state=scene.current_state,
                pipeline_id=pipeline_id,
                planner_id=planner_id,
                allowed_planning_time=timeout,
                num_planning_attempts=int(self._properties["num_planning_attempts"]),
                max_velocity_scaling_factor=velocity,
                max_acceleration_scaling_factor=acceleration,
                seed=_seed(context),
                path_constraints=constraints,
            )
            retries = int(self._properties["max_validation_retries"]) if self._properties["validate_solution"] else 0
            for attempt in range(retries + 1):
                if attempt:
                    request.seed = _seed(context) if request.seed is not None else None
                response = pipeline.plan(scene, request)
                if not response.success:
                    messages.append(f"{pipeline_id}{'/' + planner_id if planner_id else ''}: {response.error_code}")
                    break
                if self._properties["validate_solution"] and not response.validated:
                    # Joint limits unscaled: the industrial LIN/CIRC scale Cartesian limits, not joint ones.
                    report = validate_trajectory(scene, response.trajectory, group, scene.current_state)
                    if not report.valid:
                        messages.append(f"{pipeline_id}{'/' + planner_id if planner_id else ''}: computed path is not "
                                        f"valid: {'; '.join(report.problems[:2])}")
                        continue
                object.__setattr__(self, "_last_planner", response.planner_id or planner_id)
                return PlanResult(True, response.trajectory, response.message, response.planner_id or planner_id)
        return PlanResult(False, None, "; ".join(messages), planner_id)

    def plan(self, from_scene, to_scene, group, timeout, context=None, path_constraints=None):
        values = to_scene.current_state.group_positions(group)
        goal = JointGoal(values, tolerance=float(self._properties["goal_joint_tolerance"]))
        return self._plan(from_scene, group, goal, timeout, context, path_constraints)

    def plan_pose(self, from_scene, link, offset, target, group, timeout, context=None, path_constraints=None):
        goal = PoseGoal(np.asarray(target, dtype=float), link=link, ik_frame_offset=np.asarray(offset, dtype=float),
                        position_tolerance=float(self._properties["goal_position_tolerance"]),
                        orientation_tolerance=float(self._properties["goal_orientation_tolerance"]))
        return self._plan(from_scene, group, goal, timeout, context, path_constraints)


class CartesianPath(PlannerInterface):
    """A straight line of the ik frame, MTC's CartesianPath solver."""

    def __init__(self, step_size: float = 0.01, jump_threshold: float = 1.5, min_fraction: float = 1.0) -> None:
        super().__init__()
        p = self._properties
        p.declare("ik_frame", None, "frame to move linearly (for joint-space targets)", type=PoseStamped,
                  coerce=as_pose_stamped)
        p.declare("step_size", step_size, "step size between consecutive waypoints (m)", type=float)
        p.declare("jump_threshold", jump_threshold, "acceptable fraction of mean joint motion per step", type=float)
        p.declare("min_fraction", min_fraction, "fraction of motion required for success", type=float)
        p.declare("precision", CartesianPrecision(), "precision of the linear path (MoveIt's CartesianPrecision)",
                  type=CartesianPrecision)
        p.declare("max_cartesian_speed", 0.0, "max Cartesian speed of cartesian_speed_limited_link (m/s; 0: "
                  "no limit): the trajectory is slowed down uniformly", type=float)
        p.declare("cartesian_speed_limited_link", "", "link whose speed max_cartesian_speed limits (empty: the "
                  "link the ik_frame is on)", type=str)

    def setStepSize(self, step_size: float) -> None:
        self._properties.set("step_size", step_size)

    def setJumpThreshold(self, threshold: float) -> None:
        self._properties.set("jump_threshold", threshold)

    def setMinFraction(self, fraction: float) -> None:
        self._properties.set("min_fraction", fraction)

    def setPrecision(self, precision: CartesianPrecision) -> None:
        self._properties.set("precision", precision)

    def setIKFrame(self, pose_or_link: Any, link: str | None = None) -> None:
        self._properties.set("ik_frame", pose_or_link if link is None else PoseStamped(link, pose_or_link))

    @property
    def planner_id(self) -> str:
        return "CartesianPath"

    def init(self, robot_model):
        super().init(robot_model)
        p = self._properties
        if not p["step_size"] > 0:
            raise ValueError(f"step_size must be > 0, got {p['step_size']}")
        if p["jump_threshold"] < 0:
            raise ValueError(f"jump_threshold must be >= 0, got {p['jump_threshold']}")
        if not 0.0 <= p["min_fraction"] <= 1.0:
            raise ValueError(f"min_fraction must be in [0, 1], got {p['min_fraction']}")
        if not p["max_cartesian_speed"] >= 0.0:
            raise ValueError(f"max_cartesian_speed must be >= 0 m/s (0: no limit), got {p['max_cartesian_speed']}")
        limited = p["cartesian_speed_limited_link"]
        if limited and not robot_model.has_link(limited):
            raise ValueError(f"cartesian_speed_limited_link '{limited}' is not a link of robot '{robot_model.name}'")

    def plan(self, from_scene, to_scene, group, timeout, context=None, path_constraints=None):
        link, ik_pose = robot_tip_for_frame(self._properties["ik_frame"], from_scene, group)
        offset = inverse(from_scene.current_state.frame_pose(link)) @ ik_pose
        target = to_scene.current_state.frame_pose(link) @ offset
        return self.plan_pose(from_scene, link, offset, target, group, timeout, context, path_constraints)

    def plan_pose(self, from_scene, link, offset, target, group, timeout, context=None, path_constraints=None):
        parts = ("pose", group, link, np.asarray(offset, dtype=float).tobytes(), np.asarray(target, dtype=float).tobytes(),
                 _constraints_key(path_constraints))
        return self._memoized(context, from_scene, parts,
                              lambda: self._plan_pose(from_scene, link, offset, target, group, path_constraints))

    def _plan_pose(self, from_scene, link, offset, target, group, path_constraints=None):
        constraints, failed = _constraint_failure(self, path_constraints, from_scene)
        if failed is not None:
            return failed
        velocity, acceleration = self._scaling()
        p = self._properties
        result = compute_cartesian_path(
            from_scene, group, from_scene.current_state, [np.asarray(target, dtype=float)], link=link,
            ik_frame_offset=np.asarray(offset, dtype=float), eef_step=float(p["step_size"]),
            jump_threshold=float(p["jump_threshold"]), avoid_collisions=True, velocity_scaling=velocity,
            acceleration_scaling=acceleration, path_constraints=constraints, precision=p["precision"],
        )
        if not result.success:
            return PlanResult(False, None, result.message, self.planner_id)
        fraction = result.fraction
        if fraction < float(p["min_fraction"]) - 1e-12:
            return PlanResult(False, result.trajectory, f"min_fraction not met. Achieved: {fraction:.6f} "
                                                        f"({result.message})", self.planner_id)
        trajectory = result.trajectory
        if p["max_cartesian_speed"] > 0.0 and trajectory is not None:
            limited = p["cartesian_speed_limited_link"] or link
            trajectory = limit_cartesian_link_speed(trajectory, from_scene.current_state, limited,
                                                    float(p["max_cartesian_speed"]))
        return PlanResult(True, trajectory, f"achieved fraction: {fraction:.6f}", self.planner_id)


class JointInterpolationPlanner(PlannerInterface):
    """A straight line in joint space from start to goal, every ``max_step`` checked."""

    def __init__(self, max_step: float = DEFAULT_MAX_STEP) -> None:
        super().__init__()
        self._properties.declare("max_step", max_step, "max joint step between checked states (rad)", type=float)
        self._properties.declare("max_effort", None, "max_effort for gripper commands (passed through)", type=float)

    def setMaxStep(self, max_step: float) -> None:
        self._properties.set("max_step", max_step)

    @property
    def planner_id(self) -> str:
        return "JointInterpolation"

    def init(self, robot_model):
        super().init(robot_model)
        if not self._properties["max_step"] > 0:
            raise ValueError(f"max_step must be > 0, got {self._properties['max_step']}")

    def plan(self, from_scene, to_scene, group, timeout, context=None, path_constraints=None):
        goal = to_scene.current_state.group_positions(group)
        return self._memoized(context, from_scene, ("state", group, goal.tobytes(), _constraints_key(path_constraints)),
                              lambda: self._plan_line(from_scene, group, goal, path_constraints))

    def _plan_line(self, from_scene, group, goal, path_constraints=None):
        constraints, failed = _constraint_failure(self, path_constraints, from_scene)
        if failed is not None:
            return failed
        model = from_scene.robot_model
        jmg = model.group(group)
        start = from_scene.current_state
        try:
            path, message = interpolate_joint_path(from_scene, group, start, goal, float(self._properties["max_step"]))
        except PlanningError as exc:
            return PlanResult(False, None, str(exc), self.planner_id)
        if path is None:
            return PlanResult(False, None, message, self.planner_id)
        broken = _check_path(constraints, start, jmg.joint_names, path, "line")
        if broken is not None:
            return PlanResult(False, None, f"joint interpolation: {broken}", self.planner_id)
        velocity, acceleration = self._scaling()
        # The line is collision-checked above; timing its two ends gives the same straight
        # motion (the timing never leaves the path) at a fraction of the cost.
        trajectory = time_path(model, jmg, path[[0, -1]], velocity, acceleration)
        return PlanResult(True, trajectory, message, self.planner_id)

    def plan_pose(self, from_scene, link, offset, target, group, timeout, context=None, path_constraints=None):
        model = from_scene.robot_model
        jmg = model.group(group)
        timeout = self._timeout(timeout)
        constraints, failed = _constraint_failure(self, path_constraints, from_scene)
        if failed is not None:
            return failed
        rng = np.random.default_rng(_seed(context))
        goal = PoseGoal(np.asarray(target, dtype=float), link=link, ik_frame_offset=np.asarray(offset, dtype=float))
        try:
            states = goal_states(from_scene, jmg, from_scene.current_state, goal, 8, max(timeout, 1e-3), rng)
        except PlanningFailure as exc:
            return PlanResult(False, None, f"IK failed for pose target: {exc.message}", self.planner_id)
        if constraints:  # as MTC: the IK solution must satisfy the path constraints
            kept = [state for state in states if constraints.satisfied(state)]
            if not kept:
                return PlanResult(False, None, "IK failed for pose target: no solution satisfies the path "
                                               f"constraints ({constraints.violation(states[0])})", self.planner_id)
            states = kept
        to_scene = from_scene.diff()
        to_scene.set_current_state(states[0])
        return self.plan(from_scene, to_scene, group, timeout, context, path_constraints)


class MultiPlanner(PlannerInterface):
    """Tries its planners in order and answers with the first success (MTC's MultiPlanner), each
    getting the time the ones before it left; a failure says why every planner failed."""

    def __init__(self, *planners: PlannerInterface) -> None:
        super().__init__()
        object.__setattr__(self, "_planners", [])
        self.add(*planners)

    def add(self, *planners: PlannerInterface) -> None:
        for planner in planners:
            if not isinstance(planner, PlannerInterface):
                raise TaskError(f"MultiPlanner.add expects planners, got {type(planner).__name__}")
            self._planners.append(planner)

    def clear(self) -> None:
        self._planners.clear()

    def __len__(self) -> int:
        return len(self._planners)

    def __getitem__(self, index: int) -> PlannerInterface:
        return self._planners[index]

    def __iter__(self):
        return iter(self._planners)

    def init(self, robot_model: "RobotModel") -> None:
        super().init(robot_model)
        if not self._planners:
            raise ValueError("MultiPlanner has no planners: add() at least one")
        for planner in self._planners:
            planner.init(robot_model)

    def _first_success(self, timeout: float, attempt: Callable[[PlannerInterface, float], PlanResult]) -> PlanResult:
        deadline = time.monotonic() + self._timeout(timeout)
        failures: list[str] = []
        last: PlanResult | None = None
        for planner in self._planners:
            remaining = deadline - time.monotonic()
            if remaining <= 0.0:
                failures.append(f"{planner.planner_id}: no time left")
                break
            last = attempt(planner, remaining)
            if last:
                return last
            failures.append(f"{planner.planner_id}: {last.message}")
        return PlanResult(False, last.trajectory if last else None, "; ".join(failures), self.planner_id)

    def plan(self, from_scene, to_scene, group, timeout, context=None, path_constraints=None):
        extra = {"path_constraints": path_constraints} if path_constraints is not None else {}
        return self._first_success(timeout, lambda p, t: p.plan(from_scene, to_scene, group, t, context, **extra))

    def plan_pose(self, from_scene, link, offset, target, group, timeout, context=None, path_constraints=None):
        extra = {"path_constraints": path_constraints} if path_constraints is not None else {}
        return self._first_success(timeout, lambda p, t: p.plan_pose(from_scene, link, offset, target, group, t,
                                                                      context, **extra))
