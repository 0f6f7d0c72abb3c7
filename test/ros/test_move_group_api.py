"""move_group's interface with raw rclpy and real moveit_msgs requests, as MoveGroupInterface or a
hand-written client sends them: every service and action on its default name, and the error
codes a MoveIt user relies on. planning_server + mock_controllers run in real processes."""
from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator

import numpy as np
import pytest
from action_msgs.msg import GoalStatus
from control_msgs.action import FollowJointTrajectory
from geometry_msgs.msg import Pose
from moveit_msgs.action import ExecuteTrajectory, MoveGroup
from moveit_msgs.msg import (
    CollisionObject,
    Constraints,
    JointConstraint,
    MoveItErrorCodes,
    OrientationConstraint,
    PlanningSceneComponents,
    PositionConstraint,
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
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from sensor_msgs.msg import JointState
from shape_msgs.msg import SolidPrimitive
from std_msgs.msg import String

from interfaces_py.action_client import ActionClient
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_arm import ARM, READY, TIP, tip_pose
from ros_testing import ProbeNode, wait_until, robot_processes

FAR = [1.0, -1.0, -0.8, 0.3, 0.5, 0.8]
C = MoveItErrorCodes


class Client(ProbeNode):
    """A plain rclpy node with one client per service and action of move_group."""

    def __init__(self) -> None:
        super().__init__("move_group_api_test")  # spun by spin_until, not in the background
        self.joint_state: JointState | None = None
        self.recorded: list[JointState] | None = None  # every /joint_states message while recording
        self.node.create_subscription(JointState, "/joint_states", self._on_js, 10)
        self.move = ActionClient(self.node, MoveGroup, "/move_action")
        # move_action's feedback as published, (goal id, state): rclpy's ActionClient drops the
        # feedback callback once the goal's result has come, and a topic message can be taken
        # after the result of a fast plan that followed it
        self.move_feedback: list[tuple[bytes, str]] = []
        self.node.create_subscription(
            MoveGroup.Impl.FeedbackMessage, "/move_action/_action/feedback",
            lambda m: self.move_feedback.append((bytes(m.goal_id.uuid), m.feedback.state)), 10)
        self.execute = ActionClient(self.node, ExecuteTrajectory, "/execute_trajectory")
        self.stop_pub = self.node.create_publisher(String, "/trajectory_execution_event", 10)
        self.object_pub = self.node.create_publisher(CollisionObject, "/collision_object", 10)

    def _on_js(self, msg: JointState) -> None:
        self.joint_state = msg
        if self.recorded is not None:
            self.recorded.append(msg)

    def spin_until(self, future, timeout: float = 30.0):
        self.executor.spin_until_future_complete(future, timeout_sec=timeout)
        assert future.done(), "no answer in time"
        return future.result()

    def call(self, srv_type, name: str, request, timeout: float = 30.0):
        client = self.node.create_client(srv_type, name)
        try:
            assert client.wait_for_service(10.0), f"{name} is not offered"
            return self.spin_until(client.call_async(request), timeout)
        finally:
            self.node.destroy_client(client)

    def arm(self) -> np.ndarray:
        self.joint_state = None
        deadline = time.monotonic() + 5
        while self.joint_state is None and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.1)
        index = {n: i for i, n in enumerate(self.joint_state.name)}
        return np.array([self.joint_state.position[index[j]] for j in ARM])

    def send(self, action: ActionClient, goal, feedback=None):
        assert action.wait_for_server(10.0)
        handle = self.spin_until(action.send_goal_async(goal, feedback_callback=feedback))
        assert handle.accepted
        return handle

    def set_mock_param(self, name: str, value: float) -> None:
        request = SetParameters.Request(parameters=[Parameter(name=name, value=ParameterValue(
            type=ParameterType.PARAMETER_DOUBLE, double_value=float(value)))])
        result = self.call(SetParameters, "/controller_manager/set_parameters", request)
        assert result.results[0].successful, result.results[0].reason

    @contextlib.contextmanager
    def mock_fault(self, name: str, after: float) -> Iterator[None]:
        """mock_controllers' fault ``name`` (e.g. arm_controller.fail_after) armed at ``after`` s
        into a trajectory while the block runs, disarmed (-1) after it."""
        self.set_mock_param(name, after)
        try:
            yield
        finally:
            self.set_mock_param(name, -1.0)


@contextlib.contextmanager
def move_group_client(*server_params: str, ready: str | None = None) -> Iterator[Client]:
    """planning_server (with ``server_params``) + mock_controllers up, and a Client of theirs
    (``.server``: the server's process); all closed at exit. ``ready``: a line the server prints
    once it is ready for the tests (waited for, 120 s)."""
    with robot_processes(*server_params) as (_, server):
        if ready is not None:
            assert server.wait_for_output(ready, 120.0), server.output()[-2000:]
        user = Client()
        user.server = server
        try:
            yield user
        finally:
            user.close()


@pytest.fixture(scope="module")
def client():
    with move_group_client() as user:
        yield user


def joint_goal(values, group: str = "arm") -> GetMotionPlan.Request:
    request = GetMotionPlan.Request()
    r = request.motion_plan_request
    r.group_name = group
    r.allowed_planning_time = 5.0
    r.num_planning_attempts = 1
    r.goal_constraints = [Constraints(joint_constraints=[
        JointConstraint(joint_name=j, position=float(v), tolerance_above=1e-3, tolerance_below=1e-3, weight=1.0)
        for j, v in zip(ARM, values)])]
    return request


def joint_state(values) -> JointState:
    return JointState(name=list(ARM), position=[float(v) for v in values])


def box(object_id: str, position, size=(0.06, 0.06, 0.06), operation=CollisionObject.ADD) -> CollisionObject:
    obj = CollisionObject(id=object_id, operation=operation)
    obj.header.frame_id = "world"
    obj.pose.position.x, obj.pose.position.y, obj.pose.position.z = (float(v) for v in position)
    obj.pose.orientation.w = 1.0
    obj.primitives = [SolidPrimitive(type=SolidPrimitive.BOX, dimensions=list(size))]
    obj.primitive_poses = [Pose()]
    obj.primitive_poses[0].orientation.w = 1.0
    return obj


def apply(client: Client, *objects: CollisionObject) -> bool:
    request = ApplyPlanningScene.Request()
    request.scene.is_diff = True
    request.scene.robot_state.is_diff = True
    request.scene.world.collision_objects = list(objects)
    return client.call(ApplyPlanningScene, "/apply_planning_scene", request).success


def world_ids(client: Client, components: int = PlanningSceneComponents.WORLD_OBJECT_NAMES) -> list[str]:
    request = GetPlanningScene.Request()
    request.components.components = components
    return [o.id for o in client.call(GetPlanningScene, "/get_planning_scene", request).scene.world.collision_objects]


def move(client: Client, values) -> None:
    """Plan and execute through move_action; asserts success."""
    goal = MoveGroup.Goal()
    goal.request = joint_goal(values).motion_plan_request
    handle = client.send(client.move, goal)
    result = client.spin_until(handle.get_result_async()).result
    assert result.error_code.val == C.SUCCESS, result.error_code.message


# ------------------------------------------------------------------------------- planning
def test_plan_kinematic_path_plans_a_joint_goal_from_the_current_state(client: Client) -> None:
    move(client, READY)
    logged = client.server.output().count("planned 'arm' with ompl/")
    response = client.call(GetMotionPlan, "/plan_kinematic_path", joint_goal(FAR)).motion_plan_response
    assert response.error_code.val == C.SUCCESS and response.error_code.source
    # the plan's log line, written once the response is on its way (after_response), is written
    assert wait_until(lambda: client.server.output().count("planned 'arm' with ompl/") > logged, 10.0), \
        client.server.output()[-2000:]
    assert response.group_name == "arm"
    jt = response.trajectory.joint_trajectory
    assert list(jt.joint_names) == ARM
    assert np.allclose(jt.points[0].positions, READY, atol=1e-3)
    assert np.allclose(jt.points[-1].positions, FAR, atol=1e-3)
    start = dict(zip(response.trajectory_start.joint_state.name, response.trajectory_start.joint_state.position))
    assert np.allclose([start[j] for j in ARM], READY, atol=1e-3)
    assert response.planning_time > 0
    assert np.allclose(client.arm(), READY, atol=0.01)  # planning alone moves nothing


def test_unknown_group_is_invalid_group_name(client: Client) -> None:
    response = client.call(GetMotionPlan, "/plan_kinematic_path", joint_goal(FAR, group="legs"))
    code = response.motion_plan_response.error_code
    assert code.val == C.INVALID_GROUP_NAME
    assert "arm" in code.message and code.source


def test_pose_goal_with_position_and_orientation_constraints(client: Client, mycobot: RobotModel) -> None:
    goal = tip_pose(mycobot, FAR)
    request = GetMotionPlan.Request()
    r = request.motion_plan_request
    r.group_name, r.allowed_planning_time = "arm", 5.0
    position = PositionConstraint(link_name=TIP)
    position.header.frame_id = "world"
    region_pose = Pose()
    region_pose.position.x, region_pose.position.y, region_pose.position.z = goal[:3, 3]
    position.constraint_region.primitives = [SolidPrimitive(type=SolidPrimitive.SPHERE, dimensions=[0.001])]
    position.constraint_region.primitive_poses = [region_pose]
    from scipy.spatial.transform import Rotation

    q = Rotation.from_matrix(goal[:3, :3]).as_quat()
    orientation = OrientationConstraint(link_name=TIP, absolute_x_axis_tolerance=0.01,
                                        absolute_y_axis_tolerance=0.01, absolute_z_axis_tolerance=0.01, weight=1.0)
    orientation.header.frame_id = "world"
    orientation.orientation.x, orientation.orientation.y, orientation.orientation.z, orientation.orientation.w = q
    r.goal_constraints = [Constraints(position_constraints=[position], orientation_constraints=[orientation])]
    response = client.call(GetMotionPlan, "/plan_kinematic_path", request).motion_plan_response
    assert response.error_code.val == C.SUCCESS, response.error_code.message
    end = tip_pose(mycobot, response.trajectory.joint_trajectory.points[-1].positions)
    assert np.linalg.norm(end[:3, 3] - goal[:3, 3]) < 1e-3
    assert Rotation.from_matrix(end[:3, :3].T @ goal[:3, :3]).magnitude() < 0.01


def test_goal_and_start_in_collision(client: Client, mycobot: RobotModel) -> None:
    obstacle = tip_pose(mycobot, FAR)[:3, 3]
    assert apply(client, box("blocker", obstacle))
    try:
        response = client.call(GetMotionPlan, "/plan_kinematic_path", joint_goal(FAR)).motion_plan_response
        assert response.error_code.val == C.GOAL_IN_COLLISION, response.error_code.message
        request = joint_goal(READY)
        request.motion_plan_request.start_state.joint_state = joint_state(FAR)
        response = client.call(GetMotionPlan, "/plan_kinematic_path", request).motion_plan_response
        assert response.error_code.val == C.START_STATE_IN_COLLISION, response.error_code.message
        validity = client.call(GetStateValidity, "/check_state_validity", GetStateValidity.Request(
            group_name="arm", robot_state=__import__("moveit_msgs.msg", fromlist=["RobotState"]).RobotState(
                joint_state=joint_state(FAR))))
        assert not validity.valid
        assert any("blocker" in (c.contact_body_1, c.contact_body_2) for c in validity.contacts)
        free = client.call(GetStateValidity, "/check_state_validity", GetStateValidity.Request(group_name="arm"))
        assert free.valid and not free.contacts
    finally:
        assert apply(client, box("blocker", obstacle, operation=CollisionObject.REMOVE))
    assert "blocker" not in world_ids(client)


# ------------------------------------------------------------------------------- kinematics
def test_compute_fk_in_a_link_frame_and_unknown_links(client: Client, mycobot: RobotModel) -> None:
    from moveit_msgs.msg import RobotState as RobotStateMsg

    request = GetPositionFK.Request(fk_link_names=[TIP, "link3"],
                                    robot_state=RobotStateMsg(joint_state=joint_state(FAR)))
    request.header.frame_id = "link2"
    response = client.call(GetPositionFK, "/compute_fk", request)
    assert response.error_code.val == C.SUCCESS
    assert list(response.fk_link_names) == [TIP, "link3"]
    state = RobotState(mycobot)
    state.set_joint_positions(dict(zip(ARM, FAR)))
    expected = np.linalg.inv(state.frame_pose("link2")) @ state.frame_pose(TIP)
    p = response.pose_stamped[0].pose.position
    assert response.pose_stamped[0].header.frame_id == "link2"
    assert np.allclose([p.x, p.y, p.z], expected[:3, 3], atol=1e-9)
    bad = client.call(GetPositionFK, "/compute_fk", GetPositionFK.Request(fk_link_names=["no_such_link"]))
    assert bad.error_code.val == C.INVALID_LINK_NAME and "no_such_link" in bad.error_code.message


def test_compute_ik_solves_and_reports_no_ik_solution(client: Client, mycobot: RobotModel) -> None:
    goal = tip_pose(mycobot, FAR)
    from scipy.spatial.transform import Rotation

    request = GetPositionIK.Request()
    request.ik_request.group_name = "arm"
    request.ik_request.pose_stamped.header.frame_id = "world"
    pose = request.ik_request.pose_stamped.pose
    pose.position.x, pose.position.y, pose.position.z = goal[:3, 3]
    pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = \
        Rotation.from_matrix(goal[:3, :3]).as_quat()
    response = client.call(GetPositionIK, "/compute_ik", request)
    assert response.error_code.val == C.SUCCESS
    values = dict(zip(response.solution.joint_state.name, response.solution.joint_state.position))
    assert np.linalg.norm(tip_pose(mycobot, [values[j] for j in ARM])[:3, 3] - goal[:3, 3]) < 1e-4
    pose.position.x = 3.0  # far out of reach
    response = client.call(GetPositionIK, "/compute_ik", request)
    assert response.error_code.val == C.NO_IK_SOLUTION and response.error_code.message


def test_compute_cartesian_path_straight_down(client: Client, mycobot: RobotModel) -> None:
    move(client, READY)
    start = tip_pose(mycobot, READY)
    from scipy.spatial.transform import Rotation

    request = GetCartesianPath.Request(group_name="arm", link_name=TIP, max_step=0.005, avoid_collisions=True)
    request.header.frame_id = "world"
    waypoint = Pose()
    waypoint.position.x, waypoint.position.y, waypoint.position.z = start[:3, 3] - [0, 0, 0.03]
    waypoint.orientation.x, waypoint.orientation.y, waypoint.orientation.z, waypoint.orientation.w = \
        Rotation.from_matrix(start[:3, :3]).as_quat()
    request.waypoints = [waypoint]
    response = client.call(GetCartesianPath, "/compute_cartesian_path", request)
    assert response.error_code.val == C.SUCCESS and response.fraction == pytest.approx(1.0)
    points = response.solution.joint_trajectory.points
    heights = [tip_pose(mycobot, p.positions)[2, 3] for p in points]
    assert heights[-1] == pytest.approx(start[2, 3] - 0.03, abs=1e-4)
    xy = [tip_pose(mycobot, p.positions)[:2, 3] for p in points]
    assert max(np.linalg.norm(v - start[:2, 3]) for v in xy) < 1e-3  # straight


# ------------------------------------------------------------------------------- scene
def test_planning_scene_components_and_apply(client: Client) -> None:
    assert apply(client, box("crate", (0.25, 0.2, 0.03)))
    request = GetPlanningScene.Request()
    request.components.components = PlanningSceneComponents.WORLD_OBJECT_NAMES
    scene = client.call(GetPlanningScene, "/get_planning_scene", request).scene
    crate = next(o for o in scene.world.collision_objects if o.id == "crate")
    assert not len(crate.primitives)  # names only
    assert not len(scene.robot_state.joint_state.name)
    request.components.components = PlanningSceneComponents.WORLD_OBJECT_GEOMETRY
    crate = next(o for o in client.call(GetPlanningScene, "/get_planning_scene", request).scene.world.collision_objects
                 if o.id == "crate")
    assert list(crate.primitives[0].dimensions) == pytest.approx([0.06, 0.06, 0.06])
    request.components.components = PlanningSceneComponents.ROBOT_STATE
    scene = client.call(GetPlanningScene, "/get_planning_scene", request).scene
    assert set(ARM) <= set(scene.robot_state.joint_state.name) and not len(scene.world.collision_objects)
    # a bad object is refused and changes nothing
    assert not apply(client, box("bad", (0.1, 0.1, 0.1), size=(0.1, -0.1, 0.1)))
    assert "bad" not in world_ids(client)
    # the /collision_object topic, as MoveGroupInterface's PlanningSceneInterface uses it
    client.object_pub.publish(box("crate", (0, 0, 0), operation=CollisionObject.REMOVE))
    assert wait_until(lambda: "crate" not in world_ids(client), 5.0)


def test_planner_interfaces_and_params(client: Client) -> None:
    interfaces = client.call(QueryPlannerInterfaces, "/query_planner_interface",
                             QueryPlannerInterfaces.Request()).planner_interfaces
    by_pipeline = {i.pipeline_id: list(i.planner_ids) for i in interfaces}
    assert "RRTConnectkConfigDefault" in by_pipeline["ompl"]
    assert {"PTP", "LIN", "CIRC"} <= set(by_pipeline["pilz_industrial_motion_planner"])
    get = GetPlannerParams.Request(pipeline_id="ompl", planner_config="RRTConnectkConfigDefault", group="arm")
    params = client.call(GetPlannerParams, "/get_planner_params", get).params
    assert "type" in params.keys
    request = SetPlannerParams.Request(pipeline_id="ompl", planner_config="RRTConnectkConfigDefault", group="arm")
    request.params.keys, request.params.values = ["range"], ["0.25"]
    client.call(SetPlannerParams, "/set_planner_params", request)
    params = client.call(GetPlannerParams, "/get_planner_params", get).params
    assert dict(zip(params.keys, params.values))["range"] == "0.25"
    # still plans with the changed configuration
    response = client.call(GetMotionPlan, "/plan_kinematic_path", joint_goal(FAR)).motion_plan_response
    assert response.error_code.val == C.SUCCESS


def test_stomp_and_chomp_are_listed_and_plan_through_move_group(client: Client) -> None:
    interfaces = client.call(QueryPlannerInterfaces, "/query_planner_interface",
                             QueryPlannerInterfaces.Request()).planner_interfaces
    by_pipeline = {i.pipeline_id: (i.name, list(i.planner_ids)) for i in interfaces}
    assert by_pipeline["stomp"] == ("STOMP", ["STOMP"]) and by_pipeline["chomp"] == ("CHOMP", ["CHOMP"])
    get = GetPlannerParams.Request(pipeline_id="chomp", planner_config="CHOMP", group="arm")
    params = client.call(GetPlannerParams, "/get_planner_params", get).params
    assert dict(zip(params.keys, params.values))["max_iterations"] == "200"
    for pipeline_id, planner_id in (("stomp", "STOMP"), ("chomp", "CHOMP"), ("chomp", "")):
        request = joint_goal(FAR)
        request.motion_plan_request.pipeline_id, request.motion_plan_request.planner_id = pipeline_id, planner_id
        response = client.call(GetMotionPlan, "/plan_kinematic_path", request, timeout=30.0).motion_plan_response
        assert response.error_code.val == C.SUCCESS, (pipeline_id, response.error_code.message)
        points = response.trajectory.joint_trajectory.points
        index = [list(response.trajectory.joint_trajectory.joint_names).index(j) for j in ARM]
        assert np.allclose(np.asarray(points[-1].positions)[index], FAR, atol=1e-3)
    # an id CHOMP does not have is refused with MoveIt's code, not planned by another planner
    request = joint_goal(FAR)
    request.motion_plan_request.pipeline_id, request.motion_plan_request.planner_id = "chomp", "RRTConnectkConfigDefault"
    refused = client.call(GetMotionPlan, "/plan_kinematic_path", request).motion_plan_response
    assert refused.error_code.val != C.SUCCESS


# ------------------------------------------------------------------------------- actions
def test_move_action_plan_only_moves_nothing(client: Client) -> None:
    move(client, READY)
    goal = MoveGroup.Goal()
    goal.request = joint_goal(FAR).motion_plan_request
    goal.planning_options.plan_only = True
    handle = client.send(client.move, goal)
    result = client.spin_until(handle.get_result_async()).result
    assert result.error_code.val == C.SUCCESS
    assert np.allclose(result.planned_trajectory.joint_trajectory.points[-1].positions, FAR, atol=1e-3)
    assert not len(result.executed_trajectory.joint_trajectory.points)
    # the feedback (a topic) can be taken after the result (a service answer) that followed it,
    # when rclpy no longer calls a feedback callback for the goal: read from the topic itself
    goal_id = bytes(handle.goal_id.uuid)
    assert wait_until(lambda: (client.executor.spin_once(timeout_sec=0.05),
                               (goal_id, "PLANNING") in client.move_feedback)[1], 5.0,
                      period=0.0), client.move_feedback
    assert np.allclose(client.arm(), READY, atol=0.01)


def test_move_action_cancel_is_preempted(client: Client) -> None:
    move(client, READY)
    goal = MoveGroup.Goal()
    goal.request = joint_goal(FAR).motion_plan_request
    goal.request.max_velocity_scaling_factor = 0.2  # a slow motion, to cancel in the middle
    states = []
    handle = client.send(client.move, goal, feedback=lambda m: states.append(m.feedback.state))
    # spin without pauses: /joint_states at 100 Hz would otherwise queue ahead of the feedback
    assert wait_until(lambda: (client.executor.spin_once(timeout_sec=0.01), "MONITOR" in states)[1], 20.0,
                      period=0.0)
    deadline = time.monotonic() + 0.3
    while time.monotonic() < deadline:
        client.executor.spin_once(timeout_sec=0.01)
    client.spin_until(handle.cancel_goal_async())
    response = client.spin_until(handle.get_result_async())
    assert response.status == GoalStatus.STATUS_CANCELED
    assert response.result.error_code.val == C.PREEMPTED
    arm = client.arm()
    assert not np.allclose(arm, FAR, atol=0.01) and not np.allclose(arm, READY, atol=0.01)


def _plan(client: Client, values) -> object:
    response = client.call(GetMotionPlan, "/plan_kinematic_path", joint_goal(values)).motion_plan_response
    assert response.error_code.val == C.SUCCESS
    return response.trajectory


def _execute_plan_to(client: Client, values) -> ExecuteTrajectory.Result:
    """Plan to ``values``, execute the plan through execute_trajectory; its result."""
    handle = client.send(client.execute, ExecuteTrajectory.Goal(trajectory=_plan(client, values)))
    return client.spin_until(handle.get_result_async()).result


def test_execute_trajectory_and_the_stop_event(client: Client) -> None:
    move(client, READY)
    result = _execute_plan_to(client, FAR)
    assert result.error_code.val == C.SUCCESS
    assert np.allclose(client.arm(), FAR, atol=0.01)
    handle = client.send(client.execute, ExecuteTrajectory.Goal(trajectory=_plan(client, READY)))
    time.sleep(0.3)
    client.stop_pub.publish(String(data="stop"))
    response = client.spin_until(handle.get_result_async())
    assert response.result.error_code.val == C.PREEMPTED
    assert "at rest" in response.result.error_code.message  # decelerated along the path, then answered
    assert at_rest(client)
    assert not np.allclose(client.arm(), READY, atol=0.01)


def test_controller_abort_is_control_failed(client: Client) -> None:
    move(client, READY)
    with client.mock_fault("arm_controller.fail_after", 0.2):
        result = _execute_plan_to(client, FAR)
        assert result.error_code.val == C.CONTROL_FAILED
        assert "arm_controller" in result.error_code.message


def test_stalled_controller_is_timed_out(client: Client) -> None:
    move(client, READY)
    with client.mock_fault("arm_controller.stall_after", 0.2):
        result = _execute_plan_to(client, FAR)
        assert result.error_code.val == C.TIMED_OUT, result.error_code.message
    move(client, READY)  # the controller follows again


def test_bad_requests_get_error_codes_and_the_node_survives(client: Client) -> None:
    empty = GetMotionPlan.Request()
    empty.motion_plan_request.group_name = "arm"
    code = client.call(GetMotionPlan, "/plan_kinematic_path", empty).motion_plan_response.error_code
    assert code.val == C.INVALID_GOAL_CONSTRAINTS and code.message
    handle = client.send(client.execute, ExecuteTrajectory.Goal())
    result = client.spin_until(handle.get_result_async()).result
    assert result.error_code.val == C.INVALID_MOTION_PLAN and "no points" in result.error_code.message
    nan = joint_goal([float("nan")] * 6)
    code = client.call(GetMotionPlan, "/plan_kinematic_path", nan).motion_plan_response.error_code
    assert code.val != C.SUCCESS and code.message
    assert "Traceback" not in client.server.output()
    move(client, READY)


def test_path_constraints_are_honoured(client: Client, mycobot: RobotModel) -> None:
    """An orientation path constraint (keep the flange pointing down) on GetMotionPlan and
    GetCartesianPath; every point of the answers is checked here."""
    from mycobot_planning.core.kinematics.ik_solver import solve_ik
    from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
    from mycobot_planning.core.transforms import make_pose

    scene = PlanningScene(mycobot)
    down = [0.0, 1.0, 0.0, 0.0]
    start = solve_ik(mycobot, "arm", make_pose([0.15, 0.05, 0.25], quat_xyzw=down), seed=RobotState(mycobot),
                     scene=scene, timeout=1.0, rng=0)[0]
    goal = solve_ik(mycobot, "arm", make_pose([0.17, -0.04, 0.2], quat_xyzw=down), seed=start, scene=scene,
                    timeout=1.0, rng=0)[0]
    move(client, start.group_positions("arm").tolist())
    keep_down = Constraints(orientation_constraints=[OrientationConstraint(
        link_name=TIP, absolute_x_axis_tolerance=0.1, absolute_y_axis_tolerance=0.1,
        absolute_z_axis_tolerance=3.15, weight=1.0)])
    keep_down.orientation_constraints[0].header.frame_id = "world"
    o = keep_down.orientation_constraints[0].orientation
    o.x, o.y, o.z, o.w = down

    def tilt(positions) -> float:
        z = tip_pose(mycobot, positions)[:3, 2]
        return float(np.arccos(np.clip(-z[2], -1.0, 1.0)))

    request = joint_goal(goal.group_positions("arm"))
    request.motion_plan_request.path_constraints = keep_down
    # constrained RRTConnect needs up to ~4 CPU s here: a budget that a loaded machine cannot exhaust
    request.motion_plan_request.allowed_planning_time = 30.0
    response = client.call(GetMotionPlan, "/plan_kinematic_path", request).motion_plan_response
    assert response.error_code.val == C.SUCCESS, response.error_code.message
    assert max(tilt(p.positions) for p in response.trajectory.joint_trajectory.points) <= 0.1 * np.sqrt(2) + 1e-6

    # a goal that tilts the flange breaks the constraint: MoveIt's code says so
    tilted = goal.group_positions("arm").copy()
    tilted[4] += 0.6
    request = joint_goal(tilted)
    request.motion_plan_request.path_constraints = keep_down
    code = client.call(GetMotionPlan, "/plan_kinematic_path", request).motion_plan_response.error_code
    assert code.val == C.GOAL_VIOLATES_PATH_CONSTRAINTS, code.message

    # from the goal (clear of the arm itself): a Cartesian path down, then one that would tilt the
    # flange by 0.4 rad: it stops early
    move(client, goal.group_positions("arm").tolist())
    begin = tip_pose(mycobot, goal.group_positions("arm"))
    from scipy.spatial.transform import Rotation

    def cartesian(rotation) -> GetCartesianPath.Response:
        request = GetCartesianPath.Request(group_name="arm", link_name=TIP, max_step=0.005, avoid_collisions=True,
                                           path_constraints=keep_down)
        request.header.frame_id = "world"
        waypoint = Pose()
        waypoint.position.x, waypoint.position.y, waypoint.position.z = begin[:3, 3] - [0, 0, 0.03]
        (waypoint.orientation.x, waypoint.orientation.y, waypoint.orientation.z,
         waypoint.orientation.w) = Rotation.from_matrix(begin[:3, :3] @ rotation).as_quat()
        request.waypoints = [waypoint]
        return client.call(GetCartesianPath, "/compute_cartesian_path", request)

    straight = cartesian(np.eye(3))
    assert straight.error_code.val == C.SUCCESS and straight.fraction == pytest.approx(1.0)
    turning = cartesian(Rotation.from_euler("x", 0.4).as_matrix())
    assert 0.0 < turning.fraction < 0.6
    assert max(tilt(p.positions) for p in turning.solution.joint_trajectory.points) <= 0.1 * np.sqrt(2) + 1e-6
    move(client, READY)


# ------------------------------------------------------------------------------- reacting while moving (issue 29)
SWEEP_START = [-1.2, -0.8, -0.6, 0.0, 0.0, 0.0]
SWEEP_END = [1.2, -0.8, -0.6, 0.0, 0.0, 0.0]


def flange_position(mycobot: RobotModel, joint1: float) -> np.ndarray:
    values = list(SWEEP_START)
    values[0] = joint1
    return tip_pose(mycobot, values)[:3, 3]


def sweep_goal(replan: bool = False, attempts: int = 0, delay: float = 0.0) -> MoveGroup.Goal:
    goal = MoveGroup.Goal()
    goal.request = joint_goal(SWEEP_END).motion_plan_request
    goal.request.max_velocity_scaling_factor = 0.3
    goal.request.max_acceleration_scaling_factor = 0.3
    goal.planning_options.replan = replan
    goal.planning_options.replan_attempts = attempts
    goal.planning_options.replan_delay = delay
    return goal


def run_with_intrusion(client: Client, action, goal, obj: CollisionObject | None, after: float = 0.5,
                       cancel_after: float | None = None):
    """Send ``goal``, record /joint_states, publish ``obj`` on /collision_object ``after`` s into
    the motion (the first MONITOR feedback; the goal's start for execute_trajectory); cancel
    ``cancel_after`` s into it when given. Returns (result response, feedback states, recording)."""
    states: list[str] = []
    client.recorded = []
    started: list[float] = []

    def on_feedback(msg) -> None:
        states.append(msg.feedback.state)
        if msg.feedback.state == "MONITOR" and not started:
            started.append(time.monotonic())

    handle = client.send(action, goal, feedback=on_feedback)
    result_future = handle.get_result_async()
    sent = cancelled = False
    deadline = time.monotonic() + 60.0
    while not result_future.done() and time.monotonic() < deadline:
        client.executor.spin_once(timeout_sec=0.02)
        if started and obj is not None and not sent and time.monotonic() - started[0] > after:
            client.object_pub.publish(obj)
            sent = True
        if started and cancel_after is not None and not cancelled and time.monotonic() - started[0] > cancel_after:
            handle.cancel_goal_async()
            cancelled = True
    assert result_future.done(), "no result in time"
    for _ in range(10):  # the last joint states
        client.executor.spin_once(timeout_sec=0.02)
    recording, client.recorded = client.recorded, None
    return result_future.result(), states, recording


def assert_recorded_motion_free(mycobot: RobotModel, recording, *objects) -> None:
    """Every recorded /joint_states state is free of collisions in the scene with ``objects``
    (the plain exact all-pairs check)."""
    from interfaces_py.msgs import CollisionObject as SceneObject
    from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
    from mycobot_planning.core.transforms import make_pose

    scene = PlanningScene(mycobot)
    for obj in objects:  # boxes as box() makes them
        p = obj.pose.position
        scene.add_object(SceneObject.box(obj.id, list(obj.primitives[0].dimensions), make_pose([p.x, p.y, p.z])))
    names = [n for n in recording[0].name if n in mycobot.variable_names]
    index = np.array([mycobot.variable_index(n) for n in names])
    rows = np.array([[dict(zip(m.name, m.position))[n] for n in names] for m in recording])
    assert len(rows) > 20
    hits = scene.colliding_rows(index, None, rows, all_pairs=True)
    assert not np.any(hits), f"{int(hits.sum())} recorded states collide, first at {rows[np.argmax(hits)]}"


def remove(client: Client, object_id: str) -> None:
    client.object_pub.publish(box(object_id, [0, 0, 0], operation=CollisionObject.REMOVE))
    assert wait_until(lambda: object_id not in world_ids(client), 5.0)


def at_rest(client: Client) -> bool:
    first = client.arm()
    time.sleep(0.2)
    return bool(np.allclose(client.arm(), first, atol=1e-4))


@pytest.mark.parametrize("replan", [False, True])
def test_move_action_reacts_to_an_object_appearing_on_its_path(client: Client, mycobot: RobotModel, replan) -> None:
    """The issue's scene: joint 1 sweeps from -1.2 to +1.2 rad; during the motion a 6 cm box
    appears where the flange passes at mid-sweep. Without replanning the arm stops short
    (MOTION_PLAN_INVALIDATED_BY_ENVIRONMENT_CHANGE); with it, it plans around and arrives."""
    move(client, SWEEP_START)
    intruder = box("intruder", flange_position(mycobot, 0.0))
    try:
        response, states, recording = run_with_intrusion(client, client.move, sweep_goal(replan, 3), intruder)
        code = response.result.error_code
        assert_recorded_motion_free(mycobot, recording, intruder)
        if replan:
            assert code.val == C.SUCCESS, code.message
            assert "replan" in code.message
            assert np.allclose(client.arm(), SWEEP_END, atol=0.02)
            assert states.count("MONITOR") >= 2 and states.count("PLANNING") >= 2
        else:
            assert code.val == C.MOTION_PLAN_INVALIDATED_BY_ENVIRONMENT_CHANGE, code.message
            assert "intruder" in code.message and "at rest" in code.message
            assert response.status == GoalStatus.STATUS_ABORTED
            arm = client.arm()
            assert -1.2 < arm[0] < 0.0  # stopped on the way, before the box
            assert at_rest(client)
    finally:
        remove(client, "intruder")


def test_execute_trajectory_stops_short_of_an_object_on_its_path(client: Client, mycobot: RobotModel) -> None:
    move(client, SWEEP_START)
    request = joint_goal(SWEEP_END)
    request.motion_plan_request.max_velocity_scaling_factor = 0.3
    request.motion_plan_request.max_acceleration_scaling_factor = 0.3
    response = client.call(GetMotionPlan, "/plan_kinematic_path", request).motion_plan_response
    assert response.error_code.val == C.SUCCESS
    intruder = box("intruder", flange_position(mycobot, 0.0))
    try:
        result, _, recording = run_with_intrusion(client, client.execute,
                                                  ExecuteTrajectory.Goal(trajectory=response.trajectory), intruder)
        assert result.result.error_code.val == C.MOTION_PLAN_INVALIDATED_BY_ENVIRONMENT_CHANGE
        assert_recorded_motion_free(mycobot, recording, intruder)
        assert at_rest(client)
    finally:
        remove(client, "intruder")


def test_an_object_away_from_the_path_does_not_stop_the_motion(client: Client, mycobot: RobotModel) -> None:
    move(client, SWEEP_START)
    far = box("bystander", [0.0, -0.35, 0.05], size=(0.05, 0.05, 0.05))
    try:
        response, _, _ = run_with_intrusion(client, client.move, sweep_goal(), far)
        assert response.result.error_code.val == C.SUCCESS, response.result.error_code.message
        assert np.allclose(client.arm(), SWEEP_END, atol=0.02)
    finally:
        remove(client, "bystander")


def test_cancel_brings_the_arm_to_rest_along_its_path(client: Client) -> None:
    move(client, SWEEP_START)
    response, _, recording = run_with_intrusion(client, client.move, sweep_goal(), None, cancel_after=1.0)
    assert response.status == GoalStatus.STATUS_CANCELED
    assert response.result.error_code.val == C.PREEMPTED
    assert at_rest(client)
    arm = client.arm()
    assert SWEEP_START[0] < arm[0] < SWEEP_END[0]
    assert np.allclose(arm[1:], SWEEP_START[1:], atol=1e-3)  # stopped on the path (only joint 1 moves)


@pytest.mark.parametrize("attempts, delay, words", [(-1, 0.0, "replan_attempts must be >= 0"),
                                                    (2, float("nan"), "replan_delay must be a number")])
def test_bad_replanning_options_are_refused_and_change_nothing(client: Client, attempts, delay, words) -> None:
    move(client, READY)
    goal = MoveGroup.Goal()
    goal.request = joint_goal(FAR).motion_plan_request
    goal.planning_options.replan = True
    goal.planning_options.replan_attempts = attempts
    goal.planning_options.replan_delay = delay
    goal.planning_options.planning_scene_diff.is_diff = True
    goal.planning_options.planning_scene_diff.world.collision_objects = [box("not_applied", [0.3, 0.3, 0.3])]
    handle = client.send(client.move, goal)
    response = client.spin_until(handle.get_result_async())
    assert response.status == GoalStatus.STATUS_ABORTED
    assert words in response.result.error_code.message
    assert "not_applied" not in world_ids(client)
    assert np.allclose(client.arm(), READY, atol=0.01)


def test_cancelling_the_controllers_own_goal_decelerates_within_the_limits(client: Client) -> None:
    """A FollowJointTrajectory goal cancelled mid-motion on the controller itself (what
    moveit_simple_controller_manager does to stop): the joints slow down along the goal's path
    within their acceleration limits (5 rad/s^2), the goal ends canceled once they are at rest."""
    move(client, SWEEP_START)
    controller = ActionClient(client.node, FollowJointTrajectory, "/arm_controller/follow_joint_trajectory")
    response = client.call(GetMotionPlan, "/plan_kinematic_path", joint_goal(SWEEP_END)).motion_plan_response
    assert response.error_code.val == C.SUCCESS
    goal = FollowJointTrajectory.Goal()
    goal.trajectory = response.trajectory.joint_trajectory
    duration = goal.trajectory.points[-1].time_from_start.sec + goal.trajectory.points[-1].time_from_start.nanosec * 1e-9
    client.recorded = []
    handle = client.send(controller, goal)
    result = handle.get_result_async()
    deadline = time.monotonic() + duration * 0.45
    while time.monotonic() < deadline:
        client.executor.spin_once(timeout_sec=0.01)
    cancelled_at = len(client.recorded)
    client.spin_until(handle.cancel_goal_async())
    response = client.spin_until(result)
    deadline = time.monotonic() + 0.3
    while time.monotonic() < deadline:
        client.executor.spin_once(timeout_sec=0.01)
    recording, client.recorded = client.recorded, None
    assert response.status == GoalStatus.STATUS_CANCELED
    index = list(recording[0].name).index(ARM[0])
    t = np.array([m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in recording])
    v = np.array([m.velocity[index] for m in recording])
    q = np.array([m.position[index] for m in recording])
    assert abs(v[cancelled_at]) > 0.5  # it was moving fast when cancelled
    # over 80 ms windows: a message's velocity is the controller's last update (up to a 10 ms
    # period old), not its stamp's. A hold at once would show 30+ rad/s^2 here; the precise
    # limit check is the follower's unit test.
    k = np.arange(max(cancelled_at - 2, 0), len(v) - 8)
    dv = np.abs(v[k + 8] - v[k]) / (t[k + 8] - t[k])
    assert np.all(dv <= 5.0 * 1.3), dv.max()  # about the 5 rad/s^2 limit
    assert abs(v[-1]) < 1e-6 and abs(q[-1] - q[-5]) < 1e-6  # at rest
    assert q[-1] - q[cancelled_at] > 0.02 and q[-1] < SWEEP_END[0] - 0.1  # slowed down on the way, short of the end


def three_step_solution(client: Client):
    """An MTC solution of three sub-trajectories: to the sweep's start's neighbour (-0.6 rad),
    across the sweep (+1.2), back (+0.6); planned at 30 % speed."""
    from moveit_task_constructor_msgs.msg import Solution, SubTrajectory

    middle, back = list(SWEEP_START), list(SWEEP_START)
    middle[0], back[0] = -0.6, 0.6

    def planned(start, goal):
        request = joint_goal(goal)
        request.motion_plan_request.start_state.joint_state.name = list(ARM)
        request.motion_plan_request.start_state.joint_state.position = [float(v) for v in start]
        request.motion_plan_request.max_velocity_scaling_factor = 0.3
        request.motion_plan_request.max_acceleration_scaling_factor = 0.3
        response = client.call(GetMotionPlan, "/plan_kinematic_path", request).motion_plan_response
        assert response.error_code.val == C.SUCCESS, response.error_code.message
        return response.trajectory

    solution = Solution(task_id="react")
    for k, (a, b) in enumerate([(SWEEP_START, middle), (middle, SWEEP_END), (SWEEP_END, back)]):
        step = SubTrajectory(trajectory=planned(a, b))
        step.info.id, step.info.comment = k, ["approach", "sweep", "return"][k]
        step.scene_diff.is_diff = True
        step.scene_diff.robot_state.is_diff = True
        solution.sub_trajectory.append(step)
    first = solution.sub_trajectory[0].trajectory.joint_trajectory.points[-1].time_from_start
    return solution, first.sec + first.nanosec * 1e-9


def run_solution(client: Client, solution, at: float, act) -> object:
    """Execute ``solution`` on /execute_task_solution, recording /joint_states; ``act(handle)``
    ``at`` s after the goal was accepted. Returns (result response, recording)."""
    from moveit_task_constructor_msgs.action import ExecuteTaskSolution

    executor = ActionClient(client.node, ExecuteTaskSolution, "/execute_task_solution")
    client.recorded = []
    handle = client.send(executor, ExecuteTaskSolution.Goal(solution=solution))
    result = handle.get_result_async()
    start = time.monotonic()
    acted = False
    while not result.done() and time.monotonic() - start < 60.0:
        client.executor.spin_once(timeout_sec=0.01)
        if not acted and time.monotonic() - start > at:
            act(handle)
            acted = True
    response = client.spin_until(result)
    recording, client.recorded = client.recorded, None
    return response, recording


def test_a_task_solution_stops_at_the_step_whose_path_became_invalid(client: Client, mycobot: RobotModel) -> None:
    """A box appears on the second sub-trajectory's path: the execution stops there short of the
    box and fails naming that step (MTC does not replan); the third never runs."""
    move(client, SWEEP_START)
    solution, first = three_step_solution(client)
    intruder = box("intruder", flange_position(mycobot, 0.3))
    try:
        response, recording = run_solution(client, solution, first + 0.3,
                                           lambda handle: client.object_pub.publish(intruder))
        code = response.result.error_code
        assert code.val == C.MOTION_PLAN_INVALIDATED_BY_ENVIRONMENT_CHANGE, code.message
        assert "step 1" in code.message and "intruder" in code.message
        assert_recorded_motion_free(mycobot, recording, intruder)
        arm = client.arm()
        assert -0.6 < arm[0] < 0.3 and at_rest(client)  # stopped in the sweep, before the box; never returned
    finally:
        remove(client, "intruder")


def test_cancelling_a_task_solution_brings_the_arm_to_rest(client: Client) -> None:
    move(client, SWEEP_START)
    solution, first = three_step_solution(client)
    response, _ = run_solution(client, solution, first + 0.5, lambda handle: handle.cancel_goal_async())
    assert response.status == GoalStatus.STATUS_CANCELED
    assert response.result.error_code.val == C.PREEMPTED
    assert at_rest(client)
    assert -0.6 < client.arm()[0] < SWEEP_END[0]
