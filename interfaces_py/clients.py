"""Blocking Python clients of the planning_server: MoveIt's PlanningSceneInterface and MoveGroup.

The full story: docs/interfaces.md, section interfaces_py.clients.
"""
from __future__ import annotations

import math
import uuid
from typing import Any, Iterable, Mapping, Sequence

import numpy as np
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from interfaces_py.background_spin import BackgroundSpin
from interfaces_py.json_rpc import JsonRpcClient, RpcError, RpcTimeout
from interfaces_py.pose_conversion import pose_message
from interfaces_py.msgs import (
    AttachedCollisionObject,
    CollisionObject,
    JointTrajectory,
    MessageError,
    MoveItErrorCode,
    PlanningScene,
    Pose,
    RobotState,
    RobotTrajectory,
)

__all__ = [
    "MoveGroupClient",
    "PlanResult",
    "PlanningSceneInterface",
    "RpcError",
    "RpcTimeout",
]

DEFAULT_SERVER = "/planning_server"
# How long an execution may take, at most, beyond the trajectory's own duration before the
# client stops waiting (the server's own limit is duration x 1.2 + 0.5 s by default).
_EXECUTION_SLACK = 10.0


class _RosHandle:
    """A node to talk through: a private one spun in a daemon thread, or the caller's."""

    def __init__(self, node: Node | None, prefix: str) -> None:
        self._context: Context | None = None
        self._spin: BackgroundSpin | None = None
        if node is not None:
            self.node = node
            return
        self._context = Context()
        rclpy.init(context=self._context)
        self.node = Node(f"{prefix}_{uuid.uuid4().hex[:8]}", context=self._context)
        # Single-threaded on purpose: the callbacks (answers arriving) are short, and rclpy's
        # multi-threaded executor busy-polls while callbacks are queued, eating the CPU (and the
        # GIL) of the script that is waiting for the answer.
        executor = SingleThreadedExecutor(context=self._context)
        executor.add_node(self.node)
        self._spin = BackgroundSpin(executor, name=f"{prefix} executor")

    @property
    def owned(self) -> bool:
        return self._context is not None

    def close(self) -> None:
        if self._context is None:
            return
        context, self._context = self._context, None
        if self._spin is not None:
            self._spin.stop()
        try:
            self.node.destroy_node()
        except Exception:  # best-effort teardown: the context may already be shut down (Ctrl-C)
            pass
        rclpy.try_shutdown(context=context)


class _Client:
    """Shared plumbing: node, JSON-RPC client, default timeout, context-manager support."""

    _prefix = "planning_client"

    def __init__(self, node: Node | None = None, server: str = DEFAULT_SERVER, timeout: float = 10.0,
                 _handle: _RosHandle | None = None) -> None:
        if not isinstance(timeout, (int, float)) or isinstance(timeout, bool) or not timeout > 0:
            raise ValueError(f"timeout must be a positive number of seconds, got {timeout!r}")
        self.timeout = float(timeout)
        self.server = server
        self._handle = _handle or _RosHandle(node, self._prefix)
        self._owns_handle = _handle is None
        self._rpc = JsonRpcClient(self._handle.node, server)

    @property
    def node(self) -> Node:
        return self._handle.node

    def wait_for_server(self, timeout: float | None = None) -> bool:
        """True once the planning_server answers requests (False after ``timeout``)."""
        return self._rpc.wait_for_server(self.timeout if timeout is None else timeout)

    def call(self, method: str, params: Mapping[str, Any] | None = None, timeout: float | None = None) -> Any:
        """Raw JSON-RPC call (result dict, RpcError on an error answer or timeout)."""
        return self._rpc.call(method, dict(params or {}), self.timeout if timeout is None else timeout)

    def close(self) -> None:
        if self._owns_handle:
            self._handle.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


# ---------------------------------------------------------------------------- conversions
def _pose_json(pose: Any, what: str = "pose") -> Any:
    """A pose as the server accepts it (a Pose dict), from any form pose_conversion takes."""
    return pose_message(pose, what).to_dict()


def _stamped(pose: Any, frame_id: str) -> tuple[Any, str]:
    """(pose, frame) of a geometry_msgs/PoseStamped (or our dict form), else ``pose`` in ``frame_id``."""
    header = getattr(pose, "header", None)
    if header is not None and hasattr(pose, "pose"):
        return pose.pose, getattr(header, "frame_id", "") or frame_id
    return pose, frame_id


def _trajectory_json(trajectory: Any) -> dict[str, Any]:
    if isinstance(trajectory, PlanResult):
        trajectory = trajectory.trajectory
    if isinstance(trajectory, (RobotTrajectory, JointTrajectory)):
        return trajectory.to_dict()
    if isinstance(trajectory, Mapping):
        return dict(trajectory)
    raise ValueError(f"expected a RobotTrajectory or JointTrajectory, got {type(trajectory).__name__}")


def _error_code(data: Any) -> MoveItErrorCode:
    try:
        return MoveItErrorCode.from_dict(data)
    except (MessageError, TypeError):
        return MoveItErrorCode(MoveItErrorCode.FAILURE, f"malformed answer from the planning server: {data!r}")


def _rpc_failure(exc: RpcError) -> MoveItErrorCode:
    if isinstance(exc, RpcTimeout):
        return MoveItErrorCode(MoveItErrorCode.TIMED_OUT, exc.message, "client")
    code = exc.code if exc.code in MoveItErrorCode._NAMES else MoveItErrorCode.COMMUNICATION_FAILURE
    return MoveItErrorCode(code, exc.message, "planning_server")


def _fraction_check(value: float, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or not 0 < value <= 1:
        raise ValueError(f"{name} must be in (0, 1], got {value!r}")
    return float(value)


# ---------------------------------------------------------------------------- scene
class PlanningSceneInterface(_Client):
    """moveit_commander's PlanningSceneInterface: world and attached collision objects."""

    _prefix = "planning_scene_interface"

    # ---- adding and changing objects
    def apply_collision_objects(self, objects: Iterable[CollisionObject | Mapping], timeout: float | None = None) -> None:
        """Apply CollisionObjects (their operation: ADD, REMOVE, APPEND, MOVE), all or nothing."""
        payload = [o.to_dict() if isinstance(o, CollisionObject) else dict(o) for o in objects]
        if not payload:
            raise ValueError("no collision objects given")
        self.call("apply_collision_object", {"objects": payload}, timeout)

    def apply_collision_object(self, obj: CollisionObject | Mapping, timeout: float | None = None) -> None:
        self.apply_collision_objects([obj], timeout)

    add_object = apply_collision_object
    add_objects = apply_collision_objects

    def __init__(self, ns: str = "", synchronous: bool = True, service_timeout: float = 10.0, *,
                 node: Node | None = None, server: str = DEFAULT_SERVER, timeout: float | None = None,
                 _handle: _RosHandle | None = None) -> None:
        """moveit_commander's constructor (``ns``, ``synchronous``, ``service_timeout``) plus ours.
        Every change is a request the planning_server answers, so calls are always synchronous;
        ``ns`` prefixes the server's name."""
        if not isinstance(ns, str):
            raise ValueError(f"ns must be a string, got {type(ns).__name__}")
        name = f"{ns.rstrip('/')}/{server.lstrip('/')}" if ns else server
        super().__init__(node, name, service_timeout if timeout is None else timeout, _handle=_handle)

    # moveit_commander's shape calls: name, pose (PoseStamped, Pose, 4x4, 7 numbers), dimensions
    def add_box(self, name: str, pose: Any = None, size: Sequence[float] = (1, 1, 1), frame_id: str = "world") -> None:
        """Box of ``size`` (x, y, z) centred at ``pose`` (a PoseStamped's frame wins over ``frame_id``)."""
        pose, frame_id = _stamped(pose, frame_id)
        self.add_object(self._shape("box", name, pose, frame_id, size=size))

    def add_cylinder(self, name: str, pose: Any = None, height: float = 1.0, radius: float = 1.0,
                     frame_id: str = "world") -> None:
        pose, frame_id = _stamped(pose, frame_id)
        self.add_object(self._shape("cylinder", name, pose, frame_id, height=height, radius=radius))

    def add_sphere(self, name: str, pose: Any = None, radius: float = 1.0, frame_id: str = "world") -> None:
        pose, frame_id = _stamped(pose, frame_id)
        self.add_object(self._shape("sphere", name, pose, frame_id, radius=radius))

    @staticmethod
    def _shape(kind: str, object_id: str, pose: Any, frame_id: str, **dims: Any) -> CollisionObject:
        pose_msg = Pose.from_dict(_pose_json(pose)) if pose is not None else None
        try:
            return getattr(CollisionObject, kind)(object_id, pose=pose_msg, frame_id=frame_id, **dims)
        except MessageError as exc:
            raise ValueError(str(exc)) from None

    def move_object(self, object_id: str, pose: Any, frame_id: str = "world") -> None:
        """Move a world object to ``pose`` (in ``frame_id``), keeping its shapes."""
        self.add_object(CollisionObject(id=object_id, frame_id=frame_id, pose=_pose_json(pose),
                                        operation=CollisionObject.MOVE))

    def remove_object(self, object_id: str) -> None:
        """Remove a world object (RpcError naming the known ids if there is none by that name)."""
        self.add_object(CollisionObject(id=object_id, operation=CollisionObject.REMOVE))

    def remove_world_object(self, object_id: str | None = None) -> None:
        """moveit_commander's name: remove one world object, or all of them when no id is given."""
        if object_id is not None:
            self.remove_object(object_id)
            return
        ids = list(self.get_objects())
        if ids:
            self.apply_collision_objects([CollisionObject(id=i, operation=CollisionObject.REMOVE) for i in ids])

    def clear(self) -> None:
        """Detach every attached object and remove every object (world and detached)."""
        for object_id in list(self.get_attached_objects()):
            self.detach_object(object_id)
        self.remove_world_object()

    # ---- attached objects
    def attach_object(self, object_id: str, link_name: str | None = None, touch_links: Sequence[str] | None = None,
                      weight: float = 0.0) -> dict[str, Any]:
        """Attach a world object to a link where it is now (default: the end effector's parent
        link, touching the end effector's links). Returns the link and touch links used."""
        params: dict[str, Any] = {"object_id": object_id, "weight": weight}
        if link_name:
            params["link_name"] = link_name
        if touch_links is not None:
            params["touch_links"] = list(touch_links)
        return self.call("attach_object", params)

    def attach_collision_object(self, attached: AttachedCollisionObject | Mapping) -> None:
        """Apply an AttachedCollisionObject message (ADD attaches its object, REMOVE detaches)."""
        data = attached.to_dict() if isinstance(attached, AttachedCollisionObject) else dict(attached)
        self.call("attach_object", {"attached_object": data})

    def detach_object(self, object_id: str) -> None:
        """Put an attached object back into the world where it is now."""
        self.call("detach_object", {"object_id": object_id})

    remove_attached_object = detach_object

    # ---- queries
    def get_objects(self, object_ids: Sequence[str] | None = None) -> dict[str, CollisionObject]:
        """World objects by id (world frame); ``object_ids`` filters (unknown ids are absent)."""
        result = self.call("get_objects", {"ids": list(object_ids)} if object_ids else {})
        return {k: CollisionObject.from_dict(v) for k, v in result["objects"].items()}

    def get_attached_objects(self, object_ids: Sequence[str] | None = None) -> dict[str, AttachedCollisionObject]:
        """Attached objects by id (object posed in its link's frame)."""
        result = self.call("get_objects", {"ids": list(object_ids)} if object_ids else {})
        return {k: AttachedCollisionObject.from_dict(v) for k, v in result["attached_objects"].items()}

    def get_object_poses(self, object_ids: Sequence[str] | None = None) -> dict[str, Pose]:
        """Current world poses of world and attached objects (attached ones follow their link)."""
        result = self.call("get_objects", {"ids": list(object_ids)} if object_ids else {})
        poses = {k: Pose.from_dict(v["pose"]) for k, v in result["objects"].items()}
        poses.update({k: Pose.from_dict(v) for k, v in result["attached_object_poses"].items()})
        return poses

    def get_known_object_names(self) -> list[str]:
        result = self.call("get_objects")
        return sorted(list(result["objects"]) + list(result["attached_objects"]))

    def get_planning_scene(self) -> PlanningScene:
        return PlanningScene.from_dict(self.call("get_planning_scene"))

    def apply_planning_scene(self, scene: PlanningScene | Mapping) -> None:
        """Apply a PlanningScene message: a diff (is_diff) updates, a full one replaces."""
        data = scene.to_dict() if isinstance(scene, PlanningScene) else dict(scene)
        self.call("apply_planning_scene", {"scene": data})


# ---------------------------------------------------------------------------- move group
class PlanResult(tuple):
    """``(success, trajectory, error_code)`` of MoveGroupClient.plan(), plus ``planning_time``."""

    def __new__(cls, success: bool, trajectory: RobotTrajectory | None, error_code: MoveItErrorCode,
                planning_time: float = 0.0) -> "PlanResult":
        self = super().__new__(cls, (success, trajectory, error_code))
        self.planning_time = planning_time
        return self

    @property
    def success(self) -> bool:
        return self[0]

    @property
    def trajectory(self) -> RobotTrajectory | None:
        return self[1]

    @property
    def error_code(self) -> MoveItErrorCode:
        return self[2]

    def __bool__(self) -> bool:
        return bool(self[0])


class MoveGroupClient(_Client):
    """moveit_commander's MoveGroupCommander for one planning group, through the planning_server.

    Targets and request options are kept client-side (set_* methods) and sent with each plan().
    """

    _prefix = "move_group_client"

    def __init__(self, group: str = "arm", node: Node | None = None, server: str = DEFAULT_SERVER,
                 timeout: float = 10.0, _handle: _RosHandle | None = None) -> None:
        if not isinstance(group, str) or not group:
            raise ValueError(f"group must be a planning group name, got {group!r}")
        super().__init__(node, server, timeout, _handle)
        self.group = group
        self._goal: dict[str, Any] | None = None
        self._start_state: dict[str, Any] | None = None
        self._options: dict[str, Any] = {}
        self._end_effector_link: str | None = None
        self._last_plan_duration: float | None = None
        self.last_result: dict[str, Any] | None = None
        self._scene: PlanningSceneInterface | None = None

    @property
    def scene(self) -> PlanningSceneInterface:
        """A PlanningSceneInterface sharing this client's node."""
        if self._scene is None:
            self._scene = PlanningSceneInterface(server=self.server, timeout=self.timeout, _handle=self._handle)
        return self._scene

    def get_name(self) -> str:
        return self.group

    def get_planning_frame(self) -> str:
        return "world"

    # ---- targets
    def set_named_target(self, name: str) -> None:
        if not isinstance(name, str) or not name:
            raise ValueError(f"named target must be a non-empty string, got {name!r}")
        self._goal = {"named": name}

    def set_joint_value_target(self, values: Sequence[float] | Mapping[str, float] | np.ndarray) -> None:
        """Joint goal: one value per group joint (in group order) or {joint name: value}."""
        if isinstance(values, Mapping):
            goal = {str(k): float(v) for k, v in values.items()}
            bad = [k for k, v in goal.items() if not math.isfinite(v)]
        else:
            goal = [float(v) for v in np.asarray(values, dtype=float).reshape(-1)]
            bad = [i for i, v in enumerate(goal) if not math.isfinite(v)]
        if bad:
            raise ValueError(f"joint target has NaN or infinite values at {bad}")
        self._goal = {"joints": goal}

    def set_pose_target(self, pose: Any, end_effector_link: str | None = None) -> None:
        """Pose goal in the world frame for ``end_effector_link`` (default: set_end_effector_link's
        or the group's tip link): Pose, 4x4 matrix, [x, y, z, qx, qy, qz, qw] or geometry_msgs/Pose."""
        goal: dict[str, Any] = {"pose": _pose_json(pose, "pose target")}
        link = end_effector_link or self._end_effector_link
        if link:
            goal["link"] = link
        self._goal = goal

    def set_end_effector_link(self, link: str) -> None:
        self._end_effector_link = link or None

    def get_end_effector_link(self) -> str | None:
        return self._end_effector_link

    def clear_pose_targets(self) -> None:
        self._goal = None

    def set_start_state_to_current_state(self) -> None:
        self._start_state = None

    set_start_state_to_current = set_start_state_to_current_state

    def set_start_state(self, state: RobotState | Mapping[str, float]) -> None:
        """Plan from this state: a RobotState message, or {joint: value} (other joints: current)."""
        if isinstance(state, RobotState):
            self._start_state = state.to_dict()
        elif isinstance(state, Mapping):
            self._start_state = RobotState.from_joint_positions(dict(state), is_diff=True).to_dict()
        else:
            raise ValueError(f"start state must be a RobotState or a {{joint: value}} dict, got {type(state).__name__}")

    # ---- request options
    def set_planner_id(self, planner_id: str) -> None:
        self._options["planner_id"] = str(planner_id)

    def set_pipeline_id(self, pipeline_id: str) -> None:
        self._options["pipeline_id"] = str(pipeline_id)

    set_planning_pipeline_id = set_pipeline_id

    def set_planning_time(self, seconds: float) -> None:
        if isinstance(seconds, bool) or not isinstance(seconds, (int, float)) or not math.isfinite(seconds) or seconds <= 0:
            raise ValueError(f"planning time must be > 0 seconds, got {seconds!r}")
        self._options["allowed_planning_time"] = float(seconds)

    def get_planning_time(self) -> float | None:
        return self._options.get("allowed_planning_time")

    def set_num_planning_attempts(self, attempts: int) -> None:
        if isinstance(attempts, bool) or not isinstance(attempts, int) or attempts < 1:
            raise ValueError(f"planning attempts must be an integer >= 1, got {attempts!r}")
        self._options["num_planning_attempts"] = attempts

    def set_max_velocity_scaling_factor(self, value: float) -> None:
        self._options["max_velocity_scaling_factor"] = _fraction_check(value, "max_velocity_scaling_factor")

    def set_max_acceleration_scaling_factor(self, value: float) -> None:
        self._options["max_acceleration_scaling_factor"] = _fraction_check(value, "max_acceleration_scaling_factor")

    # ---- state
    def get_current_state(self) -> RobotState:
        """The planning_server's current robot state (active joints)."""
        return RobotState.from_dict(self.call("get_state")["robot_state"])

    def get_current_joint_values(self) -> dict[str, float]:
        """Current values of every active joint, by name (the group's joints among them)."""
        return self.get_current_state().joint_positions()

    # ---- planning and execution
    def _request(self) -> dict[str, Any]:
        if self._goal is None:
            raise ValueError("no target set: call set_named_target, set_joint_value_target or set_pose_target first")
        request: dict[str, Any] = {"group": self.group, "goal": dict(self._goal), **self._options}
        if self._start_state is not None:
            request["start_state"] = self._start_state
        return request

    def _planning_timeout(self) -> float:
        return float(self._options.get("allowed_planning_time", 5.0)) * max(1, self._options.get("num_planning_attempts", 1)) + self.timeout

    def plan(self, timeout: float | None = None) -> PlanResult:
        """Plan to the target: PlanResult ``(success, RobotTrajectory | None, MoveItErrorCode)``."""
        request = self._request()
        try:
            result = self.call("plan", request, timeout or self._planning_timeout())
        except RpcError as exc:
            return PlanResult(False, None, _rpc_failure(exc))
        code = _error_code(result.get("error_code"))
        trajectory = RobotTrajectory.from_dict(result["trajectory"]) if result.get("trajectory") else None
        if trajectory is not None:
            self._last_plan_duration = trajectory.joint_trajectory.duration
        return PlanResult(bool(code) and trajectory is not None, trajectory, code, float(result.get("planning_time", 0.0)))

    def _execution_timeout(self, duration: float | None) -> float:
        if duration is None:
            return 300.0
        return duration * 2.0 + _EXECUTION_SLACK + self.timeout

    def execute(self, trajectory: Any = None, wait: bool = True, timeout: float | None = None) -> MoveItErrorCode:
        """Execute a trajectory (RobotTrajectory, JointTrajectory, PlanResult) or, with None, the
        server's last plan. Blocks until done unless ``wait`` is False. Truthy on success."""
        params: dict[str, Any] = {"wait": bool(wait)}
        duration = self._last_plan_duration
        if trajectory is not None:
            params["trajectory"] = _trajectory_json(trajectory)
            jt = params["trajectory"].get("joint_trajectory", params["trajectory"])
            points = jt.get("points") or []
            duration = float(points[-1].get("time_from_start", 0.0)) if points else 0.0
        try:
            result = self.call("execute", params, timeout or self._execution_timeout(duration))
        except RpcError as exc:
            return _rpc_failure(exc)
        self.last_result = result
        return _error_code(result.get("error_code"))

    def go(self, wait: bool = True, timeout: float | None = None) -> MoveItErrorCode:
        """Plan to the target and execute the plan (MoveIt's go())."""
        request = self._request()
        if not wait:
            request["wait"] = False
        try:
            result = self.call("plan_and_execute", request,
                               timeout or self._planning_timeout() + self._execution_timeout(None))
        except RpcError as exc:
            return _rpc_failure(exc)
        self.last_result = result
        return _error_code(result.get("error_code"))

    def compute_cartesian_path(self, waypoints: Sequence[Any], eef_step: float = 0.01, jump_threshold: float = 0.0,
                               avoid_collisions: bool = True, timeout: float | None = None
                               ) -> tuple[RobotTrajectory | None, float]:
        """Straight-line path of the end effector through ``waypoints`` (world frame), from the
        start state: (trajectory of the reachable part, fraction achieved). Fraction -1.0 means
        the request failed (self.last_result["error_code"] says why), as in MoveIt."""
        poses = [_pose_json(w, f"waypoint {k}") for k, w in enumerate(waypoints)]
        if not poses:
            raise ValueError("compute_cartesian_path needs at least one waypoint")
        request: dict[str, Any] = {"group": self.group, "waypoints": poses, "eef_step": float(eef_step),
                                   "jump_threshold": float(jump_threshold), "avoid_collisions": bool(avoid_collisions)}
        for key in ("max_velocity_scaling_factor", "max_acceleration_scaling_factor"):
            if key in self._options:
                request[key] = self._options[key]
        if self._end_effector_link:
            request["link"] = self._end_effector_link
        if self._start_state is not None:
            request["start_state"] = self._start_state
        try:
            result = self.call("compute_cartesian_path", request, timeout or self.timeout + 10.0)
        except RpcError as exc:
            self.last_result = {"error_code": _rpc_failure(exc).to_dict()}
            return None, -1.0
        self.last_result = result
        if not _error_code(result.get("error_code")):
            return None, -1.0
        trajectory = RobotTrajectory.from_dict(result["trajectory"]) if result.get("trajectory") else None
        return trajectory, float(result.get("fraction", 0.0))

    def execute_task_solution(self, steps: Sequence[Mapping[str, Any]] | Mapping[str, Any], wait: bool = True,
                              timeout: float | None = None) -> MoveItErrorCode:
        """Execute a task solution (see mycobot_planning.core.trajectory_execution.parse_task_solution)."""
        payload = dict(steps) if isinstance(steps, Mapping) else {"steps": list(steps)}
        payload["wait"] = bool(wait)
        try:
            result = self.call("execute_task_solution", payload, timeout or 600.0)
        except RpcError as exc:
            return _rpc_failure(exc)
        self.last_result = result
        return _error_code(result.get("error_code"))

    def stop(self) -> bool:
        """Stop the running execution (it ends PREEMPTED). False if nothing was executing."""
        return bool(self.call("stop").get("stopped"))

    # ---- scene shortcuts (MoveGroupCommander has attach/detach too)
    def attach_object(self, object_id: str, link_name: str | None = None, touch_links: Sequence[str] | None = None) -> bool:
        self.scene.attach_object(object_id, link_name, touch_links)
        return True

    def detach_object(self, object_id: str) -> bool:
        self.scene.detach_object(object_id)
        return True

    def close(self) -> None:
        super().close()
