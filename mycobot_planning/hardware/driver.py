"""The driver's core (ROS-free): the link to the arm over pymycobot and the I/O loop that reads
the arm back, feeds the readback to the trajectory followers and streams position + speed
commands sampled from their trajectories.

One thread owns the serial link. Every command period it

1. reads the joint angles (``get_angles``; the gripper value every cycle while a gripper goal
   runs, else every ``gripper_read_period``; the error code every ``status_period``);
2. hands the readback to the followers (which check path tolerance, goal tolerance, goal time);
3. sends ``send_angles`` with the trajectory's position one ``lookahead`` ahead and the speed that
   gets the farthest joint there in that time (``set_gripper_value`` likewise), or the library's
   ``stop`` when a goal ended without succeeding (cancel, path tolerance, error).

A failed read or write (the port went away, the arm stopped answering) aborts the running goals
with the reason, refuses new ones, and the loop reconnects every ``reconnect_period`` until the
port answers again. The full story: docs/hardware.md.
"""
from __future__ import annotations

import logging
import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from .follower import MeasuredTrajectoryFollower
from .servo_model import FIRMWARE_MAX_DEG, FIRMWARE_MIN_DEG, deg_per_s_to_speed, describe_error

#: Default ports and baud rates per model variant (Elephant Robotics' documentation: the M5
#: version enumerates its USB serial adapter, the Pi version talks to its Atom on the UART at 1 Mbaud).
MODEL_DEFAULTS = {"M5": ("/dev/ttyUSB0", 115200), "Pi": ("/dev/ttyAMA0", 1000000)}


class LinkError(RuntimeError):
    """The arm cannot be reached (port missing, closed, or no answer)."""


@dataclass
class DriverConfig:
    port: str = "/dev/ttyUSB0"
    baud: int = 115200
    model: str = "M5"
    #: Hz of the I/O loop: one readback and one command per period
    command_rate: float = 25.0
    #: s ahead of now that each command aims at; 0: one command period
    lookahead: float = 0.0
    #: degrees added to each joint after direction (joint i: angle = direction * deg(q) + offset)
    joint_offsets_deg: Sequence[float] = (0.0,) * 6
    joint_directions: Sequence[int] = (1,) * 6
    #: deg/s of a joint at speed 100 (the arm's speed byte is a percentage of this)
    full_speed_deg_s: float = 160.0
    #: factor on the speed each command asks for (above 1 catches up faster, below 1 lags more)
    speed_scaling: float = 1.0
    #: gripper calibration: joint position (rad) and gripper value (0-100) when open and closed
    gripper_open_position: float = 0.0
    gripper_closed_position: float = -0.5
    gripper_open_value: int = 100
    gripper_closed_value: int = 0
    #: gripper value units per second at speed 100
    gripper_full_speed: float = 200.0
    gripper_read_period: float = 0.2
    status_period: float = 0.25
    reconnect_period: float = 1.0
    #: s pyserial waits per read call inside pymycobot
    serial_timeout: float = 0.1

    def check(self) -> None:
        if self.model not in MODEL_DEFAULTS:
            raise ValueError(f"model must be one of {sorted(MODEL_DEFAULTS)}, got {self.model!r}")
        if len(self.joint_offsets_deg) != 6 or len(self.joint_directions) != 6:
            raise ValueError("joint_offsets and joint_directions need 6 values each (joints 1-6)")
        if any(d not in (1, -1) for d in self.joint_directions):
            raise ValueError(f"joint_directions must be 1 or -1, got {list(self.joint_directions)}")
        if self.gripper_open_position == self.gripper_closed_position:
            raise ValueError("gripper_open_position and gripper_closed_position must differ")
        if self.gripper_open_value == self.gripper_closed_value:
            raise ValueError("gripper_open_value and gripper_closed_value must differ")

    @property
    def period(self) -> float:
        return 1.0 / self.command_rate

    @property
    def ahead(self) -> float:
        return self.lookahead if self.lookahead > 0 else self.period

    # ------------------------------------------------------------------ conversions
    def to_degrees(self, q: Sequence[float]) -> list[float]:
        return [d * math.degrees(v) + o for v, d, o in zip(q, self.joint_directions, self.joint_offsets_deg)]

    def to_radians(self, degrees: Sequence[float]) -> np.ndarray:
        return np.array([math.radians((a - o) * d) for a, d, o in
                         zip(degrees, self.joint_directions, self.joint_offsets_deg)])

    def firmware_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """The firmware's joint limits as joint positions (rad)."""
        a = self.to_radians(FIRMWARE_MIN_DEG)
        b = self.to_radians(FIRMWARE_MAX_DEG)
        return np.minimum(a, b), np.maximum(a, b)

    def gripper_value(self, q: float) -> int:
        f = (q - self.gripper_open_position) / (self.gripper_closed_position - self.gripper_open_position)
        value = self.gripper_open_value + f * (self.gripper_closed_value - self.gripper_open_value)
        return int(max(0, min(100, round(value))))

    def gripper_position(self, value: float) -> float:
        f = (value - self.gripper_open_value) / (self.gripper_closed_value - self.gripper_open_value)
        return self.gripper_open_position + f * (self.gripper_closed_position - self.gripper_open_position)

    def gripper_limits(self) -> tuple[float, float]:
        lo, hi = sorted((self.gripper_open_position, self.gripper_closed_position))
        return lo, hi


class ArmLink:
    """The arm through pymycobot's MyCobot280 (serial). Every failure is a LinkError."""

    def __init__(self, port: str, baud: int, timeout: float = 0.1) -> None:
        self.port, self.baud, self.timeout = port, int(baud), timeout
        self.mc: Any = None
        logging.getLogger("pymycobot").setLevel(logging.CRITICAL)  # failures are reported as LinkError

    def open(self) -> None:
        try:
            from pymycobot import MyCobot280
            import serial
        except ImportError as exc:  # pragma: no cover - pinned in requirements
            raise LinkError(f"pymycobot is not installed ({exc}); pip install pymycobot==4.0.7") from None
        try:
            self.mc = MyCobot280(self.port, str(self.baud), timeout=self.timeout)
        except (serial.SerialException, OSError, ValueError) as exc:
            self.mc = None
            raise LinkError(f"cannot open {self.port}: {exc}") from None

    def close(self) -> None:
        mc, self.mc = self.mc, None
        if mc is not None:
            try:
                mc.close()
            except Exception:  # noqa: BLE001 - closing a dead port
                pass

    @property
    def is_open(self) -> bool:
        return self.mc is not None

    def _call(self, what: str, fn: Callable[[], Any]) -> Any:
        if self.mc is None:
            raise LinkError(f"{self.port} is not open")
        try:
            return fn()
        except Exception as exc:  # pyserial's SerialException/OSError, or a garbled answer
            raise LinkError(f"{what} on {self.port} failed: {exc}") from None

    def _answer(self, what: str, value: Any) -> Any:
        if value is None or value == -1 or (isinstance(value, list) and not value):
            raise LinkError(f"the arm on {self.port} did not answer {what}")
        return value

    def get_angles(self) -> list[float]:
        value = self._answer("get_angles", self._call("get_angles", self.mc.get_angles))
        if not isinstance(value, list) or len(value) != 6:
            raise LinkError(f"the arm on {self.port} answered get_angles with {value!r}")
        return [float(v) for v in value]

    def send_angles(self, degrees: Sequence[float], speed: int) -> None:
        self._answer("send_angles", self._call(
            "send_angles", lambda: self.mc.send_angles([round(float(d), 2) for d in degrees], int(speed))))

    def get_gripper_value(self) -> int:
        return int(self._answer("get_gripper_value", self._call("get_gripper_value", self.mc.get_gripper_value)))

    def set_gripper_value(self, value: int, speed: int) -> None:
        self._answer("set_gripper_value", self._call(
            "set_gripper_value", lambda: self.mc.set_gripper_value(int(value), int(speed))))

    def stop(self) -> None:
        self._call("stop", self.mc.stop)

    def get_error_information(self) -> int:
        return int(self._answer("get_error_information",
                                self._call("get_error_information", self.mc.get_error_information)))

    def prepare(self) -> str:
        """After opening: the controller answers, the servos are powered, fresh mode (latest
        command first) is on. Returns a short description."""
        connected = self._call("is_controller_connected", self.mc.is_controller_connected)
        if connected != 1:
            raise LinkError(f"the arm on {self.port} says its controller is not connected ({connected!r})")
        powered = self._call("is_power_on", self.mc.is_power_on)
        if powered != 1:
            self._call("power_on", self.mc.power_on)
        self._call("set_fresh_mode", lambda: self.mc.set_fresh_mode(1))
        return "powered" if powered == 1 else "powered on now"


@dataclass
class RateCounter:
    times: list[float] = field(default_factory=list)

    def tick(self, t: float) -> None:
        self.times.append(t)
        if len(self.times) > 5000:
            del self.times[:1000]

    def rate(self, window: float = 5.0) -> float:
        if len(self.times) < 2:
            return 0.0
        recent = [t for t in self.times if t >= self.times[-1] - window]
        if len(recent) < 2 or recent[-1] <= recent[0]:
            return 0.0
        return (len(recent) - 1) / (recent[-1] - recent[0])


class DriverCore:
    """The I/O loop between the followers and the arm. ``lock`` is the one the followers are
    used under elsewhere (the node's); ``on_event(level, text)`` receives log lines;
    ``on_change(follower, state)`` every goal state change this loop caused."""

    def __init__(self, config: DriverConfig, arm: MeasuredTrajectoryFollower,
                 gripper: MeasuredTrajectoryFollower | None = None, *, lock: Any = None,
                 clock: Callable[[], float] = time.time, on_event: Callable[[str, str], None] | None = None,
                 on_change: Callable[[MeasuredTrajectoryFollower, Any], None] | None = None,
                 link_factory: Callable[[DriverConfig], ArmLink] | None = None) -> None:
        config.check()
        self.config = config
        self.arm = arm
        self.gripper = gripper
        self.lock = lock or threading.RLock()
        self.clock = clock
        self._on_event = on_event or (lambda level, text: None)
        self._on_change = on_change or (lambda follower, state: None)
        self.link = (link_factory or (lambda c: ArmLink(c.port, c.baud, c.serial_timeout)))(config)
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._thread: threading.Thread | None = None
        self.connected = False
        self.reason = f"not connected to {config.port} yet"
        self.readbacks = RateCounter()
        self.commands = RateCounter()
        self.stops_sent = 0
        self._last_angles: np.ndarray | None = None
        self._last_read_t = 0.0
        self._velocity = np.zeros(6)
        self._was_active = {id(arm): False}
        if gripper is not None:
            self._was_active[id(gripper)] = False
        self._last_target: np.ndarray | None = None
        self._last_gripper_target: int | None = None
        self._next_gripper_read = 0.0
        self._next_status = 0.0
        self.error_code = 0
        #: when a list: (time, arm readback, desired arm position at that time or None) per readback
        self.trace: list[tuple[float, np.ndarray, np.ndarray | None]] | None = None
        self._set_unavailable(self.reason)

    def _event(self, level: str, text: str) -> None:
        try:
            self._on_event(level, text)
        except Exception:  # noqa: BLE001 - a failing log sink must not stop the loop that keeps the arm safe
            pass

    # ------------------------------------------------------------------ life cycle
    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="mycobot-driver-io", daemon=True)
        self._thread.start()

    def wake(self) -> None:
        """Run the next cycle now (a goal just started: its first command need not wait for the
        period to end)."""
        self._wake.set()

    def close(self, stop_arm: bool = True) -> bool:
        """End the loop; stop the arm (the library's stop command) and close the port. True when
        a stop command reached the port."""
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(3.0)
        sent = False
        if stop_arm and self.link.is_open:
            try:
                self.link.stop()
                self.stops_sent += 1
                sent = True
                self._event("info", f"stop command sent to the arm on {self.config.port}")
            except LinkError as exc:
                self._event("warning", f"could not send the stop command: {exc}")
        self.link.close()
        return sent

    def stats(self) -> dict[str, Any]:
        return {"connected": self.connected, "reason": self.reason, "port": self.config.port,
                "command_rate_hz": self.commands.rate(), "readback_rate_hz": self.readbacks.rate(),
                "error_code": self.error_code, "stops_sent": self.stops_sent}

    # ------------------------------------------------------------------ loop
    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                self._loop()
                return
            except Exception as exc:  # noqa: BLE001 - never let the I/O thread die
                self._event("error", f"driver loop error ({type(exc).__name__}: {exc}); resuming")
                self._stop.wait(0.1)

    def _loop(self) -> None:
        next_try = 0.0
        while not self._stop.is_set():
            if not self.connected:
                now = time.monotonic()
                if now < next_try:
                    self._stop.wait(min(0.05, next_try - now))
                    continue
                next_try = now + self.config.reconnect_period
                self._connect()
                continue
            start = time.monotonic()
            try:
                self._cycle()
            except LinkError as exc:
                self._lost(str(exc))
                next_try = time.monotonic() + self.config.reconnect_period
                continue
            except Exception as exc:  # noqa: BLE001 - a bug must not end the loop that keeps the arm safe
                self._event("error", f"driver loop error ({type(exc).__name__}: {exc}); stopping the arm")
                self._abort_goals(f"driver error: {exc}")
                self._safe_stop()
            spare = self.config.period - (time.monotonic() - start)
            if spare > 0:
                self._wake.wait(spare)
            self._wake.clear()

    def _connect(self) -> None:
        first = self.reason.startswith("not connected")
        try:
            self.link.close()
            self.link.open()
            how = self.link.prepare()
            angles = self.link.get_angles()
            value = self.link.get_gripper_value() if self.gripper is not None else None
            code = self.link.get_error_information()
        except LinkError as exc:
            self.link.close()
            text = str(exc)
            if text != self.reason or first:
                self._event("error" if not first else "warning",
                            f"no arm on {self.config.port}: {text}; retrying every {self.config.reconnect_period:g} s")
            self.reason = text
            self._set_unavailable(f"the arm on {self.config.port} is not connected ({text})")
            return
        now = self.clock()
        q = self.config.to_radians(angles)
        self._last_angles, self._last_read_t, self._velocity = q, now, np.zeros(6)
        with self.lock:
            self.arm.measure(q, None, now)
            if self.gripper is not None and value is not None:
                self.gripper.measure([self.config.gripper_position(value)], None, now)
        self.error_code = code
        self.connected = True
        self.reason = ""
        self._last_target = None
        self._last_gripper_target = None
        self._set_unavailable(self._error_text(code) if code else "")
        self._event("info", f"connected to the arm on {self.config.port} at {self.config.baud} baud ({how}); "
                            f"joints at {[round(a, 2) for a in angles]} deg"
                    + (f", gripper value {value}" if value is not None else ""))

    def _lost(self, reason: str) -> None:
        self.connected = False
        self.reason = reason
        text = f"lost the arm on {self.config.port}: {reason}"
        self._refuse_and_abort(f"the arm on {self.config.port} is not connected ({reason})", text)
        self._safe_stop()
        self.link.close()
        self._event("error", text + f"; goals aborted, reconnecting every {self.config.reconnect_period:g} s")

    def _safe_stop(self) -> None:
        try:
            if self.link.is_open:
                self.link.stop()
                self.stops_sent += 1
        except LinkError:
            pass

    def _set_unavailable(self, text: str) -> None:
        with self.lock:
            for f in self._followers():
                f.unavailable = text

    def _refuse_and_abort(self, refusal: str, reason: str) -> None:
        """New goals refused with ``refusal``, then the running ones aborted with ``reason``, in
        one step under the lock (the node's, not reentrant: taken once): a client that resends
        as soon as its goal is aborted must not start a motion before the refusal is in place
        (seen: a goal accepted while error 17 was being handled)."""
        now = self.clock()
        with self.lock:
            for f in self._followers():
                f.unavailable = refusal
            self._abort_locked(now, reason)

    def _abort_goals(self, reason: str) -> None:
        now = self.clock()
        with self.lock:
            self._abort_locked(now, reason)

    def _abort_locked(self, now: float, reason: str) -> None:
        for f in self._followers():
            for state in f.abort(now, reason):
                self._on_change(f, state)
            self._was_active[id(f)] = False

    def _followers(self) -> list[MeasuredTrajectoryFollower]:
        return [self.arm] + ([self.gripper] if self.gripper is not None else [])

    @staticmethod
    def _error_text(code: int) -> str:
        return f"the arm reports error {code} ({describe_error(code)})"

    def _cycle(self) -> None:
        c = self.config
        angles = self.link.get_angles()
        now = self.clock()
        q = c.to_radians(angles)
        if self._last_angles is not None and now > self._last_read_t:
            raw = (q - self._last_angles) / (now - self._last_read_t)
            self._velocity = 0.5 * self._velocity + 0.5 * raw
        self._last_angles, self._last_read_t = q, now
        self.readbacks.tick(now)
        gripper_value = None
        if self.gripper is not None and (self.gripper.active or now >= self._next_gripper_read):
            gripper_value = self.link.get_gripper_value()
            self._next_gripper_read = now + c.gripper_read_period
        if now >= self._next_status:
            self._next_status = now + c.status_period
            self._check_error(self.link.get_error_information())

        stop = False
        arm_cmd = gripper_cmd = None
        with self.lock:
            self.arm.measure(q, self._velocity, now)
            if self.trace is not None:
                self.trace.append((now, q.copy(), self.arm.desired_at(now)))
            if gripper_value is not None:
                self.gripper.measure([c.gripper_position(gripper_value)], None, now)
            for f in self._followers():
                state = f.update(now)
                if state is not None:
                    self._on_change(f, state)
                was, active = self._was_active[id(f)], f.active
                if was and not active and f.status != "succeeded":
                    stop = True
                self._was_active[id(f)] = active
            if self.arm.active:
                target = self.arm.desired_at(now + c.ahead)
                arm_cmd = (np.array(c.to_degrees(target)), np.array(c.to_degrees(q)))
            if self.gripper is not None and self.gripper.active:
                target_q = float(self.gripper.desired_at(now + c.ahead)[0])
                current = gripper_value if gripper_value is not None else c.gripper_value(
                    float(self.gripper.positions[0]))
                gripper_cmd = (c.gripper_value(target_q), current)
        if stop:
            self.link.stop()
            self.stops_sent += 1
            self._last_target = None
            self._last_gripper_target = None
            self._event("info", "stop command sent: a goal ended before it succeeded")
            return
        if arm_cmd is not None:
            target_deg, actual_deg = arm_cmd
            if self._last_target is None or np.max(np.abs(target_deg - self._last_target)) > 0.005:
                distance = float(np.max(np.abs(target_deg - actual_deg)))
                speed = deg_per_s_to_speed(distance / c.ahead * c.speed_scaling, c.full_speed_deg_s)
                self.link.send_angles(target_deg, speed)
                self._last_target = target_deg
                self.commands.tick(now)
        else:
            self._last_target = None
        if gripper_cmd is not None:
            target_value, current = gripper_cmd
            if target_value != self._last_gripper_target:
                units_s = abs(target_value - current) / c.ahead * c.speed_scaling
                speed = deg_per_s_to_speed(units_s, c.gripper_full_speed)
                self.link.set_gripper_value(target_value, speed)
                self._last_gripper_target = target_value
        else:
            self._last_gripper_target = None

    def _check_error(self, code: int) -> None:
        if code == self.error_code:
            return
        self.error_code = code
        if code:
            text = self._error_text(code)
            self._event("error", f"{text}: stopping the arm, goals aborted, new goals refused until it clears")
            self._refuse_and_abort(text, text)
            self._safe_stop()
        else:
            self._event("info", "the arm's error cleared; goals are accepted again")
            self._set_unavailable("")
