"""MoveIt's CartesianPrecision: how far a Cartesian path may leave its straight line.

A Cartesian path is a chain of IK solutions; the robot moves between them in joint space, and
there its ik frame bulges away from the line, most halfway between two states. MoveIt (Jazzy)
bounds that bulge: ``translational`` m and ``rotational`` rad at most, refining the steps until
it holds or until a step would be shorter than ``max_resolution`` of the whole path, where the
path stops. compute_cartesian_path does the same with :class:`PrecisionCheck` (forward
kinematics at the joint-space midpoint of a step) and halves its steps until the check passes.

Most steps are far too short to bulge: along a joint-space line with steps delta, the ik frame's
second derivative is at most (sum |delta_j|)^2 x R in position (R bounds the distance from any
joint of the chain to the frame: the sum of the chain's link offsets) and (sum |delta_j|)^2 in
angle, and a curve leaves its chord by at most an eighth of that. A step whose bound (plus the
IK tolerance; the angle's bound doubled, as it holds to first order only) is within the
precision needs no forward kinematics (:meth:`PrecisionCheck.needs_check`); chains with a
prismatic joint are always checked.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ...robot_model.robot_model import group_configuration

__all__ = ["CartesianPrecision", "PrecisionCheck"]


@dataclass
class CartesianPrecision:
    """MoveIt's defaults: 1 mm, 0.01 rad, steps down to 1e-5 of the path."""

    translational: float = 0.001  # m: the ik frame's largest distance from the line
    rotational: float = 0.01  # rad: its largest angle from the interpolated orientation
    max_resolution: float = 1e-5  # the shortest step, as a fraction of the whole path

    def __post_init__(self) -> None:
        for name in ("translational", "rotational", "max_resolution"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
                raise ValueError(f"CartesianPrecision.{name} must be a number > 0, got {value!r}")
            setattr(self, name, float(value))

    def __str__(self) -> str:
        return (f"CartesianPrecision(translational={self.translational:g}, rotational={self.rotational:g}, "
                f"max_resolution={self.max_resolution:g})")


class PrecisionCheck:
    """The ik frame halfway between two consecutive states of a group, against the straight
    line between their targets. Its own Pinocchio data: the caller's IK solver keeps views
    into the model's shared one."""

    def __init__(self, model, group_indices: np.ndarray, link: str, offset: np.ndarray | None,
                 full: np.ndarray, precision: CartesianPrecision, revolute_only: bool = False,
                 tolerances: tuple[float, float] = (0.0, 0.0)) -> None:
        self.precision = precision
        self.model = model
        self.pmodel = model.pin_model
        self.pdata = None  # made on the first check: most paths never need one
        self.fid = model.frame_id(link)
        self.idx = np.asarray(group_indices)
        self.dof = len(self.idx)
        self.full = np.array(full, dtype=float)
        self.q: np.ndarray | None = None  # the configuration buffer, made with pdata on the first check
        self.offset = None if offset is None else np.asarray(offset, dtype=float)
        # R: an upper bound on the distance from any joint of the chain to the ik frame
        reach = _chain_reach(model, self.fid)
        if self.offset is not None:
            reach += math.sqrt(float(self.offset[:3, 3] @ self.offset[:3, 3]))
        # the largest sum |delta_j| whose bounds (plus the IK tolerances) stay within the precision
        position_tolerance, orientation_tolerance = tolerances
        room = min((precision.translational - position_tolerance) * 8.0 / max(reach, 1e-9),
                   (precision.rotational - orientation_tolerance) * 4.0)
        self._skip_below = math.sqrt(room) if revolute_only and room > 0 else 0.0

    def needs_check(self, delta: np.ndarray, largest: float) -> bool:
        """False when the step ``delta`` (group values; ``largest`` its largest magnitude) is
        provably too short to miss the precision."""
        if largest * self.dof < self._skip_below:  # sum |delta_j| <= dof x largest: no sum needed
            return False
        return float(np.abs(delta).sum()) >= self._skip_below

    def needs_checks(self, deltas: np.ndarray, largest: np.ndarray) -> np.ndarray:
        """:meth:`needs_check` for many steps at once (rows of ``deltas``; ``largest`` their
        largest magnitudes): a boolean per step."""
        deltas = np.asarray(deltas, dtype=float)
        if not self._skip_below:
            return np.ones(len(deltas), dtype=bool)
        candidates = np.asarray(largest, dtype=float) * self.dof >= self._skip_below
        if not candidates.any():
            return candidates
        return candidates & (np.abs(deltas).sum(axis=1) >= self._skip_below)

    def deviation(self, a: np.ndarray, b: np.ndarray, p0: np.ndarray, r0: np.ndarray, p1: np.ndarray,
                  r1: np.ndarray) -> tuple[float, float]:
        """(m, rad): how far the ik frame is, halfway from group values ``a`` to ``b``, from the
        midpoint of the targets (p0, r0) -> (p1, r1)."""
        x = 0.5 * (np.asarray(a) + np.asarray(b))
        if self.pdata is None:
            self.pdata = self.pmodel.createData()
            self.slots = self.model.q_slots(self.idx)
            self.q = np.array(self.model.to_q(self.full), dtype=float)
        q = group_configuration(self.model, x, self.slots, self.q, self.full, self.idx)
        pin.forwardKinematics(self.pmodel, self.pdata, q)
        placement = pin.updateFramePlacement(self.pmodel, self.pdata, self.fid)
        rotation = placement.rotation
        position = placement.translation
        if self.offset is not None:
            position = position + rotation @ self.offset[:3, 3]
            rotation = rotation @ self.offset[:3, :3]
        expected_rotation = r0 @ pin.exp3(0.5 * pin.log3(r0.T @ r1))
        translational = float(np.linalg.norm(position - 0.5 * (p0 + p1)))
        rotational = float(np.linalg.norm(pin.log3(expected_rotation.T @ rotation)))
        return translational, rotational

    def exceeded(self, translational: float, rotational: float) -> bool:
        return translational > self.precision.translational or rotational > self.precision.rotational


def _chain_reach(model, fid: int) -> float:
    """The sum of the offsets of the frame and of every joint above it: no joint of the chain is
    farther from the frame, whatever the configuration (cached on the model, per frame)."""
    def measure() -> float:
        pmodel = model.pin_model
        frame = pmodel.frames[fid]
        reach = float(np.linalg.norm(frame.placement.translation))
        joint = frame.parentJoint
        while joint > 0:
            reach += float(np.linalg.norm(pmodel.jointPlacements[joint].translation))
            joint = pmodel.parents[joint]
        return reach

    return model.cached(("chain_reach", fid), measure)
