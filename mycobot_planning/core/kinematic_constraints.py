"""Path constraints, as MoveIt's kinematic_constraints decide them: joint, position and
orientation constraints that every state of a path must satisfy.

MoveIt evaluates an orientation constraint on the rotation between the desired orientation and
the link's, as XYZ Euler angles (parameterization 0) or a rotation vector (1), each compared with
its axis tolerance; a position constraint on the link's point (link pose times
target_point_offset) lying inside one of the region's primitives. Frames are resolved once, at
the request's start state (for world-fixed frames, such as the world or the robot's base, that
is exact). Planners use ``PathConstraints.satisfied`` inside their state validity check (a state
off the constraint manifold is invalid), and every planned path is checked again densely.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from .robot_state import RobotState

XYZ_EULER_ANGLES = 0
ROTATION_VECTOR = 1


class ConstraintError(ValueError):
    """A constraint that cannot be evaluated (unknown link, bad region, bad tolerance)."""


@dataclass(frozen=True)
class JointPathConstraint:
    joint: str
    position: float
    tolerance_above: float
    tolerance_below: float

    def violation(self, state: RobotState) -> str | None:
        value = state.joint_position(self.joint)
        if self.position - self.tolerance_below - 1e-9 <= value <= self.position + self.tolerance_above + 1e-9:
            return None
        return (f"joint {self.joint} = {value:.4f} is outside [{self.position - self.tolerance_below:.4f}, "
                f"{self.position + self.tolerance_above:.4f}]")


@dataclass(frozen=True)
class OrientationPathConstraint:
    link: str
    orientation: np.ndarray  # 3x3, world frame
    tolerances: np.ndarray  # rad per axis
    parameterization: int = XYZ_EULER_ANGLES

    def error(self, link_pose: np.ndarray) -> np.ndarray:
        difference = Rotation.from_matrix(self.orientation.T @ link_pose[:3, :3])
        if self.parameterization == ROTATION_VECTOR:
            return np.abs(difference.as_rotvec())
        return np.abs(difference.as_euler("XYZ"))

    def violation(self, poses: Mapping[str, np.ndarray]) -> str | None:
        error = self.error(poses[self.link])
        if np.all(error <= self.tolerances + 1e-9):
            return None
        axis = int(np.argmax(error - self.tolerances))
        return (f"orientation of {self.link} is {error[axis]:.4f} rad off about {'xyz'[axis]} "
                f"(tolerance {self.tolerances[axis]:g})")


@dataclass(frozen=True)
class Region:
    kind: str  # box, sphere, cylinder
    dimensions: tuple[float, ...]
    pose_inverse: np.ndarray  # world -> region frame

    def contains(self, point: np.ndarray) -> bool:
        local = self.pose_inverse[:3, :3] @ point + self.pose_inverse[:3, 3]
        if self.kind == "box":
            return bool(np.all(np.abs(local) <= np.asarray(self.dimensions) / 2 + 1e-9))
        if self.kind == "sphere":
            return float(np.linalg.norm(local)) <= self.dimensions[0] + 1e-9
        height, radius = self.dimensions
        return abs(local[2]) <= height / 2 + 1e-9 and float(np.hypot(local[0], local[1])) <= radius + 1e-9


@dataclass(frozen=True)
class PositionPathConstraint:
    link: str
    offset: np.ndarray  # the constrained point in the link frame
    regions: tuple[Region, ...]

    def violation(self, poses: Mapping[str, np.ndarray]) -> str | None:
        pose = poses[self.link]
        point = pose[:3, :3] @ self.offset + pose[:3, 3]
        if any(region.contains(point) for region in self.regions):
            return None
        return f"the point of {self.link} at {np.round(point, 4).tolist()} left its constraint region"


@dataclass(frozen=True)
class PathConstraints:
    joints: tuple[JointPathConstraint, ...] = ()
    orientations: tuple[OrientationPathConstraint, ...] = ()
    positions: tuple[PositionPathConstraint, ...] = ()
    links: tuple[str, ...] = field(default=())

    def __bool__(self) -> bool:
        return bool(self.joints or self.orientations or self.positions)

    def violation(self, state: RobotState) -> str | None:
        """Why ``state`` breaks a constraint, or None when it satisfies them all."""
        for joint in self.joints:
            problem = joint.violation(state)
            if problem:
                return problem
        if not self.orientations and not self.positions:
            return None
        poses = state.frame_poses(self.links)
        for constraint in (*self.orientations, *self.positions):
            problem = constraint.violation(poses)
            if problem:
                return problem
        return None

    def satisfied(self, state: RobotState) -> bool:
        return self.violation(state) is None


# ----------------------------------------------------------------------------- from the JSON form
def _matrix(pose: Any) -> np.ndarray:
    position = np.asarray(pose.get("position", [0, 0, 0]), dtype=float)
    quat = np.asarray(pose.get("orientation", [0, 0, 0, 1]), dtype=float)
    if position.shape != (3,) or quat.shape != (4,) or not np.all(np.isfinite(position)) \
            or not np.all(np.isfinite(quat)) or np.linalg.norm(quat) < 1e-9:
        raise ConstraintError(f"invalid pose {pose!r}")
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_quat(quat / np.linalg.norm(quat)).as_matrix()
    matrix[:3, 3] = position
    return matrix


def path_constraints_from_json(data: Mapping[str, Any] | None, start: RobotState,
                               frame_pose: Any) -> PathConstraints:
    """Constraints from their JSON form (see interfaces_py.moveit_conversions.path_constraints_from_msg);
    ``frame_pose(frame)`` gives a frame's world pose at the start state (raises for an unknown one)."""
    if not data:
        return PathConstraints()
    model = start.model
    joints, orientations, positions, links = [], [], [], []

    def link_of(entry: Mapping[str, Any], what: str) -> str:
        link = entry.get("link")
        if not isinstance(link, str) or not model.has_link(link):
            raise ConstraintError(f"{what}: unknown link {link!r} of robot '{model.name}'")
        links.append(link)
        return link

    for entry in data.get("joints", []):
        name = entry.get("joint")
        if name not in model.variable_names:
            raise ConstraintError(f"joint constraint: unknown joint {name!r}")
        above, below = float(entry.get("above", 0.0)), float(entry.get("below", 0.0))
        if not (np.isfinite(above) and np.isfinite(below)) or above < 0 or below < 0:
            raise ConstraintError(f"joint constraint on {name}: tolerances must be finite and >= 0")
        joints.append(JointPathConstraint(name, float(entry["position"]), above, below))
    for entry in data.get("orientation", []):
        link = link_of(entry, "orientation constraint")
        tolerances = np.asarray(entry.get("tolerance", []), dtype=float)
        if tolerances.shape != (3,) or not np.all(np.isfinite(tolerances)) or np.any(tolerances < 0):
            raise ConstraintError(f"orientation constraint on {link}: needs 3 tolerances >= 0 (x, y, z axis)")
        base = frame_pose(entry.get("frame") or "world")
        desired = base[:3, :3] @ _matrix({"orientation": entry.get("orientation", [0, 0, 0, 1])})[:3, :3]
        orientations.append(OrientationPathConstraint(link, desired, tolerances,
                                                      int(entry.get("parameterization", XYZ_EULER_ANGLES))))
    for entry in data.get("position", []):
        link = link_of(entry, "position constraint")
        base = frame_pose(entry.get("frame") or "world")
        regions = []
        for region in entry.get("regions", []):
            kind, dims = region.get("type"), tuple(float(d) for d in region.get("dimensions", []))
            expected = {"box": 3, "sphere": 1, "cylinder": 2}.get(kind)
            if expected is None or len(dims) != expected or not all(np.isfinite(dims)) or min(dims) <= 0:
                raise ConstraintError(f"position constraint on {link}: region {region!r} must be a box (3 sizes), "
                                      "sphere (radius) or cylinder (height, radius) with positive sizes")
            regions.append(Region(kind, dims, np.linalg.inv(base @ _matrix(region.get("pose", {})))))
        if not regions:
            raise ConstraintError(f"position constraint on {link}: the constraint region is empty")
        offset = np.asarray(entry.get("offset", [0, 0, 0]), dtype=float)
        positions.append(PositionPathConstraint(link, offset, tuple(regions)))
    return PathConstraints(tuple(joints), tuple(orientations), tuple(positions), tuple(dict.fromkeys(links)))


def first_violation(constraints: PathConstraints, start: RobotState, joint_names: Sequence[str],
                    positions: np.ndarray) -> tuple[int, str] | None:
    """(index, reason) of the first row of ``positions`` (states of ``joint_names``) that breaks
    the constraints, or None."""
    state = start.copy()
    index = [state.model.variable_index(n) for n in joint_names]
    q = state.positions.copy()
    for k, row in enumerate(np.asarray(positions, dtype=float)):
        q[index] = row
        state.set_positions(q)
        problem = constraints.violation(state)
        if problem:
            return k, problem
    return None
