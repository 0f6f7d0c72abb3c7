"""Unmodified pymycobot (MyCobot280, 4.0.7) drives the emulated arm on its pseudo-terminal."""
from __future__ import annotations

import time

import pytest

pymycobot = pytest.importorskip("pymycobot", reason="pymycobot 4.0.7 is installed by scripts/setup.sh")
serial = pytest.importorskip("serial", reason="pyserial is installed by scripts/setup.sh")

from mycobot_planning.hardware import emulator as emu_module  # noqa: E402
from mycobot_planning.hardware.emulator import EmulatedArm, control_request  # noqa: E402
from mycobot_planning.hardware.servo_model import ServoConfig  # noqa: E402

from test_driver_core import wait_until as poll_until  # noqa: E402


def wait_until(predicate, timeout: float = 10.0) -> bool:
    return poll_until(predicate, timeout)


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    link = tmp_path_factory.mktemp("emu") / "port"
    with EmulatedArm(link, servo=ServoConfig(noise_deg=0.0)) as emulated:
        mc = pymycobot.MyCobot280(emulated.port, "115200")
        yield emulated, mc
        mc.close()


def test_status_queries(arm):
    emulated, mc = arm
    assert mc.is_controller_connected() == 1
    assert mc.is_power_on() == 1
    assert mc.get_error_information() == 0
    assert mc.get_servo_status() == [0, 0, 0, 0, 0, 0]
    assert mc.get_system_version() == 3.5


def test_send_angles_moves_the_joints_and_get_angles_reads_them(arm):
    emulated, mc = arm
    assert mc.send_angles([20, -10, 30, 0, 5, 0], 100) == 1
    assert wait_until(lambda: mc.get_angles() == [20.0, -10.0, 30.0, 0.0, 5.0, 0.0])
    names = [name for _, name, _ in emulated.received()]
    assert "SEND_ANGLES" in names and "GET_ANGLES" in names
    assert mc.send_angle(1, -15.5, 100) == 1
    assert wait_until(lambda: mc.get_angles()[0] == -15.5)


def test_stop_halts_the_motion_midway(arm):
    emulated, mc = arm
    mc.send_angles([0, 0, 0, 0, 0, 0], 100)
    assert wait_until(lambda: mc.get_angles() == [0.0] * 6)
    mc.send_angles([150, 0, 0, 0, 0, 0], 10)  # 16 deg/s: takes about 9 s
    time.sleep(0.3)
    assert mc.stop() == 1
    halted = mc.get_angles()[0]
    assert 0.0 < halted < 150.0
    time.sleep(0.3)
    assert mc.get_angles()[0] == pytest.approx(halted, abs=0.2)


def test_gripper_value(arm):
    emulated, mc = arm
    assert mc.get_gripper_value() == 100
    assert mc.set_gripper_value(30, 100) == 1
    assert wait_until(lambda: mc.get_gripper_value() == 30)


def test_power_off_and_on(arm):
    emulated, mc = arm
    mc.power_off()
    assert mc.is_power_on() == 0
    mc.power_on()
    assert mc.is_power_on() == 1


def test_injected_error_code_is_reported(arm):
    emulated, mc = arm
    emulated.set_error(32)
    assert mc.get_error_information() == 32
    emulated.clear()
    assert mc.get_error_information() == 0


def test_dropped_connection_fails_reads_and_a_new_port_appears_at_the_link(arm):
    emulated, mc = arm
    emulated.drop(seconds=1.5)  # long enough that the read below falls inside it on a loaded machine
    with pytest.raises(serial.SerialException):
        mc.get_angles()
    assert wait_until(lambda: emulated.connected and emulated.link.exists())
    again = pymycobot.MyCobot280(emulated.port, "115200")
    try:
        assert again.is_power_on() == 1
    finally:
        again.close()


def test_control_socket_takes_faults_and_queries(tmp_path):
    """The emulator process's --control socket: faults and queries as JSON lines."""
    import threading

    link, sock = tmp_path / "port", tmp_path / "ctl.sock"
    stop = threading.Event()
    with EmulatedArm(link) as emulated:
        server = threading.Thread(target=emu_module._serve_control, args=(emulated, sock, stop), daemon=True)
        server.start()
        assert wait_until(sock.exists)
        assert control_request(sock, {"cmd": "stall", "joint": 2})["ok"]
        state = control_request(sock, {"cmd": "state"})
        assert state["stalled"] == [2] and state["connected"] and state["port"].startswith("/dev/pts/")
        assert control_request(sock, {"cmd": "nonsense"})["ok"] is False
        stop.set()
        server.join(2.0)
