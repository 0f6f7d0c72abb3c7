"""`./scripts/demo.sh --hardware emulated`: the seeds' pick and place through robot.sh, the emulated
arm (mycobot_emulator on a pseudo-terminal) and mycobot_driver over unmodified pymycobot."""
from __future__ import annotations

import subprocess

from ros_testing import REPO, ros_env


def test_demo_on_the_emulated_arm_places_the_object_and_ends_at_home(tmp_path):
    env = ros_env()
    env["MYCOBOT_DEMO_DIR"] = str(tmp_path / "demo")
    run = subprocess.run([str(REPO / "scripts" / "demo.sh"), "--hardware", "emulated"], cwd=REPO, env=env,
                         capture_output=True, text=True, timeout=900)
    out = run.stdout + run.stderr
    assert run.returncode == 0, out[-6000:]
    assert "starting mycobot_driver on the emulated arm" in out
    assert "hardware: mycobot_driver drives the myCobot 280 on" in out
    assert "SUCCESS: the object stands at the place pose" in out
    assert "the arm's readback ended at home" in out
    driver_log = (tmp_path / "demo" / "mycobot_driver.log").read_text()
    assert "connected to the arm on" in driver_log
    assert "stop command sent to the arm" in driver_log  # the driver's shutdown
    assert "Traceback" not in driver_log
    # everything the demo started is gone again
    assert not (tmp_path / "demo" / "run" / "mycobot_driver.pid").exists()
