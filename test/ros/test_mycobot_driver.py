"""mycobot_driver on the emulated arm (pseudo-terminal, unmodified pymycobot): the mock's controller
interfaces on real I/O, and the faults a real arm has (lost port, stalled servo, out-of-limits
trajectory; SIGTERM mid-motion: test_mycobot_driver_sigterm.py, with a driver of its own)."""
from __future__ import annotations

import time

import numpy as np
import pytest

from ros_testing import NodeProcess, ProbeNode, use_session_domain, wait_until

rclpy = pytest.importorskip("rclpy", reason="rclpy is installed by scripts/setup.sh")
pytest.importorskip("pymycobot", reason="pymycobot 4.0.7 is installed by scripts/setup.sh")

from control_msgs.action import FollowJointTrajectory, GripperCommand  # noqa: E402
from trajectory_msgs.msg import JointTrajectoryPoint  # noqa: E402

from interfaces_py.action_client import ActionClient  # noqa: E402
from interfaces_py.ros_conversions import seconds_to_duration  # noqa: E402
from mycobot_planning.core.robot_trajectory.robot_trajectory import TimedTrajectory  # noqa: E402
from mycobot_planning.core.trajectory_execution.path_ahead import stop_command, stopping_trajectory  # noqa: E402
from mycobot_planning.hardware.emulator import EmulatedArm  # noqa: E402

ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6",
       "link6_to_link6_flange"]
STARTUP = 60.0  # generous: imports, model loading and pymycobot's 1.5 s port opening on a busy machine
WAIT = 30.0


def start_driver(link) -> NodeProcess:
    driver = NodeProcess("mycobot_planning.nodes.mycobot_driver",
                         ["--ros-args", "-p", f"port:={link}", "-p", "reconnect_period:=0.3"])
    assert driver.wait_for_output("mycobot_driver ready", STARTUP), driver.output()
    assert driver.wait_for_output("connected to the arm", STARTUP), driver.output()
    return driver


class Probe(ProbeNode):
    def __init__(self) -> None:
        super().__init__("driver_probe")
        self.arm = ActionClient(self.node, FollowJointTrajectory, "/arm_controller/follow_joint_trajectory")
        self.gripper = ActionClient(self.node, GripperCommand, "/grip_action_controller/gripper_cmd")
        self.listen_to_joint_states()
        self.spin_in_background()

    def arm_positions(self) -> np.ndarray:
        joints = self.joints()
        return np.array([joints[j] for j in ARM])

    def send(self, client, goal):
        """(accepted, result future or None)."""
        assert client.wait_for_server(timeout_sec=WAIT)
        future = client.send_goal_async(goal)
        assert wait_until(future.done, WAIT)
        handle = future.result()
        return handle.accepted, (handle.get_result_async() if handle.accepted else None)

    def move(self, target, duration: float = 1.5, start=None):
        start = self.arm_positions() if start is None else np.asarray(start)
        goal = FollowJointTrajectory.Goal()
        goal.trajectory.joint_names = ARM
        for t in np.linspace(0.0, duration, 11):
            s = (1 - np.cos(np.pi * t / duration)) / 2
            point = JointTrajectoryPoint()
            point.positions = (start + (np.asarray(target) - start) * s).tolist()
            point.time_from_start = seconds_to_duration(float(t))
            goal.trajectory.points.append(point)
        return self.send(self.arm, goal)


def result_of(future, timeout: float = WAIT):
    assert wait_until(future.done, timeout)
    return future.result()


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    use_session_domain()
    link = tmp_path_factory.mktemp("driver") / "mycobot_port"
    emulator = EmulatedArm(link).start()
    driver = start_driver(link)
    probe = Probe()
    try:
        assert wait_until(lambda: len(probe.joints()) == 12, WAIT), driver.output()
        yield emulator, driver, probe
    finally:
        probe.close()
        driver.stop()
        emulator.close()


def test_joint_states_come_from_the_arms_readback(rig):
    emulator, driver, probe = rig
    assert len(probe.joints()) == 12  # the six arm joints, the gripper and its five mimic joints
    assert np.allclose(probe.arm_positions(), np.radians(emulator.state()["angles"]), atol=0.01)
    assert probe.gripper.wait_for_server(timeout_sec=WAIT)


def test_follow_joint_trajectory_moves_the_arm(rig):
    emulator, driver, probe = rig
    emulator.clear()
    target = [0.3, -0.4, 0.6, 0.1, -0.3, 0.5]
    accepted, future = probe.move(target)
    assert accepted
    result = result_of(future).result
    assert result.error_code == FollowJointTrajectory.Result.SUCCESSFUL, result.error_string
    assert np.allclose(np.radians(emulator.state()["angles"]), target, atol=0.01)
    assert wait_until(lambda: np.allclose(probe.arm_positions(), target, atol=0.01), WAIT)


def test_gripper_command_sets_the_gripper_value(rig):
    emulator, driver, probe = rig
    goal = GripperCommand.Goal()
    goal.command.position = -0.25
    accepted, future = probe.send(probe.gripper, goal)
    assert accepted
    result = result_of(future).result
    assert result.reached_goal and abs(result.position + 0.25) <= 0.01
    assert emulator.state()["gripper"] == 50  # halfway between open (100) and closed (0)
    emulator.block_gripper(20)  # an object between the fingers: closing stops at value 20 (-0.4 rad)
    goal.command.position = -0.5
    accepted, future = probe.send(probe.gripper, goal)
    assert accepted
    result = result_of(future).result
    emulator.clear()
    assert result.reached_goal and abs(result.position + 0.4) <= 0.01  # stalled on the object: allow_stalling


def test_out_of_limits_trajectory_is_refused_before_any_command(rig):
    emulator, driver, probe = rig
    mark = time.monotonic()
    accepted, _ = probe.move([0.0, 2.6, 0.0, 0.0, 0.0, 0.0])  # joint 2: firmware limit 140 deg = 2.443 rad
    assert not accepted
    assert wait_until(lambda: "outside its limits" in driver.output(), WAIT)
    time.sleep(0.5)
    assert not [n for _, n, _ in emulator.received(mark) if n in ("SEND_ANGLES", "SEND_ANGLE")]


def test_a_stop_along_the_path_preempts_the_running_goal_on_the_arm(rig):
    """What move_group sends to stop the arm short of an obstacle (or on a stop request): a new
    goal along the same path that slows down to rest; it preempts the running goal and the arm's
    readback ends where the stop ends, short of the first goal's target."""
    emulator, driver, probe = rig
    emulator.clear()
    start = probe.arm_positions()
    target = start + np.array([0.9, 0.0, 0.0, 0.0, 0.0, 0.0])
    duration = 2.0
    accepted, first = probe.move(target, duration=duration)
    assert accepted
    time.sleep(0.6)
    # the first goal's path, as the probe built it (cosine blend), timed from its start
    ts = np.linspace(0.0, duration, 201)
    blend = (1 - np.cos(np.pi * ts / duration)) / 2
    path = TimedTrajectory(ARM, ts, start + np.outer(blend, target - start),
                           np.outer(np.pi / duration * np.sin(np.pi * ts / duration) / 2, target - start),
                           np.outer((np.pi / duration) ** 2 * np.cos(np.pi * ts / duration) / 2, target - start))
    now = probe.arm_positions()
    t_arm = float(ts[np.argmin(np.max(np.abs(path.positions - now), axis=1))])
    plan = stopping_trajectory(path, t_arm + 0.1, np.full(6, 5.0))
    assert plan is not None and plan.rest_at < duration
    stop = stop_command(plan, 0.1, "stop")
    goal = FollowJointTrajectory.Goal()
    goal.trajectory.joint_names = ARM
    for p in stop.points:
        point = JointTrajectoryPoint()
        point.positions, point.velocities = list(p.positions), list(p.velocities)
        point.time_from_start = seconds_to_duration(p.time_from_start)
        goal.trajectory.points.append(point)
    accepted, second = probe.send(probe.arm, goal)
    assert accepted
    assert result_of(second).result.error_code == FollowJointTrajectory.Result.SUCCESSFUL
    assert "preempted" in result_of(first).result.error_string
    rest = stop.points[-1].positions
    assert wait_until(lambda: np.allclose(np.radians(emulator.state()["angles"]), rest, atol=0.01), WAIT)
    assert np.radians(emulator.state()["angles"])[0] < target[0] - 0.1  # short of the first goal's target


def test_stalled_servo_is_aborted_by_path_tolerance(rig):
    emulator, driver, probe = rig
    emulator.clear()
    emulator.stall(3)
    start = probe.arm_positions()
    accepted, future = probe.move(start + [0.0, 0.0, -0.8, 0.0, 0.0, 0.0], duration=2.0)
    assert accepted
    result = result_of(future).result
    emulator.clear()
    assert result.error_code == FollowJointTrajectory.Result.PATH_TOLERANCE_VIOLATED
    assert "path tolerance violated" in result.error_string and "link3_to_link4" in result.error_string
    assert wait_until(lambda: "stop command sent" in driver.output(), WAIT)


def test_port_closed_mid_motion_aborts_then_motion_resumes_after_reconnect(rig):
    emulator, driver, probe = rig
    emulator.clear()
    start = probe.arm_positions()
    accepted, future = probe.move(start + [0.6, 0.0, 0.0, 0.0, 0.0, 0.0], duration=3.0)
    assert accepted
    time.sleep(0.5)
    connects = driver.output().count("connected to the arm")
    dropped = time.monotonic()
    emulator.drop(seconds=1.0)
    result = result_of(future).result
    latency = time.monotonic() - dropped
    print(f"goal aborted {latency:.3f} s after the port closed")  # measured; the bench reports rates
    assert result.error_code != FollowJointTrajectory.Result.SUCCESSFUL
    assert "lost the arm on" in result.error_string
    assert driver.alive()
    assert wait_until(lambda: driver.output().count("connected to the arm") > connects, STARTUP), driver.output()
    accepted, future = probe.move(start)
    assert accepted
    result = result_of(future).result
    assert result.error_code == FollowJointTrajectory.Result.SUCCESSFUL, result.error_string
    assert np.allclose(np.radians(emulator.state()["angles"]), start, atol=0.01)
