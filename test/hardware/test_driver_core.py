"""The driver core (ROS-free) on the emulated arm through pymycobot: following, faults, stop."""
from __future__ import annotations

import threading
import time

import numpy as np
import pytest

pytest.importorskip("pymycobot", reason="pymycobot 4.0.7 is installed by scripts/setup.sh")

from mycobot_planning.hardware.driver import DriverConfig, DriverCore  # noqa: E402
from mycobot_planning.hardware.emulator import EmulatedArm  # noqa: E402
from mycobot_planning.hardware.follower import MeasuredTrajectoryFollower  # noqa: E402
from mycobot_planning.mock_control.joint_trajectory_follower import TrajectoryCommand  # noqa: E402
from mycobot_planning.polling import wait_until as poll_until  # noqa: E402

JOINTS = [f"joint{i}" for i in range(1, 7)]
TIMEOUT = 30.0  # generous: a busy machine


def wait_until(predicate, timeout: float = TIMEOUT) -> bool:
    return bool(poll_until(predicate, timeout, 0.02))


class Rig:
    def __init__(self, link):
        self.emulator = EmulatedArm(link).start()
        self.config = DriverConfig(port=str(link), reconnect_period=0.3)
        lo, hi = self.config.firmware_limits()
        self.arm = MeasuredTrajectoryFollower(JOINTS, lo, hi, np.zeros(6), goal_tolerance=0.01, name="arm",
                                              velocity_limits=[2.79] * 6, acceleration_limits=[5.0] * 6,
                                              path_tolerance=0.2, goal_time=2.0)
        self.gripper = MeasuredTrajectoryFollower(["gripper"], [-0.5], [0.0], [0.0], goal_tolerance=0.01,
                                                  name="gripper", goal_time=3.0, allow_stalling=True)
        self.events: list[tuple[str, str]] = []
        # a plain lock, as the node gives it: a nested acquisition deadlocks here as it would there
        self.core = DriverCore(self.config, self.arm, self.gripper, lock=threading.Lock(),
                               on_event=lambda lv, t: self.events.append((lv, t)))
        self.core.start()
        assert wait_until(lambda: self.core.connected), self.events

    def submit(self, follower, times, positions):
        with self.core.lock:
            return follower.submit(TrajectoryCommand(follower.joint_names, times, positions), time.time())

    def wait_done(self, follower) -> str:
        assert wait_until(lambda: not follower.active)
        return follower.status

    def close(self):
        self.core.close()
        self.emulator.close()


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    r = Rig(tmp_path_factory.mktemp("driver") / "port")
    yield r
    r.close()


def test_follows_a_trajectory_to_its_end(rig):
    rig.emulator.clear()
    start = list(rig.arm.positions)
    goal = [0.4, -0.3, 0.5, 0.2, -0.2, 0.3]
    times = np.linspace(0.0, 1.5, 16)
    positions = [list(np.array(start) + (np.array(goal) - start) * (1 - np.cos(np.pi * t / 1.5)) / 2) for t in times]
    result = rig.submit(rig.arm, list(times), positions)
    assert result.accepted, result.reason
    assert rig.wait_done(rig.arm) == "succeeded", rig.arm.state().message
    assert np.max(np.abs(rig.arm.positions - goal)) <= 0.01
    assert np.allclose(np.radians(rig.emulator.state()["angles"]), goal, atol=0.01)


def test_gripper_maps_joint_positions_to_values(rig):
    rig.emulator.clear()
    assert rig.submit(rig.gripper, [0.0, 0.3], [[float(rig.gripper.positions[0])], [-0.5]]).accepted
    assert rig.wait_done(rig.gripper) == "succeeded", rig.gripper.state().message
    assert rig.emulator.state()["gripper"] == 0  # closed: value 0
    assert rig.submit(rig.gripper, [0.0, 0.3], [[-0.5], [-0.25]]).accepted
    assert rig.wait_done(rig.gripper) == "succeeded"
    assert rig.emulator.state()["gripper"] == 50


def test_gripper_closing_on_an_object_succeeds_where_it_stalls(rig):
    rig.emulator.clear()
    assert rig.submit(rig.gripper, [0.0, 0.3], [[float(rig.gripper.positions[0])], [0.0]]).accepted
    assert rig.wait_done(rig.gripper) == "succeeded"
    rig.emulator.block_gripper(40)  # an object: the fingers stop at value 40 (-0.3 rad)
    assert rig.submit(rig.gripper, [0.0, 0.3], [[0.0], [-0.5]]).accepted
    assert rig.wait_done(rig.gripper) == "succeeded", rig.gripper.state().message
    assert "holding an object" in rig.gripper.state().message
    assert rig.emulator.state()["gripper"] == 40
    rig.emulator.clear()


def test_out_of_limits_trajectory_is_refused_before_any_command(rig):
    rig.emulator.clear()
    mark = time.monotonic()
    # joint 2's firmware limit is 140 deg = 2.443 rad (the URDF allows 2.88)
    result = rig.submit(rig.arm, [0.0, 1.0, 2.0], [list(rig.arm.positions), [0.0, 2.6, 0, 0, 0, 0], [0.0] * 6])
    assert not result.accepted and "outside its limits" in result.reason
    too_fast = rig.submit(rig.arm, [0.0, 0.1], [list(rig.arm.positions), [1.0, 0, 0, 0, 0, 0]])
    assert not too_fast.accepted and "velocity" in too_fast.reason
    time.sleep(0.3)
    assert not [name for _, name, _ in rig.emulator.received(mark) if name == "SEND_ANGLES"]


def test_stalled_servo_aborts_by_path_tolerance_and_stops_the_arm(rig):
    rig.emulator.clear()
    rig.emulator.stall(2)
    start = list(rig.arm.positions)
    stops = rig.core.stops_sent
    result = rig.submit(rig.arm, [0.0, 2.0], [start, [start[0], start[1] + 0.8] + start[2:]])
    assert result.accepted
    assert rig.wait_done(rig.arm) == "failed"
    assert "path tolerance violated" in rig.arm.state().message and "joint2" in rig.arm.state().message
    assert wait_until(lambda: rig.core.stops_sent > stops)
    rig.emulator.clear()


def test_error_code_aborts_the_goal_and_refuses_new_ones_until_cleared(rig):
    rig.emulator.clear()
    start = list(rig.arm.positions)
    assert rig.submit(rig.arm, [0.0, 3.0], [start, [start[0] + 0.5] + start[1:]]).accepted
    time.sleep(0.3)
    rig.emulator.set_error(17, joint=1)
    assert rig.wait_done(rig.arm) == "failed"
    assert "error 17 (collision protection)" in rig.arm.state().message
    refused = rig.submit(rig.arm, [0.0, 1.0], [list(rig.arm.positions), start])
    assert not refused.accepted and "error 17" in refused.reason
    rig.emulator.clear()
    assert wait_until(lambda: rig.core.error_code == 0)
    assert rig.submit(rig.arm, [0.0, 1.0], [list(rig.arm.positions), start]).accepted
    assert rig.wait_done(rig.arm) == "succeeded"


def test_lost_port_aborts_with_a_reason_then_reconnects(rig):
    rig.emulator.clear()
    start = list(rig.arm.positions)
    assert rig.submit(rig.arm, [0.0, 3.0], [start, [start[0] + 0.6] + start[1:]]).accepted
    time.sleep(0.3)
    rig.emulator.drop(seconds=1.0)
    assert rig.wait_done(rig.arm) == "failed"
    assert "lost the arm on" in rig.arm.state().message
    refused = rig.submit(rig.arm, [0.0, 1.0], [list(rig.arm.positions), start])
    assert not refused.accepted and "not connected" in refused.reason
    assert wait_until(lambda: rig.core.connected)
    assert rig.submit(rig.arm, [0.0, 1.0], [list(rig.arm.positions), start]).accepted
    assert rig.wait_done(rig.arm) == "succeeded", rig.arm.state().message


def test_close_sends_the_stop_command(tmp_path):
    r = Rig(tmp_path / "port")
    try:
        start = list(r.arm.positions)
        assert r.submit(r.arm, [0.0, 3.0], [start, [start[0] + 0.6] + start[1:]]).accepted
        time.sleep(0.3)
        mark = time.monotonic()
        assert r.core.close()
        names = [name for _, name, _ in r.emulator.received(mark)]
        assert names and names[-1] == "STOP"
    finally:
        r.core.close(stop_arm=False)
        r.emulator.close()


def test_unreachable_port_is_retried_without_crashing(tmp_path):
    config = DriverConfig(port=str(tmp_path / "missing"), reconnect_period=0.2)
    arm = MeasuredTrajectoryFollower(JOINTS, *config.firmware_limits(), np.zeros(6), name="arm")
    events: list[tuple[str, str]] = []
    core = DriverCore(config, arm, on_event=lambda lv, t: events.append((lv, t)))
    core.start()
    try:
        assert wait_until(lambda: any("no arm on" in t for _, t in events))
        refused = arm.submit(TrajectoryCommand(JOINTS, [0.0, 1.0], [[0.0] * 6, [0.1] * 6]), time.time())
        assert not refused.accepted and "not connected" in refused.reason
        assert not core.connected
    finally:
        core.close()
