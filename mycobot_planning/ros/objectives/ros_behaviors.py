"""MoveIt Pro's motion, scene, perception and task behaviors, as clients of our public ROS
interfaces: move_group's /move_action, /execute_trajectory, /compute_cartesian_path,
/get_planning_scene, /apply_planning_scene and /check_state_validity (moveit_msgs), the
controllers' GripperCommand action (control_msgs), a PointCloud2 topic, the perception_server and
a task node's plan/execute services. A behavior sends its request in ``on_start`` and answers
RUNNING; the answer wakes the tree; a halt cancels the goal (move_group and the controllers then
stop the arm)."""
from __future__ import annotations

from typing import Any

from action_msgs.msg import GoalStatus
from control_msgs.action import GripperCommand
from geometry_msgs.msg import Pose as PoseMsg
from moveit_msgs.action import ExecuteTrajectory as ExecuteTrajectoryAction
from moveit_msgs.action import MoveGroup
from moveit_msgs.msg import (
    AttachedCollisionObject,
    CollisionObject,
    Constraints,
    JointConstraint,
    MoveItErrorCodes,
    OrientationConstraint,
    PlanningSceneComponents,
    PositionConstraint,
    RobotState,
    RobotTrajectory,
)
from moveit_msgs.srv import ApplyPlanningScene, GetCartesianPath, GetPlanningScene, GetStateValidity
from sensor_msgs.msg import JointState, PointCloud2
from shape_msgs.msg import SolidPrimitive
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory

from interfaces_py.names import (
    APPLY_PLANNING_SCENE_SERVICE,
    CARTESIAN_PATH_SERVICE,
    EXECUTE_TRAJECTORY_ACTION,
    GET_PLANNING_SCENE_SERVICE,
    MOVE_ACTION,
    STATE_VALIDITY_SERVICE,
)
from mycobot_planning.behavior_tree import (
    ANY,
    BOOL,
    DOUBLE,
    FAILURE,
    POSE_STAMPED,
    RUNNING,
    STRING,
    SUCCESS,
    VECTOR_DOUBLE,
    VECTOR_STRING,
    NodeStatus,
    PoseStamped,
    StatefulActionNode,
    SyncActionNode,
    ThreadedAction,
    input_port,
    output_port,
)
from mycobot_planning.behavior_tree.behaviors import JOINT_STATE, VECTOR_POSE_STAMPED, JointStateValue
from mycobot_planning.behavior_tree.behaviors.waypoints import WaypointError

from .ros_calls import PendingCall, PendingGoal, PendingService
from .ros_context import RosBehaviorContext

C = MoveItErrorCodes
_ERROR_NAMES = {v: k for k, v in vars(MoveItErrorCodes).items() if k.isupper() and isinstance(v, int)}


def error_name(code: int) -> str:
    return _ERROR_NAMES.get(int(code), str(code))


def _pose_msg(pose: Any) -> PoseMsg:
    msg = PoseMsg()
    msg.position.x, msg.position.y, msg.position.z = (float(v) for v in pose.position)
    msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w = (float(v) for v in pose.orientation)
    return msg


def _robot_trajectory(value: Any) -> RobotTrajectory:
    if isinstance(value, RobotTrajectory):
        return value
    if isinstance(value, JointTrajectory):
        return RobotTrajectory(joint_trajectory=value)
    raise ValueError(f"expected a moveit_msgs/RobotTrajectory or trajectory_msgs/JointTrajectory, "
                     f"got {type(value).__name__}")


class RosBehavior(StatefulActionNode):
    """A behavior waiting on ROS calls: ``start()`` returns a PendingCall (or a status at once),
    ``finish(call)`` a status or the next PendingCall; a halt cancels the call in flight."""

    def __init__(self, name: str, config: Any, context: RosBehaviorContext):
        super().__init__(name, config)
        self.context = context
        self._call: PendingCall | None = None

    @property
    def where(self) -> str:
        return self.config.path or self.name

    def fail(self, why: str) -> NodeStatus:
        self.context.log("error", f"{self.where}: {why}")
        return FAILURE

    def start(self) -> PendingCall | NodeStatus:  # pragma: no cover - abstract
        raise NotImplementedError

    def finish(self, call: PendingCall) -> PendingCall | NodeStatus:  # pragma: no cover - abstract
        raise NotImplementedError

    def goal(self, action_type: Any, name: str, goal: Any) -> PendingGoal:
        return PendingGoal(self.context.action_client(action_type, name), goal, self.emit_wake_up_signal, name)

    def service(self, srv_type: Any, name: str, request: Any) -> PendingService:
        return PendingService(self.context.service_client(srv_type, name), request, self.emit_wake_up_signal, name)

    def _advance(self, step: PendingCall | NodeStatus) -> NodeStatus:
        if isinstance(step, NodeStatus):
            self._call = None
            return step
        self._call = step
        return self.on_running() if step.done else RUNNING

    def on_start(self) -> NodeStatus:
        try:
            return self._advance(self.start())
        except (ValueError, LookupError) as exc:
            return self.fail(str(exc))

    def on_running(self) -> NodeStatus:
        call = self._call
        if call is None:
            return FAILURE
        if not call.done:
            return RUNNING
        if call.error:
            self._call = None
            return self.fail(call.error)
        try:
            return self._advance(self.finish(call))
        except (ValueError, LookupError) as exc:
            self._call = None
            return self.fail(str(exc))

    def on_halted(self) -> None:
        call, self._call = self._call, None
        if call is not None:
            call.cancel()


# ------------------------------------------------------------------------------------- motion
_SCALING = (input_port("velocity_scale_factor", DOUBLE, 1.0, "fraction of the joints' velocity limits (0, 1]"),
            input_port("acceleration_scale_factor", DOUBLE, 1.0, "fraction of the acceleration limits (0, 1]"))


class _MoveGroupBehavior(RosBehavior):
    """Plans (and unless PLAN_ONLY executes) a goal through move_group's /move_action."""

    PLAN_ONLY = False

    @classmethod
    def group_ports(cls):
        return (input_port("planning_group_name", STRING, "arm", "the planning group that moves"),
                *_SCALING,
                input_port("planning_time", DOUBLE, 5.0, "how long the planner may take (s)"),
                input_port("planner_id", STRING, "", "the planner (empty: the pipeline's default)"))

    def goal_constraints(self) -> Constraints:  # pragma: no cover - abstract
        raise NotImplementedError

    def group_name(self) -> str:
        return self.get_input("planning_group_name")

    def start(self) -> PendingCall | NodeStatus:
        goal = MoveGroup.Goal()
        r = goal.request
        r.group_name = self.group_name()
        r.num_planning_attempts = 1
        r.allowed_planning_time = float(self.get_input("planning_time"))
        r.planner_id = self.get_input("planner_id")
        for port in ("velocity_scale_factor", "acceleration_scale_factor"):
            value = self.get_input(port)
            if not 0.0 < value <= 1.0:
                raise ValueError(f"{port} must be in (0, 1], got {value}")
        r.max_velocity_scaling_factor = float(self.get_input("velocity_scale_factor"))
        r.max_acceleration_scaling_factor = float(self.get_input("acceleration_scale_factor"))
        r.start_state.is_diff = True
        r.goal_constraints = [self.goal_constraints()]
        goal.planning_options.plan_only = self.PLAN_ONLY
        goal.planning_options.planning_scene_diff.is_diff = True
        goal.planning_options.planning_scene_diff.robot_state.is_diff = True
        return self.goal(MoveGroup, MOVE_ACTION, goal)

    def finish(self, call: PendingCall) -> NodeStatus:
        code = call.result.error_code
        if call.status == GoalStatus.STATUS_CANCELED or code.val != C.SUCCESS:
            return self.fail(f"move_group: {error_name(code.val)}"
                             + (f": {code.message}" if code.message else ""))
        self.on_success(call.result)
        return SUCCESS

    def on_success(self, result: Any) -> None:
        """Outputs of a successful motion."""


def joint_constraints(state: JointStateValue, tolerance: float = 1e-3) -> Constraints:
    return Constraints(joint_constraints=[
        JointConstraint(joint_name=n, position=float(p), tolerance_above=tolerance, tolerance_below=tolerance,
                        weight=1.0) for n, p in zip(state.name, state.position)])


class MoveToJointState(_MoveGroupBehavior):
    DESCRIPTION = "Plans and executes a motion of a planning group to a joint state (through move_group)."

    @classmethod
    def provided_ports(cls):
        return (input_port("joint_state", JOINT_STATE, description="the goal: joint names and positions"),
                *cls.group_ports())

    def goal_constraints(self) -> Constraints:
        return joint_constraints(self.get_input("joint_state"))


class MoveToWaypoint(_MoveGroupBehavior):
    DESCRIPTION = "Plans and executes a motion to a saved waypoint (through move_group)."

    @classmethod
    def provided_ports(cls):
        return (input_port("waypoint_name", STRING, description="the saved waypoint to move to"),
                input_port("joint_group_name", STRING, "arm", "the planning group that moves"),
                *_SCALING,
                input_port("planning_time", DOUBLE, 5.0, "how long the planner may take (s)"),
                input_port("planner_id", STRING, "", "the planner (empty: the pipeline's default)"))

    def group_name(self) -> str:
        return self.get_input("joint_group_name")

    def goal_constraints(self) -> Constraints:
        try:
            waypoint = self.context.waypoints.get(self.get_input("waypoint_name"))
        except WaypointError as exc:
            raise LookupError(str(exc)) from None
        return joint_constraints(JointStateValue(list(waypoint.joint_names), list(waypoint.positions)))


class MoveToPose(_MoveGroupBehavior):
    DESCRIPTION = "Plans and executes a motion of a link (ik_frame) to a stamped pose (through move_group)."

    @classmethod
    def provided_ports(cls):
        return (input_port("target_pose", POSE_STAMPED, description="where ik_frame goes"),
                input_port("ik_frame", STRING, "", "the link placed at target_pose (empty: the server's ik_frame)"),
                input_port("position_tolerance", DOUBLE, 0.001, "radius of the goal region (m)"),
                input_port("orientation_tolerance", DOUBLE, 0.01, "per-axis orientation tolerance (rad)"),
                *cls.group_ports())

    def goal_constraints(self) -> Constraints:
        target: PoseStamped = self.get_input("target_pose")
        link = self.get_input("ik_frame") or self.context.ik_frame
        frame = target.frame_id or "world"
        position = PositionConstraint(link_name=link, weight=1.0)
        position.header.frame_id = frame
        region = _pose_msg(target.pose)
        position.constraint_region.primitives = [SolidPrimitive(type=SolidPrimitive.SPHERE,
                                                                dimensions=[float(self.get_input("position_tolerance"))])]
        position.constraint_region.primitive_poses = [region]
        tolerance = float(self.get_input("orientation_tolerance"))
        orientation = OrientationConstraint(link_name=link, absolute_x_axis_tolerance=tolerance,
                                            absolute_y_axis_tolerance=tolerance, absolute_z_axis_tolerance=tolerance,
                                            weight=1.0, orientation=region.orientation)
        orientation.header.frame_id = frame
        return Constraints(position_constraints=[position], orientation_constraints=[orientation])


class PlanToJointGoal(MoveToJointState):
    DESCRIPTION = "Plans (without executing) a motion to a joint state; the trajectory goes to the blackboard."
    PLAN_ONLY = True

    @classmethod
    def provided_ports(cls):
        return (input_port("joint_goal", JOINT_STATE, description="the goal: joint names and positions"),
                *cls.group_ports(),
                output_port("joint_trajectory_msg", ANY, description="the planned moveit_msgs/RobotTrajectory"))

    def goal_constraints(self) -> Constraints:
        return joint_constraints(self.get_input("joint_goal"))

    def on_success(self, result: Any) -> None:
        self.set_output("joint_trajectory_msg", result.planned_trajectory)


class PlanCartesianPath(RosBehavior):
    DESCRIPTION = "Plans a straight-line path of tip_link through poses (move_group's /compute_cartesian_path)."

    @classmethod
    def provided_ports(cls):
        return (input_port("path", VECTOR_POSE_STAMPED, description="the poses tip_link passes through"),
                input_port("planning_group_name", STRING, "arm", "the planning group that moves"),
                input_port("tip_link", STRING, "", "the link that follows the path (empty: the server's ik_frame)"),
                input_port("position_only", BOOL, False, "ignored here (the full pose is followed)"),
                input_port("eef_step", DOUBLE, 0.005, "largest Cartesian step between waypoints (m)"),
                input_port("min_fraction", DOUBLE, 1.0, "fraction of the path that must be achieved"),
                *_SCALING,
                output_port("joint_trajectory_msg", ANY, description="the planned moveit_msgs/RobotTrajectory"),
                output_port("fraction", DOUBLE, description="the fraction of the path achieved"))

    def start(self) -> PendingCall | NodeStatus:
        path = self.get_input("path")
        if not path:
            raise ValueError("path is empty")
        frames = {p.frame_id or "world" for p in path}
        if len(frames) != 1:
            raise ValueError(f"every pose of the path must be in the same frame, got {sorted(frames)}")
        request = GetCartesianPath.Request()
        request.header.frame_id = frames.pop()
        request.start_state.is_diff = True
        request.group_name = self.get_input("planning_group_name")
        request.link_name = self.get_input("tip_link") or self.context.ik_frame
        request.waypoints = [_pose_msg(p.pose) for p in path]
        request.max_step = float(self.get_input("eef_step"))
        request.avoid_collisions = True
        request.max_velocity_scaling_factor = float(self.get_input("velocity_scale_factor"))
        request.max_acceleration_scaling_factor = float(self.get_input("acceleration_scale_factor"))
        return self.service(GetCartesianPath, CARTESIAN_PATH_SERVICE, request)

    def finish(self, call: PendingCall) -> NodeStatus:
        response = call.result
        self.set_output("fraction", float(response.fraction))
        if response.error_code.val != C.SUCCESS:
            return self.fail(f"compute_cartesian_path: {error_name(response.error_code.val)}: "
                             f"{response.error_code.message}")
        if response.fraction < self.get_input("min_fraction") - 1e-9:
            return self.fail(f"only {response.fraction:.0%} of the path can be followed")
        self.set_output("joint_trajectory_msg", response.solution)
        return SUCCESS


class ExecuteTrajectory(RosBehavior):
    DESCRIPTION = "Executes a planned trajectory through move_group's /execute_trajectory (watched, cancelable)."

    @classmethod
    def provided_ports(cls):
        return (input_port("joint_trajectory_msg", ANY, description="a moveit_msgs/RobotTrajectory or "
                                                                   "trajectory_msgs/JointTrajectory"),)

    def start(self) -> PendingCall | NodeStatus:
        goal = ExecuteTrajectoryAction.Goal(trajectory=_robot_trajectory(self.get_input("joint_trajectory_msg")))
        return self.goal(ExecuteTrajectoryAction, EXECUTE_TRAJECTORY_ACTION, goal)

    def finish(self, call: PendingCall) -> NodeStatus:
        code = call.result.error_code
        if code.val != C.SUCCESS:
            return self.fail(f"execute_trajectory: {error_name(code.val)}: {code.message}")
        return SUCCESS


class ValidateTrajectory(RosBehavior):
    DESCRIPTION = ("Checks every waypoint of a trajectory against the current planning scene and the joint limits "
                   "(move_group's /check_state_validity); FAILURE names the first invalid one.")

    @classmethod
    def provided_ports(cls):
        return (input_port("joint_trajectory_msg", ANY, description="the trajectory to check"),
                input_port("planning_group_name", STRING, "arm", "the planning group the check is for"))

    def _request(self) -> GetStateValidity.Request:
        jt = self._trajectory.joint_trajectory
        request = GetStateValidity.Request(group_name=self.get_input("planning_group_name"))
        request.robot_state = RobotState(is_diff=True)
        request.robot_state.joint_state = JointState(name=list(jt.joint_names),
                                                     position=list(jt.points[self._index].positions))
        return request

    def start(self) -> PendingCall | NodeStatus:
        self._trajectory = _robot_trajectory(self.get_input("joint_trajectory_msg"))
        if not self._trajectory.joint_trajectory.points:
            raise ValueError("the trajectory has no points")
        self._index = 0
        return self.service(GetStateValidity, STATE_VALIDITY_SERVICE, self._request())

    def finish(self, call: PendingCall) -> PendingCall | NodeStatus:
        if not call.result.valid:
            contacts = ", ".join(f"{c.contact_body_1}-{c.contact_body_2}" for c in call.result.contacts[:3])
            return self.fail(f"waypoint {self._index} is invalid" + (f" (contacts: {contacts})" if contacts else ""))
        self._index += 1
        if self._index >= len(self._trajectory.joint_trajectory.points):
            return SUCCESS
        return self.service(GetStateValidity, STATE_VALIDITY_SERVICE, self._request())


class MoveGripperAction(RosBehavior):
    DESCRIPTION = ("Moves the gripper to a position through its controller's GripperCommand action; SUCCESS when it "
                   "reaches it or stalls on an object.")

    @classmethod
    def provided_ports(cls):
        return (input_port("gripper_command_action_name", STRING, "/grip_action_controller/gripper_cmd",
                           "the gripper controller's control_msgs/GripperCommand action"),
                input_port("position", DOUBLE, description="the gripper joint's goal position"),
                input_port("max_effort", DOUBLE, 0.0, "largest effort (0: no limit)"),
                input_port("timeout", DOUBLE, 10.0, "give up after this long (s)"))

    def start(self) -> PendingCall | NodeStatus:
        goal = GripperCommand.Goal()
        goal.command.position = float(self.get_input("position"))
        goal.command.max_effort = float(self.get_input("max_effort"))
        self._deadline = self.now() + float(self.get_input("timeout"))
        self.wake_up_at(self._deadline)
        return self.goal(GripperCommand, self.get_input("gripper_command_action_name"), goal)

    def on_running(self) -> NodeStatus:
        if self._call is not None and not self._call.done and self.now() >= self._deadline:
            self._call.cancel()
            self._call = None
            return self.fail(f"the gripper did not finish within {self.get_input('timeout')} s")
        return super().on_running()

    def finish(self, call: PendingCall) -> NodeStatus:
        result = call.result
        if call.status == GoalStatus.STATUS_SUCCEEDED and (result.reached_goal or result.stalled):
            return SUCCESS
        return self.fail(f"the gripper stopped at {result.position:.3f} (reached_goal={result.reached_goal}, "
                         f"stalled={result.stalled}, status {call.status})")


class Stop(SyncActionNode):
    DESCRIPTION = "Stops every motion now: move_group's stop and a cancel of the arm's and gripper's controller goals."

    def __init__(self, name: str, config: Any, context: RosBehaviorContext):
        super().__init__(name, config)
        self.context = context

    @classmethod
    def provided_ports(cls):
        return ()

    def tick(self) -> NodeStatus:
        asked = self.context.stop_arm()
        self.context.log("info", f"{self.config.path or self.name}: stop sent to move_group and {asked}")
        return SUCCESS


# -------------------------------------------------------------------------------------- scene
def _scene_request(components: int) -> GetPlanningScene.Request:
    request = GetPlanningScene.Request()
    request.components.components = components
    return request


def _apply_request(objects: list[CollisionObject] = (), attached: list[AttachedCollisionObject] = ()) -> Any:
    request = ApplyPlanningScene.Request()
    request.scene.is_diff = True
    request.scene.robot_state.is_diff = True
    request.scene.world.collision_objects = list(objects)
    request.scene.robot_state.attached_collision_objects = list(attached)
    return request


class _ApplyBehavior(RosBehavior):
    """A planning scene change through move_group's /apply_planning_scene."""

    def apply(self, objects: list[CollisionObject] = (), attached: list[AttachedCollisionObject] = ()) -> PendingCall:
        return self.service(ApplyPlanningScene, APPLY_PLANNING_SCENE_SERVICE, _apply_request(objects, attached))

    def finish(self, call: PendingCall) -> NodeStatus:
        return SUCCESS if call.result.success else self.fail("move_group refused the planning scene change")


class GetCurrentPlanningScene(RosBehavior):
    DESCRIPTION = "Reads move_group's current planning scene (moveit_msgs/PlanningScene) to the blackboard."

    @classmethod
    def provided_ports(cls):
        return (output_port("planning_scene_msg", ANY, description="the moveit_msgs/PlanningScene"),)

    def start(self) -> PendingCall | NodeStatus:
        every = sum(v for k, v in vars(PlanningSceneComponents).items() if k.isupper() and isinstance(v, int)
                    and k != "SCENE_SETTINGS") | PlanningSceneComponents.SCENE_SETTINGS
        return self.service(GetPlanningScene, GET_PLANNING_SCENE_SERVICE, _scene_request(every))

    def finish(self, call: PendingCall) -> NodeStatus:
        self.set_output("planning_scene_msg", call.result.scene)
        return SUCCESS


class AddCollisionBox(_ApplyBehavior):
    DESCRIPTION = "Adds (or replaces) a box collision object in move_group's planning scene."

    @classmethod
    def provided_ports(cls):
        return (input_port("object_id", STRING, description="the object's name"),
                input_port("pose", POSE_STAMPED, description="the box's center"),
                input_port("dimensions", VECTOR_DOUBLE, description="x;y;z sizes (m)"))

    def start(self) -> PendingCall | NodeStatus:
        size = self.get_input("dimensions")
        if len(size) != 3 or min(size) <= 0.0:
            raise ValueError(f"dimensions needs 3 positive sizes, got {size}")
        pose: PoseStamped = self.get_input("pose")
        obj = CollisionObject(id=self.get_input("object_id"), operation=CollisionObject.ADD)
        obj.header.frame_id = pose.frame_id or "world"
        obj.pose = _pose_msg(pose.pose)
        obj.primitives = [SolidPrimitive(type=SolidPrimitive.BOX, dimensions=[float(v) for v in size])]
        obj.primitive_poses = [PoseMsg()]
        obj.primitive_poses[0].orientation.w = 1.0
        return self.apply([obj])


class ResetPlanningSceneObjects(_ApplyBehavior):
    DESCRIPTION = "Removes every world collision object from move_group's planning scene (attached ones stay)."

    @classmethod
    def provided_ports(cls):
        return ()

    def start(self) -> PendingCall | NodeStatus:
        self._removing = False
        return self.service(GetPlanningScene, GET_PLANNING_SCENE_SERVICE,
                            _scene_request(PlanningSceneComponents.WORLD_OBJECT_NAMES))

    def finish(self, call: PendingCall) -> PendingCall | NodeStatus:
        if self._removing:
            return super().finish(call)
        ids = [o.id for o in call.result.scene.world.collision_objects]
        if not ids:
            return SUCCESS
        self._removing = True
        removals = [CollisionObject(id=i, operation=CollisionObject.REMOVE) for i in ids]
        for obj in removals:
            obj.header.frame_id = "world"
        return self.apply(removals)


class AttachObject(_ApplyBehavior):
    DESCRIPTION = "Attaches a world collision object to a robot link (it moves with the link; touch_links may touch it)."

    @classmethod
    def provided_ports(cls):
        return (input_port("object_id", STRING, description="the world object to attach"),
                input_port("link_name", STRING, description="the robot link it is attached to"),
                input_port("touch_links", VECTOR_STRING, [], "links allowed to touch it (besides link_name)"))

    def start(self) -> PendingCall | NodeStatus:
        attached = AttachedCollisionObject(link_name=self.get_input("link_name"),
                                           touch_links=list(self.get_input("touch_links")))
        attached.object.id = self.get_input("object_id")
        attached.object.operation = CollisionObject.ADD
        return self.apply(attached=[attached])


class DetachObject(_ApplyBehavior):
    DESCRIPTION = "Detaches an attached object: it stays in the world where it is."

    @classmethod
    def provided_ports(cls):
        return (input_port("object_id", STRING, description="the attached object"),)

    def start(self) -> PendingCall | NodeStatus:
        attached = AttachedCollisionObject()
        attached.object.id = self.get_input("object_id")
        attached.object.operation = CollisionObject.REMOVE
        return self.apply(attached=[attached])


# --------------------------------------------------------------------------------- perception
class GetPointCloud(RosBehavior):
    DESCRIPTION = "Waits for the next sensor_msgs/PointCloud2 on a topic and writes it to the blackboard."

    @classmethod
    def provided_ports(cls):
        return (input_port("topic_name", STRING, "/camera_head/depth/color/points", "the point cloud topic"),
                input_port("message_timeout_sec", DOUBLE, 10.0, "give up after this long (s)"),
                output_port("message_out", ANY, description="the sensor_msgs/PointCloud2 received"))

    def start(self) -> PendingCall | NodeStatus:
        call = PendingCall(self.emit_wake_up_signal)
        self._unsubscribe = self.context.next_message(PointCloud2, self.get_input("topic_name"), call.resolve)
        self._deadline = self.now() + float(self.get_input("message_timeout_sec"))
        self.wake_up_at(self._deadline)
        return call

    def on_running(self) -> NodeStatus:
        if self._call is not None and not self._call.done and self.now() >= self._deadline:
            self._unsubscribe()
            self._call = None
            return self.fail(f"no point cloud on {self.get_input('topic_name')} within "
                             f"{self.get_input('message_timeout_sec')} s")
        return super().on_running()

    def on_halted(self) -> None:
        self._unsubscribe()
        super().on_halted()

    def finish(self, call: PendingCall) -> NodeStatus:
        self.set_output("message_out", call.result)
        return SUCCESS


class ClearSnapshot(_ApplyBehavior):
    DESCRIPTION = "Removes the objects the last DetectObjects added from move_group's planning scene."

    @classmethod
    def provided_ports(cls):
        return ()

    def start(self) -> PendingCall | NodeStatus:
        ids, self.context.detected_object_ids = list(self.context.detected_object_ids), []
        if not ids:
            return SUCCESS
        removals = [CollisionObject(id=i, operation=CollisionObject.REMOVE) for i in ids]
        return self.apply(removals)


class DetectObjects(ThreadedAction):
    DESCRIPTION = ("Asks the perception_server to detect the support surface and the objects in its latest point "
                   "cloud, and adds them to move_group's planning scene.")

    def __init__(self, name: str, config: Any, context: RosBehaviorContext):
        super().__init__(name, config)
        self.context = context

    @classmethod
    def provided_ports(cls):
        return (input_port("target_shape", STRING, "", "cylinder or box (empty: the server's target_shape)"),
                input_port("target_dimensions", VECTOR_DOUBLE, [], "height;radius or x;y;z (empty: the server's)"),
                input_port("timeout", DOUBLE, 30.0, "give up after this long (s)"),
                output_port("object_ids", VECTOR_STRING, description="the objects added to the scene"),
                output_port("target_id", STRING, description="the object picked as the target"))

    def tick(self) -> NodeStatus:
        shape = self.get_input("target_shape") or None
        dims = self.get_input("target_dimensions") or None
        try:
            result = self.context.perception().get_planning_scene(shape, dims, float(self.get_input("timeout")),
                                                                  apply=True)
        except Exception as exc:  # the client's errors (timeout, refused request) fail the behavior
            self.context.log("error", f"{self.config.path or self.name}: perception_server: {exc}")
            return FAILURE
        if not result:
            self.context.log("error", f"{self.config.path or self.name}: perception_server: {result.message}")
            return FAILURE
        ids = [o.id for o in result.objects] + ([result.support_surface.id] if result.support_surface else [])
        self.context.detected_object_ids = ids
        self.set_output("object_ids", ids)
        target = result.target
        self.set_output("target_id", target.id if target is not None else "")
        return SUCCESS


# -------------------------------------------------------------------------------------- tasks
class PlanAndExecuteTaskNode(RosBehavior):
    DESCRIPTION = ("Runs a whole task node (e.g. the seeds' mtc_node pick and place): its ~/plan service, then its "
                   "~/execute service (std_srvs/Trigger).")

    @classmethod
    def provided_ports(cls):
        return (input_port("task_node", STRING, "/mtc_node", "the task node"),
                input_port("execute", BOOL, True, "also execute the planned solution"))

    def start(self) -> PendingCall | NodeStatus:
        self._stage = "plan"
        return self.service(Trigger, f"{self.get_input('task_node').rstrip('/')}/plan", Trigger.Request())

    def finish(self, call: PendingCall) -> PendingCall | NodeStatus:
        if not call.result.success:
            return self.fail(f"{self.get_input('task_node')} {self._stage}: {call.result.message}")
        if self._stage == "plan" and self.get_input("execute"):
            self._stage = "execute"
            return self.service(Trigger, f"{self.get_input('task_node').rstrip('/')}/execute", Trigger.Request())
        return SUCCESS


#: (class, registration ID, subcategory) of every ROS behavior
ROS_BEHAVIORS = (
    (MoveToWaypoint, "MoveToWaypoint", "Motion"),
    (MoveToJointState, "MoveToJointState", "Motion"),
    (MoveToPose, "MoveToPose", "Motion"),
    (PlanToJointGoal, "PlanToJointGoal", "Motion"),
    (PlanCartesianPath, "PlanCartesianPath", "Motion"),
    (ExecuteTrajectory, "ExecuteTrajectory", "Motion"),
    (ValidateTrajectory, "ValidateTrajectory", "Motion"),
    (MoveGripperAction, "MoveGripperAction", "Motion"),
    (Stop, "Stop", "Motion"),
    (GetCurrentPlanningScene, "GetCurrentPlanningScene", "Scene"),
    (AddCollisionBox, "AddCollisionBox", "Scene"),
    (ResetPlanningSceneObjects, "ResetPlanningSceneObjects", "Scene"),
    (AttachObject, "AttachObject", "Scene"),
    (DetachObject, "DetachObject", "Scene"),
    (GetPointCloud, "GetPointCloud", "Perception"),
    (ClearSnapshot, "ClearSnapshot", "Perception"),
    (DetectObjects, "DetectObjects", "Perception"),
    (PlanAndExecuteTaskNode, "PlanAndExecuteTaskNode", "Tasks"),
)
