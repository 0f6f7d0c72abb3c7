"""Trajectories and results: trajectory_msgs' JointTrajectory, moveit_msgs' RobotTrajectory and MoveItErrorCodes."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from .base import MessageError, _Message, _require_unique_names


@dataclass
class JointTrajectoryPoint(_Message):
    """trajectory_msgs/JointTrajectoryPoint with ``time_from_start`` as float seconds (>= 0).

    Float seconds keep JSON readable; ros_conversions maps to sec/nanosec exactly to the ns.
    ``velocities``/``accelerations`` are empty or one per position.
    """

    positions: list[float]
    velocities: list[float] = field(default_factory=list)
    accelerations: list[float] = field(default_factory=list)
    time_from_start: float = 0.0

    def _validate(self) -> None:
        n = len(self.positions)
        for fname in ("velocities", "accelerations"):
            values = getattr(self, fname)
            if values and len(values) != n:
                raise MessageError(f"JointTrajectoryPoint.{fname}",
                                   f"expected {n} values (one per position, or none), got {len(values)}")
        if self.time_from_start < 0:
            raise MessageError("JointTrajectoryPoint.time_from_start", f"must be >= 0, got {self.time_from_start}")


@dataclass
class JointTrajectory(_Message):
    """trajectory_msgs/JointTrajectory: waypoints over ``joint_names`` with non-decreasing times.

    Every point must give one position per joint name, which is what controllers require; the
    header stamp is not part of the JSON (it is set when publishing).
    """

    joint_names: list[str]
    points: list[JointTrajectoryPoint]
    frame_id: str = ""

    def _validate(self) -> None:
        _require_unique_names("JointTrajectory.joint_names", self.joint_names)
        n = len(self.joint_names)
        previous = 0.0
        for i, p in enumerate(self.points):
            if len(p.positions) != n:
                raise MessageError(f"JointTrajectory.points[{i}].positions",
                                   f"expected {n} positions (one per joint name), got {len(p.positions)}")
            if p.time_from_start < previous:
                raise MessageError(f"JointTrajectory.points[{i}].time_from_start",
                                   f"{p.time_from_start} is earlier than the previous point's {previous}")
            previous = p.time_from_start

    @classmethod
    def from_arrays(cls, joint_names: list[str], times: Any, positions: Any, velocities: Any,
                    accelerations: Any = None) -> "JointTrajectory":
        """The trajectory of (N,) times and (N, joints) arrays, checked as arrays (shapes, finite
        values, times >= 0 and non-decreasing) rather than value by value: the same rules as the
        constructor at a fraction of its cost for the hundreds of points of a planned motion."""
        trajectory = cls(joint_names=list(joint_names), points=[])  # checks the names
        n = len(trajectory.joint_names)
        arrays = {"time_from_start": np.asarray(times, dtype=float), "positions": np.asarray(positions, dtype=float),
                  "velocities": np.asarray(velocities, dtype=float)}
        if accelerations is not None:
            arrays["accelerations"] = np.asarray(accelerations, dtype=float)
        count = arrays["time_from_start"].shape[0] if arrays["time_from_start"].ndim == 1 else -1
        for name, values in arrays.items():
            shape = (count,) if name == "time_from_start" else (count, n)
            if values.shape != shape:
                raise MessageError(f"JointTrajectory.points.{name}", f"expected shape {shape}, got {values.shape}")
            if not np.isfinite(values).all():
                raise MessageError(f"JointTrajectory.points.{name}", "must be finite")
        stamps = arrays["time_from_start"]
        if count and (stamps[0] < 0 or (np.diff(stamps) < 0).any()):
            raise MessageError("JointTrajectory.points.time_from_start", "must be >= 0 and non-decreasing")
        columns = {name: values.tolist() for name, values in arrays.items()}
        empty = [[] for _ in range(count)]
        new = object.__new__
        points = []
        for time_from_start, p, v, a in zip(columns["time_from_start"], columns["positions"], columns["velocities"],
                                            columns.get("accelerations", empty)):
            point = new(JointTrajectoryPoint)  # fields checked above, as arrays
            point.__dict__.update(positions=p, velocities=v, accelerations=a, time_from_start=time_from_start)
            points.append(point)
        trajectory.points = points
        return trajectory

    @property
    def duration(self) -> float:
        """Time of the last point (0.0 for an empty trajectory)."""
        return self.points[-1].time_from_start if self.points else 0.0


@dataclass
class RobotTrajectory(_Message):
    """moveit_msgs/RobotTrajectory (joint part only), tagged with the planning group it moves."""

    joint_trajectory: JointTrajectory
    group_name: str = ""


@dataclass
class MoveItErrorCode(_Message):
    """moveit_msgs/MoveItErrorCode: the outcome of planning/execution, with MoveIt's values.

    Truthy iff SUCCESS, so ``if not result.error_code:`` reads naturally. ``message`` and
    ``source`` (the component that failed) are the Jazzy additions to the message.
    """

    val: int = 1
    message: str = ""
    source: str = ""

    SUCCESS: ClassVar[int] = 1
    UNDEFINED: ClassVar[int] = 0
    FAILURE: ClassVar[int] = 99999
    PLANNING_FAILED: ClassVar[int] = -1
    INVALID_MOTION_PLAN: ClassVar[int] = -2
    MOTION_PLAN_INVALIDATED_BY_ENVIRONMENT_CHANGE: ClassVar[int] = -3
    CONTROL_FAILED: ClassVar[int] = -4
    UNABLE_TO_AQUIRE_SENSOR_DATA: ClassVar[int] = -5  # sic: MoveIt's spelling
    TIMED_OUT: ClassVar[int] = -6
    PREEMPTED: ClassVar[int] = -7
    START_STATE_IN_COLLISION: ClassVar[int] = -10
    START_STATE_VIOLATES_PATH_CONSTRAINTS: ClassVar[int] = -11
    GOAL_IN_COLLISION: ClassVar[int] = -12
    GOAL_VIOLATES_PATH_CONSTRAINTS: ClassVar[int] = -13
    GOAL_CONSTRAINTS_VIOLATED: ClassVar[int] = -14
    INVALID_GROUP_NAME: ClassVar[int] = -15
    INVALID_GOAL_CONSTRAINTS: ClassVar[int] = -16
    INVALID_ROBOT_STATE: ClassVar[int] = -17
    INVALID_LINK_NAME: ClassVar[int] = -18
    INVALID_OBJECT_NAME: ClassVar[int] = -19
    FRAME_TRANSFORM_FAILURE: ClassVar[int] = -21
    COLLISION_CHECKING_UNAVAILABLE: ClassVar[int] = -22
    ROBOT_STATE_STALE: ClassVar[int] = -23
    SENSOR_INFO_STALE: ClassVar[int] = -24
    COMMUNICATION_FAILURE: ClassVar[int] = -25
    START_STATE_INVALID: ClassVar[int] = -26
    GOAL_STATE_INVALID: ClassVar[int] = -27
    UNRECOGNIZED_GOAL_TYPE: ClassVar[int] = -28
    CRASH: ClassVar[int] = -29
    ABORT: ClassVar[int] = -30
    NO_IK_SOLUTION: ClassVar[int] = -31
    _NAMES: ClassVar[dict[int, str]] = {}  # filled below from the constants above

    def _validate(self) -> None:
        if self.val not in self._NAMES:
            raise MessageError("MoveItErrorCode.val", f"unknown MoveIt error code {self.val}")

    @classmethod
    def is_known(cls, val: int) -> bool:
        """Whether ``val`` is one of moveit_msgs/MoveItErrorCodes' values."""
        return val in cls._NAMES

    @property
    def name(self) -> str:
        """Symbolic name of ``val``, e.g. "NO_IK_SOLUTION"."""
        return self._NAMES[self.val]

    @classmethod
    def from_name(cls, name: str, message: str = "", source: str = "") -> MoveItErrorCode:
        val = getattr(cls, name, None) if isinstance(name, str) and name.isupper() else None
        if not isinstance(val, int) or val not in cls._NAMES:
            raise MessageError("MoveItErrorCode.val", f"unknown MoveIt error code name {name!r}")
        return cls(val, message, source)

    def __bool__(self) -> bool:
        return self.val == self.SUCCESS

    def __str__(self) -> str:
        return f"{self.name}: {self.message}" if self.message else self.name


MoveItErrorCode._NAMES.update(
    {v: k for k, v in vars(MoveItErrorCode).items() if k.isupper() and not k.startswith("_") and type(v) is int}
)
