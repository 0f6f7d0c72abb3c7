"""The Newton corrector that follows a Cartesian path step by step (the IK of computeCartesianPath).

Each step's target is a few tenths of a millimetre from the previous one, so one or two Newton
iterations from the previous solution land on it; with the seed tutorials' 0.25 mm steps a pick
and place solves ~6,500 of them. ``StepSolver`` is the plain reference over Pinocchio;
``CompiledStepSolver`` runs the same iterations, tolerances and limits in one numba kernel over
the chain of joints that moves the link (Pinocchio's per-call overhead, not its arithmetic,
dominated). ``step_solver`` picks the compiled one when numba and the model allow it. Both are
proved equal on several robots in test/core/test_step_solver.py.
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np
import pinocchio as pin
from scipy.linalg import get_lapack_funcs

from ...collision_detection.batch_check import joint_kind, joint_kinematics
from ...robot_model.robot_model import JointModelGroup, RobotModel, group_configuration

try:  # a pinned dependency; without it the reference solver runs
    from numba import njit
except ImportError:  # pragma: no cover - exercised only on an install without numba
    njit = None

__all__ = ["CORRECTOR_ITERATIONS", "CORRECTOR_MAX_STEP", "CompiledStepSolver", "ORIENTATION_TOLERANCE",
           "POSITION_TOLERANCE", "StepSolver", "log3", "step_solver"]

POSITION_TOLERANCE = 1e-6  # m, per-step IK accuracy (the line is followed to this)
ORIENTATION_TOLERANCE = 1e-5  # rad
CORRECTOR_ITERATIONS = 6  # Newton iterations from the previous step before falling back
CORRECTOR_MAX_STEP = 0.5  # rad per joint per Newton iteration: larger means leaving the branch
DAMPING = 1e-10

Fallback = Callable[[np.ndarray, int], "np.ndarray | None"]


class StepSolver:
    """Newton corrector for consecutive IK targets of one link, without RobotState objects.

    Holds the frame pose and the group Jacobian at the current solution, so the next step's
    first Newton iteration (the first-order predictor q + J^+ dx) needs no extra kinematics.
    Owns its Pinocchio data (one per path). The reference for CompiledStepSolver, and what
    runs for models the compiled kernel does not cover (continuous joints or mimic followers
    in the group, joints other than one-axis revolute or prismatic on the chain).
    """

    def __init__(self, model: RobotModel, jmg: JointModelGroup, link: str, full: np.ndarray) -> None:
        self.model = model
        self.pmodel = model.pin_model
        self.pdata = self.pmodel.createData()
        self.fid = model.frame_id(link)
        self.idx = jmg.variable_indices
        self.jmap = np.ascontiguousarray(model.jacobian_map(self.idx))
        self.columns = model.jacobian_columns(self.idx)
        self.slots = model.q_slots(self.idx)
        self.q = np.array(model.to_q(full), dtype=float)
        self.lower = model.lower_limits[self.idx]
        self.upper = model.upper_limits[self.idx]
        self.full = full  # the start's positions; its group entries are rewritten only to build q
        self.nan = np.full(len(self.idx), np.nan)
        self.damping = DAMPING * np.eye(6)
        self.frame = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        self.gesv = get_lapack_funcs(("gesv",), (np.zeros((6, 6)),))[0]
        self.err = np.empty(6)
        self.update(full[self.idx].copy())

    def update(self, x: np.ndarray) -> None:
        self.x = x
        pmodel, pdata, fid = self.pmodel, self.pdata, self.fid
        q = group_configuration(self.model, x, self.slots, self.q, self.full, self.idx)
        pin.computeJointJacobians(pmodel, pdata, q)
        placement = pin.updateFramePlacement(pmodel, pdata, fid)
        self.position = placement.translation
        self.rotation = placement.rotation
        jacobian = pin.getFrameJacobian(pmodel, pdata, fid, self.frame)
        self.jacobian = jacobian[:, self.columns] if self.columns is not None else jacobian @ self.jmap

    def _solve(self, err: np.ndarray) -> np.ndarray:
        """Damped least squares J^T (J J^T + lambda I)^-1 e: the plain Newton step for a regular
        Jacobian, and (close to) the minimum-norm step at a singular one, where a plain solve
        would send the null-space joints flying although the target is reachable."""
        jac = self.jacobian
        _, _, y, info = self.gesv(jac @ jac.T + self.damping, err)
        return jac.T @ y if info == 0 else self.nan

    def correct(self, p_target: np.ndarray, r_target: np.ndarray, iterations: int = CORRECTOR_ITERATIONS) -> bool:
        """Newton from the current solution to the target; True (and state moved) on convergence.

        On failure the solver is left at the last iterate; the caller restores what it needs.
        """
        pos_tol2 = POSITION_TOLERANCE**2
        rot_tol2 = ORIENTATION_TOLERANCE**2
        err = self.err
        lower, upper = self.lower, self.upper
        log3 = pin.log3
        for _ in range(iterations + 1):
            lin = p_target - self.position
            ang = log3(r_target @ self.rotation.T)
            if lin @ lin <= pos_tol2 and ang @ ang <= rot_tol2:
                return True
            err[:3] = lin
            err[3:] = ang
            step = self._solve(err)
            if not abs(step).max() <= CORRECTOR_MAX_STEP:  # also catches NaN
                return False
            self.update(np.minimum(np.maximum(self.x + step, lower), upper))
        return False

    def follow(self, p_link: np.ndarray, r_link: np.ndarray, start: int, end: int, path: np.ndarray,
               fallback: Fallback) -> int:
        """Solve steps ``start``..``end - 1`` in turn (step s into ``path[s + 1]``), each from the
        previous solution, with ``fallback(previous, s)`` (a candidate to correct from) when the
        corrector fails. Returns the first step not solved (``end`` when all were); the solver
        is then left at the last solution."""
        correct = self.correct
        for s in range(start, end):
            previous = self.x
            if not correct(p_link[s], r_link[s]):
                candidate = fallback(previous, s)
                ok = False
                if candidate is not None:
                    self.update(candidate)
                    ok = correct(p_link[s], r_link[s])
                if not ok:
                    self.update(previous)
                    return s
            path[s + 1] = self.x
        return end


class CompiledStepSolver:
    """StepSolver's iterations in one compiled kernel over the link's chain of joints.

    The chain (the link's parent joint and its ancestors) is read from the Pinocchio model
    once; forward kinematics is batch_check's joint_kinematics, the frame Jacobian (Pinocchio's
    LOCAL_WORLD_ALIGNED) is built from the joint axes and origins, the 6x6 damped system is
    solved by Gaussian elimination with partial pivoting. Build it with :func:`step_solver`,
    which checks the model qualifies.
    """

    def __init__(self, model: RobotModel, jmg: JointModelGroup, link: str, full: np.ndarray,
                 chain: list[int], slots: np.ndarray) -> None:
        pmodel = model.pin_model
        idx = jmg.variable_indices
        n = len(chain) + 1  # row 0: the root (the universe)
        self.parents = np.arange(-1, n - 1, dtype=np.int64)
        self.parents[0] = 0
        self.kinds = np.zeros(n, dtype=np.int64)
        self.index = np.zeros(n, dtype=np.int64)
        self.axes = np.zeros((n, 3))
        self.rot0 = np.tile(np.eye(3), (n, 1, 1))
        self.trans0 = np.zeros((n, 3))
        velocity_column = {}
        for k, j in enumerate(chain, start=1):
            joint = pmodel.joints[j]
            kind, axis = joint_kind(joint)  # type: ignore[misc]  # step_solver checked it
            self.kinds[k], self.axes[k] = kind, axis
            self.index[k] = joint.idx_q
            placement = pmodel.jointPlacements[j]
            self.rot0[k], self.trans0[k] = placement.rotation, placement.translation
            velocity_column[joint.idx_v] = k
        frame = pmodel.frames[model.frame_id(link)]
        self.frame_rot = np.ascontiguousarray(frame.placement.rotation)
        self.frame_trans = np.ascontiguousarray(frame.placement.translation)
        columns = np.arange(model.pin_model.nv)[model.jacobian_columns(idx)]
        self.col_joint = np.array([velocity_column.get(int(c), -1) for c in columns], dtype=np.int64)
        self.slots = np.ascontiguousarray(slots, dtype=np.int64)
        self.q = np.array(model.to_q(full), dtype=float)
        self.lower = np.ascontiguousarray(model.lower_limits[idx], dtype=float)
        self.upper = np.ascontiguousarray(model.upper_limits[idx], dtype=float)
        self.tolerances = np.array([POSITION_TOLERANCE**2, ORIENTATION_TOLERANCE**2, CORRECTOR_MAX_STEP, DAMPING])
        dof = len(idx)
        # scratch of the kernel: joint rotations/translations, Jacobian, pose, iterate
        self.rot = np.zeros((n, 3, 3))
        self.rot[0] = np.eye(3)
        self.trans = np.zeros((n, 3))
        self.work33 = np.zeros((2, 3, 3))
        self.position = np.zeros(3)
        self.rotation = np.eye(3)
        self.jacobian = np.zeros((6, dof))
        self.system = np.zeros((6, 7))
        self.vectors = np.zeros((3, 6))
        self.previous = np.zeros(dof)
        self.x = np.zeros(dof)
        self.update(full[idx].copy())

    def _kernel_args(self) -> tuple:
        return (self.q, self.slots, self.parents, self.kinds, self.index, self.axes, self.rot0, self.trans0,
                self.rot, self.trans, self.work33, self.frame_rot, self.frame_trans, self.col_joint,
                self.position, self.rotation, self.jacobian)

    def update(self, x: np.ndarray) -> None:
        self.x[:] = x
        _update(self.x, *self._kernel_args())

    def correct(self, p_target: np.ndarray, r_target: np.ndarray, iterations: int = CORRECTOR_ITERATIONS) -> bool:
        """As StepSolver.correct."""
        return bool(_correct(p_target, r_target, iterations, self.x, self.lower, self.upper, self.tolerances,
                             self.system, self.vectors, *self._kernel_args()))

    def follow(self, p_link: np.ndarray, r_link: np.ndarray, start: int, end: int, path: np.ndarray,
               fallback: Fallback) -> int:
        """As StepSolver.follow: the kernel runs the steps the corrector solves, the fallback
        (Python, rare) runs between kernel calls."""
        p_link = np.ascontiguousarray(p_link, dtype=float)
        r_link = np.ascontiguousarray(r_link, dtype=float)
        s = start
        while s < end:
            s = int(_follow(p_link, r_link, s, end, path, CORRECTOR_ITERATIONS, self.previous, self.x, self.lower,
                            self.upper, self.tolerances, self.system, self.vectors, *self._kernel_args()))
            if s == end:
                break
            previous = self.x.copy()  # the kernel left the solver at the last solution
            candidate = fallback(previous.copy(), s)
            ok = False
            if candidate is not None:
                self.update(candidate)
                ok = self.correct(p_link[s], r_link[s])
            if not ok:
                self.update(previous)
                return s
            path[s + 1] = self.x
            s += 1
        return end


def step_solver(model: RobotModel, jmg: JointModelGroup, link: str, full: np.ndarray) -> StepSolver | CompiledStepSolver:
    """The compiled solver when numba is installed and the model qualifies (the group's
    variables are plain configuration slots, every joint of the link's chain is a one-axis
    revolute or prismatic joint); else the Pinocchio reference."""
    slots = model.q_slots(jmg.variable_indices)
    if njit is None or slots is None or model.jacobian_columns(jmg.variable_indices) is None:
        return StepSolver(model, jmg, link, full)
    pmodel = model.pin_model
    chain = []
    joint = pmodel.frames[model.frame_id(link)].parentJoint
    while joint > 0:
        kind = joint_kind(pmodel.joints[joint])
        if kind is None or kind[0] not in (_REVOLUTE, _PRISMATIC):
            return StepSolver(model, jmg, link, full)
        chain.append(joint)
        joint = pmodel.parents[joint]
    return CompiledStepSolver(model, jmg, link, full, chain[::-1], slots)


def log3(rotation: np.ndarray) -> np.ndarray:
    """The compiled kernel's rotation logarithm (for tests against pin.log3)."""
    out = np.zeros(3)
    _log3(np.ascontiguousarray(rotation, dtype=float), out)
    return out


# ---------------------------------------------------------------------------- compiled kernels
_REVOLUTE, _PRISMATIC = 1, 2  # batch_check's joint kinds


def _compiled(function):
    return njit(cache=True, nogil=True)(function) if njit is not None else function


@_compiled
def _log3(r, out):  # pragma: no cover - compiled
    """Rotation vector of r (the angle in [0, pi])."""
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
        a = np.zeros(3)
        a[best] = math.sqrt(max((r[best, best] - cos) / one, 0.0))
        for i in range(3):
            if i != best:
                a[i] = 0.5 * (r[best, i] + r[i, best]) / (one * a[best])
        if a[0] * vx + a[1] * vy + a[2] * vz < 0.0:
            a[0], a[1], a[2] = -a[0], -a[1], -a[2]
        out[0], out[1], out[2] = theta * a[0], theta * a[1], theta * a[2]


@_compiled
def _update(x, q, slots, parents, kinds, index, axes, rot0, trans0, rot, trans, work33, frame_rot, frame_trans,
            col_joint, position, rotation, jacobian):  # pragma: no cover - compiled
    """Pose and LOCAL_WORLD_ALIGNED Jacobian (group columns) of the link at group values x."""
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


@_compiled
def _newton_step(jacobian, err, damping, system, y, step):  # pragma: no cover - compiled
    """step = J^T (J J^T + damping I)^-1 err; False when the system is singular."""
    dof = jacobian.shape[1]
    for i in range(6):
        for k in range(6):
            total = 0.0
            for c in range(dof):
                total += jacobian[i, c] * jacobian[k, c]
            system[i, k] = total + (damping if i == k else 0.0)
        system[i, 6] = err[i]
    for col in range(6):  # Gaussian elimination with partial pivoting (LAPACK gesv's choice)
        pivot = col
        for i in range(col + 1, 6):
            if abs(system[i, col]) > abs(system[pivot, col]):
                pivot = i
        if system[pivot, col] == 0.0:
            return False
        if pivot != col:
            for k in range(col, 7):
                system[col, k], system[pivot, k] = system[pivot, k], system[col, k]
        for i in range(col + 1, 6):
            f = system[i, col] / system[col, col]
            if f != 0.0:
                for k in range(col, 7):
                    system[i, k] -= f * system[col, k]
    for i in range(5, -1, -1):
        total = system[i, 6]
        for k in range(i + 1, 6):
            total -= system[i, k] * y[k]
        y[i] = total / system[i, i]
    for c in range(dof):
        total = 0.0
        for i in range(6):
            total += jacobian[i, c] * y[i]
        step[c] = total
    return True


@_compiled
def _correct(p_target, r_target, iterations, x, lower, upper, tolerances, system, vectors, q, slots, parents, kinds,
             index, axes, rot0, trans0, rot, trans, work33, frame_rot, frame_trans, col_joint, position, rotation,
             jacobian):  # pragma: no cover - compiled
    """StepSolver.correct: Newton from x (kinematics current) to the target, x clamped to the
    limits after every iteration; True on convergence, else x is the last iterate."""
    err = vectors[0]
    y = vectors[1]
    step = np.empty(x.shape[0])
    relative = work33[0]  # free until the next joint_kinematics call
    for _ in range(iterations + 1):
        for i in range(3):
            err[i] = p_target[i] - position[i]
            for k in range(3):
                relative[i, k] = r_target[i, 0] * rotation[k, 0] + r_target[i, 1] * rotation[k, 1] + \
                    r_target[i, 2] * rotation[k, 2]
        _log3(relative, vectors[2, :3])
        for i in range(3):
            err[3 + i] = vectors[2, i]
        lin2 = err[0] * err[0] + err[1] * err[1] + err[2] * err[2]
        ang2 = err[3] * err[3] + err[4] * err[4] + err[5] * err[5]
        if lin2 <= tolerances[0] and ang2 <= tolerances[1]:
            return True
        if not _newton_step(jacobian, err, tolerances[3], system, y, step):
            return False
        for c in range(x.shape[0]):
            if not abs(step[c]) <= tolerances[2]:  # also catches NaN
                return False
        for c in range(x.shape[0]):
            x[c] = min(max(x[c] + step[c], lower[c]), upper[c])
        _update(x, q, slots, parents, kinds, index, axes, rot0, trans0, rot, trans, work33, frame_rot, frame_trans,
                col_joint, position, rotation, jacobian)
    return False


@_compiled
def _follow(p_link, r_link, start, end, path, iterations, previous, x, lower, upper, tolerances, system, vectors, q,
            slots, parents, kinds, index, axes, rot0, trans0, rot, trans, work33, frame_rot, frame_trans, col_joint,
            position, rotation, jacobian):  # pragma: no cover - compiled
    """Steps start..end - 1 while the corrector solves them; returns the first it does not,
    with x (and the kinematics) back at the previous step's solution."""
    for s in range(start, end):
        previous[:] = x
        if not _correct(p_link[s], r_link[s], iterations, x, lower, upper, tolerances, system, vectors, q, slots,
                        parents, kinds, index, axes, rot0, trans0, rot, trans, work33, frame_rot, frame_trans,
                        col_joint, position, rotation, jacobian):
            x[:] = previous
            _update(x, q, slots, parents, kinds, index, axes, rot0, trans0, rot, trans, work33, frame_rot,
                    frame_trans, col_joint, position, rotation, jacobian)
            return s
        path[s + 1] = x
    return end
