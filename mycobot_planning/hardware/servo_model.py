"""The emulated arm's servos: each joint moves toward its commanded angle at the commanded speed
(no acceleration phase), the readback lags by a latency and carries encoder noise, and faults can
be injected (a stalled servo, an error code). ROS-free, driven by explicit timestamps.

Units are the firmware's: degrees, speed 1-100 (% of ``full_speed_deg_s``), gripper value 0-100.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

#: The firmware's joint limits of the myCobot 280 (degrees), as pymycobot 4.0.7 checks them for
#: its MyCobot280 class (robot_info.py); the emulator clamps commands to them as the firmware does.
FIRMWARE_MIN_DEG = (-168.0, -140.0, -150.0, -150.0, -155.0, -180.0)
FIRMWARE_MAX_DEG = (168.0, 140.0, 150.0, 150.0, 160.0, 180.0)

#: get_error_information codes (pymycobot's docstring of MyCobot280.get_error_information)
ERROR_CODES = {0: "no error", 1: "joint 1 exceeds its limit", 2: "joint 2 exceeds its limit",
               3: "joint 3 exceeds its limit", 4: "joint 4 exceeds its limit", 5: "joint 5 exceeds its limit",
               6: "joint 6 exceeds its limit", 16: "collision protection", 17: "collision protection",
               18: "collision protection", 19: "collision protection",
               32: "inverse kinematics has no solution", 33: "linear motion has no adjacent solution",
               34: "linear motion has no adjacent solution"}


def describe_error(code: int) -> str:
    return ERROR_CODES.get(int(code), f"error code {int(code)}")


@dataclass
class ServoConfig:
    #: deg/s of a joint at speed 100 (the joint velocity limit of config/joint_limits.yaml:
    #: 2.792527 rad/s = 160 deg/s)
    full_speed_deg_s: float = 160.0
    #: gripper value units per second at speed 100 (the adaptive gripper needs 0.5 s for its
    #: full travel)
    gripper_full_speed: float = 200.0
    #: s between the servos' state and what get_angles reports
    readback_latency: float = 0.010
    #: degrees, standard deviation of the encoder noise on get_angles (rounded to 0.01 deg)
    noise_deg: float = 0.05
    initial_deg: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    initial_gripper: int = 100
    seed: int = 0
    min_deg: tuple[float, ...] = FIRMWARE_MIN_DEG
    max_deg: tuple[float, ...] = FIRMWARE_MAX_DEG


@dataclass
class _Sample:
    t: float
    angles: np.ndarray


class ServoModel:
    """Six joint servos and the gripper. Not thread-safe: the emulator serialises calls."""

    HISTORY_S = 1.0

    def __init__(self, config: ServoConfig | None = None, now: float = 0.0) -> None:
        self.config = config or ServoConfig()
        c = self.config
        self.min = np.array(c.min_deg, dtype=float)
        self.max = np.array(c.max_deg, dtype=float)
        self.angles = np.clip(np.array(c.initial_deg, dtype=float), self.min, self.max)
        self.targets = self.angles.copy()
        self.speeds = np.zeros(6)  # deg/s toward the targets
        self.gripper = float(c.initial_gripper)
        self.gripper_target = self.gripper
        self.gripper_speed = 0.0
        self.powered = True
        self.error_code = 0
        self.servo_status = [0] * 6
        self.stalled: set[int] = set()  # joint indices 0..5 whose servo does not move
        self.gripper_block: float | None = None  # an object between the fingers: closing stops here
        self._rng = np.random.default_rng(c.seed)
        self._now = now
        self._history: deque[_Sample] = deque()
        self._history.append(_Sample(now, self.angles.copy()))

    # ------------------------------------------------------------------ time
    def advance(self, now: float) -> None:
        dt = now - self._now
        if dt <= 0:
            return
        self._now = now
        if self.powered:
            step = self.speeds * dt
            delta = self.targets - self.angles
            move = np.clip(delta, -step, step)
            for j in self.stalled:
                move[j] = 0.0
            self.angles += move
            g_step = self.gripper_speed * dt
            moved = self.gripper + max(-g_step, min(g_step, self.gripper_target - self.gripper))
            if self.gripper_block is not None and moved < self.gripper_block <= self.gripper:
                moved = self.gripper_block
            self.gripper = moved
        self._history.append(_Sample(now, self.angles.copy()))
        while len(self._history) > 2 and self._history[1].t < now - self.HISTORY_S:
            self._history.popleft()

    @property
    def moving(self) -> bool:
        return bool(np.any(np.abs(self.targets - self.angles) > 1e-6) and self.powered)

    # ------------------------------------------------------------------ commands
    def _speed(self, speed: int) -> float:
        return max(1, min(100, int(speed))) / 100.0 * self.config.full_speed_deg_s

    def send_angles(self, degrees: list[float], speed: int) -> None:
        if not self.powered:
            return
        self.targets = np.clip(np.array(degrees[:6], dtype=float), self.min, self.max)
        self.speeds = np.full(6, self._speed(speed))

    def send_angle(self, joint: int, degree: float, speed: int) -> None:
        if not self.powered or not 1 <= joint <= 6:
            return
        j = joint - 1
        self.targets[j] = min(max(degree, self.min[j]), self.max[j])
        self.speeds[j] = self._speed(speed)

    def stop(self) -> None:
        """The firmware's stop: every joint halts where it is."""
        self.targets = self.angles.copy()
        self.gripper_target = self.gripper

    def set_gripper(self, value: int, speed: int) -> None:
        if not self.powered:
            return
        self.gripper_target = float(max(0, min(100, int(value))))
        self.gripper_speed = max(1, min(100, int(speed))) / 100.0 * self.config.gripper_full_speed

    def power_on(self) -> None:
        self.powered = True

    def power_off(self) -> None:
        self.powered = False
        self.stop()

    # ------------------------------------------------------------------ readback
    def read_angles(self) -> list[float]:
        """What get_angles answers: the servos' angles `readback_latency` ago, with noise."""
        t = self._now - self.config.readback_latency
        sample = self._history[0]
        for s in self._history:
            if s.t > t:
                break
            sample = s
        noise = self._rng.normal(0.0, self.config.noise_deg, 6) if self.config.noise_deg > 0 else 0.0
        values = sample.angles + noise
        return [round(float(v), 2) for v in values]

    def read_gripper(self) -> int:
        return int(round(self.gripper))

    def true_angles(self) -> list[float]:
        return [float(v) for v in self.angles]

    # ------------------------------------------------------------------ faults
    def stall(self, joint: int, on: bool = True) -> None:
        """joint 1..6 (0: all)."""
        joints = range(6) if joint == 0 else [joint - 1]
        for j in joints:
            (self.stalled.add if on else self.stalled.discard)(j)

    def set_error(self, code: int, joint: int = 0) -> None:
        self.error_code = int(code)
        if 1 <= joint <= 6:
            self.servo_status[joint - 1] = 1 if code else 0
        if code:
            self.stop()

    def block_gripper(self, value: float | None) -> None:
        """An object the fingers close on: the gripper value stops at `value` (None: no object)."""
        self.gripper_block = None if value is None else float(value)

    def clear_faults(self) -> None:
        self.stalled.clear()
        self.gripper_block = None
        self.error_code = 0
        self.servo_status = [0] * 6


def deg_per_s_to_speed(deg_s: float, full_speed_deg_s: float) -> int:
    """The speed byte (1-100) that moves a joint at least `deg_s`."""
    if not math.isfinite(deg_s) or deg_s <= 0:
        return 1
    return max(1, min(100, int(math.ceil(deg_s / full_speed_deg_s * 100.0 - 1e-9))))


__all__ = ["ServoConfig", "ServoModel", "FIRMWARE_MIN_DEG", "FIRMWARE_MAX_DEG", "describe_error",
           "deg_per_s_to_speed"]
