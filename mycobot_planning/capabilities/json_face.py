"""move_group's JSON face without ROS: the planning_server's JSON-RPC requests (dicts in the
schema of interfaces_py.msgs) translated to the typed capability calls of this package and their
answers back to dicts. Nothing here plans, checks limits or executes: the capability modules do.

The full story: docs/core.md, section mycobot_planning.capabilities.
"""
from __future__ import annotations

import dataclasses
import math
import time
from typing import Any, Callable, Mapping

import numpy as np

from interfaces_py.msgs import (
    JointTrajectory,
    MessageError,
    MoveItErrorCode,
    PlanningScene as PlanningSceneMsg,
    Pose,
    RobotState as RobotStateMsg,
    RobotTrajectory,
)
from interfaces_py.pose_conversion import PoseError, pose_matrix

from ..core.planning_interface.planning_interface import JointGoal, MotionPlanRequest, NamedGoal, PoseGoal
from ..core.planning_scene.planning_scene_monitor import BAD_REQUEST
from ..core.trajectory_execution import ExecutionError, parse_task_solution, parse_trajectory
from . import (cartesian_path, execute_trajectory, kinematics, move_action, plan, planner_query, planning_scene,
               state_validation, stop, task_solution)
from .move_group_context import SOURCE, MoveGroupContext, PlanningDefaults, RequestError, check_tolerance
from .state_queries import state_to_json

__all__ = ["MoveGroupJsonFace", "PlanningDefaults", "RequestError", "goal_from_parameters", "pose_from_json"]

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


class MoveGroupJsonFace(MoveGroupContext):
    """The move_group context with the JSON face's calls (see the module docstring): what the
    planning_server's JSON-RPC methods and Trigger services call."""

    def _fail(self, code: int, message: str, **extra: Any) -> dict[str, Any]:
        return {"error_code": _code(code, message), "trajectory": None, "planning_time": 0.0, **extra}

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
        return check_tolerance(value, what)

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

    def _request(self, params: Mapping[str, Any]) -> tuple[MotionPlanRequest, Any, str, Any]:
        """The JSON face's plan request as the typed call's arguments: (request, start state,
        goal frame, path constraints); what the request leaves out stays 0 / "" / None."""
        bad = MoveItErrorCode.INVALID_MOTION_PLAN
        group = self._checked_request(params, _PLAN_KEYS, "plan request")
        if "goal" not in params:
            raise RequestError(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "plan request needs a 'goal'")
        goal = self._goal(params["goal"])
        strings = {}
        for key in ("pipeline_id", "planner_id"):
            value = params.get(key)
            if value is None:
                value = ""
            if not isinstance(value, str):
                raise RequestError(bad, f"{key} must be a string, got {value!r}")
            strings[key] = value
        numbers = {}
        for key in ("allowed_planning_time", "max_velocity_scaling_factor", "max_acceleration_scaling_factor"):
            value = params.get(key)
            numbers[key] = 0.0 if value is None else self._number(value, key)
        attempts = params.get("num_planning_attempts", 0)
        if isinstance(attempts, bool) or not isinstance(attempts, int):
            raise RequestError(bad, f"num_planning_attempts must be an integer, got {attempts!r}")
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
        frame = params["goal"].get("frame", "world")
        if not isinstance(frame, str) or not frame:
            raise RequestError(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "goal 'frame' must be a frame name")
        request = MotionPlanRequest(group=group, goal=goal, seed=seed, num_planning_attempts=attempts,
                                    **strings, **numbers, **extra)
        return request, self._start_msg(params.get("start_state")), frame, params.get("path_constraints")

    def plan_request(self, params: Mapping[str, Any]) -> tuple[MotionPlanRequest, Any, str, Any]:
        """A JSON plan request read as plan() reads it: (request, start state message, goal frame,
        path constraints), RequestError when refused. The benchmark runner reads its stored
        queries through this, so a query means what it means to the planning_server."""
        return self._request(params)

    @staticmethod
    def _start_msg(start_state: Any) -> RobotStateMsg | None:
        if start_state is None or isinstance(start_state, RobotStateMsg):
            return start_state
        try:
            return RobotStateMsg.from_dict(start_state)
        except MessageError as exc:
            raise RequestError(MoveItErrorCode.INVALID_ROBOT_STATE, f"invalid start_state: {exc}") from None

    def plan(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """Plan a request (see docs/core.md, mycobot_planning.capabilities); never raises for bad input.

        Returns {"error_code", "trajectory" (RobotTrajectory dict or None), "planning_time",
        "group", "planner_id"}. A successful plan becomes the "last plan" for execute().
        """
        started = time.perf_counter()
        try:
            request, start, frame, path = self._request(params)
        except RequestError as exc:
            self.last_plan, self.last_plan_problem = None, f"the last planning request failed: {exc.message}"
            self._log("warning", f"plan request refused: {exc.message}")
            return self._fail(exc.code, exc.message)
        return self._plan_reply(plan.plan(self, request, start, frame, path, params.get("display", True)), started)

    def _plan_reply(self, result: plan.PlanResult, started: float) -> dict[str, Any]:
        if result.trajectory is None:
            out = self._fail(result.error_code.val, result.error_code.message,
                             **({"group": result.group} if result.group else {}))
            out["error_code"]["source"] = result.error_code.source
            out["planning_time"] = time.perf_counter() - started if result.group else 0.0
            return out
        return {
            "error_code": result.error_code.to_dict(),
            "trajectory": RobotTrajectory(result.trajectory, result.group).to_dict(),
            "planning_time": result.planning_time,
            "group": result.group,
            "planner_id": result.planner_id,
            **({"trajectory_cache": result.trajectory_cache} if result.trajectory_cache else {}),
        }

    def compute_cartesian_path(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """MoveIt's compute_cartesian_path: {"error_code", "trajectory", "fraction", "stop_reason"}."""
        bad = MoveItErrorCode.INVALID_MOTION_PLAN
        try:
            group = self._checked_request(params, _CARTESIAN_KEYS, "cartesian path request")
            waypoints = params.get("waypoints")
            if not isinstance(waypoints, (list, tuple)) or not waypoints:
                raise RequestError(bad, "waypoints must be a non-empty list of poses")
            if len(waypoints) > cartesian_path.MAX_WAYPOINTS:
                raise RequestError(bad, f"{len(waypoints)} waypoints: a Cartesian request may have at most "
                                        f"{cartesian_path.MAX_WAYPOINTS}")
            request = cartesian_path.CartesianPathRequest(
                group, [pose_from_json(w, f"waypoint {k}") for k, w in enumerate(waypoints)])
            for key in ("eef_step", "jump_threshold", "revolute_jump_threshold", "prismatic_jump_threshold",
                        "max_velocity_scaling_factor", "max_acceleration_scaling_factor"):
                if params.get(key) is not None:
                    setattr(request, key, self._number(params[key], key))
            avoid = params.get("avoid_collisions", True)
            if not isinstance(avoid, bool):
                raise RequestError(bad, "avoid_collisions must be true or false")
            link = params.get("link")
            if link is not None and not isinstance(link, str):
                raise RequestError(bad, "link must be a link name")
            frame = params.get("frame", "world")
            if not isinstance(frame, str) or not frame:
                raise RequestError(bad, "frame must be a frame name")
            offset = params.get("ik_frame_offset")
            request.avoid_collisions, request.link, request.frame = avoid, link or "", frame
            request.ik_frame_offset = pose_from_json(offset, "ik_frame_offset") if offset is not None else None
            request.start_state = self._start_msg(params.get("start_state"))
            request.path_constraints = params.get("path_constraints")
        except RequestError as exc:
            return self._fail(exc.code, exc.message, fraction=0.0, stop_reason="invalid_request")
        result = cartesian_path.compute_cartesian_path(self, request, params.get("display", True))
        if result.stop_reason == "invalid_request":
            return self._fail(result.error_code.val, result.error_code.message, fraction=0.0,
                              stop_reason="invalid_request")
        return {
            "error_code": result.error_code.to_dict(),
            "trajectory": RobotTrajectory(result.trajectory, group).to_dict() if result.trajectory else None,
            "fraction": result.fraction,
            "stop_reason": result.stop_reason,
            "planning_time": result.planning_time,
            **({"trajectory_cache": result.trajectory_cache} if result.trajectory_cache else {}),
        }

    # ------------------------------------------------------------------ scene
    def get_planning_scene(self) -> dict[str, Any]:
        """The whole monitored scene as a JSON PlanningScene."""
        return planning_scene.get_planning_scene(self).to_dict()

    def apply_planning_scene_json(self, scene: Any) -> dict[str, Any]:
        """Apply a JSON PlanningScene (or diff) as one change; RequestError when refused."""
        planning_scene.apply_planning_scene(self, self._message(PlanningSceneMsg, scene, "planning scene"))
        return {"applied": True}

    # ------------------------------------------------------------------ state queries
    def compute_ik(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """MoveIt's compute_ik: {"group", "pose", "frame", "link", "robot_state" (seed),
        "avoid_collisions", "timeout"} -> {"error_code", "solution" (JSON RobotState or None)}."""
        try:
            if not isinstance(params, Mapping):
                raise RequestError(BAD_REQUEST, "an IK request must be a JSON object")
            group = params.get("group", "arm")
            if not isinstance(group, str):
                raise RequestError(MoveItErrorCode.INVALID_GROUP_NAME, f"unknown planning group {group!r}; "
                                                                      f"known: {', '.join(self.model.group_names)}")
            link = params.get("link") or ""
            if not isinstance(link, str):
                raise RequestError(MoveItErrorCode.INVALID_LINK_NAME,
                                   f"unknown link {link!r} of robot '{self.model.name}'")
            timeout = self._number(params.get("timeout") or 0.0, "timeout", BAD_REQUEST)
            avoid = params.get("avoid_collisions", False)
            if not isinstance(avoid, bool):
                raise RequestError(BAD_REQUEST, "avoid_collisions must be true or false")
            frame = params.get("frame") or "world"
            if not isinstance(frame, str):
                raise RequestError(MoveItErrorCode.FRAME_TRANSFORM_FAILURE, "frame must be a frame name")
            seed = params.get("robot_state")
            seed = self._start_msg(seed) if isinstance(seed, Mapping) and seed.get("joint_names") else None
            pose = pose_from_json(params.get("pose"), "IK pose")
        except RequestError as exc:
            return {"error_code": _code(exc.code, exc.message, "compute_ik"), "solution": None}
        code, state = kinematics.compute_ik(self, group, pose, frame, link, seed, avoid, timeout)
        return {"error_code": code.to_dict(), "solution": state_to_json(state) if state is not None else None}

    def compute_fk(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """MoveIt's compute_fk: {"links", "frame", "robot_state"} -> {"error_code", "poses"
        ({link: Pose dict} in ``frame``)}."""
        try:
            if not isinstance(params, Mapping):
                raise RequestError(BAD_REQUEST, "an FK request must be a JSON object")
            links = params.get("links")
            if not isinstance(links, (list, tuple)) or not links or not all(isinstance(x, str) for x in links):
                raise RequestError(MoveItErrorCode.INVALID_LINK_NAME, "links must be a non-empty list of link names")
            frame = params.get("frame") or "world"
            if not isinstance(frame, str):
                raise RequestError(MoveItErrorCode.FRAME_TRANSFORM_FAILURE, "frame must be a frame name")
            state = params.get("robot_state")
            state = self._start_msg(state) if isinstance(state, Mapping) and state.get("joint_names") else None
        except RequestError as exc:
            return {"error_code": _code(exc.code, exc.message, "compute_fk"), "poses": {}}
        code, poses = kinematics.compute_fk(self, links, frame, state)
        if not code:
            return {"error_code": code.to_dict(), "poses": {}}
        return {"error_code": code.to_dict(), "poses": {k: Pose.from_matrix(v).to_dict() for k, v in poses.items()},
                "frame": frame}

    def check_state_validity(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """MoveIt's check_state_validity: {"robot_state", "group"} -> {"valid", "contacts",
        "out_of_bounds", "error_code"}."""
        try:
            if not isinstance(params, Mapping):
                raise RequestError(BAD_REQUEST, "a validity request must be a JSON object")
            group = params.get("group") or ""
            if not isinstance(group, str):
                raise RequestError(MoveItErrorCode.INVALID_GROUP_NAME,
                                   f"unknown planning group {group!r}; known: {', '.join(self.model.group_names)}")
            state = params.get("robot_state")
            state = self._start_msg(state) if isinstance(state, Mapping) and (
                state.get("joint_names") or state.get("attached_collision_objects")) else None
        except RequestError as exc:
            return {"valid": False, "contacts": [], "out_of_bounds": [],
                    "error_code": _code(exc.code, exc.message, "check_state_validity")}
        code, answer = state_validation.check_state_validity(self, state, group)
        return {"valid": answer.valid, "out_of_bounds": answer.bounds,
                "contacts": [{"body_a": a, "body_b": b, "depth": d} for a, b, d in answer.contacts],
                "error_code": code.to_dict()}

    # ------------------------------------------------------------------ planner interfaces
    def planner_interfaces(self) -> list[dict[str, Any]]:
        """move_group's query_planner_interface: each registered pipeline with its planner ids."""
        return [dataclasses.asdict(d) for d in planner_query.query_planner_interfaces(self)]

    def get_planner_params(self, pipeline_id: str, planner_config: str, group: str = "") -> dict[str, Any]:
        return planner_query.get_planner_params(self, pipeline_id, planner_config, group)

    def set_planner_params(self, pipeline_id: str, planner_config: str, params: Mapping[str, str],
                           replace: bool = False) -> str | None:
        return planner_query.set_planner_params(self, pipeline_id, planner_config, params, replace)

    # ------------------------------------------------------------------ execution
    def _run(self, params: Mapping[str, Any] | None, work: Callable[[], dict[str, Any]], what: str) -> dict[str, Any]:
        """Run ``work`` now (``wait`` true, the default) or in a background thread (``wait`` false:
        the answer only says it started; get_state()["execution"]["last_result"] has the outcome)."""
        wait = True if not isinstance(params, Mapping) else params.get("wait", True)
        if not isinstance(wait, bool):
            return {"error_code": _code(MoveItErrorCode.INVALID_MOTION_PLAN, f"wait must be true or false, got {wait!r}")}
        if wait:
            return work()
        refused = self.run(False, work, what)
        if refused is not None:
            return {"error_code": _code(MoveItErrorCode.FAILURE, refused), "started": False}
        return {"error_code": _code(MoveItErrorCode.SUCCESS, f"{what} started"), "started": True}

    def execute(self, params: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """Execute {"trajectory"} (RobotTrajectory or JointTrajectory) or the last plan (blocking).

        Optional "controllers": names to use. Returns ExecutionResult.to_dict().
        """
        params = params or {}
        try:
            trajectory, group, controllers = self._execution_input(params)
        except ExecutionError as exc:
            self._log("warning", f"execute refused: {exc.message}")
            return {"error_code": exc.error_code().to_dict()}
        description = f"trajectory{f' of {group!r}' if group else ''}" if trajectory is not None else ""
        return self._run(params, lambda: execute_trajectory.execute_trajectory(
            self, trajectory, controllers, description).to_dict(), "execution")

    def _execution_input(self, params: Mapping[str, Any]) -> tuple[JointTrajectory | None, str, list[str] | None]:
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
            return trajectory, group, controllers or None
        if self.last_plan is None:
            raise ExecutionError(bad, f"no plan to execute: {self.last_plan_problem}")
        return None, "", controllers or None

    def plan_and_execute(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """Plan, then execute the plan if planning succeeded: {"error_code", "plan", "execution"}.
        "replan", "replan_attempts", "replan_delay" as MoveIt's planning_options (move_action)."""
        if isinstance(params, Mapping) and "wait" in params:
            rest = {k: v for k, v in params.items() if k != "wait"}
            return self._run(params, lambda: self.plan_and_execute(rest), "plan and execute")
        started = time.perf_counter()
        if self.executor.executing_after_stop():
            status = self.executor.status()
            return {"error_code": _code(MoveItErrorCode.FAILURE,
                                        f"refused: another execution ({status['description']}) is in progress; "
                                        "stop it first or wait for it to finish"),
                    "plan": None, "execution": None}
        try:
            replanning = move_action.Replanning()
            if isinstance(params, Mapping):
                if not isinstance(params.get("replan", False), bool):
                    raise RequestError(MoveItErrorCode.INVALID_MOTION_PLAN,
                                       f"replan must be true or false, got {params['replan']!r}")
                replanning = move_action.Replanning.checked(
                    params.get("replan", False), params.get("replan_attempts", 0), params.get("replan_delay", 0.0),
                    self._log)
                params = {k: v for k, v in params.items() if k not in ("replan", "replan_attempts", "replan_delay")}
            request, start, frame, path = self._request(params)
        except RequestError as exc:
            self.last_plan, self.last_plan_problem = None, f"the last planning request failed: {exc.message}"
            self._log("warning", f"plan request refused: {exc.message}")
            failed = self._fail(exc.code, exc.message)
            return {"error_code": failed["error_code"], "plan": failed, "execution": None}
        planned, executed = move_action.plan_and_execute(self, [(request, frame)], start, path,
                                                         params.get("display", True), replanning=replanning)
        if planned is None:  # another execution started meanwhile
            return {"error_code": executed.error_code.to_dict(), "plan": None, "execution": None}
        reply = self._plan_reply(planned, started)
        if executed is None:
            return {"error_code": reply["error_code"], "plan": reply, "execution": None}
        execution = executed.to_dict()
        return {"error_code": execution["error_code"], "plan": reply, "execution": execution}

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
        return self._run(params, lambda: task_solution.execute_task_solution(self, steps).to_dict(),
                         "task solution execution")

    def stop(self) -> dict[str, Any]:
        """Stop the running execution and cancel every running plan (they answer PREEMPTED)."""
        return dataclasses.asdict(stop.stop(self))
