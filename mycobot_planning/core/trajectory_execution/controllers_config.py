"""ros2_control's controllers file (controller_manager.ros__parameters lists each controller
and its type; each controller has its own ros__parameters): the one parser of it. The mock
controllers build their controllers from it; the planning_server's execution reads which
controllers drive which joints from it (or from MoveIt's moveit_controllers.yaml, see
execution.load_controllers)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

from ...paths import read_yaml_file
from ..errors import PlanningError


class ControllerConfigError(PlanningError, ValueError):
    """controllers.yaml is malformed or names joints the robot does not have."""


# --------------------------------------------------------------------------------- config

JTC_TYPE = "joint_trajectory_controller/JointTrajectoryController"
#: ros2_control's gripper controller; the mock drives it like a one-joint JTC (JointTrajectory in),
#: so that a real setup's controllers file (``joint: <name>``) loads unchanged.
GRIPPER_TYPE = "position_controllers/GripperActionController"
BROADCASTER_TYPE = "joint_state_broadcaster/JointStateBroadcaster"


@dataclass(frozen=True)
class ControllerConfig:
    name: str
    joints: tuple[str, ...]
    update_rate: float
    goal_tolerance: float
    start_tolerance: float
    type: str = JTC_TYPE


@dataclass(frozen=True)
class ControllerManagerConfig:
    update_rate: float
    controllers: tuple[ControllerConfig, ...]
    broadcasters: tuple[str, ...]


def read_controllers_source(source: str | Path | Mapping[str, Any], what: str) -> tuple[Mapping[str, Any], str]:
    """(content, how to name it in messages) of a controllers file or of its parsed content."""
    if isinstance(source, Mapping):
        data: Any = dict(source)
        where = what
    else:
        where = f"controllers file '{source}'"
        data = read_yaml_file(source, ControllerConfigError, where)
    if not isinstance(data, Mapping):
        raise ControllerConfigError(f"{where} must hold a mapping at the top level")
    return data, where


def load_controllers_config(
    source: str | Path | Mapping[str, Any], active_joints: Sequence[str] | None = None,
    skip_other_types: bool = False,
) -> ControllerManagerConfig:
    """Parse controllers.yaml (ros2_control layout: ``controller_manager.ros__parameters`` lists
    the controllers and their types, each controller has its own ``ros__parameters``).

    With `active_joints`, every controller joint must be one of them (no mimic or fixed joints)
    and no joint may belong to two controllers. With `skip_other_types`, controllers of other
    types than trajectory and gripper controllers are ignored (a real stack has forward command
    controllers and the like; only a simulation of them must refuse what it cannot simulate).
    """
    data, where = read_controllers_source(source, "controllers config")

    def params(section: str) -> Mapping[str, Any]:
        entry = data.get(section)
        value = entry.get("ros__parameters") if isinstance(entry, Mapping) else None
        if not isinstance(value, Mapping):
            raise ControllerConfigError(f"{where}: missing '{section}: ros__parameters:' section")
        return value

    def rate(value: Any, what: str) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (0 < float(value) <= 10000):
            raise ControllerConfigError(f"{where}: {what} must be a number in (0, 10000] Hz, got {value!r}")
        return float(value)

    manager = params("controller_manager")
    cm_rate = rate(manager.get("update_rate", 100), "controller_manager.update_rate")
    controllers: list[ControllerConfig] = []
    broadcasters: list[str] = []
    owner: dict[str, str] = {}
    for name, entry in manager.items():
        if name == "update_rate":
            continue
        if not isinstance(entry, Mapping) or "type" not in entry:
            raise ControllerConfigError(f"{where}: controller_manager entry '{name}' needs a 'type'")
        ctype = entry["type"]
        if ctype == BROADCASTER_TYPE:
            broadcasters.append(str(name))
            continue
        if ctype not in (JTC_TYPE, GRIPPER_TYPE):
            if skip_other_types:
                continue
            raise ControllerConfigError(
                f"{where}: controller '{name}' has type '{ctype}'; supported: {JTC_TYPE}, {GRIPPER_TYPE}, "
                f"{BROADCASTER_TYPE}")
        cfg = params(name)
        joints = cfg.get("joints")
        if joints is None and ctype == GRIPPER_TYPE and isinstance(cfg.get("joint"), str):
            joints = [cfg["joint"]]
        if (not isinstance(joints, list) or not joints
                or not all(isinstance(j, str) and j for j in joints) or len(set(joints)) != len(joints)):
            raise ControllerConfigError(f"{where}: {name}.joints must be a non-empty list of distinct joint names")
        for joint in joints:
            if active_joints is not None and joint not in active_joints:
                raise ControllerConfigError(
                    f"{where}: {name} names joint '{joint}', which is not an active joint of the robot "
                    f"(active: {list(active_joints)})")
            if joint in owner:
                raise ControllerConfigError(f"{where}: joint '{joint}' belongs to both {owner[joint]} and {name}")
            owner[joint] = name
        tolerances = {}
        for key, default in (("goal_tolerance", 0.01), ("start_tolerance", 0.05)):
            value = cfg.get(key, default)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
                    math.isfinite(value) and value >= 0):
                raise ControllerConfigError(f"{where}: {name}.{key} must be a number >= 0, got {value!r}")
            tolerances[key] = float(value)
        c_rate = rate(cfg.get("update_rate", cm_rate), f"{name}.update_rate")
        if c_rate > cm_rate:
            # As in ros2_control: a controller runs every N-th loop of the manager, never faster.
            raise ControllerConfigError(
                f"{where}: {name}.update_rate ({c_rate:g} Hz) exceeds controller_manager.update_rate "
                f"({cm_rate:g} Hz)")
        controllers.append(ControllerConfig(name=str(name), joints=tuple(joints), update_rate=c_rate,
                                            type=str(ctype), **tolerances))
    if not controllers:
        raise ControllerConfigError(f"{where}: no controllers of type {JTC_TYPE} or {GRIPPER_TYPE}")
    return ControllerManagerConfig(cm_rate, tuple(controllers), tuple(broadcasters))
