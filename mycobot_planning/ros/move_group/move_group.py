"""move_group on the wire: MoveIt's services, actions and topics, with moveit_msgs types, on
move_group's default names, answered by the planning_server's core.

The planning_server process hosts this node beside its own (``planning_server``, the JSON and
std_srvs face). It is named ``move_group`` and carries ``robot_description`` and
``robot_description_semantic``, because MoveIt's clients (pymoveit2, MoveGroupInterface, RViz)
read the robot from the node of that name. Every request is translated (moveit_translation.py)
into the typed call of its capability module (mycobot_planning.capabilities), the calls the JSON
face makes too, so nothing is interpreted twice.

* actions: ``/move_action`` (MoveGroup: plan only, or plan and execute; feedback PLANNING,
  MONITOR, IDLE), ``/execute_trajectory`` (ExecuteTrajectory), ``/execute_task_solution``
  (moveit_task_constructor_msgs ExecuteTaskSolution, MTC's capability); all cancelable (PREEMPTED).
* services: ``/plan_kinematic_path``, ``/compute_cartesian_path``, ``/compute_ik``,
  ``/compute_fk``, ``/get_planning_scene``, ``/apply_planning_scene``, ``/check_state_validity``,
  ``/query_planner_interface``, ``/get_planner_params``, ``/set_planner_params``.
* topics in: ``/collision_object``, ``/attached_collision_object``, ``/planning_scene``
  (diffs), ``/trajectory_execution_event`` ("stop"); out: ``/monitored_planning_scene``
  (PlanningScene, on every change), ``/display_planned_path`` (DisplayTrajectory of every plan).
"""
from __future__ import annotations

import math
import sys
import threading
import traceback
from typing import Any, Callable

from geometry_msgs.msg import PoseStamped
from moveit_msgs.action import ExecuteTrajectory, MoveGroup
from moveit_task_constructor_msgs.action import ExecuteTaskSolution
from moveit_msgs.msg import (
    AttachedCollisionObject,
    CollisionObject,
    ConstraintEvalResult,
    ContactInformation,
    DisplayTrajectory,
    MoveItErrorCodes,
    PlannerInterfaceDescription,
    PlannerParams,
    PlanningScene,
)
from moveit_msgs.srv import (
    ApplyPlanningScene,
    GetCartesianPath,
    GetMotionPlan,
    GetPlannerParams,
    GetPlanningScene,
    GetPositionFK,
    GetPositionIK,
    GetStateValidity,
    QueryPlannerInterfaces,
    SetPlannerParams,
)
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from interfaces_py import names
from interfaces_py.moveit_conversions import (
    ConversionError,
    attached_object_from_msg,
    collision_object_from_msg,
    path_constraints_from_msg,
    planning_scene_from_msg,
    planning_scene_to_msg,
    pose_to_msg,
)
from interfaces_py.msgs import JointTrajectory, MoveItErrorCode, Pose, RobotState as RobotStateMsg
from interfaces_py.mtc_conversions import task_solution_from_msg
from mycobot_planning.capabilities import (
    cartesian_path,
    execute_trajectory,
    kinematics,
    move_action,
    plan,
    planner_query,
    planning_scene,
    state_validation,
    stop,
    task_solution,
)
from mycobot_planning.capabilities.json_face import RequestError
from mycobot_planning.capabilities.move_group_context import MoveGroupContext
from mycobot_planning.capabilities.plan import PlanResult
from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest
from mycobot_planning.core.trajectory_execution import ExecutionError, parse_task_solution
from mycobot_planning.ros.action_servers import ACTION_SERVER_OPTIONS
from mycobot_planning.ros.dedicated_service import DedicatedService
from mycobot_planning.ros.move_group.moveit_translation import (
    cartesian_request_from_msg,
    joint_trajectory_from_ros,
    motion_plan_request_from_msg,
    pose_from_ros,
    robot_state_from_ros,
    robot_state_to_ros,
    robot_trajectory_to_ros,
)

LATCHED_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
INPUT_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
#: s between two checks for a cancel request while a move_action / execute_trajectory goal runs
CANCEL_POLL = 0.02
#: Our own codes for a malformed request (JSON face) are not MoveIt's; MoveIt clients get FAILURE.
_MOVEIT_CODES = {v for k, v in vars(MoveItErrorCodes).items() if k.isupper() and isinstance(v, int)}


def flatten_parameters(tree: dict[str, Any], prefix: str) -> list[tuple[str, Any]]:
    """A YAML tree as ROS 2 parameters ("prefix.a.b", value), as a params file declares it.
    Values ROS cannot hold (None, mixed lists) are left out."""
    out: list[tuple[str, Any]] = []
    for key, value in tree.items():
        name = f"{prefix}.{key}"
        if isinstance(value, dict):
            out += flatten_parameters(value, name)
        elif isinstance(value, (bool, int, float, str)):
            out.append((name, value))
        elif isinstance(value, list) and value and len({type(v) for v in value}) == 1 \
                and isinstance(value[0], (bool, int, float, str)):
            out.append((name, value))
    return out


def _typed_code(code: MoveItErrorCode) -> MoveItErrorCodes:
    val = code.val if code.val in _MOVEIT_CODES else MoveItErrorCodes.FAILURE
    return MoveItErrorCodes(val=val, message=code.message, source=code.source)


def _empty_scene_diff(diff: Any) -> bool:
    """A PlanningScene message that changes nothing (what a client leaves unset): no object,
    joint, attached object, collision matrix entry, padding, scale, color or octomap."""
    acm = diff.allowed_collision_matrix
    return not any(len(x) for x in (
        diff.world.collision_objects, diff.robot_state.joint_state.name, diff.robot_state.attached_collision_objects,
        diff.robot_state.multi_dof_joint_state.joint_names, acm.entry_names, acm.default_entry_names,
        diff.link_padding, diff.link_scale, diff.object_colors, diff.fixed_frame_transforms,
        diff.world.octomap.octomap.data))


def _code_of(exc: Exception) -> int:
    """A refusal's MoveItErrorCodes value (a RequestError's BAD_REQUEST is no MoveIt code)."""
    return exc.moveit_code if isinstance(exc, RequestError) else int(getattr(exc, "code", MoveItErrorCodes.FAILURE))


def _failure(val: int, message: str, source: str = "move_group") -> MoveItErrorCodes:
    return MoveItErrorCodes(val=val if val in _MOVEIT_CODES else MoveItErrorCodes.FAILURE, message=message,
                            source=source)


class MoveGroupFace(Node):
    """The ``move_group`` node of the planning_server process (see module docstring)."""

    def __init__(self, core: MoveGroupContext, urdf: str, srdf: str, joint_limits: dict | None,
                 kinematics: dict | None, context: Any, log: Callable[[str, str], None]) -> None:
        super().__init__(names.MOVE_GROUP_NODE, context=context)
        self.core = core
        self._log = log
        self.declare_parameter("robot_description", urdf)
        self.declare_parameter("robot_description_semantic", srdf)
        # as move_group carries them: what loads the same robot model elsewhere (MTC's loadRobotModel)
        for prefix, tree in (("robot_description_planning", joint_limits), ("robot_description_kinematics", kinematics)):
            for name, value in flatten_parameters(tree or {}, prefix):
                self.declare_parameter(name, value)
        self._request_group = ReentrantCallbackGroup()
        self._inputs = MutuallyExclusiveCallbackGroup()
        self._scene_lock = threading.Lock()
        self._goals_lock = threading.Lock()
        self._active_goals = 0
        self._scene_pub = self.create_publisher(PlanningScene, names.MONITORED_PLANNING_SCENE, LATCHED_QOS)
        # volatile, depth 10, as move_group publishes it
        self._display_pub = self.create_publisher(DisplayTrajectory, names.DISPLAY_PLANNED_PATH, 10)

        for cls, topic, handler in (
            (CollisionObject, names.COLLISION_OBJECT, self._on_collision_object),
            (AttachedCollisionObject, names.ATTACHED_COLLISION_OBJECT, self._on_attached_object),
            (PlanningScene, names.PLANNING_SCENE, self._on_planning_scene),
            (String, names.TRAJECTORY_EXECUTION_EVENT, self._on_execution_event),
        ):
            self.create_subscription(cls, topic, handler, INPUT_QOS, callback_group=self._inputs)
        # each service on threads of its own, not on the node's executor (dedicated_service.py:
        # about 1 ms less per call); the count is how many requests of it can run at once
        self._dedicated_services = [DedicatedService(self, srv, name, self._guarded(name, handler), threads=threads)
                          for srv, name, handler, threads in (
            (GetMotionPlan, names.PLAN_SERVICE, self._srv_plan, 4),
            (GetCartesianPath, names.CARTESIAN_PATH_SERVICE, self._srv_cartesian, 4),
            (GetPositionIK, names.IK_SERVICE, self._srv_ik, 2),
            (GetPositionFK, names.FK_SERVICE, self._srv_fk, 2),
            (GetPlanningScene, names.GET_PLANNING_SCENE_SERVICE, self._srv_get_scene, 2),
            (ApplyPlanningScene, names.APPLY_PLANNING_SCENE_SERVICE, self._srv_apply_scene, 2),
            (GetStateValidity, names.STATE_VALIDITY_SERVICE, self._srv_validity, 2),
            (QueryPlannerInterfaces, names.QUERY_PLANNERS_SERVICE, self._srv_query_planners, 1),
            (GetPlannerParams, names.GET_PLANNER_PARAMS_SERVICE, self._srv_get_planner_params, 1),
            (SetPlannerParams, names.SET_PLANNER_PARAMS_SERVICE, self._srv_set_planner_params, 1),
        )]
        self._move_action = ActionServer(self, MoveGroup, names.MOVE_ACTION,
                                         self._counted(self._execute_move_group, MoveGroup),
                                         goal_callback=lambda goal: GoalResponse.ACCEPT,
                                         cancel_callback=lambda handle: CancelResponse.ACCEPT,
                                         callback_group=self._request_group,
                                         **ACTION_SERVER_OPTIONS)
        self._execute_action = ActionServer(self, ExecuteTrajectory, names.EXECUTE_TRAJECTORY_ACTION,
                                            self._counted(self._execute_trajectory, ExecuteTrajectory),
                                            goal_callback=lambda goal: GoalResponse.ACCEPT,
                                            cancel_callback=lambda handle: CancelResponse.ACCEPT,
                                            callback_group=self._request_group,
                                            **ACTION_SERVER_OPTIONS)

        # MTC's move_group capability (ExecuteTaskSolutionCapability)
        self._task_action = ActionServer(self, ExecuteTaskSolution, names.EXECUTE_TASK_SOLUTION_ACTION,
                                         self._counted(self._execute_task_solution, ExecuteTaskSolution),
                                         goal_callback=lambda goal: GoalResponse.ACCEPT,
                                         cancel_callback=lambda handle: CancelResponse.ACCEPT,
                                         callback_group=self._request_group,
                                         **ACTION_SERVER_OPTIONS)

    def close(self) -> None:
        """The services' threads stopped, then the action servers destroyed."""
        for service in self._dedicated_services:
            service.close()
        for server in (self._move_action, self._execute_action, self._task_action):
            server.destroy()

    # ------------------------------------------------------------------ plumbing
    def active_goals(self) -> int:
        """Action goals running now (their clients not answered yet)."""
        with self._goals_lock:
            return self._active_goals

    def _counted(self, execute: Callable[[Any], Any], action: Any) -> Callable[[Any], Any]:
        """An action's execute callback, counted in active_goals (shutdown waits for them); if
        rclpy goes down under a goal anyway, its end is logged, not a traceback."""
        def run(goal_handle: Any) -> Any:
            with self._goals_lock:
                self._active_goals += 1
            try:
                return execute(goal_handle)
            except Exception as exc:
                if self.context.ok():
                    raise
                print(f"[WARN] [move_group]: a goal ended during shutdown ({type(exc).__name__}): its client "
                      "got no result", file=sys.stderr, flush=True)
                return action.Result()
            finally:
                with self._goals_lock:
                    self._active_goals -= 1
        return run

    def _guarded(self, name: str, handler: Callable[[Any, Any], Any]) -> Callable[[Any, Any], Any]:
        """A service handler that answers even when the handler fails: the response carries
        FAILURE and the log has the traceback (a client must never wait for nothing)."""
        def serve(request: Any, response: Any) -> Any:
            try:
                return handler(request, response)
            except (ConversionError, RequestError) as exc:
                self._log("warning", f"{name}: refused: {exc.message}")
                if hasattr(response, "error_code"):
                    response.error_code = _failure(_code_of(exc), exc.message, name.strip("/"))
                return response
            except Exception as exc:
                self._log("error", f"{name} failed: {type(exc).__name__}: {exc}\n{traceback.format_exc()}")
                if hasattr(response, "error_code"):
                    response.error_code = _failure(MoveItErrorCodes.FAILURE,
                                                   f"internal error ({type(exc).__name__}); the log has the details")
                return response
        return serve

    def publish_scene(self) -> None:
        """/monitored_planning_scene: the full scene (called on every change)."""
        with self._scene_lock:
            msg, _ = self.core.scene_snapshot()
            self._scene_pub.publish(planning_scene_to_msg(msg.to_dict(), stamp=self.get_clock().now().to_msg()))

    def publish_display(self, trajectory: JointTrajectory) -> None:
        """/display_planned_path: what RViz's MotionPlanning display animates (built only when
        someone listens: the message is volatile, as move_group's)."""
        if self._display_pub.get_subscription_count() == 0:
            return
        msg = DisplayTrajectory()
        msg.model_id = self.core.model.name
        start = dict(zip(trajectory.joint_names, trajectory.points[0].positions)) if trajectory.points else {}
        state = dict(self.core.joint_positions()[0] or {})
        state.update(start)
        msg.trajectory_start = robot_state_to_ros(state)
        msg.trajectory = [robot_trajectory_to_ros(trajectory, self.core.model.root_link)]
        self._display_pub.publish(msg)

    # ------------------------------------------------------------------ planning
    def _plan_request(self, msg: Any) -> tuple[list[tuple[MotionPlanRequest, str]], RobotStateMsg | None, Any]:
        """A moveit_msgs/MotionPlanRequest as the plan capability's arguments, joint goals
        completed (see _complete_joint_goals)."""
        requests, start, path = motion_plan_request_from_msg(msg)
        self._complete_joint_goals([r for r, _ in requests], start)
        return requests, start, path

    def _complete_joint_goals(self, requests: list[MotionPlanRequest], start: RobotStateMsg | None) -> None:
        """Joints of the group that a goal's joint constraints leave out keep their start-state
        values (MoveIt would sample them anywhere in their bounds)."""
        joint_requests = [r for r in requests if isinstance(r.goal, JointGoal) and isinstance(r.goal.values, dict)]
        if not joint_requests or not self.core.model.has_group(joint_requests[0].group):
            return  # the capability answers INVALID_GROUP_NAME
        values = dict(self.core.joint_positions()[0] or {})
        if start is not None:
            values.update(start.joint_positions())
        for request in joint_requests:
            for name in self.core.model.group(request.group).joint_names:
                if name not in request.goal.values and name in values:
                    request.goal.values[name] = float(values[name])

    def _trajectory_start(self, result: PlanResult) -> Any:
        """The state a plan starts from, as the response's trajectory_start."""
        state = result.start_state
        values = state.to_joint_dict(include_mimic=False) if state is not None else dict(
            self.core.joint_positions()[0] or {})
        return robot_state_to_ros(values, self.get_clock().now().to_msg())

    def _srv_plan(self, request: GetMotionPlan.Request, response: GetMotionPlan.Response) -> GetMotionPlan.Response:
        try:
            result = plan.plan_any(self.core, *self._plan_request(request.motion_plan_request))
        except ConversionError as exc:
            response.motion_plan_response.error_code = _failure(_code_of(exc), exc.message, "plan_kinematic_path")
            response.motion_plan_response.group_name = request.motion_plan_request.group_name
            self._log("warning", f"plan_kinematic_path: refused: {exc.message}")
            return response
        out = response.motion_plan_response
        out.group_name = result.group or request.motion_plan_request.group_name
        out.error_code = _typed_code(result.error_code)
        out.planning_time = float(result.planning_time)
        if result.trajectory is not None:
            out.trajectory = robot_trajectory_to_ros(result.trajectory, self.core.model.root_link)
            out.trajectory_start = self._trajectory_start(result)
        return response

    def _srv_cartesian(self, request: GetCartesianPath.Request,
                       response: GetCartesianPath.Response) -> GetCartesianPath.Response:
        result = cartesian_path.compute_cartesian_path(self.core, cartesian_request_from_msg(request))
        response.error_code = _typed_code(result.error_code)
        response.fraction = float(result.fraction)
        if result.trajectory is not None:
            response.solution = robot_trajectory_to_ros(result.trajectory, self.core.model.root_link)
            response.start_state = robot_state_to_ros(result.start_state.to_joint_dict(include_mimic=False),
                                                      self.get_clock().now().to_msg())
        return response

    # ------------------------------------------------------------------ kinematics and validity
    def _srv_ik(self, request: GetPositionIK.Request, response: GetPositionIK.Response) -> GetPositionIK.Response:
        ik = request.ik_request
        if len(ik.pose_stamped_vector):
            raise ConversionError(MoveItErrorCodes.FAILURE,
                                  "pose_stamped_vector (several IK links at once) is not supported; use pose_stamped")
        timeout = ik.timeout.sec + ik.timeout.nanosec * 1e-9
        code, state = kinematics.compute_ik(self.core, ik.group_name, pose_from_ros(ik.pose_stamped.pose, "IK pose"),
                                            ik.pose_stamped.header.frame_id or "world", ik.ik_link_name,
                                            robot_state_from_ros(ik.robot_state), bool(ik.avoid_collisions),
                                            max(timeout, 0.0), path_constraints_from_msg(ik.constraints))
        response.error_code = _typed_code(code)
        if state is not None:
            response.solution = robot_state_to_ros(state.to_joint_dict(include_mimic=False),
                                                   self.get_clock().now().to_msg())
        return response

    def _srv_fk(self, request: GetPositionFK.Request, response: GetPositionFK.Response) -> GetPositionFK.Response:
        frame = request.header.frame_id or "world"
        code, poses = kinematics.compute_fk(self.core, list(request.fk_link_names), frame,
                                            robot_state_from_ros(request.robot_state))
        response.error_code = _typed_code(code)
        stamp = self.get_clock().now().to_msg()
        for link, pose in poses.items():
            stamped = PoseStamped()
            stamped.header.frame_id = frame
            stamped.header.stamp = stamp
            stamped.pose = pose_to_msg(Pose.from_matrix(pose).to_dict())
            response.pose_stamped.append(stamped)
            response.fk_link_names.append(link)
        return response

    def _srv_validity(self, request: GetStateValidity.Request,
                      response: GetStateValidity.Response) -> GetStateValidity.Response:
        code, answer = state_validation.check_state_validity(self.core, robot_state_from_ros(request.robot_state),
                                                             request.group_name,
                                                             path_constraints_from_msg(request.constraints))
        if code.val != MoveItErrorCodes.SUCCESS:
            raise ConversionError(code.val, code.message)
        response.valid = bool(answer.valid)
        response.constraint_result = [ConstraintEvalResult(result=bool(ok), distance=float(distance))
                                      for ok, distance in answer.constraint_results]
        for body_a, body_b, depth in answer.contacts:
            info = ContactInformation()
            info.header.frame_id = "world"
            info.contact_body_1, info.contact_body_2 = body_a, body_b
            info.depth = float(depth)
            response.contacts.append(info)
        return response

    # ------------------------------------------------------------------ scene
    def _srv_get_scene(self, request: GetPlanningScene.Request,
                       response: GetPlanningScene.Response) -> GetPlanningScene.Response:
        msg = planning_scene.get_planning_scene(self.core)
        response.scene = planning_scene_to_msg(msg.to_dict(), int(request.components.components),
                                               self.get_clock().now().to_msg())
        return response

    def _check_padding(self, scene: Any) -> None:
        """A PlanningScene's link_padding and link_scale: links the robot has, padding finite and
        >= 0, scale finite and > 0 (ConversionError, INVALID_LINK_NAME or INVALID_MOTION_PLAN,
        otherwise). Valid entries are accepted and not applied: collision checking here uses the
        links' own geometry (said in the log, never silently)."""
        entries = [("link_padding", p.link_name, p.padding, 0.0) for p in scene.link_padding]
        entries += [("link_scale", s.link_name, s.scale, 1.0) for s in scene.link_scale]
        for what, link, value, neutral in entries:
            if not self.core.model.has_link(link):
                raise ConversionError(MoveItErrorCodes.INVALID_LINK_NAME,
                                      f"{what} names link {link!r}, which robot '{self.core.model.name}' does not have")
            ok = math.isfinite(value) and (value >= 0.0 if what == "link_padding" else value > 0.0)
            if not ok:
                raise ConversionError(MoveItErrorCodes.INVALID_MOTION_PLAN,
                                      f"{what} of link {link!r} must be a finite number "
                                      f"{'>= 0' if what == 'link_padding' else '> 0'}, got {value!r}")
            if value != neutral:
                self._log("warning", f"{what} {value:g} of link {link!r} accepted but not applied: collision "
                                     "checking uses the links' own geometry")

    def _srv_apply_scene(self, request: ApplyPlanningScene.Request,
                         response: ApplyPlanningScene.Response) -> ApplyPlanningScene.Response:
        try:
            self._check_padding(request.scene)
            planning_scene.apply_planning_scene(self.core, planning_scene_from_msg(request.scene))
        except (ConversionError, RequestError) as exc:
            self._log("warning", f"apply_planning_scene: refused: {exc.message}")
            response.success = False
            return response
        response.success = True
        return response

    def _topic(self, topic: str, apply: Callable[[], dict[str, Any] | Any]) -> None:
        try:
            apply()
        except (ConversionError, RequestError) as exc:
            self._log("warning", f"refused update on {topic}: {exc.message}")
        except Exception as exc:  # one bad message never takes the node down
            self._log("error", f"update on {topic} failed: {type(exc).__name__}: {exc}\n{traceback.format_exc()}")

    def _on_collision_object(self, msg: CollisionObject) -> None:
        self._topic(names.COLLISION_OBJECT,
                    lambda: self.core.apply_collision_objects([collision_object_from_msg(msg)]))

    def _on_attached_object(self, msg: AttachedCollisionObject) -> None:
        """MoveIt's conventions beyond a plain message: ADD without shapes attaches the world
        object of that id; REMOVE detaches by id from whatever link holds it (every attached
        object when the id is empty) and puts it back into the world."""
        obj = msg.object
        operation = obj.operation[0] if isinstance(obj.operation, (bytes, bytearray)) else int(obj.operation)

        def apply() -> Any:
            if operation == 1:  # REMOVE
                ids = [obj.id] if obj.id else self.core.get_objects()["attached_objects"].keys()
                return [self.core.detach_object(i) for i in list(ids)]
            if operation == 0 and not len(obj.primitives) and not len(obj.meshes):
                return self.core.attach_object(obj.id, msg.link_name or None, list(msg.touch_links) or None)
            return self.core.apply_attached_collision_object(attached_object_from_msg(msg))

        self._topic(names.ATTACHED_COLLISION_OBJECT, apply)

    def _on_planning_scene(self, msg: PlanningScene) -> None:
        self._topic(names.PLANNING_SCENE, lambda: self.core.apply_planning_scene(planning_scene_from_msg(msg)))

    def _on_execution_event(self, msg: String) -> None:
        if msg.data == "stop":
            self._log("info", f"{names.TRAJECTORY_EXECUTION_EVENT}: stop")
            stop.stop(self.core)
        else:
            self._log("warning", f"{names.TRAJECTORY_EXECUTION_EVENT}: unknown event {msg.data!r} (known: 'stop')")

    # ------------------------------------------------------------------ planner interfaces
    def _srv_query_planners(self, request: QueryPlannerInterfaces.Request,
                            response: QueryPlannerInterfaces.Response) -> QueryPlannerInterfaces.Response:
        for entry in planner_query.query_planner_interfaces(self.core):
            response.planner_interfaces.append(PlannerInterfaceDescription(
                name=entry.name, pipeline_id=entry.pipeline_id, planner_ids=entry.planner_ids))
        return response

    def _srv_get_planner_params(self, request: GetPlannerParams.Request,
                                response: GetPlannerParams.Response) -> GetPlannerParams.Response:
        params = planner_query.get_planner_params(self.core, request.pipeline_id, request.planner_config,
                                                  request.group)
        response.params = PlannerParams(keys=list(params), values=list(params.values()),
                                        descriptions=[""] * len(params))
        return response

    def _srv_set_planner_params(self, request: SetPlannerParams.Request,
                                response: SetPlannerParams.Response) -> SetPlannerParams.Response:
        p = request.params
        if len(p.keys) != len(p.values):  # moveit_msgs/SetPlannerParams has no answer: the log says why
            problem = f"params has {len(p.keys)} keys but {len(p.values)} values; nothing changed"
        elif len(set(p.keys)) != len(p.keys):
            problem = "params names a key twice; nothing changed"
        else:
            problem = planner_query.set_planner_params(self.core, request.pipeline_id, request.planner_config,
                                                       dict(zip(p.keys, p.values)), bool(request.replace))
        if problem:
            self._log("warning", f"set_planner_params: refused: {problem}")
        return response

    # ------------------------------------------------------------------ actions
    def _execute_with_cancel(self, goal_handle: Any, run: Callable[[], Any],
                             armed: threading.Event | None = None,
                             planning_cancel: threading.Event | None = None) -> Any:
        """Run an execution, stopping it when the goal's client cancels (once ``armed`` is set,
        when given). Before that, a cancel sets ``planning_cancel`` (the goal's requests' cancel:
        their planners stop within a poll, PREEMPTED) and the plan does not execute. Only this
        goal's plans are cancelled, never another client's."""
        done = threading.Event()

        def watch() -> None:
            while not done.wait(CANCEL_POLL):
                if not goal_handle.is_cancel_requested:
                    continue
                if armed is None or armed.is_set():
                    stop.stop(self.core)
                    return
                if planning_cancel is not None and not planning_cancel.is_set():
                    planning_cancel.set()

        watcher = threading.Thread(target=watch, name="cancel watcher", daemon=True)
        watcher.start()
        try:
            return run()
        finally:
            done.set()

    def _finish(self, goal_handle: Any, code: MoveItErrorCodes) -> None:
        if code.val == MoveItErrorCodes.SUCCESS:
            goal_handle.succeed()
        elif goal_handle.is_cancel_requested:
            code.val = MoveItErrorCodes.PREEMPTED
            goal_handle.canceled()
        else:
            goal_handle.abort()

    def _execute_move_group(self, goal_handle: Any) -> MoveGroup.Result:
        goal = goal_handle.request
        result = MoveGroup.Result()
        feedback = MoveGroup.Feedback()
        options = goal.planning_options
        try:
            try:  # checked before anything is applied: a refused goal changes nothing
                replanning = move_action.Replanning.checked(bool(options.replan), int(options.replan_attempts),
                                                            float(options.replan_delay), self._log)
            except RequestError as exc:
                raise ConversionError(exc.code, exc.message) from None
            # The goal's scene diff is planned with, never applied to the live scene (MoveIt
            # plans on a copy of the monitored scene with the diff): a goal changes nothing there.
            scene_diff = None
            if not _empty_scene_diff(options.planning_scene_diff):
                try:
                    self._check_padding(options.planning_scene_diff)
                    scene_diff = planning_scene_from_msg(options.planning_scene_diff)
                    self.core.scene_with_diff(scene_diff)  # checked now: a refused diff plans nothing
                except RequestError as exc:
                    raise ConversionError(exc.moveit_code, f"planning_scene_diff refused: {exc.message}") from None
            requests, start, path = self._plan_request(goal.request)
        except ConversionError as exc:
            self._log("warning", f"move_action: refused: {exc.message}")
            result.error_code = _failure(_code_of(exc), exc.message, "move_action")
            goal_handle.abort()
            return result
        feedback.state = "PLANNING"
        goal_handle.publish_feedback(feedback)

        def planned_ok(planned: PlanResult) -> bool:
            """Between planning and execution: the plan goes into the result; a cancelled goal
            does not move; the feedback says MONITOR."""
            result.planned_trajectory = robot_trajectory_to_ros(planned.trajectory, self.core.model.root_link)
            result.trajectory_start = self._trajectory_start(planned)
            if goal_handle.is_cancel_requested:
                return False
            feedback.state = "MONITOR"
            goal_handle.publish_feedback(feedback)
            executing.set()
            return True

        def replanning_now(attempt: int) -> None:
            feedback.state = "PLANNING"  # as move_group: PLANNING again, then MONITOR
            goal_handle.publish_feedback(feedback)

        def replanned(planned: PlanResult) -> None:
            result.planned_trajectory = robot_trajectory_to_ros(planned.trajectory, self.core.model.root_link)
            feedback.state = "MONITOR"
            goal_handle.publish_feedback(feedback)

        executing = threading.Event()
        planning_cancel = threading.Event()  # set when the client cancels while the goal plans
        for request, _ in requests:
            request.cancel = planning_cancel
        planned, executed = self._execute_with_cancel(goal_handle, lambda: move_action.plan_and_execute(
            self.core, requests, start, path, plan_only=options.plan_only, before_execution=planned_ok,
            replanning=replanning, cancelled=lambda: goal_handle.is_cancel_requested, on_replan=replanning_now,
            on_replanned=replanned, scene_diff=scene_diff), executing, planning_cancel)
        if planned is None:  # refused: another execution runs
            result.error_code = _typed_code(executed.error_code)
            goal_handle.abort()
            return result
        result.planning_time = float(planned.planning_time)
        code = _typed_code(planned.error_code)
        if code.val != MoveItErrorCodes.SUCCESS or planned.trajectory is None:
            result.error_code = code
            self._finish(goal_handle, code)
            return result
        if options.plan_only:
            result.planned_trajectory = robot_trajectory_to_ros(planned.trajectory, self.core.model.root_link)
            result.trajectory_start = self._trajectory_start(planned)
            result.error_code = code
            goal_handle.succeed()
            return result
        if executed is None:  # cancelled after planning
            result.error_code = _failure(MoveItErrorCodes.PREEMPTED, "canceled after planning")
            goal_handle.canceled()
            return result
        result.error_code = _typed_code(executed.error_code)
        if result.error_code.val == MoveItErrorCodes.SUCCESS:
            result.executed_trajectory = result.planned_trajectory
        feedback.state = "IDLE"
        goal_handle.publish_feedback(feedback)
        self._finish(goal_handle, result.error_code)
        return result

    def _execute_task_solution(self, goal_handle: Any) -> ExecuteTaskSolution.Result:
        """Execute an MTC solution step by step (trajectories, then each step's scene diff), as
        MTC's execute_task_solution capability does; cancel stops it (PREEMPTED)."""
        result = ExecuteTaskSolution.Result()
        try:
            for sub in goal_handle.request.solution.sub_trajectory:
                self._check_padding(sub.scene_diff)
            steps = parse_task_solution(task_solution_from_msg(goal_handle.request.solution))
        except (ConversionError, ExecutionError) as exc:
            self._log("warning", f"execute_task_solution: refused: {exc.message}")
            result.error_code = _failure(_code_of(exc), exc.message, "execute_task_solution")
            goal_handle.abort()
            return result
        executed = self._execute_with_cancel(goal_handle,
                                             lambda: task_solution.execute_task_solution(self.core, steps))
        result.error_code = _typed_code(executed.error_code)
        self._finish(goal_handle, result.error_code)
        return result

    def _execute_trajectory(self, goal_handle: Any) -> ExecuteTrajectory.Result:
        goal = goal_handle.request
        result = ExecuteTrajectory.Result()
        try:
            trajectory, _ = joint_trajectory_from_ros(goal.trajectory)
        except ConversionError as exc:
            self._log("warning", f"execute_trajectory: refused: {exc.message}")
            result.error_code = _failure(_code_of(exc), exc.message, "execute_trajectory")
            goal_handle.abort()
            return result
        controllers = list(goal.controller_names) or None
        feedback = ExecuteTrajectory.Feedback(state="MONITOR")
        goal_handle.publish_feedback(feedback)
        executed = self._execute_with_cancel(goal_handle, lambda: execute_trajectory.execute_trajectory(
            self.core, trajectory, controllers))
        result.error_code = _typed_code(executed.error_code)
        self._finish(goal_handle, result.error_code)
        return result
