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

from typing import Callable

import numpy as np
import pinocchio as pin
from scipy.linalg import get_lapack_funcs

from ...jit import compiled
from ...kinematics.chain_kinematics import ChainTables, chain_tables, damped_step, frame_kinematics, log3_into
from ...robot_model.robot_model import JointModelGroup, RobotModel, group_configuration

__all__ = ["CORRECTOR_ITERATIONS", "CORRECTOR_MAX_STEP", "CompiledStepSolver", "ORIENTATION_TOLERANCE",
           "POSITION_TOLERANCE", "StepSolver", "step_solver"]

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
    """StepSolver's iterations in one compiled kernel over the link's chain of joints
    (kinematics/chain_kinematics.py). Build it with :func:`step_solver`, which checks the
    model qualifies."""

    def __init__(self, model: RobotModel, jmg: JointModelGroup, full: np.ndarray, tables: ChainTables) -> None:
        idx = jmg.variable_indices
        self.tables = tables
        self.scratch = tables.scratch()
        self.position, self.rotation, self.jacobian = (self.scratch.position, self.scratch.rotation,
                                                       self.scratch.jacobian)
        self.q = np.array(model.to_q(full), dtype=float)
        self.lower = np.ascontiguousarray(model.lower_limits[idx], dtype=float)
        self.upper = np.ascontiguousarray(model.upper_limits[idx], dtype=float)
        self.tolerances = np.array([POSITION_TOLERANCE**2, ORIENTATION_TOLERANCE**2, CORRECTOR_MAX_STEP, DAMPING])
        dof = len(idx)
        self.system = np.zeros((6, 7))
        self.vectors = np.zeros((3, 6))
        self.previous = np.zeros(dof)
        self.x = np.zeros(dof)
        self.kinematics = tables.arguments(self.q, self.scratch)
        self.update(full[idx].copy())

    def update(self, x: np.ndarray) -> None:
        self.x[:] = x
        frame_kinematics(self.x, *self.kinematics)

    def correct(self, p_target: np.ndarray, r_target: np.ndarray, iterations: int = CORRECTOR_ITERATIONS) -> bool:
        """As StepSolver.correct."""
        return bool(_correct(p_target, r_target, iterations, self.x, self.lower, self.upper, self.tolerances,
                             self.system, self.vectors, *self.kinematics))

    def follow(self, p_link: np.ndarray, r_link: np.ndarray, start: int, end: int, path: np.ndarray,
               fallback: Fallback) -> int:
        """As StepSolver.follow: the kernel runs the steps the corrector solves, the fallback
        (Python, rare) runs between kernel calls."""
        p_link = np.ascontiguousarray(p_link, dtype=float)
        r_link = np.ascontiguousarray(r_link, dtype=float)
        s = start
        while s < end:
            s = int(_follow(p_link, r_link, s, end, path, CORRECTOR_ITERATIONS, self.previous, self.x, self.lower,
                            self.upper, self.tolerances, self.system, self.vectors, *self.kinematics))
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
    """The compiled solver when chain_tables covers the group and link (numba installed, the
    group's variables plain configuration slots, one-axis revolute or prismatic joints on the
    chain); else the Pinocchio reference."""
    tables = chain_tables(model, jmg.variable_indices, link)
    if tables is None:
        return StepSolver(model, jmg, link, full)
    return CompiledStepSolver(model, jmg, full, tables)


# ---------------------------------------------------------------------------- compiled kernels
@compiled
def _correct(p_target, r_target, iterations, x, lower, upper, tolerances, system, vectors, q, slots, parents, kinds,
             index, axes, rot0, trans0, rot, trans, work33, frame_rot, frame_trans, col_joint, position, rotation,
             jacobian):  # pragma: no cover - compiled
    """StepSolver.correct: Newton from x (kinematics current) to the target, x clamped to the
    limits after every iteration; True on convergence, else x is the last iterate."""
    err = vectors[0]
    y = vectors[1]
    step = np.empty(x.shape[0])
    unblocked = np.zeros(x.shape[0], dtype=np.bool_)
    relative = work33[0]  # free until the next joint_kinematics call
    for _ in range(iterations + 1):
        for i in range(3):
            err[i] = p_target[i] - position[i]
            for k in range(3):
                relative[i, k] = r_target[i, 0] * rotation[k, 0] + r_target[i, 1] * rotation[k, 1] + \
                    r_target[i, 2] * rotation[k, 2]
        log3_into(relative, vectors[2, :3])
        for i in range(3):
            err[3 + i] = vectors[2, i]
        lin2 = err[0] * err[0] + err[1] * err[1] + err[2] * err[2]
        ang2 = err[3] * err[3] + err[4] * err[4] + err[5] * err[5]
        if lin2 <= tolerances[0] and ang2 <= tolerances[1]:
            return True
        if not damped_step(jacobian, 6, err, tolerances[3], unblocked, system, y, step):
            return False
        for c in range(x.shape[0]):
            if not abs(step[c]) <= tolerances[2]:  # also catches NaN
                return False
        for c in range(x.shape[0]):
            x[c] = min(max(x[c] + step[c], lower[c]), upper[c])
        frame_kinematics(x, q, slots, parents, kinds, index, axes, rot0, trans0, rot, trans, work33, frame_rot, frame_trans,
                col_joint, position, rotation, jacobian)
    return False


@compiled
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
            frame_kinematics(x, q, slots, parents, kinds, index, axes, rot0, trans0, rot, trans, work33, frame_rot,
                    frame_trans, col_joint, position, rotation, jacobian)
            return s
        path[s + 1] = x
    return end
