"""Integration tests: the mock controller manager as a real process, driven over ROS.

One node process serves the whole module (start-up costs seconds); every test moves the robot
from wherever the previous one left it (first points in the future, so the controller
interpolates from its current state), identifies its goals by goal id (header.frame_id), and
checks that the process is still alive afterwards.
"""
from __future__ import annotations

import json
import math
import threading
import time
from typing import Any, Sequence

import numpy as np
import pytest

from ros_testing import NodeProcess, use_session_domain, wait_until

rclpy = pytest.importorskip("rclpy")

from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.parameter_client import AsyncParameterClient  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import String  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint  # noqa: E402

from interfaces_py.background_spin import BackgroundSpin  # noqa: E402
from interfaces_py.ros_conversions import seconds_to_duration  # noqa: E402
from mycobot_planning.core import RobotModel  # noqa: E402

MODULE = "mycobot_planning.nodes.mock_controllers"
ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6",
       "link6_to_link6_flange"]
MIMIC = ["gripper_base_to_gripper_left2", "gripper_left3_to_gripper_left1", "gripper_base_to_gripper_right3",
         "gripper_base_to_gripper_right2", "gripper_right3_to_gripper_right1"]
ALL_JOINTS = ARM + ["gripper_controller"] + MIMIC
INITIAL_LINK3 = 0.2  # set on the command line: initial_positions.link3_to_link4
STARTUP = 30.0  # generous: imports and model loading on a busy machine
WAIT = 15.0


class Probe:
    """The test's own node: watches /joint_states and controller states, sends commands."""

    def __init__(self) -> None:
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = Node("mock_controllers_probe", context=self.context)
        self.lock = threading.Lock()
        self.joint_states: list[tuple[float, JointState]] = []  # (receipt monotonic time, msg)
        self.states: dict[str, list[dict[str, Any]]] = {"arm_controller": [], "grip_action_controller": []}
        self.node.create_subscription(JointState, "/joint_states", self._on_joint_state, 200)
        self.publishers = {}
        self.stop_clients = {}
        for name in self.states:
            self.node.create_subscription(String, f"/{name}/state", lambda m, n=name: self._on_state(n, m), 500)
            self.publishers[name] = self.node.create_publisher(JointTrajectory, f"/{name}/joint_trajectory", 10)
            self.stop_clients[name] = self.node.create_client(Trigger, f"/{name}/stop")
        self.params = AsyncParameterClient(self.node, "controller_manager")
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.spinner = BackgroundSpin(self.executor, name="controllers probe executor")

    def close(self) -> None:
        self.spinner.stop()
        self.node.destroy_node()
        self.context.try_shutdown()

    # ---- subscriptions
    def _on_joint_state(self, msg: JointState) -> None:
        with self.lock:
            self.joint_states.append((time.monotonic(), msg))
            if len(self.joint_states) > 5000:
                del self.joint_states[:1000]

    def _on_state(self, name: str, msg: String) -> None:
        with self.lock:
            self.states[name].append(json.loads(msg.data))
            if len(self.states[name]) > 20000:
                del self.states[name][:5000]

    def js_count(self) -> int:
        with self.lock:
            return len(self.joint_states)

    def latest(self) -> dict[str, float]:
        with self.lock:
            msg = self.joint_states[-1][1]
        return dict(zip(msg.name, msg.position))

    def arm(self) -> np.ndarray:
        latest = self.latest()
        return np.array([latest[j] for j in ARM])

    def wait_messages(self, count: int) -> None:
        """Wait until `count` more /joint_states messages arrived (time passes, robot observed)."""
        target = self.js_count() + count
        assert wait_until(lambda: self.js_count() >= target, WAIT), "/joint_states stopped"

    def goal_states(self, controller: str, goal_id: str) -> list[dict[str, Any]]:
        with self.lock:
            return [s for s in self.states[controller] if s["goal_id"] == goal_id]

    def wait_status(self, controller: str, goal_id: str, statuses: Sequence[str], timeout: float = WAIT) -> dict:
        found: list[dict] = []

        def seen() -> bool:
            found[:] = [s for s in self.goal_states(controller, goal_id) if s["status"] in statuses]
            return bool(found)

        assert wait_until(seen, timeout), (
            f"{controller} goal {goal_id} never reached {statuses}; saw "
            f"{[s['status'] for s in self.goal_states(controller, goal_id)][-5:]}")
        return found[0]

    # ---- commands
    def send(self, controller: str, goal_id: str, joint_names: Sequence[str],
             points: Sequence[tuple[float, Sequence[float]]], velocities: bool = True) -> None:
        msg = JointTrajectory()
        msg.header.frame_id = goal_id
        msg.joint_names = list(joint_names)
        for t, positions in points:
            point = JointTrajectoryPoint(positions=[float(p) for p in positions],
                                         time_from_start=seconds_to_duration(t))
            if velocities:
                point.velocities = [0.0] * len(positions)
            msg.points.append(point)
        publisher = self.publishers[controller]
        assert wait_until(lambda: publisher.get_subscription_count() > 0, WAIT)
        publisher.publish(msg)

    def send_raw(self, controller: str, msg: JointTrajectory) -> None:
        publisher = self.publishers[controller]
        assert wait_until(lambda: publisher.get_subscription_count() > 0, WAIT)
        publisher.publish(msg)

    def stop(self, controller: str) -> Trigger.Response:
        client = self.stop_clients[controller]
        assert client.wait_for_service(WAIT)
        future = client.call_async(Trigger.Request())
        assert wait_until(future.done, WAIT)
        return future.result()

    def set_param(self, name: str, value: Any):
        assert self.params.wait_for_services(WAIT)
        future = self.params.set_parameters([Parameter(name, value=value)])
        assert wait_until(future.done, WAIT)
        return future.result().results[0]


@pytest.fixture(scope="module")
def setup():
    use_session_domain()
    proc = NodeProcess(MODULE, ["--ros-args", "-p", f"initial_positions.link3_to_link4:={INITIAL_LINK3}"])
    probe = None
    try:
        assert proc.wait_for_output("controller_manager ready", STARTUP), proc.output()
        probe = Probe()
        assert wait_until(lambda: probe.js_count() > 0, WAIT), "no /joint_states"
        first = probe.latest()
        yield proc, probe, first
        assert proc.alive(), proc.output()
    finally:
        if probe is not None:
            probe.close()
        proc.stop()


@pytest.fixture()
def probe(setup) -> Probe:
    proc, probe, _ = setup
    yield probe
    assert proc.alive(), f"the node died:\n{proc.output()[-3000:]}"


@pytest.fixture(scope="module")
def model() -> RobotModel:
    return RobotModel.mycobot()


def arm_target(probe: Probe, offset: float) -> list[float]:
    """A reachable target `offset` rad away from where the arm is, inside the limits."""
    here = probe.arm()
    return [float(np.clip(q + (offset if q < 1.0 else -offset), -2.5, 2.5)) for q in here]


def start_slow_motion(probe: Probe, goal_id: str) -> list[float]:
    """Send the arm on a 4 s trajectory (goal ``goal_id``) to a target 1 rad away and wait until
    arm_controller executes it; the target."""
    far = arm_target(probe, 1.0)
    probe.send("arm_controller", goal_id, ARM, [(4.0, far)])
    probe.wait_status("arm_controller", goal_id, ["executing"])
    return far


# ---------------------------------------------------------------- /joint_states


def test_joint_states_start_at_the_initial_positions(setup):
    _, _, first = setup
    assert sorted(first) == sorted(ALL_JOINTS)
    assert first["link3_to_link4"] == pytest.approx(INITIAL_LINK3)
    assert all(first[j] == 0.0 for j in ALL_JOINTS if j != "link3_to_link4")


def test_joint_states_carry_all_twelve_joints_at_100_hz(probe):
    probe.wait_messages(5)
    with probe.lock:
        start = len(probe.joint_states)
    t0 = time.monotonic()
    time.sleep(1.0)
    with probe.lock:
        window = probe.joint_states[start:]
    elapsed = time.monotonic() - t0
    rate = len(window) / elapsed
    print(f"/joint_states rate: {rate:.1f} Hz over {elapsed:.2f} s")
    assert rate >= 90.0
    for _, msg in window:
        assert list(msg.name) == ALL_JOINTS
        assert len(msg.position) == 12 and len(msg.velocity) == 12
    stamps = [m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for _, m in window]
    assert all(b > a for a, b in zip(stamps, stamps[1:]))


# ---------------------------------------------------------------- following


def test_arm_follows_a_trajectory_and_ends_at_its_last_point(probe):
    start = probe.arm()
    via = arm_target(probe, 0.3)
    goal = arm_target(probe, 0.6)
    probe.send("arm_controller", "follow-1", ARM, [(0.5, via), (1.0, goal)])
    executing = probe.wait_status("arm_controller", "follow-1", ["executing"])
    assert executing["active"] and executing["joint_names"] == ARM
    done = probe.wait_status("arm_controller", "follow-1", ["succeeded"])
    assert not done["active"]
    assert done["actual"]["positions"] == pytest.approx(goal, abs=1e-9)
    assert wait_until(lambda: np.max(np.abs(probe.arm() - goal)) <= 0.01, WAIT)
    # Along the way the joints passed near the via point and never jumped.
    with probe.lock:
        trace = [np.array([dict(zip(m.name, m.position))[j] for j in ARM]) for _, m in probe.joint_states[-400:]]
    assert min(np.max(np.abs(q - via)) for q in trace) < 0.05
    steps = [np.max(np.abs(b - a)) for a, b in zip(trace, trace[1:])]
    assert max(steps) < 0.1
    assert np.max(np.abs(start - goal)) > 0.5


def test_joint_order_in_the_command_is_free(probe):
    goal = arm_target(probe, 0.2)
    order = list(reversed(range(6)))
    probe.send("arm_controller", "reordered", [ARM[i] for i in order], [(0.4, [goal[i] for i in order])])
    probe.wait_status("arm_controller", "reordered", ["succeeded"])
    assert wait_until(lambda: np.max(np.abs(probe.arm() - goal)) <= 0.01, WAIT)


def test_gripper_moves_and_mimic_joints_follow(probe, model):
    probe.send("grip_action_controller", "grip-close", ["gripper_controller"], [(0.5, [-0.34])])
    done = probe.wait_status("grip_action_controller", "grip-close", ["succeeded"])
    assert done["actual"]["positions"] == [-0.34]
    assert wait_until(lambda: probe.latest()["gripper_controller"] == -0.34, WAIT)  # held exactly
    js = probe.latest()
    variables = np.zeros(len(model.variable_names))
    variables[model.variable_index("gripper_controller")] = js["gripper_controller"]
    expected = model.mimic_values(variables)
    for joint in MIMIC:
        assert js[joint] == pytest.approx(expected[joint], abs=1e-9)
    assert js["gripper_left3_to_gripper_left1"] == pytest.approx(0.34)
    probe.send("grip_action_controller", "grip-open", ["gripper_controller"], [(0.5, [0.0])])
    probe.wait_status("grip_action_controller", "grip-open", ["succeeded"])


def test_new_trajectory_preempts_the_running_one_without_a_jump(probe):
    start_slow_motion(probe, "pre-old")
    start = probe.arm()
    assert wait_until(lambda: np.max(np.abs(probe.arm() - start)) > 0.05, WAIT)
    back = [float(v) for v in start]
    probe.send("arm_controller", "pre-new", ARM, [(1.0, back)])
    preempted = probe.wait_status("arm_controller", "pre-old", ["preempted"])
    assert "pre-new" in preempted["message"] and not preempted["active"]
    probe.wait_status("arm_controller", "pre-new", ["succeeded"])
    assert "succeeded" not in [s["status"] for s in probe.goal_states("arm_controller", "pre-old")]
    assert wait_until(lambda: np.max(np.abs(probe.arm() - back)) <= 0.01, WAIT)
    with probe.lock:
        trace = [np.array([dict(zip(m.name, m.position))[j] for j in ARM]) for _, m in probe.joint_states[-500:]]
    assert max(np.max(np.abs(b - a)) for a, b in zip(trace, trace[1:])) < 0.1


def test_stop_service_holds_the_current_position(probe):
    far = start_slow_motion(probe, "to-stop")
    start = probe.arm()
    assert wait_until(lambda: np.max(np.abs(probe.arm() - start)) > 0.05, WAIT)
    response = probe.stop("arm_controller")
    assert response.success and "to-stop" in response.message
    stopped = probe.wait_status("arm_controller", "to-stop", ["stopped"])
    assert not stopped["active"]
    probe.wait_messages(5)
    held = probe.arm()
    probe.wait_messages(30)
    assert probe.arm().tolist() == held.tolist()
    assert np.max(np.abs(held - far)) > 0.1
    assert np.max(np.abs(held - np.array(stopped["actual"]["positions"]))) <= 0.01
    again = probe.stop("arm_controller")
    assert again.success and "not executing" in again.message


def test_empty_trajectory_stops_like_jtc(probe):
    start_slow_motion(probe, "to-empty")
    empty = JointTrajectory()
    empty.joint_names = ARM
    probe.send_raw("arm_controller", empty)
    probe.wait_status("arm_controller", "to-empty", ["stopped"])


# ---------------------------------------------------------------- malformed commands


def _malformed(case: str) -> tuple[JointTrajectory, str]:
    msg = JointTrajectory()
    msg.joint_names = list(ARM)

    def point(t, positions):
        return JointTrajectoryPoint(positions=positions, time_from_start=seconds_to_duration(t))

    if case == "unknown joint":
        msg.joint_names = ARM[:5] + ["elbow"]
        msg.points = [point(1.0, [0.0] * 6)]
        reason = "unknown joint ['elbow']"
    elif case == "decreasing time":
        msg.points = [point(1.0, [0.0] * 6), point(0.5, [0.1] * 6)]
        reason = "times must strictly increase"
    elif case == "NaN":
        msg.points = [point(1.0, [0.0, 0.0, math.nan, 0.0, 0.0, 0.0])]
        reason = "points[0].positions[2] (link3_to_link4) is nan"
    elif case == "outside limits":
        msg.points = [point(1.0, [0.0, 0.0, 0.0, 3.5, 0.0, 0.0])]
        reason = "puts link4_to_link5 at 3.5, outside its limits"
    elif case == "size mismatch":
        msg.points = [point(1.0, [0.0] * 5)]
        reason = "points[0].positions has 5 values, expected 6"
    else:
        raise AssertionError(case)
    msg.header.frame_id = f"bad-{case.replace(' ', '-')}"
    return msg, reason


@pytest.mark.parametrize("case", ["unknown joint", "decreasing time", "NaN", "outside limits", "size mismatch"])
def test_malformed_command_is_rejected_with_its_reason_and_nothing_moves(probe, case):
    msg, reason = _malformed(case)
    probe.wait_messages(3)
    before = probe.arm()
    probe.send_raw("arm_controller", msg)
    rejected = probe.wait_status("arm_controller", msg.header.frame_id, ["aborted", "executing", "succeeded"])
    assert rejected["status"] == "aborted"
    assert rejected["message"].startswith("rejected: ") and reason in rejected["message"]
    probe.wait_messages(30)
    assert probe.arm().tolist() == before.tolist()
    assert [s["status"] for s in probe.goal_states("arm_controller", msg.header.frame_id)] == ["aborted"]


# ---------------------------------------------------------------- fault injection and parameters


def test_fail_after_ends_the_goal_as_failed_and_holds(probe):
    result = probe.set_param("arm_controller.fail_after", 0.3)
    assert result.successful, result.reason
    try:
        far = arm_target(probe, 1.0)
        probe.send("arm_controller", "to-fail", ARM, [(2.0, far)])
        failed = probe.wait_status("arm_controller", "to-fail", ["failed", "succeeded"])
        assert failed["status"] == "failed" and not failed["active"]
        assert "fail_after" in failed["message"]
        probe.wait_messages(5)
        held = probe.arm()
        assert np.max(np.abs(held - far)) > 0.2
        probe.wait_messages(30)
        assert probe.arm().tolist() == held.tolist()
    finally:
        assert probe.set_param("arm_controller.fail_after", -1.0).successful
    probe.send("arm_controller", "after-fail", ARM, [(0.5, far)])
    probe.wait_status("arm_controller", "after-fail", ["succeeded"])


def test_stall_after_stops_the_joints_while_the_goal_stays_active(probe):
    assert probe.set_param("arm_controller.stall_after", 0.2).successful
    try:
        far = arm_target(probe, 1.0)
        probe.send("arm_controller", "to-stall", ARM, [(1.0, far)])
        stalled = probe.wait_status("arm_controller", "to-stall", ["stalled", "succeeded", "failed"])
        assert stalled["status"] == "stalled" and stalled["active"] and "stall_after" in stalled["message"]
        statuses = [s["status"] for s in probe.goal_states("arm_controller", "to-stall")]
        assert statuses[0] == "executing" and "succeeded" not in statuses
        # The command reached the goal, the joints did not.
        assert stalled["desired"]["positions"] == pytest.approx(far, abs=1e-9)
        assert max(abs(e) for e in stalled["error"]["positions"]) > 0.2
        assert np.max(np.abs(probe.arm() - far)) > 0.2
        probe.stop("arm_controller")
        probe.wait_status("arm_controller", "to-stall", ["stopped"])
    finally:
        assert probe.set_param("arm_controller.stall_after", -1).successful  # integers are fine too


def test_parameters_refuse_bad_values_with_a_reason(probe):
    result = probe.set_param("initial_positions.link1_to_link2", 5.0)
    assert not result.successful and "outside" in result.reason
    result = probe.set_param("grip_action_controller.fail_after", "soon")
    assert not result.successful and "finite number of seconds" in result.reason
    result = probe.set_param("publish_rate", 0.5)
    assert not result.successful and "out of range" in result.reason
    assert probe.set_param("publish_rate", 150.0).successful  # off the control loop: own timer
    probe.wait_messages(30)
    assert probe.set_param("publish_rate", 100).successful  # back in the control loop
    probe.wait_messages(10)


def test_setting_an_initial_position_while_idle_moves_the_joint(probe):
    assert probe.set_param("initial_positions.gripper_controller", -0.2).successful
    assert wait_until(lambda: abs(probe.latest()["gripper_controller"] + 0.2) < 1e-12, WAIT)
    assert probe.latest()["gripper_base_to_gripper_right3"] == pytest.approx(0.2)
    # While executing, it is refused instead of making the joint jump.
    probe.send("grip_action_controller", "slow-grip", ["gripper_controller"], [(5.0, [0.1])])
    probe.wait_status("grip_action_controller", "slow-grip", ["executing"])
    result = probe.set_param("initial_positions.gripper_controller", 0.0)
    assert not result.successful and "executing goal slow-grip" in result.reason
    probe.stop("grip_action_controller")


def test_bad_configuration_exits_with_a_one_line_error():
    use_session_domain()
    proc = NodeProcess(MODULE, ["--ros-args", "-p", "controllers_file:=/nonexistent/controllers.yaml"],
                       name="mock_controllers_bad")
    try:
        assert wait_until(lambda: not proc.alive(), STARTUP)
        output = proc.output()
    finally:
        code = proc.stop()
    assert code == 1
    assert "[ERROR] cannot read controllers file '/nonexistent/controllers.yaml'" in output
    assert "Traceback" not in output
