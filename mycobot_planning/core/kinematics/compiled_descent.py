"""IKSolver's damped Gauss-Newton descents as compiled kernels (chain_kinematics.py).

The same iterations as IKSolver._descend and _descend_batch: the error log6(current^-1 target)
with the Jacobian Jlog6(target^-1 current) J_local (or the position error with the world-aligned
Jacobian's linear rows), the damped step bounded by max_step, the active-set pass at the joint
limits or plain clamping, the early abort of far-off restarts. What differs: a batch runs its
starts one after the other inside the kernel (each start's arithmetic was already its own), and
a singular damped system ends only the start it belongs to, where the NumPy batch gave up on
all of them. test/core/test_compiled_descent.py holds both to the Pinocchio descents.
"""
from __future__ import annotations

import numpy as np

from ..jit import compiled
from .chain_kinematics import ChainTables, damped_step, frame_kinematics, jlog6_into, log6_into

__all__ = ["CompiledDescent"]


class CompiledDescent:
    """The descents of one IKSolver (one group, one link) with the buffers they write: like the
    solver's Pinocchio data, one thread at a time."""

    def __init__(self, tables: ChainTables, lower: np.ndarray, upper: np.ndarray, position_tolerance: float,
                 orientation_tolerance: float, max_step: float, damping: float, abort_error: float) -> None:
        self.tables = tables
        self.scratch = tables.scratch()
        dof = len(tables.slots)
        self.lower = np.ascontiguousarray(lower, dtype=float)
        self.upper = np.ascontiguousarray(upper, dtype=float)
        self.parameters = np.array([position_tolerance**2, orientation_tolerance**2, max_step, damping,
                                    abort_error**2])
        self.matrices = np.zeros((3, 6, 6))  # Jlog6, the 6x7 system's first 6 columns live in system
        self.system = np.zeros((6, 7))
        self.jac = np.zeros((6, dof))
        self.vectors = np.zeros((4, 6))
        self.dof_vectors = np.zeros((4, dof))
        self.blocked = np.zeros(dof, dtype=np.bool_)

    def _arguments(self, q: np.ndarray) -> tuple:
        return (self.lower, self.upper, self.parameters, self.matrices, self.system, self.jac, self.vectors,
                self.dof_vectors, self.blocked) + self.tables.arguments(q, self.scratch)

    def descend(self, x: np.ndarray, q: np.ndarray, target_rotation: np.ndarray, target_translation: np.ndarray,
                position_only: bool, max_iterations: int, abort_at: int, limit_pass: bool) -> bool:
        """IKSolver._descend from group values x (updated in place); q is the configuration the
        group's slots are written into."""
        return bool(_descend(x, target_rotation, target_translation, position_only, max_iterations, False, abort_at,
                             limit_pass, *self._arguments(q)))

    def descend_batch(self, xs: np.ndarray, budgets: np.ndarray, q: np.ndarray, target_rotation: np.ndarray,
                      target_translation: np.ndarray, position_only: bool, abort_at: int) -> np.ndarray:
        """IKSolver._descend_batch over the rows of xs (updated in place); which converged."""
        converged = np.zeros(len(xs), dtype=np.bool_)
        _descend_batch(xs, np.ascontiguousarray(budgets, dtype=np.int64), converged, target_rotation,
                       target_translation, position_only, abort_at, *self._arguments(q))
        return converged


@compiled
def _descend(x, target_rot, target_trans, position_only, budget, final_check, abort_at, limit_pass, lower, upper,
             parameters, matrices, system, jac, vectors, dof_vectors, blocked, q, slots, parents, kinds, index, axes,
             rot0, trans0, rot, trans, work33, frame_rot, frame_trans, col_joint, position, rotation,
             jacobian):  # pragma: no cover - compiled
    """Up to ``budget`` damped Gauss-Newton steps from x (in place), the convergence checked
    before each and, with ``final_check``, after the last; True on convergence."""
    pos_tol2, rot_tol2, max_step, damping, abort2 = (parameters[0], parameters[1], parameters[2], parameters[3],
                                                      parameters[4])
    dof = x.shape[0]
    err, y, err2, pd = vectors[0], vectors[1], vectors[2], vectors[3]
    step, moved, reach = dof_vectors[0], dof_vectors[1], dof_vectors[2]
    jl = matrices[0]
    rd = matrices[1, :3, :3]
    rows = 3 if position_only else 6
    for iteration in range(budget + 1 if final_check else budget):
        frame_kinematics(x, q, slots, parents, kinds, index, axes, rot0, trans0, rot, trans, work33, frame_rot,
                         frame_trans, col_joint, position, rotation, jacobian)
        if position_only:
            for i in range(3):
                err[i] = target_trans[i] - position[i]
            lin2 = err[0] * err[0] + err[1] * err[1] + err[2] * err[2]
            if lin2 < pos_tol2:
                return True
            if iteration == budget or (iteration == abort_at and lin2 > abort2):
                return False
            for i in range(3):
                for c in range(dof):
                    jac[i, c] = jacobian[i, c]
        else:
            # delta = current^-1 target: rd = Rc^T Rt, pd = Rc^T (pt - pc)
            for i in range(3):
                pd[i] = 0.0
                for k in range(3):
                    rd[i, k] = rotation[0, i] * target_rot[0, k] + rotation[1, i] * target_rot[1, k] + \
                        rotation[2, i] * target_rot[2, k]
                    pd[i] += rotation[k, i] * (target_trans[k] - position[k])
            log6_into(rd, pd, err)
            lin2 = err[0] * err[0] + err[1] * err[1] + err[2] * err[2]
            ang2 = err[3] * err[3] + err[4] * err[4] + err[5] * err[5]
            if lin2 < pos_tol2 and ang2 < rot_tol2:
                return True
            if iteration == budget or (iteration == abort_at and lin2 + ang2 > abort2):
                return False
            # J = Jlog6(delta^-1) J_local; delta^-1 = (rd^T, -rd^T pd); J_local = Rc^T J_world_aligned
            inv_rot = work33[0]
            for i in range(3):
                err2[i] = 0.0
                for k in range(3):
                    inv_rot[i, k] = rd[k, i]
                    err2[i] -= rd[k, i] * pd[k]
            jlog6_into(inv_rot, err2[:3], jl)
            for c in range(dof):
                for i in range(3):
                    y[i] = rotation[0, i] * jacobian[0, c] + rotation[1, i] * jacobian[1, c] + \
                        rotation[2, i] * jacobian[2, c]
                    y[3 + i] = rotation[0, i] * jacobian[3, c] + rotation[1, i] * jacobian[4, c] + \
                        rotation[2, i] * jacobian[5, c]
                for i in range(6):
                    total = 0.0
                    for k in range(6):
                        total += jl[i, k] * y[k]
                    jac[i, c] = total
        for c in range(dof):
            blocked[c] = False
        if not damped_step(jac, rows, err, damping, blocked, system, y, step):
            return False
        _bound(step, max_step)
        clamped_differs = False
        if limit_pass:
            for c in range(dof):
                moved[c] = min(max(x[c] + step[c], lower[c]), upper[c])
                if moved[c] != x[c] + step[c]:
                    blocked[c] = True
                    clamped_differs = True
        if clamped_differs:
            # joints the step pushes past a limit stop there; the others take up what they no
            # longer do (one active-set pass)
            for c in range(dof):
                reach[c] = moved[c] - x[c]
            for i in range(rows):
                total = err[i]
                for c in range(dof):
                    if blocked[c]:
                        total -= jac[i, c] * reach[c]
                err2[i] = total
            if not damped_step(jac, rows, err2, damping, blocked, system, y, step):
                return False
            for c in range(dof):
                if blocked[c]:
                    step[c] = reach[c]
            _bound(step, max_step)
            for c in range(dof):
                x[c] = min(max(x[c] + step[c], lower[c]), upper[c])
        elif limit_pass:
            for c in range(dof):
                x[c] = moved[c]
        else:
            for c in range(dof):
                x[c] = min(max(x[c] + step[c], lower[c]), upper[c])
    return False


@compiled
def _bound(step, max_step):  # pragma: no cover - compiled
    """Scale the step so that no joint moves more than max_step."""
    largest = 0.0
    for c in range(step.shape[0]):
        largest = max(largest, abs(step[c]))
    if largest > max_step:
        factor = max_step / largest
        for c in range(step.shape[0]):
            step[c] *= factor


@compiled
def _descend_batch(xs, budgets, converged, target_rot, target_trans, position_only, abort_at, lower, upper,
                   parameters, matrices, system, jac, vectors, dof_vectors, blocked, q, slots, parents, kinds, index,
                   axes, rot0, trans0, rot, trans, work33, frame_rot, frame_trans, col_joint, position, rotation,
                   jacobian):  # pragma: no cover - compiled
    for k in range(xs.shape[0]):
        converged[k] = _descend(xs[k], target_rot, target_trans, position_only, budgets[k], True, abort_at, False,
                                lower, upper, parameters, matrices, system, jac, vectors, dof_vectors, blocked, q,
                                slots, parents, kinds, index, axes, rot0, trans0, rot, trans, work33, frame_rot,
                                frame_trans, col_joint, position, rotation, jacobian)
