"""Real processes for integration tests: own ROS domain, localhost discovery, guaranteed cleanup.

Each pytest session picks a ROS_DOMAIN_ID of its own (from its PID) and limits discovery to
localhost, so parallel runs on one machine never see each other's nodes. Every process is started
in its own process group and killed with it at the end, even when a test fails.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable, Iterable

REPO = Path(__file__).resolve().parent.parent
PYTHON = sys.executable


def ros_env(domain_id: int | None = None) -> dict[str, str]:
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(domain_id if domain_id is not None else session_domain_id())
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["PYTHONUNBUFFERED"] = "1"
    env.pop("ROS_LOCALHOST_ONLY", None)
    return env


def session_domain_id() -> int:
    """1..100, stable for this test session (env override: MYCOBOT_TEST_DOMAIN_ID)."""
    override = os.environ.get("MYCOBOT_TEST_DOMAIN_ID")
    if override:
        return int(override)
    return 1 + os.getpid() % 100


def use_session_domain() -> None:
    """Make this test process (its in-process rclpy clients) join the session's domain."""
    os.environ.update({k: v for k, v in ros_env().items() if k.startswith("ROS_")})


class NodeProcess:
    """One node started as `python -m <module> --ros-args ...`, output captured to a log file."""

    def __init__(self, module: str, args: Iterable[str] = (), name: str | None = None, log_dir: Path | None = None):
        self.module = module
        self.name = name or module.rsplit(".", 1)[-1]
        log_dir = log_dir or Path(os.environ.get("MYCOBOT_TEST_LOG_DIR", "/tmp/mycobot_test_logs"))
        log_dir.mkdir(parents=True, exist_ok=True)
        self.log_path = log_dir / f"{self.name}-{os.getpid()}-{time.monotonic_ns()}.log"
        self._log = open(self.log_path, "w")
        self.proc = subprocess.Popen(
            [PYTHON, "-m", module, *args],
            cwd=REPO,
            env=ros_env(),
            stdout=self._log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )

    def output(self) -> str:
        if not self._log.closed:
            self._log.flush()
        return self.log_path.read_text(errors="replace")

    def wait_for_output(self, text: str, timeout: float = 20.0) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if text in self.output():
                return True
            if self.proc.poll() is not None:
                return text in self.output()
            time.sleep(0.05)
        return False

    def alive(self) -> bool:
        return self.proc.poll() is None

    def stop(self, timeout: float = 5.0) -> int | None:
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGINT)
                self.proc.wait(timeout)
            except (ProcessLookupError, subprocess.TimeoutExpired):
                try:
                    os.killpg(self.proc.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                self.proc.wait(timeout)
        self._log.close()
        return self.proc.returncode


def wait_until(predicate: Callable[[], bool], timeout: float, period: float = 0.05) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(period)
    return predicate()
