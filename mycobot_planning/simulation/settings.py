"""How the robot is simulated: time step, servo gains, gripper, contact and camera settings.

One dataclass per concern, read from ``config/mujoco_sim.yaml`` (a ROS parameter file, so the
``mujoco_sim`` node of a later part loads the same file). Why each value is what it is:
docs/simulation.md, sections "Servo gains" and "Contact".
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, is_dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..paths import read_yaml_file
from .errors import SimulationModelError

NODE_NAME = "mujoco_sim"


def finite_number(name: str, value: Any, low: float = -math.inf, high: float = math.inf, *,
                  low_open: bool = False) -> float:
    """``value`` as a float, or SimulationModelError naming ``name`` and the bound it breaks."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SimulationModelError(f"{name} must be a finite number, got {value!r}")
    if value < low or value > high or (low_open and value == low):
        bound = f"> {low:g}" if low_open else f">= {low:g}"
        upper = "" if high == math.inf else f" and <= {high:g}"
        raise SimulationModelError(f"{name} must be {bound}{upper}, got {value!r}")
    return float(value)


def friction_triple(name: str, value: Any) -> tuple[float, float, float]:
    """MuJoCo friction [sliding, torsional, rolling] from 1 to 3 numbers >= 0 (missing ones:
    MuJoCo's defaults)."""
    values = [value] if isinstance(value, (int, float)) and not isinstance(value, bool) else value
    if isinstance(values, np.ndarray):
        values = values.tolist()
    if not isinstance(values, (list, tuple)) or not 1 <= len(values) <= 3:
        raise SimulationModelError(f"{name} must be 1 to 3 numbers [sliding, torsional, rolling], got {value!r}")
    out = [finite_number(f"{name}[{i}]", v, 0.0) for i, v in enumerate(values)]
    defaults = (1.0, 0.005, 0.0001)  # MuJoCo's defaults for the missing ones
    return tuple(out + list(defaults[len(out):]))  # type: ignore[return-value]


@dataclass(frozen=True)
class ArmServoSettings:
    """Position servo of every arm joint: a MuJoCo position actuator (kp, kv) per joint.

    ``kp = (I + armature) * (2 pi bandwidth_hz)^2`` and ``kv = 2 damping_ratio sqrt(kp (I +
    armature))`` with I the joint's own inertia at the model's reference pose, so every joint
    answers like a second-order system of that bandwidth. ``velocity_feedforward`` shifts the
    actuator's target by ``kv/kp x`` the commanded velocity, which turns the actuator into
    ``kp (q_ref - q) + kv (qd_ref - qd)``: a servo that tracks a moving target without lag, as a
    position+velocity command interface gives. ``gravity_compensation`` adds the robot's own
    weight to the actuator force (MuJoCo gravcomp through the actuators, clamped with them at the
    joint's effort limit): the servos' integral action. Payloads are not compensated.
    ``effort_limit`` (N m): the most each arm servo exerts, gravity compensation included (0: the
    URDF's effort limit of each joint)."""

    bandwidth_hz: float = 10.0
    damping_ratio: float = 1.0
    armature: float = 0.005
    velocity_feedforward: bool = True
    gravity_compensation: bool = True
    effort_limit: float = 0.0

    def __post_init__(self) -> None:
        finite_number("arm_servo.effort_limit", self.effort_limit, 0.0)
        finite_number("arm_servo.bandwidth_hz", self.bandwidth_hz, 0.0, low_open=True)
        finite_number("arm_servo.damping_ratio", self.damping_ratio, 0.0, low_open=True)
        finite_number("arm_servo.armature", self.armature, 0.0)


@dataclass(frozen=True)
class GripperSettings:
    """The gripper: one position actuator on the gripper group's joint, the mimic joints held to
    it by equality constraints, and the GripperActionController's goal and stall rules (its
    parameter names and defaults: goal_tolerance 0.01, stall_velocity_threshold 0.001 (unit/s),
    stall_timeout 1.0 s). The servo's force is clamped to a command's ``max_effort`` (0: the
    joint's effort limit from the URDF)."""

    bandwidth_hz: float = 50.0
    damping_ratio: float = 1.0
    armature: float = 0.0005
    goal_tolerance: float = 0.01
    stall_velocity_threshold: float = 0.001
    stall_timeout: float = 1.0

    def __post_init__(self) -> None:
        finite_number("gripper.bandwidth_hz", self.bandwidth_hz, 0.0, low_open=True)
        finite_number("gripper.damping_ratio", self.damping_ratio, 0.0, low_open=True)
        finite_number("gripper.armature", self.armature, 0.0)
        finite_number("gripper.goal_tolerance", self.goal_tolerance, 0.0)
        finite_number("gripper.stall_velocity_threshold", self.stall_velocity_threshold, 0.0)
        finite_number("gripper.stall_timeout", self.stall_timeout, 0.0)


@dataclass(frozen=True)
class FingertipSettings:
    """Contact of the finger pads (the collision geometry of ``fingertip_links``).

    ``margin``: the pads' rubber, modelled as a contact that starts this far from the rigid
    collision box (m) and pushes back softly (``solref``: time constant and damping ratio of the
    contact spring); ``condim`` 4 adds torsional friction so a held object cannot spin about the
    pad normal, 6 also rolling friction."""

    condim: int = 4
    friction: tuple[float, float, float] = (1.0, 0.005, 0.0001)
    margin: float = 0.0005
    solref: tuple[float, float] = (0.002, 1.0)

    def __post_init__(self) -> None:
        if self.condim not in (1, 3, 4, 6):
            raise SimulationModelError(f"contact.fingertip.condim must be 1, 3, 4 or 6, got {self.condim!r}")
        object.__setattr__(self, "friction", friction_triple("contact.fingertip.friction", self.friction))
        finite_number("contact.fingertip.margin", self.margin, 0.0, 0.01)
        if len(self.solref) != 2:
            raise SimulationModelError(f"contact.fingertip.solref must be [timeconst, dampratio], got {self.solref!r}")
        finite_number("contact.fingertip.solref[0]", self.solref[0], 0.0, low_open=True)
        finite_number("contact.fingertip.solref[1]", self.solref[1], 0.0, low_open=True)
        object.__setattr__(self, "solref", (float(self.solref[0]), float(self.solref[1])))


@dataclass(frozen=True)
class ContactSettings:
    """Solver options for contacts: elliptic friction cones, ``impratio`` (how much harder
    friction is enforced than normal contact: a high value keeps held objects from creeping)
    and MuJoCo's noslip post-pass (0: off)."""

    cone: str = "elliptic"
    impratio: float = 10.0
    noslip_iterations: int = 10
    fingertip: FingertipSettings = field(default_factory=FingertipSettings)

    def __post_init__(self) -> None:
        if self.cone not in ("elliptic", "pyramidal"):
            raise SimulationModelError(f"contact.cone must be 'elliptic' or 'pyramidal', got {self.cone!r}")
        finite_number("contact.impratio", self.impratio, 1.0)
        if isinstance(self.noslip_iterations, bool) or not isinstance(self.noslip_iterations, int) \
                or self.noslip_iterations < 0:
            raise SimulationModelError(f"contact.noslip_iterations must be an integer >= 0, got "
                                       f"{self.noslip_iterations!r}")


@dataclass(frozen=True)
class SimulationSettings:
    """Everything about simulating the robot (the world comes from the scene file)."""

    timestep: float = 0.001
    integrator: str = "implicitfast"
    speed_factor: float = 1.0
    arm_group: str = "arm"
    gripper_group: str = "gripper"
    #: links whose collision geometry are the finger pads (empty: the gripper group's leaf links)
    fingertip_links: tuple[str, ...] = ()
    camera_rate: float = 10.0
    arm_servo: ArmServoSettings = field(default_factory=ArmServoSettings)
    gripper: GripperSettings = field(default_factory=GripperSettings)
    contact: ContactSettings = field(default_factory=ContactSettings)

    def __post_init__(self) -> None:
        finite_number("timestep", self.timestep, 0.0002, 0.002)
        if self.integrator not in ("Euler", "RK4", "implicit", "implicitfast"):
            raise SimulationModelError(f"integrator must be one of Euler, RK4, implicit, implicitfast, got "
                                       f"{self.integrator!r}")
        finite_number("speed_factor", self.speed_factor, 0.0, 100.0, low_open=True)
        finite_number("camera_rate", self.camera_rate, 0.0, 60.0)
        for name in ("arm_group", "gripper_group"):
            if not isinstance(getattr(self, name), str):
                raise SimulationModelError(f"{name} must be a group name (a string)")
        object.__setattr__(self, "fingertip_links", tuple(self.fingertip_links))

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any], what: str = "settings") -> "SimulationSettings":
        """From the nested mapping of the parameter file; unknown keys are refused by name."""
        return _build(cls, data, what)


def _build(kind: type, data: Any, where: str) -> Any:
    if not isinstance(data, Mapping):
        raise SimulationModelError(f"{where} must be a mapping, got {type(data).__name__}")
    known = {f.name: f for f in fields(kind)}
    unknown = sorted(set(data) - set(known))
    if unknown:
        raise SimulationModelError(f"{where}: unknown keys {unknown} (known: {sorted(known)})")
    values: dict[str, Any] = {}
    for name, value in data.items():
        default = known[name].default_factory() if callable(known[name].default_factory) else known[name].default
        if is_dataclass(default):
            values[name] = _build(type(default), value, f"{where}.{name}")
        elif isinstance(default, tuple):
            if not isinstance(value, (list, tuple)):
                raise SimulationModelError(f"{where}.{name} must be a list, got {value!r}")
            values[name] = tuple(value)
        else:
            values[name] = value
    try:
        return kind(**values)
    except TypeError as exc:
        raise SimulationModelError(f"{where}: {exc}") from None


def load_settings(path: str | Path) -> SimulationSettings:
    """Settings from a parameter file (``mujoco_sim: ros__parameters: {...}`` or a plain map)."""
    data = read_yaml_file(path, SimulationModelError, f"simulation settings '{path}'") or {}
    if isinstance(data, Mapping) and NODE_NAME in data:
        data = data[NODE_NAME]
    if isinstance(data, Mapping) and "ros__parameters" in data:
        data = data["ros__parameters"] or {}
    try:
        return SimulationSettings.from_mapping(data, NODE_NAME)
    except SimulationModelError as exc:
        raise SimulationModelError(f"{path}: {exc}") from None
