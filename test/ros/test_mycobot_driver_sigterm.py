"""mycobot_driver on SIGTERM mid-motion: the library's stop command reaches the arm before the
process exits. A module of its own: no other driver may serve the same actions meanwhile."""
from __future__ import annotations

import os
import signal
import time

import pytest

from ros_testing import use_session_domain, wait_until

rclpy = pytest.importorskip("rclpy", reason="rclpy is installed by scripts/setup.sh")
pytest.importorskip("pymycobot", reason="pymycobot 4.0.7 is installed by scripts/setup.sh")

from mycobot_planning.hardware.emulator import EmulatedArm  # noqa: E402
from test_mycobot_driver import WAIT, Probe, start_driver  # noqa: E402


def test_sigterm_mid_motion_sends_stop_before_exit(tmp_path):
    use_session_domain()
    link = tmp_path / "mycobot_port"
    with EmulatedArm(link) as emulator:
        driver = start_driver(link)
        probe = Probe()
        try:
            assert wait_until(lambda: len(probe.joints()) == 12, WAIT)
            accepted, _ = probe.move([0.5, 0.0, 0.0, 0.0, 0.0, 0.0], duration=3.0)
            assert accepted
            assert wait_until(lambda: any(n == "SEND_ANGLES" for _, n, _ in emulator.received()), WAIT)
            mark = time.monotonic()
            os.killpg(driver.proc.pid, signal.SIGTERM)
            driver.proc.wait(WAIT)
            names = [n for _, n, _ in emulator.received(mark)]
            assert "STOP" in names, names
            assert "SEND_ANGLES" not in names[names.index("STOP"):]
            assert emulator.state()["angles"][0] < 28.0  # halted short of 0.5 rad (28.6 deg)
            assert "stop command sent to the arm" in driver.output()
            assert "Traceback" not in driver.output()
        finally:
            probe.close()
            driver.stop()
