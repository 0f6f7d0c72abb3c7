"""One process of a bring-up: a package module run as ``python -m MODULE ARGS``, leading a process
group of its own (so stopping it reaches its children and nothing else), its output in one log
file, and stopped by escalation (SIGINT, then SIGTERM, then SIGKILL to the group).

A process started by another invocation (robot.sh start, then robot.sh stop) is adopted from its
PID: it counts as ours only while that PID runs the same module (a reused PID is not ours).
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Mapping, Sequence


def _state(pid: int) -> str:
    """The process state letter from /proc (R, S, Z, ...), "" when there is no such process."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return ""


def group_alive(pgid: int) -> bool:
    """Some process of the group led by ``pgid`` remains."""
    try:
        os.killpg(pgid, 0)
        return True
    except ProcessLookupError:
        return False
    except PermissionError:
        return True


class ManagedProcess:
    """``name`` names the log (``<log_dir>/<name>.log``); ``module`` is run with the Python of
    this interpreter (a path ending in .py is run as a script)."""

    def __init__(self, name: str, module: str, args: Sequence[str] = (), log_path: Path | None = None) -> None:
        self.name = name
        self.module = module
        self.args = list(args)
        self.log_path = log_path
        self.proc: subprocess.Popen | None = None
        self.pid: int | None = None

    # ------------------------------------------------------------------ life cycle
    def command(self) -> list[str]:
        return [sys.executable, *([self.module] if self.module.endswith(".py") else ["-m", self.module]), *self.args]

    def start(self, env: Mapping[str, str], cwd: Path | None = None, header: str = "") -> int:
        """Start it in a session (and process group) of its own, output appended to the log
        (whose previous content is kept as ``<log>.1`` when ``header`` is given: a fresh log)."""
        assert self.log_path is not None, "a process needs a log file"
        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        if header:
            if self.log_path.exists():
                self.log_path.replace(self.log_path.with_name(self.log_path.name + ".1"))
            self.log_path.write_text(header + "\n")
        with open(self.log_path, "a") as log:
            self.proc = subprocess.Popen(self.command(), cwd=cwd, env=dict(env), stdout=log, stderr=subprocess.STDOUT,
                                         stdin=subprocess.DEVNULL, start_new_session=True)
        self.pid = self.proc.pid
        return self.pid

    def adopt(self, pid: int) -> None:
        """Take over a process started elsewhere (from its recorded PID)."""
        self.pid = pid
        self.proc = None

    def running(self) -> bool:
        """Its PID runs (not a zombie) — right after start, before it runs Python."""
        if self.pid is None:
            return False
        if self.proc is not None:
            return self.proc.poll() is None
        return _state(self.pid) not in ("", "Z", "X")

    def alive(self) -> bool:
        """It runs and is what we started: its command line names the module."""
        if not self.running():
            return False
        if self.proc is not None:
            return True
        try:
            cmdline = Path(f"/proc/{self.pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            return False
        return self.module in cmdline

    def returncode(self) -> int | None:
        return self.proc.poll() if self.proc is not None else None

    def signal(self, sig: int) -> None:
        """Send ``sig`` to its whole process group."""
        if self.pid is not None:
            try:
                os.killpg(self.pid, sig)
            except (ProcessLookupError, PermissionError):
                pass

    def wait_gone(self, timeout: float) -> bool:
        """Wait until nothing of its process group remains (reaping our child)."""
        deadline = time.monotonic() + timeout
        while True:
            if self.proc is not None:
                self.proc.poll()
            if self.pid is None or not group_alive(self.pid):
                return True
            if time.monotonic() >= deadline:
                return False
            time.sleep(0.05)

    def stop(self, grace: float = 10.0, signalled: bool = False, report=None) -> bool:
        """SIGINT to the group (unless ``signalled`` already), SIGTERM after ``grace`` s, SIGKILL
        3 s later; ``report(text)`` hears each escalation. True when the group is gone."""
        say = report or (lambda text: None)
        if self.pid is None:
            return True
        if not signalled:
            self.signal(signal.SIGINT)
        if self.wait_gone(grace):
            return True
        say(f"{self.name}: still running {grace:g} s after SIGINT, sending SIGTERM")
        self.signal(signal.SIGTERM)
        if self.wait_gone(3.0):
            return True
        say(f"{self.name}: still running after SIGTERM, sending SIGKILL")
        self.signal(signal.SIGKILL)
        return self.wait_gone(3.0)

    # ------------------------------------------------------------------ output
    def output(self) -> str:
        try:
            return self.log_path.read_text(errors="replace") if self.log_path is not None else ""
        except OSError:
            return ""

    def tail(self, lines: int = 20) -> str:
        return "\n".join(self.output().splitlines()[-lines:])

    def wait_for_output(self, text: str, timeout: float = 20.0) -> bool:
        """``text`` appeared in its log within ``timeout`` s (False at once when it exited)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if text in self.output():
                return True
            if not self.running():
                return text in self.output()
            time.sleep(0.05)
        return False
