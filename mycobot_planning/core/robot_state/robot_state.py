"""RobotState: one joint vector over the model's active variables, with group views.

A state is a NumPy vector plus a reference to its (immutable, shared) RobotModel, so copying one
is a single array copy: planners and task stages copy states freely. Mimic joints are derived,
never stored. Kinematic queries use the model's shared Pinocchio data buffer (not thread-safe).
"""
from __future__ import annotations

from typing import Iterable, Mapping

import numpy as np
import pinocchio as pin

from ..errors import StateError
from ..robot_model.robot_model import RobotModel

_REFERENCE = {
    "world": pin.ReferenceFrame.LOCAL_WORLD_ALIGNED,
    "local_world_aligned": pin.ReferenceFrame.LOCAL_WORLD_ALIGNED,
    "local": pin.ReferenceFrame.LOCAL,
}


def as_vector(values: Iterable[float] | np.ndarray, size: int, what: str) -> np.ndarray:
    """A finite float vector of the given size, or a StateError naming what was wrong."""
    try:
        arr = np.array(values, dtype=float).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise StateError(f"{what}: not a vector of numbers ({exc})") from None
    if arr.size != size:
        raise StateError(f"{what}: expected {size} values, got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise StateError(f"{what}: contains NaN or infinite values")
    return arr


class RobotState:
    """Positions of every active joint of a RobotModel."""

    __slots__ = ("model", "_positions")

    def __init__(self, model: RobotModel, positions: Iterable[float] | np.ndarray | None = None) -> None:
        self.model = model
        if positions is None:
            self._positions = model.default_positions()
        else:
            self._positions = as_vector(positions, len(model.variable_names), "robot state positions")

    # ------------------------------------------------------------------ values
    @property
    def positions(self) -> np.ndarray:
        """The joint vector, in model.variable_names order (a view: write through set_positions)."""
        return self._positions

    def set_positions(self, values: Iterable[float] | np.ndarray) -> None:
        self._positions = as_vector(values, len(self.model.variable_names), "robot state positions")

    def set_joint_positions(self, values: Mapping[str, float]) -> None:
        """Set some joints by name; mimic joints are refused (they follow their source)."""
        new = self._positions.copy()
        for name, value in values.items():
            try:
                index = self.model.variable_index(name)
            except ValueError:
                raise StateError(
                    f"unknown or non-active joint '{name}'; active joints: {self.model.variable_names}"
                ) from None
            value = float(value)
            if not np.isfinite(value):
                raise StateError(f"joint '{name}': value is NaN or infinite")
            new[index] = value
        self._positions = new

    def joint_position(self, name: str) -> float:
        if name in self.model.mimic_joint_names:
            return self.model.mimic_values(self._positions)[name]
        return float(self._positions[self.model.variable_index(name)])

    def group_positions(self, group: str) -> np.ndarray:
        return self._positions[self.model.group(group).variable_indices].copy()

    def set_group_positions(self, group: str, values: Iterable[float] | np.ndarray) -> None:
        jmg = self.model.group(group)
        arr = as_vector(values, jmg.variable_count, f"positions for group '{group}'")
        new = self._positions.copy()
        new[jmg.variable_indices] = arr
        self._positions = new

    def set_named(self, name: str, group: str | None = None) -> None:
        """Apply an SRDF named state ("home", "ready", "open", ...)."""
        values = self.model.named_state(name, group)
        active = {k: v for k, v in values.items() if k in self.model.variable_names}
        self.set_joint_positions(active)

    def to_joint_dict(self, include_mimic: bool = True) -> dict[str, float]:
        out = {name: float(v) for name, v in zip(self.model.variable_names, self._positions)}
        if include_mimic:
            out.update(self.model.mimic_values(self._positions))
        return out

    def copy(self) -> "RobotState":
        clone = RobotState.__new__(RobotState)
        clone.model = self.model
        clone._positions = self._positions.copy()
        return clone

    # ------------------------------------------------------------------ limits
    def satisfies_bounds(self, margin: float = 0.0) -> bool:
        p = self._positions
        return bool(np.all(p >= self.model.lower_limits - margin) and np.all(p <= self.model.upper_limits + margin))

    def violated_bounds(self, margin: float = 1e-9) -> list[str]:
        """Names of the joints outside their limits, with their values, for error messages."""
        out = []
        for name, value, low, high in zip(
            self.model.variable_names, self._positions, self.model.lower_limits, self.model.upper_limits
        ):
            if value < low - margin or value > high + margin:
                out.append(f"{name}={value:.4f} outside [{low:.4f}, {high:.4f}]")
        return out

    def enforce_bounds(self) -> None:
        self._positions = np.clip(self._positions, self.model.lower_limits, self.model.upper_limits)

    # ------------------------------------------------------------------ kinematics
    @property
    def q(self) -> np.ndarray:
        """Pinocchio configuration vector (mimic joints are derived inside Pinocchio)."""
        return self.model.to_q(self._positions)

    def frame_pose(self, frame: str) -> np.ndarray:
        """4x4 pose of a link or frame in the model root ('world') frame."""
        model = self.model
        fid = model.frame_id(frame)
        pin.forwardKinematics(model.pin_model, model.pin_data, self.q)
        return pin.updateFramePlacement(model.pin_model, model.pin_data, fid).homogeneous.copy()

    def frame_poses(self, frames: Iterable[str]) -> dict[str, np.ndarray]:
        model = self.model
        pin.framesForwardKinematics(model.pin_model, model.pin_data, self.q)
        return {f: model.pin_data.oMf[model.frame_id(f)].homogeneous.copy() for f in frames}

    def jacobian(self, frame: str, group: str | None = None, reference: str = "world") -> np.ndarray:
        """6xN geometric Jacobian (linear; angular) of a frame over a group's (or all) variables.

        reference 'world' gives velocities at the frame origin in world axes (MoveIt's convention);
        'local' gives them in the frame's own axes.
        """
        if reference not in _REFERENCE:
            raise StateError(f"unknown Jacobian reference '{reference}'; use one of {sorted(_REFERENCE)}")
        model = self.model
        fid = model.frame_id(frame)
        full = pin.computeFrameJacobian(model.pin_model, model.pin_data, self.q, fid, _REFERENCE[reference])
        indices = None if group is None else model.group(group).variable_indices
        return full @ model.jacobian_map(indices)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, RobotState) and other.model is self.model and np.array_equal(
            other._positions, self._positions
        )

    def __repr__(self) -> str:
        values = ", ".join(f"{n}={v:.4f}" for n, v in zip(self.model.variable_names, self._positions))
        return f"RobotState({values})"
