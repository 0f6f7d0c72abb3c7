"""Path constraints as a manifold ``f(x) = 0`` over a group's joint values, for planners that
plan on it instead of finding it by rejection: MoveIt's ompl_interface/detail/ompl_constraints.cpp
(each constrained quantity's excess over its bounds, with its Jacobian), which OMPL's projected
state space uses to project samples and interpolate along the constraints
(core/planners/ompl/solve.py), and STOMP to cost its rollouts. The constraints themselves, and
how a state is judged against them: kinematic_constraints.py.
"""
from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
import pinocchio as pin
from scipy.spatial.transform import Rotation

from ..robot_model.robot_model import group_configuration
from ..robot_state.robot_state import RobotState
from .kinematic_constraints import NEARLY_FREE, ROTATION_VECTOR, XYZ_EULER_ANGLES, PathConstraints

__all__ = ["ANGLE_MARGIN", "ConstraintManifold", "LENGTH_MARGIN", "MARGIN_SHARE"]

#: shrink each bound by this share of its half-width for planning (at most the caps below), so
#: that the straight segments between projected states stay inside the real bounds
MARGIN_SHARE = 0.1
ANGLE_MARGIN = 0.01  # rad
LENGTH_MARGIN = 0.005  # m


def _margin(half_width: float, cap: float) -> float:
    return min(MARGIN_SHARE * half_width, cap)


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _euler_rates(angles: np.ndarray) -> np.ndarray:
    """d(XYZ intrinsic Euler angles)/dt per body angular velocity of R = Rx(a) Ry(b) Rz(c)."""
    _, b, c = angles
    cb, sb, cc, sc = math.cos(b), math.sin(b), math.cos(c), math.sin(c)
    body = np.array([[cb * cc, sc, 0.0], [-cb * sc, cc, 0.0], [sb, 0.0, 1.0]])  # body rate per Euler rate
    return np.linalg.pinv(body)


class ConstraintManifold:
    """Path constraints as ``f(x) = 0`` over a group's joint values ``x``: every constrained
    quantity (a joint value, an orientation error axis, a region coordinate of a point) gives one
    row, its excess over its bounds (0 inside), with the Jacobian of that excess (MoveIt's
    constrained state space: ompl_constraints.cpp's bounds penalty). OMPL's ProjectedStateSpace
    projects states onto ``f = 0`` by Newton steps and interpolates along it.

    Bounds are the constraints' tolerances shrunk by a small margin (MARGIN_SHARE, at most
    ANGLE_MARGIN / LENGTH_MARGIN), widened where a ``reference`` state (start, goals) lies
    beyond them, so that those states are on the manifold. Position constraints with several
    regions (a union) are not projected (they stay checked by rejection); so are joints outside
    the group. ``codim`` is the number of rows (0: nothing to project).

    Owns its Pinocchio data: safe next to other kinematic queries of the same model.
    """

    def __init__(self, constraints: PathConstraints, start: RobotState, group: str,
                 references: Sequence[RobotState] = ()) -> None:
        model = start.model
        jmg = model.group(group)
        self.model = model
        self.dim = jmg.variable_count
        self._indices = np.asarray(jmg.variable_indices)
        self._full = start.positions.copy()
        self._slots = model.q_slots(self._indices)
        self._q = np.array(model.to_q(self._full), dtype=float)
        self._data = model.pin_model.createData()
        self._columns = model.jacobian_map(self._indices)  # nv x dim
        # rows: (kind, constraint, axes or region, lower bounds, upper bounds)
        self._rows: list[list[Any]] = []
        names = list(jmg.joint_names)
        for c in constraints.joints:
            if c.joint in names:
                width = (c.tolerance_above + c.tolerance_below) / 2
                m = _margin(width, ANGLE_MARGIN)
                self._rows.append(["joint", c, names.index(c.joint),
                                   np.array([c.position - c.tolerance_below + m]),
                                   np.array([c.position + c.tolerance_above - m])])
        for c in constraints.orientations:
            # an axis whose tolerance is (nearly) the largest error there is stays free here: its
            # error wraps around at +-pi, where f would jump (validity still holds the exact bound)
            free = np.array([math.pi, math.pi / 2 if c.parameterization == XYZ_EULER_ANGLES else math.pi, math.pi])
            axes = [i for i in range(3) if c.tolerances[i] < free[i] - NEARLY_FREE]
            if axes:
                tol = c.tolerances[axes]
                bound = tol - np.array([_margin(t, ANGLE_MARGIN) for t in tol])
                self._rows.append(["orientation", c, axes, -bound, bound])
        for c in constraints.positions:
            if len(c.regions) != 1:
                continue
            region = c.regions[0]
            if region.kind == "box":
                half = np.asarray(region.dimensions) / 2
                bound = half - np.array([_margin(h, LENGTH_MARGIN) for h in half])
                self._rows.append(["box", c, region, -bound, bound])
            elif region.kind == "sphere":
                r = region.dimensions[0]
                self._rows.append(["sphere", c, region, np.array([-np.inf]), np.array([r - _margin(r, LENGTH_MARGIN)])])
            else:
                height, r = region.dimensions
                h = height / 2
                self._rows.append(["cylinder", c, region, np.array([-np.inf, -(h - _margin(h, LENGTH_MARGIN))]),
                                   np.array([r - _margin(r, LENGTH_MARGIN), h - _margin(h, LENGTH_MARGIN)])])
        self.codim = int(sum(len(row[3]) for row in self._rows))
        self._links = list(dict.fromkeys(row[1].link for row in self._rows if row[0] != "joint"))
        self._frame_ids = {link: model.frame_id(link) for link in self._links}
        self._last_x: np.ndarray | None = None
        self._last_values: list[np.ndarray] = []
        self._last_poses: dict[str, np.ndarray] = {}
        # the references (start, goals) lie on the manifold: widen the bounds where they do not
        for reference in references:
            values = self._values(np.asarray(reference.positions[self._indices], dtype=float))
            for row, value in zip(self._rows, values):
                row[3] = np.minimum(row[3], value)
                row[4] = np.maximum(row[4], value)

    def __bool__(self) -> bool:
        return self.codim > 0

    # -------------------------------------------------------------- kinematics
    def _configure(self, x: np.ndarray) -> np.ndarray:
        return group_configuration(self.model, x, self._slots, self._q, self._full, self._indices)

    def _values(self, x: np.ndarray) -> list[np.ndarray]:
        """The constrained quantities at ``x`` (cached for the Jacobian that usually follows)."""
        if self._last_x is not None and np.array_equal(x, self._last_x):
            return self._last_values
        pm, data = self.model.pin_model, self._data
        poses = {}
        if self._links:
            pin.forwardKinematics(pm, data, self._configure(x))
            for link in self._links:
                poses[link] = pin.updateFramePlacement(pm, data, self._frame_ids[link]).homogeneous
        values = []
        for kind, c, extra, _, _ in self._rows:
            if kind == "joint":
                values.append(np.array([x[extra]]))
            elif kind == "orientation":
                values.append(c.signed_error(c.rotation(poses[c.link]))[extra])
            else:
                local = extra.local(c.point(poses[c.link]))
                if kind == "box":
                    values.append(local)
                elif kind == "sphere":
                    values.append(np.array([np.linalg.norm(local)]))
                else:
                    values.append(np.array([math.hypot(local[0], local[1]), local[2]]))
        self._last_x, self._last_values, self._last_poses = x.copy(), values, poses
        return values

    def value(self, x: np.ndarray) -> np.ndarray:
        """f(x): each row's excess over its bounds (0 inside)."""
        x = np.asarray(x, dtype=float)
        out = np.empty(self.codim)
        i = 0
        for row, value in zip(self._rows, self._values(x)):
            lower, upper = row[3], row[4]
            n = len(value)
            out[i:i + n] = np.where(value > upper, value - upper, np.where(value < lower, value - lower, 0.0))
            i += n
        return out

    def values_many(self, xs: np.ndarray) -> np.ndarray:
        """f(x) for every row of ``xs`` (M x dim) at once: (M x codim), the same numbers as
        :meth:`value` row by row; the rotations of all rows go to SciPy in one call, which is
        what makes a cost over many states (STOMP's rollouts) affordable."""
        xs = np.asarray(xs, dtype=float).reshape(-1, self.dim)
        count = len(xs)
        pm, data = self.model.pin_model, self._data
        poses = {link: np.empty((count, 4, 4)) for link in self._links}
        if self._links:
            for m in range(count):
                pin.forwardKinematics(pm, data, self._configure(xs[m]))
                for link in self._links:
                    poses[link][m] = pin.updateFramePlacement(pm, data, self._frame_ids[link]).homogeneous
        self._last_x = None  # the shared buffers now hold other configurations
        out = np.empty((count, self.codim))
        i = 0
        for kind, c, extra, lower, upper in self._rows:
            if kind == "joint":
                value = xs[:, [extra]]
            elif kind == "orientation":
                rotation = poses[c.link][:, :3, :3]
                if c.offset is not None:
                    rotation = rotation @ c.offset[:3, :3]
                difference = Rotation.from_matrix(c.orientation.T @ rotation)
                if c.parameterization == ROTATION_VECTOR:
                    value = (difference.as_rotvec() @ c.axes.T)[:, extra]
                else:
                    value = difference.as_euler("XYZ")[:, extra]
            else:
                pose = poses[c.link]
                point = pose[:, :3, :3] @ c.offset + pose[:, :3, 3]
                local = point @ extra.pose_inverse[:3, :3].T + extra.pose_inverse[:3, 3]
                if kind == "box":
                    value = local
                elif kind == "sphere":
                    value = np.linalg.norm(local, axis=1, keepdims=True)
                else:
                    value = np.stack([np.hypot(local[:, 0], local[:, 1]), local[:, 2]], axis=1)
            n = value.shape[1]
            out[:, i:i + n] = np.where(value > upper, value - upper, np.where(value < lower, value - lower, 0.0))
            i += n
        return out

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """df/dx (codim x dim): the quantities' Jacobian rows where they exceed their bounds, 0 inside."""
        x = np.asarray(x, dtype=float)
        values = self._values(x)
        poses = self._last_poses
        pm, data = self.model.pin_model, self._data
        jacobians = {}
        if self._links:
            pin.computeJointJacobians(pm, data, self._configure(x))
            for link in self._links:
                full = pin.getFrameJacobian(pm, data, self._frame_ids[link], pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
                jacobians[link] = full @ self._columns  # 6 x dim: linear (world), angular (world)
        out = np.zeros((self.codim, self.dim))
        i = 0
        for (kind, c, extra, lower, upper), value in zip(self._rows, values):
            n = len(value)
            active = (value > upper) | (value < lower)
            if not active.any():
                i += n
                continue
            if kind == "joint":
                rows = np.zeros((1, self.dim))
                rows[0, extra] = 1.0
            elif kind == "orientation":
                angular = jacobians[c.link][3:]
                rotation = c.rotation(poses[c.link])
                body = rotation.T @ angular  # body angular velocity of the constrained frame
                if c.parameterization == ROTATION_VECTOR:
                    rates = c.axes @ pin.Jlog3(c.orientation.T @ rotation)
                else:
                    rates = _euler_rates(Rotation.from_matrix(c.orientation.T @ rotation).as_euler("XYZ"))
                rows = (rates @ body)[extra]
            else:
                pose = poses[c.link]
                point = c.point(pose)
                linear, angular = jacobians[c.link][:3], jacobians[c.link][3:]
                point_jacobian = linear - _skew(point - pose[:3, 3]) @ angular
                local_jacobian = extra.pose_inverse[:3, :3] @ point_jacobian
                local = extra.local(point)
                if kind == "box":
                    rows = local_jacobian
                elif kind == "sphere":
                    norm = float(np.linalg.norm(local))
                    rows = (local / norm)[None, :] @ local_jacobian if norm > 1e-12 else np.zeros((1, self.dim))
                else:
                    radial = math.hypot(local[0], local[1])
                    first = (np.array([local[0], local[1], 0.0]) / radial)[None, :] @ local_jacobian \
                        if radial > 1e-12 else np.zeros((1, self.dim))
                    rows = np.vstack([first, local_jacobian[2:3]])
            out[i:i + n] = rows * active[:, None]
            i += n
        return out
