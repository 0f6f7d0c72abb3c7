"""An emulated myCobot 280 on a pseudo-terminal: answers the firmware's serial protocol for the
commands the driver and pymycobot's MyCobot280 use, with the servo model of servo_model.py and
the timing of a serial line at a given baud rate. Unmodified pymycobot drives it.

    python -m mycobot_planning.hardware.emulator --link /tmp/mycobot_port --control /tmp/mycobot.sock

``--link`` is a symlink to the pseudo-terminal (give it to the driver as its port); a dropped
connection removes it and a reconnect points it at a new pseudo-terminal, as a USB adapter that
is unplugged and plugged in again. ``--control`` is a Unix socket taking one JSON object per line
(faults and queries, see ``EmulatedArm.control``). The full story: docs/hardware.md.
"""
from __future__ import annotations

import argparse
import json
import os
import select
import signal
import socket
import sys
import threading
import time
import tty
from collections import deque
from pathlib import Path
from typing import Any

from .protocol import Cmd, Frame, FrameParser, decode_angles, encode_angles, encode_frame, wire_seconds
from .servo_model import ServoConfig, ServoModel, describe_error

#: byte the firmware answers set commands with ("done")
OK = 1
#: SOFTWARE_VERSION answer: 3.5 as pymycobot reads it (value / 10)
SOFTWARE_VERSION = 35


class EmulatedArm:
    """The arm behind a pseudo-terminal, served by a thread of its own.

    ``baud`` (bits/s, 8N1) and ``firmware_latency`` (s per command) time the answers: an answer
    leaves once the request has crossed the line, the firmware has worked and the answer has
    crossed back, one frame after the other.
    """

    def __init__(self, link: str | Path | None = None, *, baud: int = 115200, firmware_latency: float = 0.002,
                 servo: ServoConfig | None = None, clock: Any = time.monotonic) -> None:
        self.link = Path(link) if link else None
        self.baud = int(baud)
        self.firmware_latency = float(firmware_latency)
        self._clock = clock
        self._lock = threading.RLock()
        self.model = ServoModel(servo, clock())
        self._master: int | None = None
        self._slave: int | None = None
        self.port_path = ""  # /dev/pts/N of the current connection
        self._parser = FrameParser()
        self._pending: deque[tuple[float, bytes]] = deque()
        self._line_free = 0.0
        self._log: list[tuple[float, str, bytes]] = []  # (time, command name, data) of every frame received
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._reconnect_at: float | None = None
        self.connected = False
        self.mute = False  # fault: frames are read but never answered

    # ------------------------------------------------------------------ life cycle
    def start(self) -> "EmulatedArm":
        self._open()
        self._thread = threading.Thread(target=self._serve, name="mycobot-emulator", daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(2.0)
        with self._lock:
            self._close_pty()

    def __enter__(self) -> "EmulatedArm":
        return self.start()

    def __exit__(self, *exc: Any) -> None:
        self.close()

    @property
    def port(self) -> str:
        """What to give pymycobot / the driver as the port: the link, or the pseudo-terminal."""
        return str(self.link) if self.link else self.port_path

    def _open(self) -> None:
        master, slave = os.openpty()
        tty.setraw(slave)
        os.set_blocking(master, False)
        self._master, self._slave = master, slave
        self.port_path = os.ttyname(slave)
        self._parser = FrameParser()
        self._pending.clear()
        if self.link:
            tmp = self.link.with_name(self.link.name + ".tmp")
            tmp.unlink(missing_ok=True)
            tmp.symlink_to(self.port_path)
            os.replace(tmp, self.link)
        self.connected = True

    def _close_pty(self) -> None:
        for fd in (self._master, self._slave):
            if fd is not None:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self._master = self._slave = None
        self.connected = False
        if self.link:
            try:
                if self.link.is_symlink() and os.readlink(self.link) == self.port_path:
                    self.link.unlink()
            except OSError:
                pass

    # ------------------------------------------------------------------ faults and queries
    def drop(self, seconds: float | None = None) -> None:
        """Drop the connection (the pseudo-terminal goes away: the driver's reads fail); with
        `seconds`, a new one appears at the link after that long."""
        with self._lock:
            self._close_pty()
            self._reconnect_at = None if seconds is None else self._clock() + max(0.0, float(seconds))

    def reconnect(self) -> None:
        with self._lock:
            self._reconnect_at = None
            if not self.connected:
                self._open()

    def stall(self, joint: int, on: bool = True) -> None:
        with self._lock:
            self.model.stall(int(joint), on)

    def set_error(self, code: int, joint: int = 0) -> None:
        with self._lock:
            self.model.set_error(int(code), int(joint))

    def block_gripper(self, value: float | None) -> None:
        with self._lock:
            self.model.block_gripper(value)

    def clear(self) -> None:
        with self._lock:
            self.model.clear_faults()
            self.mute = False

    def received(self, since: float = 0.0) -> list[tuple[float, str, bytes]]:
        with self._lock:
            return [entry for entry in self._log if entry[0] >= since]

    def state(self) -> dict[str, Any]:
        with self._lock:
            self.model.advance(self._clock())
            m = self.model
            return {"angles": m.true_angles(), "targets": [float(v) for v in m.targets],
                    "gripper": m.read_gripper(), "powered": m.powered, "error_code": m.error_code,
                    "error": describe_error(m.error_code), "stalled": sorted(j + 1 for j in m.stalled),
                    "connected": self.connected, "port": self.port_path, "moving": m.moving,
                    "commands": len(self._log), "time": self._clock()}

    def control(self, request: dict[str, Any]) -> dict[str, Any]:
        """One control request (the --control socket's JSON): {"cmd": ...} with
        state | log (since) | stall (joint 1-6 or 0 = all, on) | drop (seconds) | reconnect |
        error (code, joint) | block_gripper (value: an object stops the closing fingers there;
        null: none) | mute (on) | clear."""
        cmd = request.get("cmd")
        if cmd == "state":
            return self.state()
        if cmd == "log":
            since = float(request.get("since", 0.0))
            return {"log": [[t, name, data.hex()] for t, name, data in self.received(since)]}
        if cmd == "stall":
            self.stall(int(request.get("joint", 0)), bool(request.get("on", True)))
        elif cmd == "drop":
            seconds = request.get("seconds")
            self.drop(None if seconds is None else float(seconds))
        elif cmd == "reconnect":
            self.reconnect()
        elif cmd == "error":
            self.set_error(int(request.get("code", 0)), int(request.get("joint", 0)))
        elif cmd == "block_gripper":
            value = request.get("value")
            self.block_gripper(None if value is None else float(value))
        elif cmd == "mute":
            with self._lock:
                self.mute = bool(request.get("on", True))
        elif cmd == "clear":
            self.clear()
        else:
            return {"ok": False, "error": f"unknown cmd {cmd!r}"}
        return {"ok": True}

    # ------------------------------------------------------------------ serving
    def _serve(self) -> None:
        while not self._stop.is_set():
            with self._lock:
                now = self._clock()
                if not self.connected and self._reconnect_at is not None and now >= self._reconnect_at:
                    self._reconnect_at = None
                    self._open()
                master = self._master
                self.model.advance(now)  # a dense history: the readback latency is exact
                self._flush_due(now)
                wait = 0.005
                if self._pending:
                    wait = max(0.0, min(wait, self._pending[0][0] - now))
            if master is None:
                time.sleep(0.005)
                continue
            try:
                ready, _, _ = select.select([master], [], [], wait)
            except (OSError, ValueError):
                continue
            if not ready:
                continue
            with self._lock:
                if self._master != master:
                    continue
                try:
                    chunk = os.read(master, 4096)
                except BlockingIOError:
                    continue
                except OSError:
                    chunk = b""
                if chunk:
                    self._on_bytes(chunk, self._clock())

    def _flush_due(self, now: float) -> None:
        while self._pending and self._pending[0][0] <= now and self._master is not None:
            _, data = self._pending.popleft()
            try:
                os.write(self._master, data)
            except OSError:
                pass

    def _on_bytes(self, chunk: bytes, now: float) -> None:
        self.model.advance(now)
        for frame in self._parser.feed(chunk):
            self._log.append((now, frame.name, frame.data))
            answer = self._answer(frame, now)
            if answer is None or self.mute:
                continue
            arrived = now + wire_seconds(len(frame.encode()), self.baud)
            start = max(arrived + self.firmware_latency, self._line_free)
            done = start + wire_seconds(len(answer), self.baud)
            self._line_free = done
            self._pending.append((done, answer))

    def _answer(self, frame: Frame, now: float) -> bytes | None:
        """The firmware's answer to one frame (None: no answer)."""
        m, c, d = self.model, frame.cmd, frame.data
        if c == Cmd.GET_ANGLES:
            return encode_frame(c, encode_angles(m.read_angles()))
        if c == Cmd.SEND_ANGLES and len(d) >= 13:
            m.send_angles(decode_angles(d[:12]), d[12])
        elif c == Cmd.SEND_ANGLE and len(d) >= 4:
            m.send_angle(d[0], decode_angles(d[1:3])[0], d[3])
        elif c == Cmd.STOP:
            m.stop()
        elif c == Cmd.PAUSE:
            m.stop()
        elif c == Cmd.RESUME:
            pass
        elif c == Cmd.POWER_ON or c == Cmd.FOCUS_ALL_SERVOS:
            m.power_on()
        elif c == Cmd.POWER_OFF or c == Cmd.RELEASE_ALL_SERVOS:
            m.power_off()
        elif c == Cmd.SET_GRIPPER_VALUE and len(d) >= 2:
            m.set_gripper(d[0], d[1])
        elif c == Cmd.SET_GRIPPER_STATE and len(d) >= 2:
            m.set_gripper(100 if d[0] == 0 else 0, d[1])
        elif c == Cmd.CLEAR_ERROR_INFO:
            m.error_code = 0
        elif c in (Cmd.SET_FRESH_MODE, Cmd.SET_SPEED):
            pass
        elif c == Cmd.IS_POWER_ON:
            return encode_frame(c, [1 if m.powered else 0])
        elif c == Cmd.IS_CONTROLLER_CONNECTED:
            return encode_frame(c, [1])
        elif c == Cmd.GET_GRIPPER_VALUE:
            return encode_frame(c, [m.read_gripper()])
        elif c == Cmd.GET_ERROR_INFO:
            return encode_frame(c, [0, m.error_code & 0xFF])
        elif c == Cmd.GET_SERVO_STATUS:
            return encode_frame(c, [v & 0xFF for v in m.servo_status])
        elif c in (Cmd.IS_MOVING, Cmd.IS_GRIPPER_MOVING):
            moving = m.moving if c == Cmd.IS_MOVING else abs(m.gripper_target - m.gripper) > 0.5
            return encode_frame(c, [1 if moving else 0])
        elif c == Cmd.IS_IN_POSITION:
            return encode_frame(c, [0 if m.moving else 1])
        elif c == Cmd.IS_PAUSED:
            return encode_frame(c, [0])
        elif c == Cmd.GET_FRESH_MODE:
            return encode_frame(c, [1])
        elif c == Cmd.GET_SPEED:
            return encode_frame(c, [50])
        elif c == Cmd.SOFTWARE_VERSION:
            return encode_frame(c, [SOFTWARE_VERSION])
        else:
            return None  # unknown to this firmware: no answer (pymycobot times out)
        return encode_frame(c, [OK])


# ---------------------------------------------------------------------------------- control
def control_request(socket_path: str | Path, request: dict[str, Any], timeout: float = 5.0) -> dict[str, Any]:
    """Send one request to a running emulator's --control socket; its JSON answer."""
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
        sock.settimeout(timeout)
        sock.connect(str(socket_path))
        sock.sendall(json.dumps(request).encode() + b"\n")
        data = b""
        while not data.endswith(b"\n"):
            chunk = sock.recv(65536)
            if not chunk:
                break
            data += chunk
    return json.loads(data.decode() or "{}")


def _serve_control(arm: EmulatedArm, path: Path, stop: threading.Event) -> None:
    path.unlink(missing_ok=True)
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    # bound under another name and moved into place once listening: a client that sees the path
    # can connect (bind alone creates the file, and a connect before listen is refused)
    staging = path.with_name(path.name + ".tmp")
    staging.unlink(missing_ok=True)
    server.bind(str(staging))
    server.listen(4)
    os.replace(staging, path)
    server.settimeout(0.2)
    try:
        while not stop.is_set():
            try:
                conn, _ = server.accept()
            except socket.timeout:
                continue
            with conn:
                conn.settimeout(5.0)
                data = b""
                try:
                    while not data.endswith(b"\n"):
                        chunk = conn.recv(65536)
                        if not chunk:
                            break
                        data += chunk
                    try:
                        request = json.loads(data.decode() or "{}")
                        answer = arm.control(request) if isinstance(request, dict) else {
                            "ok": False, "error": "send one JSON object"}
                    except (ValueError, TypeError) as exc:
                        answer = {"ok": False, "error": f"bad request: {exc}"}
                    conn.sendall(json.dumps(answer).encode() + b"\n")
                except OSError:
                    pass
    finally:
        server.close()
        path.unlink(missing_ok=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="mycobot_emulator", description=(
        "An emulated myCobot 280 answering the firmware's serial protocol on a pseudo-terminal."))
    parser.add_argument("--link", default="", help="symlink to create to the pseudo-terminal (the port to "
                        "give the driver); empty: print the /dev/pts path only")
    parser.add_argument("--control", default="", help="Unix socket for faults and queries (JSON lines)")
    parser.add_argument("--baud", type=int, default=115200, help="baud rate whose timing the answers follow")
    parser.add_argument("--firmware-latency", type=float, default=0.002, help="s the firmware takes per command")
    parser.add_argument("--readback-latency", type=float, default=0.010, help="s get_angles lags the servos")
    parser.add_argument("--noise", type=float, default=0.05, help="encoder noise, degrees (standard deviation)")
    parser.add_argument("--full-speed", type=float, default=160.0, help="deg/s of a joint at speed 100")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    if args.baud <= 0 or args.firmware_latency < 0 or args.readback_latency < 0 or args.noise < 0 \
            or args.full_speed <= 0:
        print("[ERROR] --baud and --full-speed must be > 0, latencies and noise >= 0", file=sys.stderr)
        return 1
    servo = ServoConfig(full_speed_deg_s=args.full_speed, readback_latency=args.readback_latency,
                        noise_deg=args.noise, seed=args.seed)
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    try:
        arm = EmulatedArm(args.link or None, baud=args.baud, firmware_latency=args.firmware_latency,
                          servo=servo).start()
    except OSError as exc:
        print(f"[ERROR] cannot create the emulated arm's port: {exc}", file=sys.stderr)
        return 1
    control_thread = None
    if args.control:
        control_thread = threading.Thread(target=_serve_control, args=(arm, Path(args.control), stop), daemon=True)
        control_thread.start()
    print(f"mycobot_emulator ready: emulated myCobot 280 on {arm.port_path}"
          + (f" (link {arm.link})" if arm.link else "") + f", {args.baud} baud"
          + (f", control socket {args.control}" if args.control else ""), flush=True)
    try:
        while not stop.wait(0.2):
            pass
    finally:
        arm.close()
        if control_thread is not None:
            control_thread.join(1.0)
        print("mycobot_emulator stopped", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
