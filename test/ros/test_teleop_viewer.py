"""The viewer's Teleoperate panel in headless Chromium, against real processes (mock_controllers,
planning_server, servo_node, task_viewer): holding a joint jog button moves that joint only,
holding a Cartesian jog button moves the flange along the base frame's axis (and along the tool's
axis in the tool frame), a joint slider dragged and let go moves that joint there smoothly, a
waypoint saved from the page is listed and the arm moves back to it, renamed and erased from the
page (bad names refused in the page), the gripper
closes and opens, a pose target is planned, previewed and executed on approval, Stop clicked in
the page stops a running move; a screenshot of the panel.

Every motion is judged on /joint_states (what the controllers did). A button is held until the
arm has moved (judged there too), never for a fixed time; each wait has a generous deadline."""
from __future__ import annotations

import math
import re
import shutil
import time
from pathlib import Path

import numpy as np
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

import headless_chromium
from interfaces_py.json_rpc import JsonRpcClient
from mycobot_planning.core import RobotModel, RobotState
from mycobot_planning.paths import config_file
from mycobot_planning.visualization.pose_target import format_pose, parse_pose
from ros_testing import NodeProcess, ProbeNode, robot_processes, wait_until

pytestmark = pytest.mark.skipif(not headless_chromium.available(), reason="needs Debian's chromium (setup.sh installs it as root)")

ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6",
       "link6_to_link6_flange"]
GRIPPER = "gripper_controller"
START = [0.0, 0.3, -1.6, 0.0, 0.3, 0.0]  # room along +y before the elbow singularity (test_servo_node)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
SHOTS = Path("/tmp/mycobot_test_logs")


class Probe(ProbeNode):
    def __init__(self) -> None:
        super().__init__("teleop_test_probe")
        self.latest: dict[str, float] = {}
        self.max_step = 0.0
        self.history: list[tuple[float, dict[str, float]]] = []
        self.node.create_subscription(JointState, "/joint_states", self._record, 100)
        self.url = self.collect(String, "/task_viewer/url", LATCHED)
        self.command = self.node.create_publisher(JointTrajectory, "/arm_controller/joint_trajectory", 10)
        self.rpc = JsonRpcClient(self.node, "/task_viewer")
        self.spin_in_background()

    def _record(self, msg) -> None:
        with self.lock:
            before = [self.latest.get(j) for j in ARM]
            self.latest.update(zip(msg.name, msg.position))
            if None not in before:  # the largest change between two joint states: a jump shows here
                self.max_step = max(self.max_step, max(abs(self.latest[j] - b) for j, b in zip(ARM, before)))
            self.history.append((time.monotonic(), dict(self.latest)))
            del self.history[:-400]

    def arm(self) -> np.ndarray:
        with self.lock:
            return np.array([self.latest[j] for j in ARM])

    def joint(self, name: str) -> float:
        with self.lock:
            return self.latest[name]

    def settle(self, timeout: float = 60.0) -> np.ndarray:
        """Wait until the arm has not moved for 0.3 s; its positions."""
        def still() -> bool:
            with self.lock:
                recent = [np.array([q[j] for j in ARM]) for t, q in self.history if t > time.monotonic() - 0.3]
            return len(recent) > 5 and np.max(np.ptp(np.array(recent), axis=0)) < 1e-6
        assert wait_until(still, timeout), "the arm did not come to rest"
        return self.arm()

    def teleop(self) -> dict:
        return self.rpc.call("get_state", timeout=15.0)["teleop"]


def tip(model: RobotModel, arm) -> np.ndarray:
    state = RobotState(model)
    state.set_joint_positions(dict(zip(ARM, arm)))
    return state.frame_pose("link6_flange")[:3, 3]


def angle_deg(a, b) -> float:
    return math.degrees(math.acos(np.clip(np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)), -1, 1)))


@pytest.fixture(scope="module")
def system(tmp_path_factory):
    waypoints = tmp_path_factory.mktemp("teleop") / "waypoints.yaml"
    shutil.copy(config_file("waypoints/mycobot_waypoints.yaml"), waypoints)  # saves go to a copy
    with robot_processes(f"waypoints_file:={waypoints}"):
        servo = NodeProcess("mycobot_planning.nodes.servo_node",
                            ["--ros-args", "--params-file", str(config_file("servo_node.yaml"))])
        viewer = NodeProcess("mycobot_planning.nodes.task_viewer", ["--ros-args", "-p", "port:=0"])
        probe = Probe()
        try:
            assert servo.wait_for_output("servo_node ready", 90), servo.output()[-3000:]
            assert viewer.wait_for_output("task_viewer: open http://127.0.0.1:", 90), viewer.output()[-3000:]
            assert probe.rpc.wait_for_server(60.0), viewer.output()[-3000:]
            assert wait_until(lambda: probe.url and set(ARM) <= set(probe.latest), 60.0)
            # the arm away from the straight-up 'home' (a singularity for Cartesian jogs)
            msg = JointTrajectory(joint_names=ARM, points=[JointTrajectoryPoint(positions=START, velocities=[0.0] * 6)])
            msg.points[0].time_from_start.sec = 2
            probe.command.publish(msg)
            assert wait_until(lambda: np.max(np.abs(probe.arm() - START)) < 1e-4, 60.0), probe.arm()
            with headless_chromium.Chromium(width=1280, height=1700) as page:
                page.navigate(probe.url[-1].data)
                assert page.wait_for("document.body && document.body.innerText.includes('Teleoperate')", 90), \
                    page.text()[:2000]
                yield {"probe": probe, "page": page, "servo": servo, "viewer": viewer}
                assert page.exceptions == []
        finally:
            probe.close()
            viewer.stop()
            servo.stop()
            assert "Traceback" not in viewer.output(), viewer.output()[-3000:]
            assert "Traceback" not in servo.output(), servo.output()[-3000:]


def hold(system, button: str, until, what: str, timeout: float = 60.0) -> None:
    """Hold ``button`` down until ``until()`` (the arm has moved), then let go."""
    page = system["page"]
    x, y = page.press_button(button)
    try:
        assert wait_until(until, timeout), \
            f"{what}: panel {system['probe'].teleop()}; servo_node: {system['servo'].output()[-1500:]}"
    finally:
        page.release_at(x, y)


def test_joint_jog_moves_only_that_joint(system):
    probe = system["probe"]
    start = probe.settle()
    hold(system, "J1+", lambda: probe.arm()[0] > start[0] + 0.05, "holding J1+ did not move the first joint")
    moved = probe.settle() - start
    assert moved[0] > 0.05
    assert np.all(np.abs(moved[1:]) < 1e-9)
    assert probe.teleop()["jog_repeats"] > 0


def test_cartesian_jog_moves_the_flange_along_the_axis(system):
    probe = system["probe"]
    model = RobotModel.mycobot()
    start = probe.settle()
    assert probe.teleop()["frame"] == "base"
    hold(system, "+y", lambda: np.linalg.norm(tip(model, probe.arm()) - tip(model, start)) > 0.01,
         "holding +y did not move the flange")
    moved = tip(model, probe.settle()) - tip(model, start)
    assert np.linalg.norm(moved) > 0.01
    assert angle_deg(moved, [0.0, 1.0, 0.0]) <= 2.0


def test_a_saved_waypoint_is_listed_and_the_arm_moves_back_to_it(system):
    probe, page = system["probe"], system["page"]
    saved = probe.settle()
    page.type_into("Waypoint name", "teleop test")
    page.click_button("Save current state")
    assert wait_until(lambda: "teleop test" in probe.teleop()["waypoints"], 60.0), probe.teleop()
    assert "saved waypoint 'teleop test'" in probe.teleop()["message"]
    hold(system, "J2+", lambda: probe.arm()[1] > saved[1] + 0.1, "holding J2+ did not move the second joint")
    away = probe.settle()
    assert np.max(np.abs(away - saved)) > 0.1
    page.select_option("Saved waypoint", "teleop test")
    page.click_button("Move to waypoint")
    assert wait_until(lambda: "at waypoint 'teleop test'" in probe.teleop()["message"], 120.0), probe.teleop()
    assert np.max(np.abs(probe.settle() - saved)) < 1e-3


def test_gripper_closes_and_opens(system):
    probe, page = system["probe"], system["page"]
    page.click_button("Close gripper")
    assert wait_until(lambda: probe.joint(GRIPPER) < -0.45, 60.0), probe.joint(GRIPPER)
    page.click_button("Open gripper")
    assert wait_until(lambda: probe.joint(GRIPPER) > -0.05, 60.0), probe.joint(GRIPPER)


def test_joint_sliders_follow_the_arm_and_move_a_joint(system):
    probe, page = system["probe"], system["page"]
    model = RobotModel.mycobot()
    start = probe.settle()
    limits = dict(zip(model.variable_names, zip(model.lower_limits, model.upper_limits)))

    def shown() -> bool:  # every slider shows where its joint is, within the joint's limits
        for joint, position in zip(ARM, probe.arm()):
            info = page.slider(joint)
            if not info or abs(info["value"] - position) > 0.006:
                return False
            assert limits[joint][0] <= info["min"] < info["max"] <= limits[joint][1], (joint, info)
        return True
    assert wait_until(shown, 30.0), [page.slider(j) for j in ARM]
    with probe.lock:
        probe.max_step = 0.0
    page.drag_slider(ARM[0], start[0] + 0.3)
    # a pause in the drag may have moved the arm part of the way first: the moves end at the last value
    assert wait_until(lambda: abs(probe.teleop()["slider_goal"].get(ARM[0], 0.0) - (start[0] + 0.3)) < 0.05
                      and not probe.teleop()["slider_targets"], 60.0), probe.teleop()
    assert "at the sliders' positions" in probe.teleop()["message"], probe.teleop()
    goal = probe.teleop()["slider_goal"]
    moved = probe.settle() - start
    assert abs(moved[0] - (goal[ARM[0]] - start[0])) < 1e-3, (moved, goal)
    assert np.all(np.abs(moved[1:]) < 1e-3), moved
    assert probe.max_step < 0.1, f"the joint jumped {probe.max_step} rad between two joint states"
    assert wait_until(lambda: abs(page.slider(ARM[0])["value"] - probe.arm()[0]) < 0.006, 10.0)


def test_waypoints_are_renamed_and_erased_from_the_page_and_bad_names_refused(system):
    probe, page = system["probe"], system["page"]
    page.type_into("Waypoint name", "to rename")
    page.click_button("Save current state")
    assert wait_until(lambda: probe.teleop()["selected_waypoint"] == "to rename", 60.0), probe.teleop()
    page.type_into("Waypoint name", "Home")  # a name taken
    page.click_button("Rename waypoint")
    assert wait_until(lambda: "not renamed" in probe.teleop()["message"], 30.0), probe.teleop()
    assert "exists already" in probe.teleop()["message"]
    assert page.wait_for("document.body.innerText.includes(\"a waypoint named 'Home' exists already\")", 10.0)
    page.type_into("Waypoint name", "bad\x07name")  # a control character
    page.click_button("Rename waypoint")
    assert wait_until(lambda: "control characters" in probe.teleop()["message"], 30.0), probe.teleop()
    assert page.wait_for("document.body.innerText.includes('contains control characters')", 10.0), page.text()[-500:]
    assert "to rename" in probe.teleop()["waypoints"]
    page.type_into("Waypoint name", "renamed")
    page.click_button("Rename waypoint")
    # listed, then selected (the 2 s poll may list it before the rename's own refresh selects it)
    assert wait_until(lambda: probe.teleop()["selected_waypoint"] == "renamed", 30.0), probe.teleop()
    assert "to rename" not in probe.teleop()["waypoints"], probe.teleop()
    page.click_button("Erase waypoint")
    assert wait_until(lambda: "again" in probe.teleop()["message"], 10.0), probe.teleop()
    assert "renamed" in probe.teleop()["waypoints"]
    page.click_button("Erase waypoint")
    assert wait_until(lambda: "renamed" not in probe.teleop()["waypoints"], 30.0), probe.teleop()
    assert "erased waypoint 'renamed'" in probe.teleop()["message"]


def test_tool_frame_jog_moves_the_flange_along_the_tool_axis(system):
    probe, page = system["probe"], system["page"]
    model = RobotModel.mycobot()
    start = probe.settle()
    state = RobotState(model)
    state.set_joint_positions(dict(zip(ARM, start)))
    tool_z = state.frame_pose(model.group("arm").tip_link)[:3, 2]
    page.select_option("Jog frame", "tool")
    try:
        assert wait_until(lambda: probe.teleop()["frame"] == "tool", 10.0)
        hold(system, "+z", lambda: np.linalg.norm(tip(model, probe.arm()) - tip(model, start)) > 0.01,
             "holding +z in the tool frame did not move the flange")
        moved = tip(model, probe.settle()) - tip(model, start)
    finally:
        page.select_option("Jog frame", "base")
    assert np.linalg.norm(moved) > 0.01
    assert angle_deg(moved, tool_z) <= 5.0, (moved, tool_z)


def test_a_pose_target_is_planned_previewed_and_run_only_when_approved(system):
    """The Pose target panel: the target placed at the tool, typed 2 cm higher; "Plan to target"
    previews the plan (the orange robot on /planned_path) and moves nothing; "Execute previewed
    plan" runs it and the flange ends at the target."""
    probe, page = system["probe"], system["page"]
    model = RobotModel.mycobot()

    def panel() -> dict:
        return probe.rpc.call("get_state", timeout=15.0)["pose_target"]
    start = probe.settle()
    page.click_button("Target at the tool")
    assert wait_until(lambda: panel()["target"] is not None, 30.0), (panel(), system["viewer"].output()[-3000:])
    state = RobotState(model)
    state.set_joint_positions(dict(zip(ARM, start)))
    goal = state.frame_pose("link6_flange")
    goal[2, 3] += 0.02
    assert np.allclose(parse_pose(panel()["target"])[:3, 3], goal[:3, 3] - [0.0, 0.0, 0.02], atol=2e-4)
    page.type_into("Target pose", format_pose(goal))
    assert wait_until(lambda: np.allclose(parse_pose(panel()["target"]), goal, atol=1e-3), 30.0), panel()
    page.click_button("Plan to target")
    assert wait_until(lambda: panel()["previewed"], 60.0), panel()
    view = probe.rpc.call("get_state", timeout=15.0)
    assert wait_until(lambda: (probe.rpc.call("get_state", timeout=15.0)["preview"] or {}).get("source")
                      == "planned_path", 30.0), view["preview"]
    assert np.max(np.abs(probe.arm() - start)) < 1e-6, "the arm moved before the plan was approved"
    page.click_button("Execute previewed plan")
    assert wait_until(lambda: "at the target" in panel()["message"], 120.0), panel()
    state.set_joint_positions(dict(zip(ARM, probe.settle())))
    reached = state.frame_pose("link6_flange")
    assert np.linalg.norm(reached[:3, 3] - goal[:3, 3]) < 1e-3
    assert np.linalg.norm(reached[:3, :3] - goal[:3, :3]) < 1e-2


def test_stop_in_the_page_stops_a_running_move(system):
    """Stop arm, clicked in the page while a previewed plan runs (the base turned 150° at velocity
    scaling 0.04: over ten seconds of motion; a click in a software-rendered
    page on this loaded machine can take seconds), stops the arm along its path: the move ends PREEMPTED short of the target,
    with no jump between two joint states."""
    probe, page = system["probe"], system["page"]
    model = RobotModel.mycobot()

    def view() -> dict:
        return probe.rpc.call("get_state", timeout=15.0)
    start = probe.settle()
    state = RobotState(model)
    state.set_joint_positions(dict(zip(ARM, start)))
    turn = np.eye(4)
    angle = math.radians(150.0) * (-1.0 if start[0] > 0 else 1.0)
    turn[:2, :2] = [[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]]
    goal = turn @ state.frame_pose("link6_flange")
    page.click_button("Target at the tool")
    assert wait_until(lambda: view()["pose_target"]["target"] is not None, 30.0)
    page.type_into("Target pose", format_pose(goal))
    assert wait_until(lambda: np.allclose(parse_pose(view()["pose_target"]["target"]), goal, atol=1e-3), 30.0)
    # slower than the panel's 0.1: a click takes seconds in a software-rendered page on a loaded machine
    page.drag_slider("Velocity scaling", 0.04)
    assert wait_until(lambda: view()["pose_target"]["scaling"] <= 0.05, 30.0), view()["pose_target"]
    page.click_button("Plan to target")
    assert wait_until(lambda: view()["pose_target"]["previewed"], 60.0), view()["pose_target"]
    found = re.search(r"a ([0-9.]+) s move", view()["pose_target"]["message"])
    assert found and float(found.group(1)) > 10.0, f"too short a move to stop from the page: {view()['pose_target']}"
    with probe.lock:
        probe.max_step = 0.0
    page.click_button("Execute previewed plan")
    assert wait_until(lambda: np.max(np.abs(probe.arm() - start)) > 0.02, 30.0), "the previewed plan did not start"
    page.click_button("Stop arm")
    assert wait_until(lambda: "PREEMPTED" in view()["pose_target"]["message"], 30.0), view()["pose_target"]
    stopped = probe.settle()
    state.set_joint_positions(dict(zip(ARM, stopped)))
    assert np.linalg.norm(state.frame_pose("link6_flange")[:3, 3] - goal[:3, 3]) > 0.02, "the move was not stopped"
    assert probe.max_step < 0.1, f"the joints jumped {probe.max_step} rad between two joint states"


def test_screenshot_of_the_panel(system):
    page = system["page"]
    page.evaluate("[...document.querySelectorAll('label')].find(l => l.innerText.trim() === 'Jog speed')"
                  ".scrollIntoView({block: 'start'})")
    SHOTS.mkdir(parents=True, exist_ok=True)
    shot = page.screenshot(SHOTS / "teleoperate_panel.png")
    assert shot.stat().st_size > 10_000
    text = page.text()
    for label in ("J1−", "J6+", "+x", "−yaw", "Stop arm", "Open gripper", "Save current state", "Move to waypoint",
                  "Rename waypoint", "Erase waypoint", ARM[0], "Target at the tool", "Plan to target",
                  "Execute previewed plan"):
        assert label in text, label
