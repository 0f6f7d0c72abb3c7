"""Cost terms: how a stage ranks its solutions (MTC's cost_terms.h).

The full story: docs/task.md, section mycobot_planning.task.cost_terms.
"""
from __future__ import annotations

import math
from enum import IntEnum
from typing import TYPE_CHECKING, Any, Callable, Mapping, Sequence

import numpy as np
import pinocchio as pin

from .errors import TaskError

if TYPE_CHECKING:  # pragma: no cover
    from .storage import SolutionSequence, SubTrajectory, WrappedSolution

__all__ = [
    "Clearance",
    "Constant",
    "CostTerm",
    "DistanceToReference",
    "LambdaCostTerm",
    "LinkMotion",
    "LinkRotation",
    "PathLength",
    "TrajectoryCostTerm",
    "TrajectoryDuration",
]


class CostTerm:
    """Keep the solution's own cost (the default of every stage)."""

    def subtrajectory_cost(self, s: "SubTrajectory") -> tuple[float, str]:
        return s.cost, ""

    def sequence_cost(self, s: "SolutionSequence") -> tuple[float, str]:
        return s.cost, ""

    def wrapped_cost(self, s: "WrappedSolution") -> tuple[float, str]:
        return s.cost, ""

    def __call__(self, solution) -> float:
        """Cost of a solution under this term (convenience for users and tests)."""
        return solution.compute_cost(self)[0]


class TrajectoryCostTerm(CostTerm):
    """Terms defined on sub-trajectories; sequences sum their children, wrappers delegate."""

    class Mode(IntEnum):
        """Which states a term looks at (MTC's ``TrajectoryCostTerm.Mode``)."""

        AUTO = 0  #: the trajectory if there is one, else the start state
        START_INTERFACE = 1
        END_INTERFACE = 2
        TRAJECTORY = 3

    AUTO, START_INTERFACE, END_INTERFACE, TRAJECTORY = Mode

    def subtrajectory_cost(self, s: "SubTrajectory") -> tuple[float, str]:
        raise NotImplementedError

    def sequence_cost(self, s: "SolutionSequence") -> tuple[float, str]:
        total, comments = 0.0, []
        for child in s.children:
            cost, comment = child.compute_cost(self)
            total += cost
            if comment:
                comments.append(comment)
        return total, ", ".join(comments)

    def wrapped_cost(self, s: "WrappedSolution") -> tuple[float, str]:
        return s.wrapped.compute_cost(self)


class Constant(CostTerm):
    def __init__(self, cost: float = 0.0) -> None:
        if not isinstance(cost, (int, float)) or isinstance(cost, bool) or math.isnan(cost):
            raise TaskError(f"Constant cost must be a number, got {cost!r}")
        self.cost = float(cost)

    def subtrajectory_cost(self, s):
        return self.cost, ""

    def sequence_cost(self, s):
        return self.cost, ""

    def wrapped_cost(self, s):
        return self.cost, ""


class PathLength(TrajectoryCostTerm):
    """Joint-space length of the trajectory; ``joints`` restricts it (a list, or a mapping of
    joint name to weight)."""

    def __init__(self, joints: Sequence[str] | Mapping[str, float] | None = None) -> None:
        if joints is None:
            self.joints: dict[str, float] = {}
        elif isinstance(joints, Mapping):
            self.joints = {str(k): float(v) for k, v in joints.items()}
        else:
            self.joints = {str(j): 1.0 for j in joints}

    def subtrajectory_cost(self, s):
        traj = s.trajectory
        if traj is None or len(traj) < 2:
            return 0.0, ""
        steps = np.abs(np.diff(traj.positions, axis=0))
        if not self.joints:
            return float(steps.sum()), ""
        weights = np.array([self.joints.get(name, 0.0) for name in traj.joint_names])
        return float((steps * weights).sum()), ""


class TrajectoryDuration(TrajectoryCostTerm):
    def subtrajectory_cost(self, s):
        return (0.0 if s.trajectory is None else float(s.trajectory.duration)), ""


def _link_frames(s: "SubTrajectory", link: str, cost_name: str) -> tuple[list[np.ndarray] | None, str]:
    """The link's pose at each waypoint of ``s``'s trajectory; (None, MTC's comment) when the
    robot has no such link."""
    traj = s.trajectory
    start = s.start.scene.current_state
    model = start.model
    if not model.has_link(link):
        return None, f"{cost_name}: frame '{link}' unknown in trajectory"
    indices = np.array([model.variable_index(n) for n in traj.joint_names], dtype=int)
    state = start.copy()
    positions = start.positions.copy()
    frames = []
    for row in traj.positions:
        positions[indices] = row
        state.set_positions(positions)
        frames.append(state.frame_pose(link))
    return frames, ""


class _LinkPathCost(TrajectoryCostTerm):
    """The sum over consecutive waypoints of ``_step`` between a link's poses along the
    trajectory; ``_label`` names the cost term in its messages."""

    _label = ""

    def __init__(self, link: str) -> None:
        if not isinstance(link, str) or not link:
            raise TaskError(f"{self._label} needs a link name, got {link!r}")
        self.link_name = link

    @staticmethod
    def _step(a: np.ndarray, b: np.ndarray) -> float:
        """The measure between two consecutive poses (4x4) of the link."""
        raise NotImplementedError

    def subtrajectory_cost(self, s):
        if s.trajectory is None or len(s.trajectory) == 0:
            return 0.0, ""
        frames, comment = _link_frames(s, self.link_name, f"{self._label}Cost")
        if frames is None:
            return math.inf, comment
        return sum(self._step(a, b) for a, b in zip(frames, frames[1:])), ""


class LinkMotion(_LinkPathCost):
    """Length (m) of the path of a link's origin along the trajectory."""

    _label = "LinkMotion"

    @staticmethod
    def _step(a: np.ndarray, b: np.ndarray) -> float:
        return float(np.linalg.norm(b[:3, 3] - a[:3, 3]))


class LinkRotation(_LinkPathCost):
    """Total orientation change (rad) of a link along the trajectory: the sum of the angles
    between the link's orientations at consecutive waypoints (MTC's cost::LinkRotation)."""

    _label = "LinkRotation"

    @staticmethod
    def _step(a: np.ndarray, b: np.ndarray) -> float:
        return float(np.linalg.norm(pin.log3(a[:3, :3].T @ b[:3, :3])))


class Clearance(TrajectoryCostTerm):
    """Prefer solutions far from obstacles: cost 1/(d + 1e-5) for clearance d (m).

    ``mode``: AUTO (the trajectory's waypoints if there is one, else the start state),
    START_INTERFACE, END_INTERFACE or TRAJECTORY. The group is read from the interface state's
    property ``group_property`` if present, else from the creating stage's property.
    """

    PREFIX = "Clearance: "

    def __init__(self, with_world: bool = True, cumulative: bool = False, group_property: str = "group",
                 mode: int = 0, distance_to_cost: Callable[[float], float] | None = None) -> None:
        self.with_world = bool(with_world)
        self.cumulative = bool(cumulative)
        self.group_property = group_property
        self.mode = mode
        self.distance_to_cost = distance_to_cost or (lambda d: 1.0 / (d + 1e-5))

    def _group(self, s) -> str | None:
        state = s.end if self.mode == self.END_INTERFACE else s.start
        value = state.properties.get(self.group_property)
        if value is None and s.creator is not None and self.group_property in s.creator.properties:
            value = s.creator.properties[self.group_property]
        return value

    def _distance(self, scene, robot_state, group):
        report = scene.distance(robot_state, include_self=not self.with_world, include_world=self.with_world,
                                links=group)
        if report.min_distance <= 0:
            return report.min_distance, report
        if self.cumulative:
            return float(sum(d for d, _ in report.per_link.values())), report
        return report.min_distance, report

    def subtrajectory_cost(self, s):
        group = self._group(s)
        state = s.end if self.mode == self.END_INTERFACE else s.start
        scene = state.scene
        use_states = self.mode in (self.START_INTERFACE, self.END_INTERFACE) or (
            self.mode == self.AUTO and (s.trajectory is None or len(s.trajectory) == 0))
        if use_states:
            distance, report = self._distance(scene, scene.current_state, group)
            if math.isinf(distance):
                return math.inf, self.PREFIX + "no collision pairs to measure"
            if distance < 0:
                return math.inf, (self.PREFIX + f"allegedly valid solution collides between '{report.body_a}' "
                                  f"and '{report.body_b}'")
            if self.cumulative:
                comment = self.PREFIX + f"cumulative distance {distance}"
            else:
                comment = self.PREFIX + f"distance {distance} between '{report.body_a}' and '{report.body_b}'"
            return self.distance_to_cost(distance), comment
        model = scene.robot_model
        traj = s.trajectory
        indices = np.array([model.variable_index(n) for n in traj.joint_names], dtype=int)
        robot_state = s.start.scene.current_state.copy()
        positions = robot_state.positions.copy()
        total = 0.0
        for row in traj.positions:
            positions[indices] = row
            robot_state.set_positions(positions)
            distance, report = self._distance(scene, robot_state, group)
            if distance < 0:
                return math.inf, (self.PREFIX + f"allegedly valid solution collides between '{report.body_a}' "
                                  f"and '{report.body_b}'")
            total += distance
        total /= len(traj)
        comment = self.PREFIX + f"average{' cumulative' if self.cumulative else ''} distance: {total}"
        return self.distance_to_cost(total), comment


class DistanceToReference(TrajectoryCostTerm):
    """Joint-space distance to a reference state (a joint map), at the start/end state or
    averaged over the trajectory (AUTO: trajectory if any, else the start state)."""

    def __init__(self, reference: Mapping[str, float], mode: int = 0, weights: Mapping[str, float] | None = None) -> None:
        self.reference = {str(k): float(v) for k, v in reference.items()}
        self.mode = mode
        self.weights = dict(weights or {})

    def _distance(self, positions: Mapping[str, float]) -> float:
        total = 0.0
        for name, value in self.reference.items():
            weight = self.weights.get(name, 1.0) if self.weights else 1.0
            total += weight * abs(positions[name] - value)
        return total

    def subtrajectory_cost(self, s):
        state = s.end if self.mode == self.END_INTERFACE else s.start
        base = state.scene.current_state.to_joint_dict(include_mimic=False)
        unknown = [n for n in self.reference if n not in base]
        if unknown:
            return math.inf, f"DistanceToReference: unknown joints {unknown}"
        traj = s.trajectory
        if self.mode != self.AUTO or traj is None or len(traj) == 0:
            return self._distance(base), ""
        total = 0.0
        for row in traj.positions:
            values = dict(base)
            values.update(zip(traj.joint_names, (float(v) for v in row)))
            total += self._distance(values)
        return total / len(traj), ""


class LambdaCostTerm(TrajectoryCostTerm):
    """A user callable ``f(solution)`` returning a cost or ``(cost, comment)``."""

    def __init__(self, function: Callable[[Any], Any]) -> None:
        if not callable(function):
            raise TaskError(f"LambdaCostTerm needs a callable, got {type(function).__name__}")
        self.function = function

    def subtrajectory_cost(self, s):
        result = self.function(s)
        if isinstance(result, tuple):
            cost, comment = result
            return float(cost), str(comment)
        return float(result), ""
