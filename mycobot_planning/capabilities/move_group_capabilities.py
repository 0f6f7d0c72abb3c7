"""The planning server's logic without ROS: MoveIt's move_group capabilities on our core.

The full story: docs/core.md, section mycobot_planning.capabilities.move_group_capabilities.
"""
from __future__ import annotations

import math
import threading
import time
import traceback
import dataclasses
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import yaml

from interfaces_py.pose_conversion import PoseError, pose_matrix
from interfaces_py.msgs import (
    JointTrajectory,
    MessageError,
    MoveItErrorCode,
    PlanningScene as PlanningSceneMsg,
    Pose,
    RobotState as RobotStateMsg,
    RobotTrajectory,
)

from ..core.planners.cartesian.cartesian_path import compute_cartesian_path
from ..core.errors import SceneError, StateError
from ..core.trajectory_execution import (
    ControllerBus,
    ControllerInfo,
    ExecutionError,
    ExecutionSettings,
    TrajectoryExecutionManager,
    parse_task_solution,
    parse_trajectory,
)
from ..core.robot_trajectory.robot_trajectory import timed_to_joint_trajectory
from ..core.kinematic_constraints.kinematic_constraints import ConstraintError, PathConstraints, path_constraints_from_json
from ..core.planning_interface.planning_contexts import ContextFactory, PlanningContextPool
from ..core.planners.pilz import KNOWN_PLANNER_IDS as PILZ_PLANNER_IDS
from ..core.planning_interface.planning_interface import JointGoal, MotionPlanRequest, NamedGoal, PoseGoal
from ..core.planning_scene.planning_scene import PlanningScene
from ..core.planning_scene.planning_scene_monitor import BAD_REQUEST, PlanningSceneMonitor, RequestError
from ..core.robot_model.robot_model import RobotModel
from .state_queries import DEFAULT_IK_TIMEOUT, MAX_IK_TIMEOUT, StateQueries, state_to_json

__all__ = ["PlanningDefaults", "MoveGroupCapabilities", "RequestError", "goal_from_parameters", "pose_from_json"]

SOURCE = "planning_server"

# Request budgets: a request beyond them is refused with the bound, so no client can occupy the
# planner for hours (move_group has no such bounds; one careless request there blocks everyone).
#: s: the longest allowed_planning_time a plan request may ask for.
MAX_PLANNING_TIME = 300.0
#: num_planning_attempts at most (each attempt shares the planning time).
MAX_PLANNING_ATTEMPTS = 1000
#: waypoints of one Cartesian request at most (each is one IK target).
MAX_WAYPOINTS = 10_000

_PLAN_KEYS = {
    "group", "goal", "pipeline_id", "planner_id", "allowed_planning_time", "num_planning_attempts",
    "max_velocity_scaling_factor", "max_acceleration_scaling_factor", "start_state", "seed", "display",
    "circ_center", "circ_interim", "num_ik_goals", "path_constraints",
}
_GOAL_KEYS = {"named", "joints", "pose", "link", "ik_frame_offset", "tolerance", "position_tolerance",
              "orientation_tolerance", "frame"}
_CARTESIAN_KEYS = {
    "group", "waypoints", "link", "ik_frame_offset", "eef_step", "jump_threshold", "avoid_collisions",
    "max_velocity_scaling_factor", "max_acceleration_scaling_factor", "start_state", "frame", "display",
    "revolute_jump_threshold", "prismatic_jump_threshold", "path_constraints",
}



@dataclass
class PlanningDefaults:
    """What a request does not say (MoveIt's plan_request_params)."""

    pipeline_id: str = "ompl"
    planner_id: str = ""
    planning_time: float = 5.0
    num_planning_attempts: int = 1
    max_velocity_scaling_factor: float = 1.0
    max_acceleration_scaling_factor: float = 1.0
    sample_period: float = 0.01  # s between published trajectory points (0: planner breakpoints only)


def _code(val: int, message: str, source: str = SOURCE) -> dict[str, Any]:
    return MoveItErrorCode(val, message, source).to_dict()


def pose_from_json(value: Any, what: str = "pose") -> np.ndarray:
    """A 4x4 world pose from any form interfaces_py.pose_conversion accepts; a bad one is refused
    with INVALID_GOAL_CONSTRAINTS, as move_group answers a malformed goal."""
    try:
        return pose_matrix(value, what)
    except PoseError as exc:
        raise RequestError(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, f"invalid {exc}") from None


def goal_from_parameters(values: Mapping[str, Any], last_set: str | None = None) -> dict[str, Any]:
    """The plan request of the Trigger ``plan`` service from the goal.* parameters.

    ``values`` maps "group", "named_target", "joint_values", "pose", "link". The target is the
    goal parameter set last (``last_set``: "named_target", "joint_values" or "pose"), as
    MoveGroup's set_*_target replaces the previous target; without one, the first non-empty of
    named_target, joint_values, pose. RequestError when no target is set.
    """
    order = ["named_target", "joint_values", "pose"]
    if last_set in order and values.get(last_set):
        order.remove(last_set)
        order.insert(0, last_set)
    request: dict[str, Any] = {"group": values.get("group") or "arm"}
    for key in order:
        value = values.get(key)
        if not value:
            continue
        if key == "named_target":
            request["goal"] = {"named": value}
        elif key == "joint_values":
            request["goal"] = {"joints": [float(v) for v in value]}
        else:
            goal: dict[str, Any] = {"pose": [float(v) for v in value]}
            if values.get("link"):
                goal["link"] = values["link"]
            request["goal"] = goal
        return request
    raise RequestError(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS,
                       "no goal set: set goal.named_target, goal.joint_values or goal.pose first")


class MoveGroupCapabilities(PlanningSceneMonitor):
    """Monitored scene + planning + execution of the planning server (see docs/core.md (mycobot_planning.capabilities.move_group_capabilities)).

    Thread-safe: ROS callbacks (joint states, scene updates, requests, stop) arrive on several
    executor threads. The scene is guarded by one lock held only for short updates; planning
    works on a copy of the scene, so joint states keep flowing while a planner runs; executions
    are serialised by the execution manager (one at a time, stop always answered).
    """

    def __init__(
        self,
        model: RobotModel,
        pipeline: Any,
        controllers: Sequence[ControllerInfo],
        bus: ControllerBus,
        settings: ExecutionSettings | None = None,
        defaults: PlanningDefaults | None = None,
        clock: Callable[[], float] = time.monotonic,
        log: Callable[[str, str], None] | None = None,
        context_factory: ContextFactory | None = None,
    ) -> None:
        """``context_factory`` builds another (model, pipeline) pair like ``model`` and ``pipeline``:
        with it, plans of several clients run at once (see planning_contexts.py); without it,
        one after the other."""
        super().__init__(model, clock, log)
        self.pipeline = pipeline
        self.contexts = PlanningContextPool(model, pipeline, context_factory)
        self._cancels: set[threading.Event] = set()
        self.defaults = defaults or PlanningDefaults()
        self._last_plan: tuple[JointTrajectory, str] | None = None
        self._last_plan_problem = "nothing has been planned yet"
        self.trajectory_listeners: list[Callable[[JointTrajectory], None]] = []
        self.executor = TrajectoryExecutionManager(
            model, controllers, bus, self.joint_positions, settings or ExecutionSettings(), clock=clock, log=self._log
        )
        self.queries = StateQueries(model)

    # ------------------------------------------------------------------ settings
    @property
    def settings(self) -> ExecutionSettings:
        return self.executor.settings

    @settings.setter
    def settings(self, value: ExecutionSettings) -> None:
        self.executor.settings = value

    @property
    def joint_state_timeout(self) -> float:
        return self.executor.settings.joint_state_timeout

    def _joint_state_arrived(self) -> None:
        self.executor.notify()

    # ------------------------------------------------------------------ planning
    def _fail(self, code: int, message: str, **extra: Any) -> dict[str, Any]:
        return {"error_code": _code(code, message), "trajectory": None, "planning_time": 0.0, **extra}

    def _start_scene(self, start_state: Any, group_joints: Sequence[str]) -> PlanningScene:
        """A copy of the monitored scene whose current state is the request's start state.

        A start state naming every active joint needs no joint states; otherwise its joints (if
        any) are merged onto the current state, which must be fresh (RequestError otherwise).
        """
        msg = None
        if start_state is not None:
            try:
                msg = start_state if isinstance(start_state, RobotStateMsg) else RobotStateMsg.from_dict(start_state)
            except MessageError as exc:
                raise RequestError(MoveItErrorCode.INVALID_ROBOT_STATE, f"invalid start_state: {exc}") from None
        given = msg.joint_positions() if msg is not None else {}
        mimic = set(self.model.mimic_joint_names)
        active = {n: v for n, v in given.items() if n not in mimic}
        unknown = [n for n in active if n not in self.model.variable_names]
        if unknown:
            raise RequestError(MoveItErrorCode.INVALID_ROBOT_STATE,
                               f"start_state names joints {unknown} that robot '{self.model.name}' does not have")
        outside = self._limit_problems(active)
        if outside:
            raise RequestError(MoveItErrorCode.INVALID_ROBOT_STATE,
                               "start_state is outside the joint limits: " + "; ".join(outside))
        complete = all(n in active for n in self.model.variable_names)
        if not complete:
            problem = self.joint_state_problem([j for j in group_joints if j not in active])
            if problem is not None:
                raise RequestError(*problem)
        scene = self.scene_copy()
        try:
            if active:
                scene.set_current_state(active)
            if msg is not None:
                for attached in msg.attached_collision_objects:
                    scene.apply_attached_collision_object(attached)
        except (StateError, SceneError, ValueError) as exc:
            raise RequestError(MoveItErrorCode.INVALID_ROBOT_STATE, f"invalid start_state: {exc}") from None
        return scene

    def _goal(self, goal: Any) -> JointGoal | NamedGoal | PoseGoal:
        bad = MoveItErrorCode.INVALID_GOAL_CONSTRAINTS
        if not isinstance(goal, Mapping):
            raise RequestError(bad, "goal must be an object with one of 'named', 'joints' or 'pose'")
        unknown = sorted(set(goal) - _GOAL_KEYS)
        if unknown:
            raise RequestError(bad, f"goal has unknown keys {unknown}; known: {sorted(_GOAL_KEYS)}")
        kinds = [k for k in ("named", "joints", "pose") if goal.get(k) is not None]
        if len(kinds) != 1:
            raise RequestError(bad, f"goal needs exactly one of 'named', 'joints' or 'pose', got {kinds or 'none'}")
        tolerance = self._tolerance(goal.get("tolerance", 1e-4), "goal tolerance")
        if kinds[0] == "named":
            if not isinstance(goal["named"], str) or not goal["named"]:
                raise RequestError(bad, "goal 'named' must be a named state string such as 'home'")
            return NamedGoal(goal["named"], tolerance)
        if kinds[0] == "joints":
            values = goal["joints"]
            if isinstance(values, Mapping):
                if not all(isinstance(k, str) for k in values):
                    raise RequestError(bad, "goal 'joints' must map joint names to numbers")
                checked = {k: self._number(v, f"goal joint '{k}'", bad) for k, v in values.items()}
                return JointGoal(checked, tolerance)
            if not isinstance(values, (list, tuple)):
                raise RequestError(bad, "goal 'joints' must be a list of numbers or a {joint: value} object")
            return JointGoal([self._number(v, f"goal joints[{i}]", bad) for i, v in enumerate(values)], tolerance)
        pose = pose_from_json(goal["pose"], "goal pose")
        link = goal.get("link")
        if link is not None and (not isinstance(link, str)):
            raise RequestError(bad, "goal 'link' must be a link name")
        offset = goal.get("ik_frame_offset")
        return PoseGoal(
            pose,
            link or None,
            pose_from_json(offset, "ik_frame_offset") if offset is not None else None,
            self._tolerance(goal.get("position_tolerance", 1e-4), "position_tolerance"),
            self._tolerance(goal.get("orientation_tolerance", 1e-3), "orientation_tolerance"),
        )

    @classmethod
    def _tolerance(cls, value: Any, what: str) -> float:
        number = cls._number(value, what, MoveItErrorCode.INVALID_GOAL_CONSTRAINTS)
        if number < 0:
            raise RequestError(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, f"{what} must not be negative, got {number:g}")
        return number

    @staticmethod
    def _number(value: Any, what: str, code: int = MoveItErrorCode.INVALID_MOTION_PLAN) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise RequestError(code, f"{what} must be a finite number, got {value!r}")
        return float(value)

    def _checked_request(self, params: Any, keys: set[str], what: str) -> str:
        """A request object with known keys only; returns its planning group (default "arm")."""
        if not isinstance(params, Mapping):
            raise RequestError(MoveItErrorCode.INVALID_MOTION_PLAN, f"a {what} must be a JSON object")
        unknown = sorted(set(params) - keys)
        if unknown:
            raise RequestError(MoveItErrorCode.INVALID_MOTION_PLAN,
                               f"{what} has unknown keys {unknown}; known: {sorted(keys)}")
        group = params.get("group", "arm")
        if not isinstance(group, str) or not self.model.has_group(group):
            raise RequestError(MoveItErrorCode.INVALID_GROUP_NAME,
                               f"unknown planning group {group!r}; known: {', '.join(self.model.group_names)}")
        return group

    def _request(self, params: Mapping[str, Any]) -> tuple[MotionPlanRequest, PlanningScene]:
        bad = MoveItErrorCode.INVALID_MOTION_PLAN
        group = self._checked_request(params, _PLAN_KEYS, "plan request")
        if "goal" not in params:
            raise RequestError(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "plan request needs a 'goal'")
        goal = self._goal(params["goal"])
        d = self.defaults
        strings = {}
        for key, default in (("pipeline_id", d.pipeline_id), ("planner_id", d.planner_id)):
            value = params.get(key)
            if value is None or value == "":
                value = default
            if not isinstance(value, str):
                raise RequestError(bad, f"{key} must be a string, got {value!r}")
            strings[key] = value
        numbers = {}
        for key, default in (("allowed_planning_time", d.planning_time),
                             ("max_velocity_scaling_factor", d.max_velocity_scaling_factor),
                             ("max_acceleration_scaling_factor", d.max_acceleration_scaling_factor)):
            value = params.get(key)
            numbers[key] = default if value is None or value == 0 else self._number(value, key)
        if not 0 < numbers["allowed_planning_time"] <= MAX_PLANNING_TIME:
            raise RequestError(bad, f"allowed_planning_time must be in (0, {MAX_PLANNING_TIME:g}] s, "
                                    f"got {numbers['allowed_planning_time']:g}")
        for key in ("max_velocity_scaling_factor", "max_acceleration_scaling_factor"):
            if not 0 < numbers[key] <= 1:
                raise RequestError(bad, f"{key} must be in (0, 1], got {numbers[key]:g}")
        attempts = params.get("num_planning_attempts", d.num_planning_attempts)
        if isinstance(attempts, bool) or not isinstance(attempts, int):
            raise RequestError(bad, f"num_planning_attempts must be an integer, got {attempts!r}")
        if attempts == 0:
            attempts = d.num_planning_attempts  # MoveIt reads 0 as "the default"
        if not 1 <= attempts <= MAX_PLANNING_ATTEMPTS:
            raise RequestError(bad, f"num_planning_attempts must be in [1, {MAX_PLANNING_ATTEMPTS}], got {attempts}")
        seed = params.get("seed")
        if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int)):
            raise RequestError(bad, f"seed must be an integer, got {seed!r}")
        extra = {}
        for key in ("circ_center", "circ_interim"):
            if params.get(key) is not None:
                value = params[key]
                if not isinstance(value, (list, tuple)) or len(value) != 3:
                    raise RequestError(bad, f"{key} must be 3 numbers (x, y, z)")
                extra[key] = [self._number(v, key) for v in value]
        if params.get("num_ik_goals") is not None:
            n = params["num_ik_goals"]
            if isinstance(n, bool) or not isinstance(n, int) or n < 1:
                raise RequestError(bad, f"num_ik_goals must be an integer >= 1, got {n!r}")
            extra["num_ik_goals"] = n
        scene = self._start_scene(params.get("start_state"), self.model.group(group).joint_names)
        frame = params["goal"].get("frame", "world")
        if not isinstance(frame, str) or not frame:
            raise RequestError(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "goal 'frame' must be a frame name")
        if isinstance(goal, PoseGoal):
            goal.pose = self._in_world([goal.pose], frame, scene)[0]
        request = MotionPlanRequest(
            group=group, goal=goal, start_state=scene.current_state.copy(), seed=seed,
            num_planning_attempts=attempts, path_constraints=self._path_constraints(params, scene),
            **strings, **numbers, **extra,
        )
        return request, scene

    def _path_constraints(self, params: Mapping[str, Any], scene: PlanningScene) -> PathConstraints | None:
        """The request's path constraints ({"joints", "orientation", "position"}, see
        core/kinematic_constraints/kinematic_constraints.py), frames resolved at the start state."""
        data = params.get("path_constraints")
        if data is None:
            return None
        if not isinstance(data, Mapping) or set(data) - {"joints", "orientation", "position"}:
            raise RequestError(MoveItErrorCode.INVALID_MOTION_PLAN,
                               "path_constraints must be an object with 'joints', 'orientation' and 'position' lists")

        def frame_pose(frame: str) -> np.ndarray:
            try:
                return scene.frame_pose(frame)
            except SceneError as exc:
                raise RequestError(MoveItErrorCode.FRAME_TRANSFORM_FAILURE, f"path constraint frame: {exc}") from None

        try:
            constraints = path_constraints_from_json(data, scene.current_state, frame_pose)
        except (ConstraintError, KeyError, TypeError, ValueError) as exc:
            if isinstance(exc, RequestError):
                raise
            raise RequestError(MoveItErrorCode.INVALID_MOTION_PLAN, f"invalid path constraint: {exc}") from None
        return constraints or None

    def plan(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """Plan a request (see docs/core.md (mycobot_planning.capabilities.move_group_capabilities)); never raises for bad input.

        Returns {"error_code", "trajectory" (RobotTrajectory dict or None), "planning_time",
        "group", "planner_id"}. A successful plan becomes the "last plan" for execute().
        """
        started = time.perf_counter()
        try:
            request, scene = self._request(params)
        except RequestError as exc:
            self._last_plan, self._last_plan_problem = None, f"the last planning request failed: {exc.message}"
            self._log("warning", f"plan request refused: {exc.message}")
            return self._fail(exc.code, exc.message)
        try:
            response = self._plan_in_context(scene, request)
        except Exception as exc:  # planners promise not to raise; if one does, answer anyway
            response = None
            self._log("error", f"planner raised {type(exc).__name__}: {exc}\n{traceback.format_exc()}")
            message = ("the planner failed on this request with an internal error (the planning_server's log has "
                       "the details)")
        if response is None or not response.success or response.trajectory is None:
            code = response.error_code if response is not None else MoveItErrorCode(MoveItErrorCode.FAILURE, message)
            self._last_plan, self._last_plan_problem = None, f"the last planning request failed: {code}"
            self._log("warning", f"planning for '{request.group}' failed: {code}")
            result = self._fail(code.val, code.message, group=request.group)
            result["error_code"]["source"] = code.source or request.pipeline_id
            result["planning_time"] = time.perf_counter() - started
            return result
        trajectory = timed_to_joint_trajectory(response.trajectory, self.defaults.sample_period or None)
        self._last_plan = (trajectory, request.group)
        self._last_plan_problem = ""
        if params.get("display", True):
            self._display(trajectory)
        self._log("info", f"planned '{request.group}' with {request.pipeline_id}/{response.planner_id or 'default'}: "
                          f"{trajectory.duration:.3f} s trajectory in {response.planning_time:.3f} s")
        return {
            "error_code": _code(MoveItErrorCode.SUCCESS, response.error_code.message, request.pipeline_id),
            "trajectory": RobotTrajectory(trajectory, request.group).to_dict(),
            "planning_time": response.planning_time,
            "group": request.group,
            "planner_id": response.planner_id,
        }

    def _plan_in_context(self, scene: PlanningScene, request: MotionPlanRequest) -> Any:
        """Plan on a free planning context, cancellable by stop()."""
        cancel = threading.Event()
        request.cancel = cancel
        with self._lock:
            self._cancels.add(cancel)
        try:
            with self.contexts.acquire() as context:
                local = context.scene_for(scene)
                return context.pipeline.plan(local, context.request_for(request, local))
        finally:
            with self._lock:
                self._cancels.discard(cancel)

    def _display(self, trajectory: JointTrajectory) -> None:
        for listener in list(self.trajectory_listeners):
            try:
                listener(trajectory)
            except Exception as exc:
                self._log("error", f"publishing the planned trajectory failed: {exc}")

    def compute_cartesian_path(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """MoveIt's compute_cartesian_path: {"error_code", "trajectory", "fraction", "stop_reason"}."""
        bad = MoveItErrorCode.INVALID_MOTION_PLAN
        try:
            group = self._checked_request(params, _CARTESIAN_KEYS, "cartesian path request")
            waypoints = params.get("waypoints")
            if not isinstance(waypoints, (list, tuple)) or not waypoints:
                raise RequestError(bad, "waypoints must be a non-empty list of poses")
            if len(waypoints) > MAX_WAYPOINTS:
                raise RequestError(bad, f"{len(waypoints)} waypoints: a Cartesian request may have at most "
                                        f"{MAX_WAYPOINTS}")
            poses = [pose_from_json(w, f"waypoint {k}") for k, w in enumerate(waypoints)]
            offset = params.get("ik_frame_offset")
            kwargs: dict[str, Any] = {}
            for key, default in (("eef_step", 0.01), ("jump_threshold", 0.0), ("revolute_jump_threshold", 0.0),
                                 ("prismatic_jump_threshold", 0.0)):
                kwargs[key] = self._number(params.get(key, default), key)
            for key in ("max_velocity_scaling_factor", "max_acceleration_scaling_factor"):
                value = params.get(key)
                default = getattr(self.defaults, key)
                kwargs[key.replace("max_", "").replace("_factor", "")] = (
                    default if value is None or value == 0 else self._number(value, key))
            avoid = params.get("avoid_collisions", True)
            if not isinstance(avoid, bool):
                raise RequestError(bad, "avoid_collisions must be true or false")
            link = params.get("link")
            if link is not None and not isinstance(link, str):
                raise RequestError(bad, "link must be a link name")
            frame = params.get("frame", "world")
            if not isinstance(frame, str) or not frame:
                raise RequestError(bad, "frame must be a frame name")
            if link is not None and link and not self.model.has_link(link):
                raise RequestError(bad, f"unknown link {link!r} of robot '{self.model.name}'")
            ik_offset = pose_from_json(offset, "ik_frame_offset") if offset is not None else None
            scene = self._start_scene(params.get("start_state"), self.model.group(group).joint_names)
            poses = self._in_world(poses, frame, scene)
            kwargs["path_constraints"] = self._path_constraints(params, scene)
        except RequestError as exc:
            return self._fail(exc.code, exc.message, fraction=0.0, stop_reason="invalid_request")
        with self.contexts.acquire() as context:
            local = context.scene_for(scene)
            result = compute_cartesian_path(
                local, group, local.current_state.copy(), poses, link=link or None,
                ik_frame_offset=ik_offset, avoid_collisions=avoid, **kwargs,
            )
        out: dict[str, Any] = {
            "error_code": _code(result.error_code.val, result.error_code.message, "cartesian_path"),
            "trajectory": None,
            "fraction": float(result.fraction),
            "stop_reason": result.stop_reason,
            "planning_time": result.planning_time,
        }
        if result.success and result.trajectory is not None:
            trajectory = timed_to_joint_trajectory(result.trajectory, self.defaults.sample_period or None)
            out["trajectory"] = RobotTrajectory(trajectory, group).to_dict()
            if params.get("display", True) and result.fraction > 0:
                self._display(trajectory)
        self._log("info" if result.success else "warning",
                  f"cartesian path for '{group}': fraction {result.fraction:.3f} ({result.stop_reason}) {result.message}")
        return out

    def _in_world(self, poses: list[np.ndarray], frame: str, scene: PlanningScene) -> list[np.ndarray]:
        """Waypoints given in ``frame`` (the world, the robot's root link or any robot link, posed
        at the start state, as MoveIt reads a waypoint's header.frame_id) in the world frame."""
        if frame in ("world", "/world", self.model.root_link):
            return poses
        if not self.model.has_link(frame):
            raise RequestError(MoveItErrorCode.FRAME_TRANSFORM_FAILURE,
                               f"unknown frame {frame!r}: waypoints may be given in 'world', "
                               f"'{self.model.root_link}' or a link of robot '{self.model.name}'")
        base = scene.current_state.frame_pose(frame)
        return [base @ pose for pose in poses]

    # ------------------------------------------------------------------ state queries
    def compute_ik(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """MoveIt's compute_ik: {"group", "pose", "frame", "link", "robot_state" (seed),
        "avoid_collisions", "timeout"} -> {"error_code", "solution" (JSON RobotState or None)}."""
        try:
            if not isinstance(params, Mapping):
                raise RequestError(BAD_REQUEST, "an IK request must be a JSON object")
            group = params.get("group", "arm")
            if not isinstance(group, str) or not self.model.has_group(group):
                raise RequestError(MoveItErrorCode.INVALID_GROUP_NAME,
                                   f"unknown planning group {group!r}; known: {', '.join(self.model.group_names)}")
            link = params.get("link") or ""
            if not isinstance(link, str) or (link and not self.model.has_link(link)):
                raise RequestError(MoveItErrorCode.INVALID_LINK_NAME,
                                   f"unknown link {link!r} of robot '{self.model.name}'")
            timeout = params.get("timeout") or DEFAULT_IK_TIMEOUT
            timeout = self._number(timeout, "timeout", BAD_REQUEST)
            if not 0 < timeout <= MAX_IK_TIMEOUT:
                raise RequestError(BAD_REQUEST, f"timeout must be in (0, {MAX_IK_TIMEOUT:g}] s, got {timeout:g}")
            avoid = params.get("avoid_collisions", False)
            if not isinstance(avoid, bool):
                raise RequestError(BAD_REQUEST, "avoid_collisions must be true or false")
            frame = params.get("frame") or "world"
            if not isinstance(frame, str):
                raise RequestError(MoveItErrorCode.FRAME_TRANSFORM_FAILURE, "frame must be a frame name")
            seed = params.get("robot_state")
            scene = self._start_scene(seed if isinstance(seed, Mapping) and seed.get("joint_names") else None,
                                      self.model.group(group).joint_names)
            target = self._in_world([pose_from_json(params.get("pose"), "IK pose")], frame, scene)[0]
        except RequestError as exc:
            return {"error_code": _code(exc.code, exc.message, "compute_ik"), "solution": None}
        answer = self.queries.compute_ik(scene, group, target, link, avoid, timeout)
        if answer.state is None:
            return {"error_code": _code(getattr(MoveItErrorCode, answer.error), answer.message, "compute_ik"),
                    "solution": None}
        return {"error_code": _code(MoveItErrorCode.SUCCESS, "", "compute_ik"),
                "solution": state_to_json(answer.state)}

    def compute_fk(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """MoveIt's compute_fk: {"links", "frame", "robot_state"} -> {"error_code", "poses"
        ({link: Pose dict} in ``frame``)}."""
        try:
            if not isinstance(params, Mapping):
                raise RequestError(BAD_REQUEST, "an FK request must be a JSON object")
            links = params.get("links")
            if not isinstance(links, (list, tuple)) or not links or not all(isinstance(x, str) for x in links):
                raise RequestError(MoveItErrorCode.INVALID_LINK_NAME, "links must be a non-empty list of link names")
            unknown = [x for x in links if not self.model.has_link(x)]
            if unknown:
                raise RequestError(MoveItErrorCode.INVALID_LINK_NAME,
                                   f"unknown links {unknown} of robot '{self.model.name}'")
            frame = params.get("frame") or "world"
            if not isinstance(frame, str):
                raise RequestError(MoveItErrorCode.FRAME_TRANSFORM_FAILURE, "frame must be a frame name")
            state = params.get("robot_state")
            scene = self._start_scene(state if isinstance(state, Mapping) and state.get("joint_names") else None,
                                      self.model.variable_names)
            if frame not in ("world", "/world") and not self.model.has_link(frame) and not scene.has_object(frame):
                raise RequestError(MoveItErrorCode.FRAME_TRANSFORM_FAILURE,
                                   f"unknown frame {frame!r}: not 'world', a link of robot '{self.model.name}' or "
                                   "an object of the scene")
            poses = self.queries.compute_fk(scene, list(links), frame)
        except RequestError as exc:
            return {"error_code": _code(exc.code, exc.message, "compute_fk"), "poses": {}}
        return {"error_code": _code(MoveItErrorCode.SUCCESS, "", "compute_fk"),
                "poses": {k: Pose.from_matrix(v).to_dict() for k, v in poses.items()}, "frame": frame}

    def check_state_validity(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """MoveIt's check_state_validity: {"robot_state", "group"} -> {"valid", "contacts",
        "out_of_bounds", "error_code"}."""
        try:
            if not isinstance(params, Mapping):
                raise RequestError(BAD_REQUEST, "a validity request must be a JSON object")
            group = params.get("group") or None
            if group is not None and (not isinstance(group, str) or not self.model.has_group(group)):
                raise RequestError(MoveItErrorCode.INVALID_GROUP_NAME,
                                   f"unknown planning group {group!r}; known: {', '.join(self.model.group_names)}")
            state = params.get("robot_state")
            given = state if isinstance(state, Mapping) and (state.get("joint_names")
                                                            or state.get("attached_collision_objects")) else None
            if given is not None and given.get("joint_names"):
                outside = self._limit_problems(dict(zip(given["joint_names"], given.get("positions", []))))
                if outside:
                    return {"valid": False, "contacts": [], "out_of_bounds": outside,
                            "error_code": _code(MoveItErrorCode.SUCCESS, "", "check_state_validity")}
            scene = self._start_scene(given, self.model.variable_names if given is None else [])
        except RequestError as exc:
            return {"valid": False, "contacts": [], "out_of_bounds": [],
                    "error_code": _code(exc.code, exc.message, "check_state_validity")}
        answer = self.queries.check_validity(scene)
        return {"valid": answer.valid, "out_of_bounds": answer.bounds,
                "contacts": [{"body_a": a, "body_b": b, "depth": d} for a, b, d in answer.contacts],
                "error_code": _code(MoveItErrorCode.SUCCESS, "", "check_state_validity")}

    # ------------------------------------------------------------------ planner interfaces
    def planner_interfaces(self) -> list[dict[str, Any]]:
        """move_group's query_planner_interface: each pipeline with its planner ids."""
        ompl = self.pipeline.ompl.config
        out = [{"name": "OMPL", "pipeline_id": "ompl", "planner_ids": sorted(ompl.planner_configs)}]
        out.append({"name": "Pilz Industrial Motion Planner", "pipeline_id": "pilz_industrial_motion_planner",
                    "planner_ids": list(PILZ_PLANNER_IDS)})
        out.append({"name": "Joint interpolation (MTC's JointInterpolationPlanner)",
                    "pipeline_id": "joint_interpolation", "planner_ids": ["joint_interpolation"]})
        return out

    def get_planner_params(self, pipeline_id: str, planner_config: str, group: str = "") -> dict[str, Any]:
        """The parameters of one OMPL planner configuration ({} when unknown), as strings."""
        if pipeline_id not in ("", "ompl"):
            return {}
        config = self.pipeline.ompl.config.planner_configs.get(planner_config)
        if config is None:
            return {}
        params = {k: str(v) for k, v in config.params.items()}
        params["type"] = config.type
        return params

    def set_planner_params(self, pipeline_id: str, planner_config: str, params: Mapping[str, str],
                           replace: bool = False) -> str | None:
        """Change an OMPL planner configuration's parameters in every planning context; None when
        applied, else why not (nothing changed)."""
        if pipeline_id not in ("", "ompl"):
            return f"pipeline {pipeline_id!r} has no settable planner parameters (only 'ompl')"
        current = self.pipeline.ompl.config
        config = current.planner_configs.get(planner_config)
        if config is None:
            return (f"unknown planner configuration {planner_config!r}; known: "
                    f"{', '.join(sorted(current.planner_configs))}")
        values: dict[str, Any] = {} if replace else dict(config.params)
        for key, text in params.items():
            if key == "type":
                continue
            try:
                values[key] = yaml.safe_load(text) if isinstance(text, str) else text
            except yaml.YAMLError:
                values[key] = text
        updated = dataclasses.replace(current, planner_configs={
            **current.planner_configs, planner_config: dataclasses.replace(config, params=values)})
        for pipeline in self.contexts.pipelines():
            pipeline.ompl.config = updated
        self._log("info", f"planner configuration {planner_config}: parameters now {values}")
        return None

    # ------------------------------------------------------------------ execution
    def _execution_reply(self, result: Any) -> dict[str, Any]:
        return result.to_dict()

    def _run(self, params: Mapping[str, Any] | None, work: Callable[[], dict[str, Any]], what: str) -> dict[str, Any]:
        """Run ``work`` now (``wait`` true, the default) or in a background thread (``wait`` false:
        the answer only says it started; get_state()["execution"]["last_result"] has the outcome)."""
        wait = True if not isinstance(params, Mapping) else params.get("wait", True)
        if not isinstance(wait, bool):
            return {"error_code": _code(MoveItErrorCode.INVALID_MOTION_PLAN, f"wait must be true or false, got {wait!r}")}
        if wait:
            return work()
        if self.executor.executing:
            status = self.executor.status()
            return {"error_code": _code(MoveItErrorCode.FAILURE,
                                        f"refused: another execution ({status['description']}) is in progress; "
                                        "stop it first or wait for it to finish"), "started": False}
        thread = threading.Thread(target=work, name=f"planning_server {what}", daemon=True)
        thread.start()
        return {"error_code": _code(MoveItErrorCode.SUCCESS, f"{what} started"), "started": True}

    def execute(self, params: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """Execute {"trajectory"} (RobotTrajectory or JointTrajectory) or the last plan (blocking).

        Optional "controllers": names to use. Returns ExecutionResult.to_dict().
        """
        params = params or {}
        try:
            trajectory, description, controllers = self._execution_input(params)
        except ExecutionError as exc:
            self._log("warning", f"execute refused: {exc.message}")
            return {"error_code": exc.error_code().to_dict()}
        return self._run(params, lambda: self._execution_reply(self.executor.execute(trajectory, controllers, description)),
                         "execution")

    def _execution_input(self, params: Mapping[str, Any]) -> tuple[JointTrajectory, str, list[str] | None]:
        bad = MoveItErrorCode.INVALID_MOTION_PLAN
        if not isinstance(params, Mapping):
            raise ExecutionError(bad, "an execute request must be a JSON object")
        unknown = sorted(set(params) - {"trajectory", "controllers", "wait"})
        if unknown:
            raise ExecutionError(bad, f"execute request has unknown keys {unknown}; known: controllers, trajectory, wait")
        controllers = params.get("controllers")
        if controllers is not None:
            if isinstance(controllers, str):
                controllers = [controllers]
            if not isinstance(controllers, list) or not all(isinstance(c, str) for c in controllers):
                raise ExecutionError(bad, "controllers must be a list of controller names")
        if params.get("trajectory") is not None:
            trajectory, group = parse_trajectory(params["trajectory"])
            return trajectory, f"trajectory{f' of {group!r}' if group else ''}", controllers or None
        last = self._last_plan
        if last is None:
            raise ExecutionError(bad, f"no plan to execute: {self._last_plan_problem}")
        return last[0], f"last plan of '{last[1]}'", controllers or None

    def plan_and_execute(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """Plan, then execute the plan if planning succeeded: {"error_code", "plan", "execution"}."""
        if isinstance(params, Mapping) and "wait" in params:
            rest = {k: v for k, v in params.items() if k != "wait"}
            return self._run(params, lambda: self.plan_and_execute(rest), "plan and execute")
        if self.executor.executing:
            status = self.executor.status()
            return {"error_code": _code(MoveItErrorCode.FAILURE,
                                        f"refused: another execution ({status['description']}) is in progress; "
                                        "stop it first or wait for it to finish"),
                    "plan": None, "execution": None}
        plan = self.plan(params)
        if not plan["error_code"]["val"] == MoveItErrorCode.SUCCESS:
            return {"error_code": plan["error_code"], "plan": plan, "execution": None}
        trajectory, _ = parse_trajectory(plan["trajectory"])
        execution = self._execution_reply(self.executor.execute(trajectory, None, f"plan of '{plan['group']}'"))
        return {"error_code": execution["error_code"], "plan": plan, "execution": execution}

    def _apply_diff_live(self, diff: PlanningSceneMsg) -> None:
        with self._lock:
            self.scene.apply_planning_scene_msg(diff)
        self._changed()

    def execute_task_solution(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """Execute a task solution ({"steps": [...]} or {"solution": {...}}); see execution.py."""
        if not isinstance(params, Mapping):
            return {"error_code": _code(MoveItErrorCode.INVALID_MOTION_PLAN, "request must be a JSON object")}
        unknown = sorted(set(params) - {"solution", "steps", "sub_trajectory", "wait"})
        data = params.get("solution", {k: v for k, v in params.items() if k != "wait"})
        try:
            if unknown:
                raise ExecutionError(MoveItErrorCode.INVALID_MOTION_PLAN,
                                     f"execute_task_solution has unknown keys {unknown}; known: solution, steps, wait")
            steps = parse_task_solution(data)
        except ExecutionError as exc:
            self._log("warning", f"task solution refused: {exc.message}")
            return {"error_code": exc.error_code().to_dict(), "steps_completed": 0, "failed_step": None,
                    "applied_scene_diffs": []}
        return self._run(
            params,
            lambda: self.executor.execute_solution(steps, self._apply_diff_live, self.scene_copy()).to_dict(),
            "task solution execution",
        )

    def stop(self) -> dict[str, Any]:
        """Stop the running execution and cancel every running plan (they answer PREEMPTED)."""
        with self._lock:
            cancels = list(self._cancels)
        for cancel in cancels:
            cancel.set()
        stopped = self.executor.stop()
        parts = (["stopping the running execution"] if stopped else []) + (
            [f"cancelling {len(cancels)} running plan{'s' if len(cancels) != 1 else ''}"] if cancels else [])
        message = " and ".join(parts) if parts else "nothing is executing or planning"
        self._log("info", f"stop requested: {message}")
        return {"stopped": stopped or bool(cancels), "message": message, "cancelled_plans": len(cancels)}

    def get_state(self, controller_states: Mapping[str, Any] | None = None) -> dict[str, Any]:
        positions, age = self.joint_positions()
        with self._lock:
            state = self.scene.current_state
            robot_state = RobotStateMsg(joint_names=list(self.model.variable_names),
                                        positions=[float(v) for v in state.positions]).to_dict()
        return {
            "robot_state": robot_state,
            "joint_state_age": age,
            "joint_state_received": positions is not None,
            "execution": self.executor.status(),
            "planning": len(self._cancels),  # plans running now (stop cancels them)
            "has_plan": self._last_plan is not None,
            "controllers": dict(controller_states or {}),
        }
