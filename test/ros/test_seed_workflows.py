"""The seeds' move_group workflows as runnable nodes, against real mock controllers and planning_server.

First the scenario geometry without ROS (poses inside the myCobot's reach, zig-zag, camera
transform), then each workflow node run as a process like ``ros2 run`` would: ROSCon exercise
1-1 (the sausage ends in the bun, detached), exercise 1-2 (Cartesian zig-zag, fraction reported,
executed to its end) and Scan-N-Plan (marker publisher + vision node + scan_n_plan: the tool ends
at the part). One pair of controller/server processes serves the module.
"""
from __future__ import annotations

import json
import math
import os
import re
import signal
from typing import Any

import numpy as np
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory as JointTrajectoryMsg

from interfaces_py.clients import PlanningSceneInterface
from interfaces_py.json_rpc import JsonRpcClient, RpcError
from interfaces_py.msgs import CollisionObject, MoveItErrorCode, PlanningScene as PlanningSceneMsg, Pose
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.kinematics.ik_solver import solve_ik
from mycobot_planning.demos.seed_scenarios import (
    DEFAULT_CAMERA_POSE,
    DEFAULT_MARKER_POSE,
    HotDogScenario,
    localize,
    pose_from_list,
    tool_down_quaternion,
    zigzag_waypoints,
)
from ros_testing import NodeProcess, ProbeNode, use_session_domain, wait_until

ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6", "link6_to_link6_flange"]
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
NODES = "mycobot_planning.nodes."
RUN_TIMEOUT = 90.0  # s: a workflow run (start-up, planning, execution), generous for a loaded machine


@pytest.fixture(scope="module")
def model() -> RobotModel:
    return RobotModel.mycobot()


def _reachable(model: RobotModel, scene: PlanningScene, pose: Pose) -> bool:
    return bool(solve_ik(model, "arm", pose.to_matrix(), link="link6_flange", scene=scene, rng=0, timeout=0.5))


# ---------------------------------------------------------------------------- geometry, no ROS
@pytest.mark.parametrize("yaw", [0.0, 0.7, -2.0])
def test_tool_down_orientation_points_the_tool_z_axis_down(yaw):
    R = Pose(orientation=tool_down_quaternion(yaw)).to_matrix()[:3, :3]
    assert R[:, 2] == pytest.approx([0.0, 0.0, -1.0], abs=1e-12)
    assert math.atan2(R[1, 0], R[0, 0]) == pytest.approx(yaw, abs=1e-12)


def test_hot_dog_poses_are_reachable_and_collision_free_on_the_mycobot(model):
    sc = HotDogScenario()
    scene = PlanningScene(model)
    scene.add_object(sc.sausage())
    scene.add_object(sc.bun())
    for pose in (sc.pick_pose(), sc.place_pose()):
        assert math.hypot(*pose.position[:2]) < 0.28  # inside the myCobot's reach
        assert _reachable(model, scene, pose), pose
    # the place pose hangs the carried sausage drop_height over its final place, same heading
    assert np.asarray(sc.place_pose().position) - [0, 0, sc.grasp_height + sc.drop_height] == pytest.approx(
        sc.place_position())
    assert sc.place_pose().orientation == pytest.approx(sc.pick_pose().orientation)
    assert sc.place_position()[2] == pytest.approx(sc.bun_size[2] + sc.sausage_radius)  # resting on the bun
    carried = Pose(position=(sc.place_position() + [0, 0, sc.drop_height]).tolist())
    assert sc.dropped_sausage_pose(carried).position == pytest.approx(sc.place_position())

    hot_dog = PlanningScene(model)
    for obj in (sc.bun(), sc.sausage(sc.place_position())):
        hot_dog.add_object(obj)
    hot_dog.apply_attached_collision_object(sc.mustard_bottle())
    assert _reachable(model, hot_dog, sc.mustard_start_pose())


def test_zigzag_waypoints_alternate_sides_along_the_sausage():
    start = Pose(position=[0.2, 0.06, 0.14], orientation=tool_down_quaternion(0.0))
    poses = zigzag_waypoints(start, length=0.05, amplitude=0.01, strokes=6)
    xyz = np.array([p.position for p in poses])
    assert len(poses) == 7
    assert xyz[:, 1] == pytest.approx(np.linspace(0.06 - 0.025, 0.06 + 0.025, 7))
    assert xyz[:, 0] == pytest.approx([0.19, 0.21, 0.19, 0.21, 0.19, 0.21, 0.19])
    assert xyz[:, 2] == pytest.approx([0.14] * 7)
    assert all(p.orientation == pytest.approx(start.orientation) for p in poses)
    assert HotDogScenario().mustard_waypoints()[0].position[2] == pytest.approx(
        HotDogScenario().mustard_start_pose().position[2])


@pytest.mark.parametrize("kwargs, problem", [
    ({"length": 0.0, "amplitude": 0.01, "strokes": 3}, "length must be a positive"),
    ({"length": 0.05, "amplitude": -0.01, "strokes": 3}, "amplitude must be"),
    ({"length": 0.05, "amplitude": 0.01, "strokes": 0}, "strokes must be an integer >= 1"),
])
def test_zigzag_refuses_bad_shapes(kwargs, problem):
    with pytest.raises(ValueError, match=problem):
        zigzag_waypoints(Pose(), **kwargs)


@pytest.mark.parametrize("kwargs, problem", [
    ({"pick_position": (0.1, float("nan"), 0.0)}, "pick_position must be 3 finite numbers"),
    ({"grasp_height": 0.005}, "grasp_height .* must exceed the sausage radius"),
    ({"bun_size": (0.04, 0.0, 0.01)}, "bun_size must be positive"),
    ({"mustard_strokes": 0}, "mustard_strokes must be an integer >= 1"),
])
def test_hot_dog_scenario_refuses_bad_values_naming_them(kwargs, problem):
    with pytest.raises(ValueError, match=problem):
        HotDogScenario(**kwargs)


def test_localize_composes_the_camera_mount_with_the_marker(model):
    camera = pose_from_list(DEFAULT_CAMERA_POSE, "camera_pose")
    marker = pose_from_list(DEFAULT_MARKER_POSE, "marker_pose")
    part = localize(marker, camera)
    # camera 0.5 m up looking down: camera x = world x, camera y = -world y, depth = down
    assert part.position == pytest.approx([0.20 + 0.02, -0.05, 0.50 - 0.40])
    R = part.to_matrix()[:3, :3]
    assert R[:, 2] == pytest.approx([0, 0, -1], abs=1e-12)  # the marker's z points down, like the tool
    assert _reachable(model, PlanningScene(model), part)
    with pytest.raises(ValueError, match="quaternion"):
        pose_from_list([0, 0, 0, 0, 0, 0, 0], "camera_pose")


# ---------------------------------------------------------------------------- processes
class Probe(ProbeNode):
    """An in-test node: joint states, planned paths, the monitored scene."""

    def __init__(self) -> None:
        super().__init__("seed_workflow_test_probe")
        self.listen_to_joint_states()
        self.display = self.collect(JointTrajectoryMsg, "/planned_path", LATCHED)
        self.scenes = self.collect(String, "/planning_server/monitored_planning_scene", LATCHED)
        self.spin_in_background()

    def latest_scene(self) -> PlanningSceneMsg | None:
        with self.lock:
            data = self.scenes[-1].data if self.scenes else None
        return PlanningSceneMsg.from_json(data) if data else None


@pytest.fixture(scope="module")
def system():
    use_session_domain()
    controllers = NodeProcess(NODES + "mock_controllers")
    server = NodeProcess(NODES + "planning_server",
                         ["--ros-args", "-p", "trajectory_execution.allowed_goal_duration_margin:=3.0"])
    probe = scene = None
    try:
        assert controllers.wait_for_output("controller_manager ready", 60), controllers.output()
        assert server.wait_for_output("planning_server ready", 60), server.output()
        probe = Probe()
        scene = PlanningSceneInterface(timeout=15.0)
        assert scene.wait_for_server(30.0), server.output()
        assert wait_until(lambda: scene.call("get_state")["joint_state_received"], 30.0)
        assert wait_until(lambda: bool(probe.joints()), 30.0)
        yield {"controllers": controllers, "server": server, "probe": probe, "scene": scene}
    finally:
        if scene is not None:
            scene.close()
        if probe is not None:
            probe.close()
        server.stop()
        controllers.stop()


def run_workflow(module: str, *ros_args: str) -> tuple[int, str]:
    """Run a workflow node to its end: (exit code, output)."""
    proc = NodeProcess(NODES + module, ["--ros-args", *ros_args] if ros_args else [])
    try:
        code = proc.proc.wait(RUN_TIMEOUT)
    finally:
        proc.stop()
    return code, proc.log_path.read_text(errors="replace")


def _flange(model: RobotModel, joints: dict[str, float], frame: str = "link6_flange") -> np.ndarray:
    state = RobotState(model)
    state.set_joint_positions({n: joints[n] for n in ARM})
    return state.frame_pose(frame)


def _object(scene: PlanningSceneMsg, object_id: str) -> CollisionObject | None:
    return next((o for o in scene.world.collision_objects if o.id == object_id), None)


def test_exercise_1_1_leaves_the_sausage_detached_in_the_bun(system):
    probe = system["probe"]
    code, output = run_workflow("move_group_exercise_1_1")
    assert code == 0, output
    for step in ("planned the pick motion", "executed the pick motion", "attached 'sausage' to 'link6_flange'",
                 "planned the place motion", "executed the place motion", "detached 'sausage'",
                 "dropped 'sausage' into the bun"):
        assert step in output, output
    expected = HotDogScenario().place_position()

    def placed() -> bool:
        scene = probe.latest_scene()
        sausage = _object(scene, "sausage") if scene is not None else None
        return sausage is not None and np.linalg.norm(np.asarray(sausage.pose.position) - expected) < 0.01

    assert wait_until(placed, 10.0), probe.latest_scene().world.collision_objects
    scene = probe.latest_scene()
    assert [a.object.id for a in scene.robot_state.attached_collision_objects] == []  # detached
    sausage = _object(scene, "sausage")
    # still lying along the world y axis (the tool kept its heading from pick to place)
    axis = sausage.pose.to_matrix()[:3, 2]
    assert abs(axis[1]) == pytest.approx(1.0, abs=0.01)
    assert _object(scene, "bun") is not None


def test_exercise_1_2_reports_the_fraction_and_executes_the_zigzag(system, model):
    probe = system["probe"]
    with probe.lock:
        shown = len(probe.display)
    code, output = run_workflow("move_group_exercise_1_2")
    assert code == 0, output
    match = re.search(r"Cartesian path: fraction ([0-9.]+) of (\d+) waypoints .* \((\d+) points", output)
    assert match, output
    assert float(match.group(1)) == pytest.approx(1.0)
    assert int(match.group(2)) == 7
    # the last planned path shown is the Cartesian one; the robot ends at its last point
    assert wait_until(lambda: len(probe.display) >= shown + 2, 10.0)
    path = probe.display[-1]
    assert len(path.points) == int(match.group(3))
    end = dict(zip(path.joint_names, path.points[-1].positions))
    assert wait_until(lambda: all(abs(probe.joints()[n] - end[n]) < 0.01 for n in ARM), 10.0), (probe.joints(), end)
    # the end of the zig-zag is its last waypoint, at the start height over the hot dog
    sc = HotDogScenario()
    last = sc.mustard_waypoints()[-1]
    assert _flange(model, probe.joints())[:3, 3] == pytest.approx(last.position, abs=2e-3)
    # the bottle is held and the mustard is on the hot dog
    assert wait_until(lambda: _object(probe.latest_scene(), "mustard") is not None, 10.0)
    scene = probe.latest_scene()
    assert [a.object.id for a in scene.robot_state.attached_collision_objects] == ["mustard_bottle"]


def test_workflow_failures_exit_1_with_the_reason(system):
    # a pick pose outside the myCobot's reach: planning fails, the step is named
    code, output = run_workflow("move_group_exercise_1_1", "-p", "pick_position:=[0.6, 0.0, 0.01]",
                                "-p", "planning_attempts:=2", "-p", "planning_time:=0.5")
    assert code == 1, output
    assert "planning the pick motion failed after 2 attempt(s)" in output and "Traceback" not in output, output
    # a refused parameter: one line, no traceback
    code, output = run_workflow("move_group_exercise_1_2", "-p", "eef_step:=5.0")
    assert code == 1, output
    assert "eef_step" in output and "Traceback" not in output, output


def test_interrupting_a_workflow_stops_the_robot(system):
    """Ctrl-C while the robot moves: the script stops the execution and exits 130."""
    proc = NodeProcess(NODES + "move_group_exercise_1_2", ["--ros-args", "-p", "reset_scene:=true"])
    try:
        assert proc.wait_for_output("executing the Cartesian zig-zag", RUN_TIMEOUT), proc.output()
        assert wait_until(lambda: system["scene"].call("get_state")["execution"]["executing"], 10.0)
        os.killpg(proc.proc.pid, signal.SIGINT)
        assert proc.proc.wait(30) == 130, proc.output()
        output = proc.output()
    finally:
        proc.stop()
    assert "interrupted" in output and "stopped the running execution" in output, output
    state = system["scene"].call("get_state")
    assert not state["execution"]["executing"]
    assert state["execution"]["last_result"]["error_code"]["val"] == MoveItErrorCode.PREEMPTED, state["execution"]


def _localizer_rpc(probe: Probe, params: dict[str, Any]) -> Any:
    client = JsonRpcClient(probe.node, "/part_localizer")
    return client.call("localize_part", params, timeout=10.0)


def test_scan_n_plan_moves_the_tool_frame_to_the_localized_part(system, model):
    probe, scene = system["probe"], system["scene"]
    scene.clear()  # the hot dog of the exercises is not part of the workcell
    # no vision node: a clear failure, not a hang
    code, output = run_workflow("scan_n_plan", "-p", "localize_timeout:=1.0")
    assert code == 1, output
    assert "is part_localizer running?" in output, output

    marker = NodeProcess(NODES + "fake_marker_publisher")
    localizer = NodeProcess(NODES + "part_localizer")
    try:
        assert marker.wait_for_output("fake_marker_publisher ready", 60), marker.output()
        assert localizer.wait_for_output("part_localizer ready", 60), localizer.output()
        expected = localize(pose_from_list(DEFAULT_MARKER_POSE, "marker"), pose_from_list(DEFAULT_CAMERA_POSE, "camera"))

        # LocalizePart as a request: the part in the base frame, or as the camera sees it
        assert wait_until(lambda: _try(lambda: _localizer_rpc(probe, {})), 20.0)
        answer = _localizer_rpc(probe, {"base_frame": "world"})
        assert answer["frame_id"] == "world"
        assert answer["pose"]["position"] == pytest.approx(expected.position, abs=1e-9)
        in_camera = _localizer_rpc(probe, {"base_frame": "camera_frame"})
        assert in_camera["pose"]["position"] == pytest.approx(DEFAULT_MARKER_POSE[:3], abs=1e-9)
        with pytest.raises(RpcError, match="unknown base frame 'tool0'"):
            _localizer_rpc(probe, {"base_frame": "tool0"})

        code, output = run_workflow("scan_n_plan")
        assert code == 0, output
        assert "part localized at" in output and "executed the motion" in output, output
        target = expected.to_matrix()
        assert wait_until(lambda: np.linalg.norm(_flange(model, probe.joints())[:3, 3] - target[:3, 3]) < 0.005,
                          10.0), (_flange(model, probe.joints()), target)
        reached = _flange(model, probe.joints())
        angle = math.acos(np.clip((np.trace(reached[:3, :3].T @ target[:3, :3]) - 1) / 2, -1, 1))
        assert angle < 0.01
        # the Trigger form answers the same pose as JSON
        client = probe.node.create_client(Trigger, "/part_localizer/localize_part")
        assert client.wait_for_service(timeout_sec=10.0)
        future = client.call_async(Trigger.Request())
        assert wait_until(future.done, 10.0)
        assert future.result().success, future.result().message
        assert json.loads(future.result().message)["pose"]["position"] == pytest.approx(expected.position, abs=1e-9)
    finally:
        localizer.stop()
        marker.stop()


def _try(fn) -> bool:
    try:
        fn()
        return True
    except RpcError:
        return False
