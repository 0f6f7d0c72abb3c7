"""objective_server: runs objectives (BehaviorTree.CPP v4 XML) with our behaviors, MoveIt Pro's way.

* ``/do_objective`` (mycobot_objective_msgs/action/DoObjectiveSequence): goal ``objective_name``
  (a BehaviorTree ID or file name in the objective library) or ``objective_xml_string`` (the name
  wins if both are set), ``parameter_overrides`` written to the root blackboard; result
  ``error_code`` (moveit_msgs/MoveItErrorCodes: SUCCESS, FAILURE, PREEMPTED when canceled or
  replaced) and ``error_message``. One objective at a time: a new goal cancels the running one.
  A tree that does not load (bad XML, unknown node, missing port, ...) is refused before
  anything runs, with the loader's file:line: node message as the result.
* ``/cancel_objective`` (CancelObjective): halts the running tree and stops the arm (move_group's
  stop and a cancel of every controller goal), then reports Cancelled.
* ``~/status`` (ObjectiveServerStatus, transient local): Idle, Loading, Running, Success, Failure,
  Cancelled, with the objective's name and why it failed.
* ``~/tree_state`` (std_msgs/String, JSON, transient local): the running tree's XML with ``_uid``s,
  every node's status by uid, and the root blackboard; at most every ``tree_state_period`` s and
  once at the end.
* ``~/operator_prompt`` (OperatorPrompt, transient local) and ``~/answer_operator_prompt``
  (AnswerOperatorPrompt): RequestTeleoperation / WaitForUserTrajectoryApproval ask; the operator
  (the browser viewer, a script) answers Continue or Fail, or moves the arm to a waypoint or a
  joint state through move_group while the prompt stays open.
* ``~/get_objectives`` (std_srvs/Trigger): the objective library as JSON in ``message``.

Parameters: objective_library_paths, waypoints_file, tick_period, tree_state_period,
planning_group, ik_frame, arm_controller_action, gripper_action. See docs/objectives.md.
"""
from __future__ import annotations

import json
import threading
import time
from pathlib import Path
from typing import Any

from action_msgs.srv import CancelGoal
from control_msgs.action import GripperCommand
from moveit_msgs.action import ExecuteTrajectory, MoveGroup
from moveit_msgs.msg import MoveItErrorCodes
from mycobot_objective_msgs.action import DoObjectiveSequence
from mycobot_objective_msgs.msg import BehaviorParameterDescription, ObjectiveServerStatus, OperatorPrompt
from mycobot_objective_msgs.srv import AnswerOperatorPrompt, CancelObjective
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import String
from std_srvs.srv import Trigger

from interfaces_py.names import EXECUTE_TRAJECTORY_ACTION, MOVE_ACTION
from mycobot_planning.ros.action_servers import ACTION_SERVER_OPTIONS
from mycobot_planning.behavior_tree import (
    BehaviorTreeFactory,
    Blackboard,
    NodeStatus,
    PoseStamped,
    TreeLoadError,
    write_tree_to_xml,
)
from mycobot_planning.behavior_tree.behaviors import (
    JointStateValue,
    OperatorPrompt as Prompt,
    OperatorPrompts,
    WaypointError,
    WaypointStore,
    register_core_behaviors,
)
from mycobot_planning.behavior_tree.exceptions import BehaviorTreeException
from mycobot_planning.behavior_tree.xml_parsing import parse_xml
from mycobot_planning.behavior_tree.objectives import (
    blackboard_json,
    default_library_paths,
    library_files,
    load_objective,
    tree_ids_of,
)
from interfaces_py.msgs import Pose
from mycobot_planning.paths import config_dir

from ..node_runtime import ParameterSpec, Parameters
from .mtc_behaviors import MTC_BEHAVIORS
from .ros_behaviors import ROS_BEHAVIORS, joint_constraints
from .ros_calls import PendingGoal
from .ros_context import LATCHED, RosBehaviorContext

NODE_NAME = "objective_server"
C = MoveItErrorCodes
S = ObjectiveServerStatus


def default_waypoints_file() -> str:
    path = config_dir() / "waypoints" / "mycobot_waypoints.yaml"
    return str(path) if path.is_file() else ""


def register_behaviors(factory: BehaviorTreeFactory, context: RosBehaviorContext) -> None:
    """Every behavior the server offers: the ROS-free ones and the ROS ones."""
    register_core_behaviors(factory, context)
    for cls, registration_id, subcategory in (*ROS_BEHAVIORS, *MTC_BEHAVIORS):
        factory.register_node_type(cls, registration_id, context, metadata={"subcategory": subcategory})


def tree_nodes_model_xml() -> str:
    """The TreeNodesModel of every behavior the server offers (for Groot2; built-ins left out,
    Groot2 knows them). config/groot/tree_nodes_model.xml is this text."""
    factory = BehaviorTreeFactory()
    register_behaviors(factory, None)  # type: ignore[arg-type]  # contexts are used only by instances
    return factory.write_tree_nodes_model_xml(include_builtin=False)


def _override_value(parameter: Any) -> Any:
    """A BehaviorParameter's value, by its description's type."""
    kind = parameter.description.type
    D = BehaviorParameterDescription
    if kind == D.TYPE_STRING:
        return parameter.string_value
    if kind == D.TYPE_DOUBLE:
        return float(parameter.double_value)
    if kind == D.TYPE_INT:
        return int(parameter.int_value)
    if kind == D.TYPE_BOOL:
        return bool(parameter.bool_value)
    if kind == D.TYPE_POSE:
        p = parameter.pose_value.pose
        return PoseStamped(parameter.pose_value.header.frame_id,
                           Pose(position=[p.position.x, p.position.y, p.position.z],
                                orientation=[p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w]))
    if kind == D.TYPE_JOINT_STATE:
        js = parameter.joint_state_value
        return JointStateValue(list(js.name), [float(v) for v in js.position])
    raise ValueError(f"parameter override '{parameter.description.name}': unknown type {kind}")


class _Run:
    """The objective running now: its goal, tree and cancel flag."""

    def __init__(self, name: str, goal_handle: Any) -> None:
        self.name = name
        self.goal_handle = goal_handle
        self.tree: Any = None
        self.cancel = threading.Event()
        self.cancel_reason = ""
        self.statuses: dict[int, str] = {}
        self.last: dict[int, str] = {}  # the last status other than IDLE (what Groot2 shows faded)
        self.failed_node = ""
        self.failed_why = ""


class ObjectiveServer(Node):
    """See the module docstring and docs/objectives.md."""

    def __init__(self) -> None:
        super().__init__(NODE_NAME)
        self.params = Parameters(self, [
            ParameterSpec("objective_library_paths", [], "folders of objective XML files searched after "
                          "config/objectives (the user's objective library; its objectives replace ours of the "
                          "same name)", array_type=Parameter.Type.STRING_ARRAY),
            ParameterSpec("waypoints_file", default_waypoints_file(), "YAML file of saved waypoints (MoveIt Pro's "
                          "format); SaveWaypoint writes to it", read_only=True),
            ParameterSpec("tick_period", 0.01, "longest time between two ticks of a running tree (s)",
                          range=(0.001, 1.0)),
            ParameterSpec("tree_state_period", 0.1, "shortest time between two ~/tree_state messages (s)",
                          range=(0.0, 10.0)),
            ParameterSpec("planning_group", "arm", "the planning group operator waypoint moves use", non_empty=True),
            ParameterSpec("ik_frame", "link6_flange", "the link MoveToPose and PlanCartesianPath place by default",
                          non_empty=True),
            ParameterSpec("arm_controller_action", "/arm_controller/follow_joint_trajectory",
                          "the arm controller's FollowJointTrajectory action (canceled to stop the arm)",
                          non_empty=True),
            ParameterSpec("gripper_action", "/grip_action_controller/gripper_cmd",
                          "the gripper controller's GripperCommand action (canceled to stop it)", non_empty=True),
            ParameterSpec("rest_timeout", 2.0, "how long a cancel waits for the arm to come to rest (s)",
                          range=(0.0, 30.0)),
        ])
        try:
            waypoints = WaypointStore(self.params.get("waypoints_file") or None)
        except WaypointError as exc:
            raise ValueError(str(exc)) from None
        self.operator = OperatorPrompts()
        self.behavior_context = RosBehaviorContext(
            self, waypoints, self.operator, planning_group=self.params.get("planning_group"),
            ik_frame=self.params.get("ik_frame"), arm_controller_action=self.params.get("arm_controller_action"),
            gripper_action=self.params.get("gripper_action"))
        # the clients most objectives use, made now so they are discovered before the first goal
        self.behavior_context.action_client(MoveGroup, MOVE_ACTION)
        self.behavior_context.action_client(ExecuteTrajectory, EXECUTE_TRAJECTORY_ACTION)
        self.behavior_context.action_client(GripperCommand, self.params.get("gripper_action"))
        for name in (self.params.get("arm_controller_action"), self.params.get("gripper_action")):
            self.behavior_context.service_client(CancelGoal, f"{name}/_action/cancel_goal")
        group = self.behavior_context.group
        self._lock = threading.Lock()
        self._run_lock = threading.Lock()
        self._run: _Run | None = None
        self._latest_goal: Any = None
        self._last_state = 0.0
        self._status_pub = self.create_publisher(ObjectiveServerStatus, "~/status", LATCHED)
        self._state_pub = self.create_publisher(String, "~/tree_state", LATCHED)
        self._prompt_pub = self.create_publisher(OperatorPrompt, "~/operator_prompt", LATCHED)
        self.operator.subscribe(self._publish_prompt)
        self._action = ActionServer(self, DoObjectiveSequence, "/do_objective", self._execute,
                                    goal_callback=lambda goal: GoalResponse.ACCEPT,
                                    handle_accepted_callback=self._accepted,
                                    cancel_callback=self._cancel_goal, callback_group=group, **ACTION_SERVER_OPTIONS)
        self.create_service(CancelObjective, "/cancel_objective", self._srv_cancel, callback_group=group)
        self.create_service(AnswerOperatorPrompt, "~/answer_operator_prompt", self._srv_answer, callback_group=group)
        self.create_service(Trigger, "~/get_objectives", self._srv_objectives, callback_group=group)
        self._publish_status("", S.IDLE)
        self._publish_prompt(None)
        self.get_logger().info(f"objective_server ready: {len(self.objective_names())} objectives in "
                               f"{[str(p) for p in self.library_paths()]}, {len(waypoints.names())} waypoints")

    # ------------------------------------------------------------------ library
    def library_paths(self) -> list[Path]:
        return [*default_library_paths(), *(Path(p) for p in self.params.get("objective_library_paths") if p)]

    def objective_names(self) -> list[str]:
        names: list[str] = []
        for path in library_files(self.library_paths()):
            try:
                names.extend(tree_ids_of(path))
            except (TreeLoadError, OSError):
                continue
        return names

    def objectives_json(self) -> list[dict[str, Any]]:
        found = []
        for path in library_files(self.library_paths()):
            try:
                root = parse_xml(path.read_bytes(), str(path))
            except (TreeLoadError, OSError):
                continue
            for element in root.children:
                if element.tag == "BehaviorTree" and element.get("ID"):
                    found.append({"name": element.get("ID"), "file": str(path),
                                  "description": element.get("_description") or "",
                                  "favorite": (element.get("_favorite") or "").lower() == "true"})
        return found

    def make_factory(self) -> BehaviorTreeFactory:
        factory = BehaviorTreeFactory()
        register_behaviors(factory, self.behavior_context)
        return factory

    # ------------------------------------------------------------------ publishing
    def _publish_status(self, name: str, status: str, message: str = "") -> None:
        msg = ObjectiveServerStatus(objective_name=name, objective_status=status, message=message)
        msg.ros_timestamp = self.get_clock().now().to_msg()
        self._status_pub.publish(msg)

    def _publish_tree_state(self, run: _Run, status: str, force: bool = False, message: str = "") -> None:
        now = time.monotonic()
        if not force and now - self._last_state < self.params.get("tree_state_period"):
            return
        self._last_state = now
        tree = run.tree
        state = {"objective": run.name, "status": status, "message": message,
                 "xml": write_tree_to_xml(tree, add_metadata=True) if tree is not None else "",
                 "nodes": dict(run.statuses), "last": dict(run.last),
                 "blackboard": blackboard_json(tree.root_blackboard()) if tree is not None else {}}
        self._state_pub.publish(String(data=json.dumps(state)))

    def _publish_prompt(self, prompt: Prompt | None) -> None:
        msg = OperatorPrompt()
        if prompt is not None:
            msg.prompt_id, msg.active = prompt.prompt_id, prompt.active
            msg.objective_name, msg.node_path, msg.prompt = prompt.objective_name, prompt.node_path, prompt.text
        msg.waypoint_names = self.behavior_context.waypoints.names()
        self._prompt_pub.publish(msg)

    # ------------------------------------------------------------------ do_objective
    def _accepted(self, goal_handle: Any) -> None:
        """A new goal cancels the running objective (MoveIt Pro: one objective at a time), and
        any goal accepted before it that has not started yet."""
        with self._lock:
            run = self._run
            self._latest_goal = goal_handle
        if run is not None:
            self._request_cancel(run, "preempted by a new objective")
        goal_handle.execute()

    def _cancel_goal(self, goal_handle: Any) -> CancelResponse:
        with self._lock:
            run = self._run
        if run is not None and run.goal_handle is goal_handle:
            self._request_cancel(run, "canceled by its client")
        return CancelResponse.ACCEPT

    def _request_cancel(self, run: _Run, reason: str) -> None:
        if not run.cancel.is_set():
            run.cancel_reason = reason
            run.cancel.set()
        if run.tree is not None:
            run.tree.emit_wake_up_signal()

    def _result(self, code: int, message: str) -> DoObjectiveSequence.Result:
        result = DoObjectiveSequence.Result(error_message=message)
        result.error_code.val = code
        result.error_code.message = message
        result.error_code.source = NODE_NAME
        return result

    def _execute(self, goal_handle: Any) -> DoObjectiveSequence.Result:
        goal = goal_handle.request
        name = goal.objective_name or "(objective_xml_string)"
        run = _Run(name, goal_handle)
        with self._run_lock:  # the previous objective, canceled in _accepted, ends first
            with self._lock:
                self._run = run
                superseded = self._latest_goal is not goal_handle
            if superseded:  # a newer goal came while this one waited for the previous to end
                with self._lock:
                    self._run = None
                return self._finish(run, goal_handle, S.CANCELLED, C.PREEMPTED, "preempted by a new objective")
            try:
                return self._run_objective(run, goal)
            except Exception as exc:  # a defect, not the objective's fault: say so, keep serving
                self.get_logger().error(f"objective '{run.name}': internal error: {exc!r}")
                self.behavior_context.stop_arm()
                return self._finish(run, goal_handle, S.FAILURE, C.FAILURE, f"internal error: {exc!r}")
            finally:
                with self._lock:
                    if self._run is run:
                        self._run = None

    def _finish(self, run: _Run, goal_handle: Any, status: str, code: int, message: str) -> DoObjectiveSequence.Result:
        self._publish_status(run.name, status, message)
        self._publish_tree_state(run, status, force=True, message=message)
        text = f"objective '{run.name}': {status}" + (f": {message}" if message else "")
        if status == S.SUCCESS:  # one call site per severity (rclpy refuses a change)
            self.get_logger().info(text)
        else:
            self.get_logger().warning(text)
        if status == S.SUCCESS:
            goal_handle.succeed()
        elif status == S.CANCELLED and goal_handle.is_cancel_requested:
            goal_handle.canceled()
        else:
            goal_handle.abort()
        return self._result(code, message)

    def _load(self, run: _Run, goal: Any) -> Any:
        factory = self.make_factory()
        blackboard = Blackboard.create()
        if goal.objective_name:
            tree_id = load_objective(factory, goal.objective_name, self.library_paths())
        else:
            factory.register_behavior_tree_from_text(goal.objective_xml_string, source="objective_xml_string")
            tree_id = factory.parser.main_tree_id()
            for other in library_files(self.library_paths()):
                try:
                    factory.register_behavior_tree_from_file(other, skip_existing=True)
                except TreeLoadError as exc:
                    self.get_logger().warning(f"objective library: skipping {exc}")
        run.name = tree_id or run.name
        for parameter in goal.parameter_overrides:
            if not parameter.description.name:
                raise ValueError("a parameter override needs description.name")
            blackboard.set(parameter.description.name, _override_value(parameter))
        return factory.create_tree(tree_id, blackboard)

    def _run_objective(self, run: _Run, goal: Any) -> DoObjectiveSequence.Result:
        goal_handle = run.goal_handle
        if not goal.objective_name and not goal.objective_xml_string.strip():
            return self._finish(run, goal_handle, S.FAILURE, C.FAILURE,
                                "the goal names no objective (objective_name or objective_xml_string)")
        self._publish_status(run.name, S.LOADING)
        try:
            tree = self._load(run, goal)
        except (TreeLoadError, ValueError) as exc:
            return self._finish(run, goal_handle, S.FAILURE, C.FAILURE, f"refused before running: {exc}")
        run.tree = tree
        self.behavior_context.objective_name = run.name
        for node in tree.nodes():
            run.statuses[node.uid] = node.status.name

        def on_status(_: float, node: Any, previous: NodeStatus, new: NodeStatus) -> None:
            run.statuses[node.uid] = new.name
            if new is not NodeStatus.IDLE:
                run.last[node.uid] = new.name
            if new is NodeStatus.FAILURE and not node.children_nodes():
                run.failed_node = node.full_path or node.name

        unsubscribe = tree.subscribe_to_status_changes(on_status)
        self._publish_status(run.name, S.RUNNING)
        self.get_logger().info(f"objective '{run.name}': running")
        try:
            status = NodeStatus.RUNNING
            while True:
                if run.cancel.is_set() or goal_handle.is_cancel_requested:
                    tree.halt_tree()
                    stopped = self.behavior_context.stop_arm()
                    self.wait_for_rest()
                    reason = run.cancel_reason or "canceled"
                    return self._finish(run, goal_handle, S.CANCELLED, C.PREEMPTED,
                                        f"{reason}: the tree was halted and the arm stopped ({', '.join(stopped)})")
                status = tree.tick_once()
                self._publish_tree_state(run, S.RUNNING)
                if status is not NodeStatus.RUNNING:
                    break
                tree.sleep(self.params.get("tick_period"))
        except BehaviorTreeException as exc:
            self.behavior_context.stop_arm()
            self.wait_for_rest()
            return self._finish(run, goal_handle, S.FAILURE, C.FAILURE, f"error while running (tree halted): {exc}")
        finally:
            unsubscribe()
            self.behavior_context.objective_name = ""
        if status is NodeStatus.SUCCESS:
            return self._finish(run, goal_handle, S.SUCCESS, C.SUCCESS, "")
        self.behavior_context.stop_arm()  # the halted behaviors canceled their goals; make sure
        self.wait_for_rest()
        where = f" (failed at {run.failed_node})" if run.failed_node else ""
        return self._finish(run, goal_handle, S.FAILURE, C.FAILURE, f"objective '{run.name}' ended {status.name}{where}")

    def wait_for_rest(self, threshold: float = 1e-4, still_for: float = 0.1) -> bool:
        """Wait (up to rest_timeout) until /joint_states has stayed within ``threshold`` for
        ``still_for`` s, judged on fresh messages only: the same cached message read twice (the
        subscription not yet served) proves nothing, and an arm still finishing its smooth stop
        was once taken for at rest that way, so the next objective planned from a moving arm."""
        deadline = time.monotonic() + self.params.get("rest_timeout")
        context = self.behavior_context
        anchor, anchor_count, since = None, -1, None
        while time.monotonic() < deadline:
            count = context.joint_state_count()
            try:
                current = context.current_joint_state().as_dict()
            except LookupError:
                return False
            if count != anchor_count:
                if anchor is not None and all(abs(current[k] - anchor.get(k, current[k])) < threshold for k in current):
                    if time.monotonic() - since >= still_for:
                        return True
                else:
                    anchor, since = current, time.monotonic()
                anchor_count = count
            time.sleep(0.02)
        return False

    # ------------------------------------------------------------------ services
    def _srv_cancel(self, request: Any, response: Any) -> Any:
        with self._lock:
            run = self._run
        if run is None:
            response.status.success = False
            response.status.error_message = "no objective is running"
            return response
        self._request_cancel(run, "canceled by /cancel_objective")
        response.status.success = True
        return response

    def _srv_objectives(self, request: Any, response: Any) -> Any:
        response.success = True
        response.message = json.dumps({"objectives": self.objectives_json(),
                                       "waypoints": self.behavior_context.waypoints.names()})
        return response

    def _srv_answer(self, request: Any, response: Any) -> Any:
        R = AnswerOperatorPrompt.Request
        if request.answer in (R.CONTINUE, R.FAIL):
            response.success, response.message = self.operator.answer(request.prompt_id, request.answer == R.CONTINUE)
            return response
        prompt = self.operator.current()
        if prompt is None or not prompt.active:
            response.success, response.message = False, "no operator prompt is open"
            return response
        try:
            if request.answer == R.MOVE_TO_WAYPOINT:
                waypoint = self.behavior_context.waypoints.get(request.waypoint_name)
                target = JointStateValue(list(waypoint.joint_names), list(waypoint.positions))
            elif request.answer == R.MOVE_TO_JOINT_STATE:
                target = JointStateValue(list(request.joint_state.name), [float(p) for p in request.joint_state.position])
                if not target.name:
                    raise ValueError("joint_state names no joint")
            else:
                raise ValueError(f"unknown answer {request.answer}")
        except (WaypointError, ValueError) as exc:
            response.success, response.message = False, str(exc)
            return response
        response.success, response.message = self.operator_move(target)
        return response

    def operator_move(self, target: JointStateValue) -> tuple[bool, str]:
        """Plan and execute a move of the planning group to ``target`` through move_group
        (the operator's waypoint move while a prompt is open)."""
        goal = MoveGroup.Goal()
        r = goal.request
        r.group_name = self.params.get("planning_group")
        r.num_planning_attempts, r.allowed_planning_time = 1, 5.0
        r.max_velocity_scaling_factor = r.max_acceleration_scaling_factor = 1.0
        r.start_state.is_diff = True
        r.goal_constraints = [joint_constraints(target)]
        goal.planning_options.planning_scene_diff.is_diff = True
        goal.planning_options.planning_scene_diff.robot_state.is_diff = True
        done = threading.Event()
        call = PendingGoal(self.behavior_context.action_client(MoveGroup, MOVE_ACTION), goal, done.set, MOVE_ACTION)
        if not done.wait(120.0):
            call.cancel()
            return False, "the move did not finish within 120 s"
        if call.error:
            return False, call.error
        code = call.result.error_code
        if code.val != C.SUCCESS:
            return False, f"move_group: {code.val}: {code.message}"
        self.get_logger().info(f"operator move to {target.as_dict()} done")
        return True, "moved"

    def close(self) -> None:
        """Shutdown: the running objective is canceled (its tree halted, the arm stopped) and
        given a few seconds to end before the node goes."""
        with self._lock:
            run = self._run
        if run is not None:
            self._request_cancel(run, "the objective_server is shutting down")
            if self._run_lock.acquire(timeout=5.0):
                self._run_lock.release()
