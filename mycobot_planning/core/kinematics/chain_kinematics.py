"""Compiled kinematics of one link's chain: pose, frame Jacobian, rotation logarithm, damped step.

The hot loops of the numerical IK (the descents of IKSolver) and of the Cartesian step solver
are many tiny iterations whose cost in Python was the calls into Pinocchio, not the arithmetic.
These numba kernels compute the same quantities over the chain of joints that moves the link,
read once from the Pinocchio model: forward kinematics is the batch sphere test's
``joint_kinematics``; the LOCAL_WORLD_ALIGNED Jacobian column of a revolute joint is
a x (p - o) over its world axis a and origin o (the axis itself for a prismatic joint); log3,
log6 and Jlog6 follow Pinocchio's formulas (series below its thresholds, the axis from the
symmetric part near pi); the damped least-squares step is solved by Gaussian elimination with
partial pivoting. Held to Pinocchio by test/core/test_chain_kinematics.py (log6, Jlog6) and
test_step_solver.py (log3; poses and Jacobians on six robots).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..collision_detection.batch_check import joint_kind, joint_kinematics
from ..jit import compiled, numba_available
from ..robot_model.robot_model import RobotModel

__all__ = ["ChainScratch", "ChainTables", "chain_tables", "damped_step", "frame_kinematics", "jlog6", "log3",
           "log3_into", "log6", "log6_into", "jlog6_into"]

_REVOLUTE, _PRISMATIC = 1, 2  # batch_check's joint kinds
_EPS = float(np.finfo(float).eps)
#: Pinocchio's Taylor thresholds (TaylorSeriesExpansion::precision<2> and <3>)
_PRECISION2 = _EPS ** (1.0 / 3.0)
_PRECISION3 = _EPS ** (1.0 / 4.0)


@dataclass(frozen=True)
class ChainTables:
    """The chain from the root to a link's parent joint (row 0 the root), the link's placement
    on that joint, the configuration slots of the group's variables and, per group variable,
    its joint's row in the chain (-1: the variable does not move the link)."""

    parents: np.ndarray
    kinds: np.ndarray
    index: np.ndarray
    axes: np.ndarray
    rot0: np.ndarray
    trans0: np.ndarray
    frame_rot: np.ndarray
    frame_trans: np.ndarray
    col_joint: np.ndarray
    slots: np.ndarray

    def scratch(self) -> "ChainScratch":
        """Fresh buffers for one computation (who computes owns them)."""
        n, dof = len(self.parents), len(self.slots)
        rot = np.zeros((n, 3, 3))
        rot[0] = np.eye(3)
        return ChainScratch(rot, np.zeros((n, 3)), np.zeros((2, 3, 3)), np.zeros(3), np.eye(3), np.zeros((6, dof)))

    def arguments(self, q: np.ndarray, scratch: "ChainScratch") -> tuple:
        """frame_kinematics' arguments after the group values."""
        return (q, self.slots, self.parents, self.kinds, self.index, self.axes, self.rot0, self.trans0, scratch.rot,
                scratch.trans, scratch.work33, self.frame_rot, self.frame_trans, self.col_joint, scratch.position,
                scratch.rotation, scratch.jacobian)


@dataclass(frozen=True)
class ChainScratch:
    rot: np.ndarray
    trans: np.ndarray
    work33: np.ndarray
    position: np.ndarray
    rotation: np.ndarray
    jacobian: np.ndarray


def chain_tables(model: RobotModel, indices: np.ndarray, link: str) -> ChainTables | None:
    """The tables of ``link`` moved by the variables ``indices``; None when numba is missing
    or the compiled kernels do not cover the case: a variable that is not a plain
    configuration slot (continuous joint, mimic source) or a chain joint other than a one-axis
    revolute or prismatic joint (those keep Pinocchio)."""
    if not numba_available():
        return None
    indices = np.asarray(indices, dtype=int)
    slots = model.q_slots(indices)
    columns = model.jacobian_columns(indices)
    if slots is None or columns is None:
        return None
    pmodel = model.pin_model
    chain = []
    joint = pmodel.frames[model.frame_id(link)].parentJoint
    while joint > 0:
        kind = joint_kind(pmodel.joints[joint])
        if kind is None or kind[0] not in (_REVOLUTE, _PRISMATIC):
            return None
        chain.append((joint, kind))
        joint = pmodel.parents[joint]
    chain.reverse()
    n = len(chain) + 1
    parents = np.arange(-1, n - 1, dtype=np.int64)
    parents[0] = 0
    kinds = np.zeros(n, dtype=np.int64)
    index = np.zeros(n, dtype=np.int64)
    axes = np.zeros((n, 3))
    rot0 = np.tile(np.eye(3), (n, 1, 1))
    trans0 = np.zeros((n, 3))
    row_of_velocity = {}
    for k, (j, (kind, axis)) in enumerate(chain, start=1):
        kinds[k], axes[k] = kind, axis
        index[k] = pmodel.joints[j].idx_q
        rot0[k] = pmodel.jointPlacements[j].rotation
        trans0[k] = pmodel.jointPlacements[j].translation
        row_of_velocity[pmodel.joints[j].idx_v] = k
    placement = pmodel.frames[model.frame_id(link)].placement
    velocity_columns = np.arange(pmodel.nv)[columns]
    col_joint = np.array([row_of_velocity.get(int(c), -1) for c in velocity_columns], dtype=np.int64)
    return ChainTables(parents, kinds, index, axes, rot0, trans0, np.ascontiguousarray(placement.rotation),
                       np.ascontiguousarray(placement.translation), col_joint,
                       np.ascontiguousarray(slots, dtype=np.int64))


# ---------------------------------------------------------------------------- Python views
def log3(rotation: np.ndarray) -> np.ndarray:
    """The compiled rotation logarithm (for tests against pin.log3)."""
    out = np.zeros(3)
    log3_into(np.ascontiguousarray(rotation, dtype=float), out)
    return out


def log6(rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """The compiled SE(3) logarithm [linear, angular] (for tests against pin.log6)."""
    out = np.zeros(6)
    log6_into(np.ascontiguousarray(rotation, dtype=float), np.ascontiguousarray(translation, dtype=float), out)
    return out


def jlog6(rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """The compiled Jlog6 (for tests against pin.Jlog6)."""
    out = np.zeros((6, 6))
    jlog6_into(np.ascontiguousarray(rotation, dtype=float), np.ascontiguousarray(translation, dtype=float), out)
    return out


# ---------------------------------------------------------------------------- kernels
@compiled
def log3_into(r, out):  # pragma: no cover - compiled
    """Rotation vector of r (angle in [0, pi]); returns the angle."""
    vx = r[2, 1] - r[1, 2]
    vy = r[0, 2] - r[2, 0]
    vz = r[1, 0] - r[0, 1]
    sin2 = math.sqrt(vx * vx + vy * vy + vz * vz)  # 2 sin(theta)
    cos = 0.5 * (r[0, 0] + r[1, 1] + r[2, 2] - 1.0)
    theta = math.atan2(0.5 * sin2, cos)
    if theta < 1e-4:  # theta / (2 sin theta) by its series
        t2 = theta * theta
        factor = 0.5 * (1.0 + t2 / 6.0 + 7.0 * t2 * t2 / 360.0)
        out[0], out[1], out[2] = factor * vx, factor * vy, factor * vz
    elif sin2 > 1e-6:
        factor = theta / sin2
        out[0], out[1], out[2] = factor * vx, factor * vy, factor * vz
    else:  # near pi: the axis from the symmetric part (R + R^T) / 2 = cos I + (1 - cos) a a^T
        one = 1.0 - cos
        best = 0
        for i in range(1, 3):
            if r[i, i] > r[best, best]:
                best = i
        a0 = math.sqrt(max((r[best, best] - cos) / one, 0.0))
        a = np.zeros(3)
        a[best] = a0
        for i in range(3):
            if i != best:
                a[i] = 0.5 * (r[best, i] + r[i, best]) / (one * a0)
        if a[0] * vx + a[1] * vy + a[2] * vz < 0.0:
            a[0], a[1], a[2] = -a[0], -a[1], -a[2]
        out[0], out[1], out[2] = theta * a[0], theta * a[1], theta * a[2]
    return theta


@compiled
def log6_into(r, p, out):  # pragma: no cover - compiled
    """[V(w)^-1 p, w] with w = log3(r)."""
    w = out[3:]
    theta = log3_into(r, w)
    if r[0, 0] + r[1, 1] + r[2, 2] >= 3.0 - _PRECISION2:  # Pinocchio's switch to the series
        t2 = theta * theta
        alpha = 1.0 - t2 / 12.0 - t2 * t2 / 720.0
        beta = 1.0 / 12.0 + t2 / 720.0
    else:
        st, ct = math.sin(theta), math.cos(theta)
        alpha = theta * st / (2.0 * (1.0 - ct))
        beta = 1.0 / (theta * theta) - st / (2.0 * theta * (1.0 - ct))
    wp = w[0] * p[0] + w[1] * p[1] + w[2] * p[2]
    out[0] = alpha * p[0] - 0.5 * (w[1] * p[2] - w[2] * p[1]) + beta * wp * w[0]
    out[1] = alpha * p[1] - 0.5 * (w[2] * p[0] - w[0] * p[2]) + beta * wp * w[1]
    out[2] = alpha * p[2] - 0.5 * (w[0] * p[1] - w[1] * p[0]) + beta * wp * w[2]


@compiled
def _add_skew(v, scale, m):  # pragma: no cover - compiled
    """m += skew(scale * v)."""
    m[0, 1] -= scale * v[2]
    m[0, 2] += scale * v[1]
    m[1, 0] += scale * v[2]
    m[1, 2] -= scale * v[0]
    m[2, 0] -= scale * v[1]
    m[2, 1] += scale * v[0]


@compiled
def jlog6_into(r, p, out):  # pragma: no cover - compiled
    """Pinocchio's Jlog6: [[A, C A], [0, A]] with A = Jlog3."""
    w = np.zeros(3)
    theta = log3_into(r, w)
    t2 = theta * theta
    st, ct = math.sin(theta), math.cos(theta)
    if theta < _PRECISION3:
        alpha = 1.0 / 12.0 + t2 / 720.0
        diag = 0.5 * (2.0 - t2 / 6.0)
        beta = 1.0 / 12.0 + t2 / 720.0
        beta_dot = 1.0 / 360.0
    else:
        st_1mct = st / (1.0 - ct)
        alpha = 1.0 / t2 - st_1mct / (2.0 * theta)
        diag = 0.5 * theta * st_1mct
        inv_2_2ct = 1.0 / (2.0 * (1.0 - ct))
        beta = 1.0 / t2 - st / theta * inv_2_2ct
        beta_dot = -2.0 / (t2 * t2) + (1.0 + st / theta) / t2 * inv_2_2ct
    a = np.zeros((3, 3))
    for i in range(3):
        for k in range(3):
            a[i, k] = alpha * w[i] * w[k]
        a[i, i] += diag
    _add_skew(w, 0.5, a)
    wp = w[0] * p[0] + w[1] * p[1] + w[2] * p[2]
    c = np.zeros((3, 3))
    for i in range(3):
        v = beta_dot * wp * w[i] - (t2 * beta_dot + 2.0 * beta) * p[i]
        for k in range(3):
            c[i, k] = v * w[k] + beta * w[i] * p[k]
        c[i, i] += wp * beta
    _add_skew(p, 0.5, c)
    for i in range(6):
        for k in range(6):
            out[i, k] = 0.0
    for i in range(3):
        for k in range(3):
            out[i, k] = a[i, k]
            out[3 + i, 3 + k] = a[i, k]
            out[i, 3 + k] = c[i, 0] * a[0, k] + c[i, 1] * a[1, k] + c[i, 2] * a[2, k]


@compiled
def frame_kinematics(x, q, slots, parents, kinds, index, axes, rot0, trans0, rot, trans, work33, frame_rot,
                     frame_trans, col_joint, position, rotation, jacobian):  # pragma: no cover - compiled
    """Pose and LOCAL_WORLD_ALIGNED Jacobian (group columns) of the link at group values x
    (written into the configuration q at slots)."""
    for i in range(x.shape[0]):
        q[slots[i]] = x[i]
    joint_kinematics(q, parents, kinds, index, axes, rot0, trans0, rot, trans, work33[0], work33[1])
    last = parents.shape[0] - 1
    for i in range(3):
        t = trans[last, i]
        for k in range(3):
            rotation[i, k] = rot[last, i, 0] * frame_rot[0, k] + rot[last, i, 1] * frame_rot[1, k] + \
                rot[last, i, 2] * frame_rot[2, k]
            t += rot[last, i, k] * frame_trans[k]
        position[i] = t
    for c in range(x.shape[0]):
        j = col_joint[c]
        if j < 0:
            for i in range(6):
                jacobian[i, c] = 0.0
            continue
        a0 = rot[j, 0, 0] * axes[j, 0] + rot[j, 0, 1] * axes[j, 1] + rot[j, 0, 2] * axes[j, 2]
        a1 = rot[j, 1, 0] * axes[j, 0] + rot[j, 1, 1] * axes[j, 1] + rot[j, 1, 2] * axes[j, 2]
        a2 = rot[j, 2, 0] * axes[j, 0] + rot[j, 2, 1] * axes[j, 1] + rot[j, 2, 2] * axes[j, 2]
        if kinds[j] == 2:  # prismatic: the frame translates along the axis
            jacobian[0, c], jacobian[1, c], jacobian[2, c] = a0, a1, a2
            jacobian[3, c] = jacobian[4, c] = jacobian[5, c] = 0.0
        else:  # revolute: a x (p - o)
            d0 = position[0] - trans[j, 0]
            d1 = position[1] - trans[j, 1]
            d2 = position[2] - trans[j, 2]
            jacobian[0, c] = a1 * d2 - a2 * d1
            jacobian[1, c] = a2 * d0 - a0 * d2
            jacobian[2, c] = a0 * d1 - a1 * d0
            jacobian[3, c], jacobian[4, c], jacobian[5, c] = a0, a1, a2


@compiled
def damped_step(jacobian, rows, err, damping, blocked, system, y, step):  # pragma: no cover - compiled
    """step = J^T (J J^T + damping I)^-1 err over the first ``rows`` rows of J, the ``blocked``
    columns taken as zero (their step is 0); False when the system is singular."""
    dof = jacobian.shape[1]
    for i in range(rows):
        for k in range(rows):
            total = 0.0
            for c in range(dof):
                if not blocked[c]:
                    total += jacobian[i, c] * jacobian[k, c]
            system[i, k] = total + (damping if i == k else 0.0)
        system[i, rows] = err[i]
    for col in range(rows):  # Gaussian elimination with partial pivoting (LAPACK gesv's choice)
        pivot = col
        for i in range(col + 1, rows):
            if abs(system[i, col]) > abs(system[pivot, col]):
                pivot = i
        if system[pivot, col] == 0.0:
            return False
        if pivot != col:
            for k in range(col, rows + 1):
                system[col, k], system[pivot, k] = system[pivot, k], system[col, k]
        for i in range(col + 1, rows):
            f = system[i, col] / system[col, col]
            if f != 0.0:
                for k in range(col, rows + 1):
                    system[i, k] -= f * system[col, k]
    for i in range(rows - 1, -1, -1):
        total = system[i, rows]
        for k in range(i + 1, rows):
            total -= system[i, k] * y[k]
        y[i] = total / system[i, i]
    for c in range(dof):
        total = 0.0
        if not blocked[c]:
            for i in range(rows):
                total += jacobian[i, c] * y[i]
        step[c] = total
    return True
