"""GenerateRandomPose: the ``pose`` property and random poses around it as ``target_pose``
(MTC's stages::GenerateRandomPose).

Each added dimension sampler (``sampleDimension``) moves or turns a copy of the seed pose, in
the order they were added, in the pose's own frame; up to ``max_solutions`` targets (the seed
first) within the stage's ``timeout`` (1 s by default, as in MTC). MTC's Python bindings offer no
way to add samplers, so there the stage spawns nothing; here without samplers it spawns the seed
pose alone, as GeneratePose does. Random numbers come from the task's seed when it has one.
"""
from __future__ import annotations

import time
from enum import IntEnum
from typing import Iterator

import numpy as np
import pinocchio as pin

from ..errors import TaskError
from ..geometry import PoseStamped
from .generate_pose import GeneratePose


class PoseDimension(IntEnum):
    """MTC's stages.PoseDimension: what a sampler of GenerateRandomPose varies."""

    X = 0
    Y = 1
    Z = 2
    ROLL = 3
    PITCH = 4
    YAW = 5


class GenerateRandomPose(GeneratePose):
    PoseDimension = PoseDimension
    X, Y, Z, ROLL, PITCH, YAW = PoseDimension
    _DIMENSIONS = {d.name: d for d in PoseDimension}

    def __init__(self, name: str = "generate random pose", monitored=None) -> None:
        super().__init__(name, monitored)
        p = self._properties
        p.declare("max_solutions", 20, "maximum number of spawned solutions", type=int)
        p.property("pose").setDescription("seed pose")
        p.property("timeout").setDefaultValue(1.0)
        self._samplers: list[tuple[int, float, str]] = []

    def sampleDimension(self, dimension: int | str, width: float, distribution: str = "normal") -> None:
        """Randomise one dimension (X, Y, Z in m, ROLL, PITCH, YAW in rad): ``normal`` with
        standard deviation ``width`` or ``uniform`` over a range ``width`` centred on the seed."""
        dof = self._DIMENSIONS.get(dimension.upper()) if isinstance(dimension, str) else dimension
        if dof not in range(6):
            raise TaskError(f"stage '{self._name}': unknown pose dimension {dimension!r}; expected "
                            f"{', '.join(self._DIMENSIONS)}")
        if distribution not in ("normal", "uniform"):
            raise TaskError(f"stage '{self._name}': distribution must be 'normal' or 'uniform', got {distribution!r}")
        if not (isinstance(width, (int, float)) and np.isfinite(width) and width >= 0.0):
            raise TaskError(f"stage '{self._name}': sampler width must be a number >= 0, got {width!r}")
        self._samplers.append((int(dof), float(width), distribution))

    def sample_dimension(self, pose_dimension: int | str, width: float) -> None:
        """MTC's Python form: a uniform sampler over a range ``width`` centred on the seed."""
        self.sampleDimension(pose_dimension, width, "uniform")

    def set_max_solutions(self, max_solutions: int) -> None:
        """MTC's Python form of ``max_solutions = n``."""
        self._properties["max_solutions"] = max_solutions

    def _targets(self, seed: PoseStamped) -> Iterator[PoseStamped]:
        yield seed
        if not self._samplers:
            return
        context = self._context
        rng = np.random.default_rng(None if context is None else context.next_seed())
        limit = int(self._properties["max_solutions"])
        deadline = time.monotonic() + self.timeout_or(1.0)
        for _ in range(limit - 1):
            if time.monotonic() >= deadline:
                return
            pose = np.array(seed.pose, dtype=float)
            for dof, width, distribution in self._samplers:
                value = rng.normal(0.0, width) if distribution == "normal" else rng.uniform(-0.5 * width, 0.5 * width)
                step = np.eye(4)
                if dof < 3:
                    step[dof, 3] = value
                else:
                    axis = np.zeros(3)
                    axis[dof - 3] = value
                    step[:3, :3] = pin.exp3(axis)
                pose = pose @ step  # in the pose's own frame, as MTC's Isometry3d translate/rotate
            yield PoseStamped(seed.frame_id, pose)
