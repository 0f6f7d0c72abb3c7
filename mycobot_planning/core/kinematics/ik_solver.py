"""Inverse kinematics for any planning group: damped Gauss-Newton on Pinocchio with random restarts.

Why numerical: the package must work for any URDF + SRDF arm, so no closed form. Each iteration is
one Pinocchio call for kinematics and joint Jacobians plus a 6x6 solve; restarts from table samples
whose poses are near the target, then from uniform random states inside the limits, give the
distinct solutions MTC's ComputeIK asks for. The iteration loop
is hand-written in Python (Pinocchio ships no IK solver); it stays short because Gauss-Newton
converges quadratically near a solution and steps are clamped far from one.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from functools import cached_property
from typing import Callable, Protocol

import numpy as np
import pinocchio as pin
from scipy.linalg import get_lapack_funcs
from scipy.spatial import cKDTree

from ..errors import KinematicsError
from .chain_kinematics import chain_tables
from .compiled_descent import CompiledDescent
from ..robot_model.robot_model import RobotModel
from ..robot_model.thread_data import thread_store
from ..robot_state.robot_state import RobotState
from ..transforms import check_pose, inverse


class StateValidity(Protocol):
    def is_state_valid(self, state: RobotState) -> bool: ...


@dataclass(frozen=True)
class IKOptions:
    """Solver knobs; the defaults solve the myCobot and the Panda in a handful of iterations."""

    position_tolerance: float = 1e-5  # metres
    orientation_tolerance: float = 1e-4  # radians
    max_iterations: int = 20
    damping: float = 1e-6
    max_step: float = 1.0  # radians (or metres) per joint per iteration, keeps steps in the linear regime
    max_iterations_restart: int = 15  # descents from table or random seeds give up sooner
    seed_table_size: int = 4000  # precomputed FK samples whose nearest poses seed the descents
    seed_neighbours: int = 8  # table seeds tried first (with the seed state)
    # Further table samples, nearest pose first, tried before uniform random restarts: they
    # converge far more often and land on different IK branches, so a search for every distinct
    # solution saturates in fewer attempts (ComputeIK on the seeds' pick and place: 100 instead
    # of 150 attempts, every solution still found in 200 of 200 runs).
    restart_neighbours: int = 120
    # Metres per unit of rotation-matrix difference in the table's nearest-pose lookup. None:
    # ORIENTATION_WEIGHT_PER_REACH times the link's reach (see IKSolver._seed_table).
    orientation_weight: float | None = None


#: The table's orientation weight per metre of reach (the RMS distance of the link's sampled
#: positions from their centre): how far apart two orientations count against two positions
#: scales with the arm. 0.27 gives the myCobot (reach 0.19 m) the 0.05 m it was tuned at; a
#: fixed 0.05 m left the Panda (reach 0.60 m, weight 0.16 m now) seeding its descents on
#: position alone: about 10 % slower IK (the `peers` poses), every pose still solved.
ORIENTATION_WEIGHT_PER_REACH = 0.27
#: Group states sampled to measure the reach
REACH_SAMPLES = 500
#: Most starts descended together (see IKSolver._descend_batch); batches grow 1, 4, 16... to it.
BATCH_SIZE = 32
#: A restart whose error (norm of log6) still exceeds ABORT_ERROR after ABORT_ITERATION steps
#: is dropped: on the seeds' pick and place 84 % of the restarts that never converge are, and 23 %
#: of those that would (late, after wandering), so a converged solution costs 30 % less work.
ABORT_ITERATION = 6
ABORT_ERROR = 0.3
#: Batches this small run start by start: the batched algebra costs more than it saves for them.
SEQUENTIAL_BELOW = 2
#: While one solution is still wanted, this many starts are descended one by one before batches
#: (on 3,000 myCobot poses 9 gave the lowest median, 16 to 130 also the lowest mean and p99).
#: Batches keep plain clamping at the limits: with _descend's active-set pass more of their
#: restarts converge, mostly onto branches already found, and ComputeIK's search for distinct
#: solutions took longer (the seeds' pick and place: 86 instead of 59 ms of IK to the first
#: solution).
SEQUENTIAL_STARTS = 32


_ORTHO_TOLERANCE = 0.999 * (1e-6 + 1e-5)  # check_pose: np.allclose(R @ R.T, I, atol=1e-6), diagonal
_ORTHO_TOLERANCE_OFF = 0.999 * 1e-6  # ... off the diagonal
_LAST_ROW_TOLERANCE = 0.999 * 1e-8  # np.allclose(last row, [0, 0, 0, 1]) for the zeros ...
_LAST_ONE_TOLERANCE = 0.999 * (1e-8 + 1e-5)  # ... and for the one
_isfinite = math.isfinite


def _target_pose(pose: object, what: str) -> np.ndarray:
    """check_pose's verdict at a tenth of its cost (IK's fixed cost per call): the same tests
    (4x4, finite, orthonormal rotation with det > 0, last row 0 0 0 1) on Python floats, with
    tolerances a hair tighter so that nothing check_pose refuses gets through; anything they do
    not pass goes to check_pose, which decides and says what is wrong."""
    if type(pose) is np.ndarray and pose.shape == (4, 4) and pose.dtype == np.float64:
        (a, b, c, x), (d, e, f, y), (g, h, i, z), (r0, r1, r2, r3) = pose.tolist()
        if (all(map(_isfinite, (a, b, c, d, e, f, g, h, i, x, y, z, r0, r1, r2, r3)))
                and abs(a * a + b * b + c * c - 1.0) <= _ORTHO_TOLERANCE
                and abs(d * d + e * e + f * f - 1.0) <= _ORTHO_TOLERANCE
                and abs(g * g + h * h + i * i - 1.0) <= _ORTHO_TOLERANCE
                and abs(a * d + b * e + c * f) <= _ORTHO_TOLERANCE_OFF
                and abs(a * g + b * h + c * i) <= _ORTHO_TOLERANCE_OFF
                and abs(d * g + e * h + f * i) <= _ORTHO_TOLERANCE_OFF
                and a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) > 0.0
                and abs(r0) <= _LAST_ROW_TOLERANCE and abs(r1) <= _LAST_ROW_TOLERANCE
                and abs(r2) <= _LAST_ROW_TOLERANCE and abs(r3 - 1.0) <= _LAST_ONE_TOLERANCE):
            return pose
    return check_pose(pose, what)


def state_distance(a: np.ndarray, b: np.ndarray) -> float:
    """MoveIt's RobotState::distance for single-variable joints: the sum of per-joint distances."""
    return float(np.sum(np.abs(a - b)))


class IKSolver:
    """IK for one group and one tip frame (optionally an ik_frame rigidly offset from it).

    Built once and reused: it caches the frame id, the Jacobian columns and the limit vectors,
    and owns the Pinocchio data its descents write, so solvers on one model may run in different
    threads; one solver serves one thread at a time.
    """

    def __init__(
        self,
        model: RobotModel,
        group: str,
        link: str | None = None,
        ik_frame_offset: np.ndarray | None = None,
        options: IKOptions = IKOptions(),
    ) -> None:
        self.model = model
        self.group = model.group(group)
        if not self.group.joint_names:
            raise KinematicsError(f"group '{group}' has no active joints to solve IK for")
        self.link = link or self.group.tip_link
        try:
            self.frame_id = model.frame_id(self.link)
        except ValueError as exc:
            raise KinematicsError(str(exc)) from None
        self.offset_inv = None
        if ik_frame_offset is not None:
            try:
                self.offset_inv = inverse(check_pose(ik_frame_offset, "ik_frame offset"))
            except ValueError as exc:
                raise KinematicsError(str(exc)) from None
        self.options = options
        self._indices = self.group.variable_indices
        self._jmap = model.jacobian_map(self._indices)
        self._lower = model.lower_limits[self._indices]
        self._upper = model.upper_limits[self._indices]
        # Sampling range: infinite limits (rare) are sampled within ±pi.
        self._sample_lower = np.where(np.isfinite(self._lower), self._lower, -math.pi)
        self._sample_upper = np.where(np.isfinite(self._upper), self._upper, math.pi)
        self._continuous = np.array([model.joint(j).type == "continuous" for j in self.group.joint_names])
        self._has_continuous = bool(self._continuous.any())
        # Per-iteration shortcuts for _descend (see there).
        self._q_slots = model.q_slots(self._indices)
        self._columns = model.jacobian_columns(self._indices)
        self._damping3 = options.damping * np.eye(3)
        self._damping6 = options.damping * np.eye(6)
        self._gesv = get_lapack_funcs(("gesv",), (np.zeros((6, 6)),))[0]
        self._seed_features: tuple = (None, None)  # (key of the last seed, its pose features)
        self._data = model.pin_model.createData()
        # The descents as compiled kernels when the chain allows (compiled_descent.py), else Pinocchio.
        tables = chain_tables(model, self._indices, self.link)
        self._kernels = None if tables is None else CompiledDescent(
            tables, self._lower, self._upper, options.position_tolerance, options.orientation_tolerance,
            options.max_step, options.damping, ABORT_ERROR)

    # ------------------------------------------------------------------ one descent
    def _seed_table(self, position_only: bool) -> tuple[cKDTree, np.ndarray]:
        """Nearest-pose lookup over random group states, built once per model, group and link.

        Starting Gauss-Newton from the sample whose pose is nearest the target lands in the right
        IK branch almost always, so most solves take one short descent instead of many restarts.
        The samples come from a fixed seed so results stay reproducible.
        """
        def build() -> tuple[cKDTree, np.ndarray]:
            rng = np.random.default_rng(12345)
            size = self.options.seed_table_size
            samples = rng.uniform(self._sample_lower, self._sample_upper, size=(size, len(self._indices)))
            full = self.model.default_positions()
            features = np.empty((size, 12))
            pmodel, pdata = self.model.pin_model, self._data
            for i, x in enumerate(samples):
                full[self._indices] = x
                pin.forwardKinematics(pmodel, pdata, self.model.to_q(full))
                pose = pin.updateFramePlacement(pmodel, pdata, self.frame_id)
                features[i, :3] = pose.translation
                features[i, 3:] = pose.rotation.reshape(-1)
            samples.flags.writeable = False  # shared through the model's cache
            if position_only:
                return cKDTree(features[:, :3]), samples
            features[:, 3:] *= self._orientation_weight
            return cKDTree(features), samples

        options = self.options
        key = ("ik_seed_table", self.group.name, self.link, position_only, options.seed_table_size,
               self._orientation_weight)
        return self.model.cached(key, build)

    @cached_property
    def _orientation_weight(self) -> float:
        """The option's weight, or ORIENTATION_WEIGHT_PER_REACH times the reach; measured on
        first use, so a solver that never looks up an orientation costs nothing more to make."""
        if self.options.orientation_weight is not None:
            return self.options.orientation_weight
        return ORIENTATION_WEIGHT_PER_REACH * self._reach()

    def _reach(self) -> float:
        """RMS distance of the link's positions over a fixed sample of group states from their
        centre (cached per model, group and link): the arm's size, for the orientation weight."""
        def measure() -> float:
            rng = np.random.default_rng(54321)
            full = self.model.default_positions()
            pmodel, pdata = self.model.pin_model, self._data
            points = np.empty((REACH_SAMPLES, 3))
            for i, x in enumerate(rng.uniform(self._sample_lower, self._sample_upper,
                                              size=(REACH_SAMPLES, len(self._indices)))):
                full[self._indices] = x
                pin.forwardKinematics(pmodel, pdata, self.model.to_q(full))
                points[i] = pin.updateFramePlacement(pmodel, pdata, self.frame_id).translation
            spread = float(np.sqrt(np.mean(np.sum((points - points.mean(axis=0)) ** 2, axis=1))))
            return spread if spread > 1e-6 else 1.0  # a link that does not move: any weight will do

        return self.model.cached(("ik_reach", self.group.name, self.link), measure)

    def _features(self, pose: pin.SE3, position_only: bool) -> np.ndarray:
        if position_only:
            return np.array(pose.translation)
        return np.concatenate([pose.translation, self._orientation_weight * pose.rotation.reshape(-1)])

    def _start_points(self, base: np.ndarray, target: pin.SE3, position_only: bool, rng: np.random.Generator):
        """Starting group vectors with their iteration budgets, best first.

        The seed comes first when its pose is at least as near the target as the nearest table
        sample (consecutive Cartesian steps, small moves: the answer stays on the seed's branch);
        otherwise the nearest table samples come first and the seed after them. Then the next
        restart_neighbours table samples, then uniform random restarts until the caller stops.
        """
        tree, samples = self._seed_table(position_only)
        first = min(self.options.seed_neighbours, len(samples))
        k = min(first + self.options.restart_neighbours, len(samples))
        features = self._features(target, position_only)
        # The first few neighbours only: most solves need no more, and a query for all k costs
        # twice as much. The rest come from a second query when the search gets that far.
        distances, nearest = tree.query(features, k=first)
        distances, nearest = np.atleast_1d(distances), np.atleast_1d(nearest)
        key = (base.tobytes(), position_only)
        if self._seed_features[0] != key:  # the same seed as the last call (a common case) is not redone
            pmodel, pdata = self.model.pin_model, self._data
            pin.forwardKinematics(pmodel, pdata, self.model.to_q(base))
            seed_pose = pin.updateFramePlacement(pmodel, pdata, self.frame_id)
            self._seed_features = (key, self._features(seed_pose, position_only))
        gap = self._seed_features[1] - features
        seed_distance = math.sqrt(float(gap @ gap))
        seed = (base[self._indices].copy(), self.options.max_iterations)
        if seed_distance <= distances[0]:
            yield seed
        for index in nearest:
            yield samples[index].copy(), self.options.max_iterations_restart
        if seed_distance > distances[0]:
            yield seed
        if k > first:
            more = np.atleast_1d(tree.query(features, k=k)[1])[first:]
            for index in more:
                yield samples[index].copy(), self.options.max_iterations_restart
        if not isinstance(rng, np.random.Generator):  # made only when uniform restarts are reached
            rng = np.random.default_rng(rng)
        while True:
            yield rng.uniform(self._sample_lower, self._sample_upper), self.options.max_iterations_restart

    def _descend(self, full: np.ndarray, target: pin.SE3, position_only: bool, max_iterations: int,
                 abort: bool = False, limit_pass: bool = False) -> bool:
        """Run damped Gauss-Newton from full[group] in place; True when the tolerance is met.

        This loop is IK's whole cost (tens of thousands of iterations per pick-and-place plan),
        so it avoids NumPy's per-call wrappers on 6-vectors: the configuration is updated in
        place when the group's variables map 1:1 onto it, the Jacobian columns are picked rather
        than multiplied by the variable map, the damped system goes to LAPACK's gesv and the
        convergence test runs on Python floats. ``abort``: give up, as _descend_batch does, when
        the error still exceeds ABORT_ERROR after ABORT_ITERATION steps (solve's restarts; not
        refine, whose one descent must not stop early). ``limit_pass`` (solve's one-by-one
        descents): a step that would carry joints past their limits stops them there and is
        solved again for the others (one active-set pass); otherwise the step is clamped, as in
        _descend_batch and refine.
        """
        if self._kernels is not None:
            x = full[self._indices].copy()
            converged = self._kernels.descend(
                x, self.model.to_q(full).copy(), np.ascontiguousarray(target.rotation),
                np.ascontiguousarray(target.translation), position_only, max_iterations,
                ABORT_ITERATION if abort else -1, limit_pass)
            full[self._indices] = x
            return converged
        model, opts = self.model, self.options
        pmodel, pdata = model.pin_model, self._data
        idx, fid = self._indices, self.frame_id
        columns, jmap = self._columns, self._jmap
        slots = self._q_slots
        x = full[idx].copy()
        lower, upper = self._lower, self._upper
        minimum, maximum = np.minimum, np.maximum
        damping = self._damping3 if position_only else self._damping6
        gesv = self._gesv
        pos_tol2 = opts.position_tolerance**2
        rot_tol2 = opts.orientation_tolerance**2
        max_step = opts.max_step
        wrap = self._has_continuous
        local = pin.ReferenceFrame.LOCAL
        world = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        compute_jacobians, frame_placement, frame_jacobian = (
            pin.computeJointJacobians, pin.updateFramePlacement, pin.getFrameJacobian)
        log6, jlog6 = pin.log6, pin.Jlog6
        abort_at = ABORT_ITERATION if abort else -1
        abort_error2 = ABORT_ERROR**2
        q = model.to_q(full).copy() if slots is not None else None
        for iteration in range(max_iterations):
            if slots is None:
                full[idx] = x
                q = model.to_q(full)
            else:
                q[slots] = x
            compute_jacobians(pmodel, pdata, q)
            current = frame_placement(pmodel, pdata, fid)
            if position_only:
                err = target.translation - current.translation
                e0, e1, e2 = err.tolist()
                lin2 = e0 * e0 + e1 * e1 + e2 * e2
                if lin2 < pos_tol2:
                    full[idx] = x
                    return True
                if iteration == abort_at and lin2 > abort_error2:
                    break
                jac = frame_jacobian(pmodel, pdata, fid, world)[:3]
            else:
                delta = current.actInv(target)
                err = log6(delta).vector
                e0, e1, e2, e3, e4, e5 = err.tolist()
                lin2 = e0 * e0 + e1 * e1 + e2 * e2
                ang2 = e3 * e3 + e4 * e4 + e5 * e5
                if lin2 < pos_tol2 and ang2 < rot_tol2:
                    full[idx] = x
                    return True
                if iteration == abort_at and lin2 + ang2 > abort_error2:
                    break
                # d log6(current^-1 target) = -Jlog6(target^-1 current) J_local dq; we solve
                # J' dq = err with J' = Jlog6(delta^-1) J_local (Pinocchio's IK example).
                jac = jlog6(delta.inverse()) @ frame_jacobian(pmodel, pdata, fid, local)
            jac = jac[:, columns] if columns is not None else jac @ jmap
            _, _, y, info = gesv(jac @ jac.T + damping, err)
            if info != 0:
                break
            step = jac.T @ y
            values = step.tolist()  # Python floats: cheaper than NumPy reductions on 7 values
            largest = max(max(values), -min(values))
            if largest > max_step:
                step *= max_step / largest
            clamped = None
            if limit_pass:
                moved = x + step
                clamped = minimum(maximum(moved, lower), upper)
            if limit_pass and clamped.tolist() != moved.tolist():
                blocked = clamped != moved
                # Joints the step pushes past a limit stop there, and the others take up what they
                # no longer do (one active-set pass): merely clamping stalls the descent at the
                # limit, which is how most descents from table seeds used to fail.
                reach = clamped - x
                free = jac * ~blocked
                _, _, y, info = gesv(free @ free.T + damping, err - jac[:, blocked] @ reach[blocked])
                if info != 0:
                    break
                step = free.T @ y
                step[blocked] = reach[blocked]
                values = step.tolist()
                largest = max(max(values), -min(values))
                if largest > max_step:
                    step *= max_step / largest
                clamped = None
            if wrap:
                x += step
                mask = self._continuous
                x[mask] = (x[mask] + math.pi) % (2 * math.pi) - math.pi
                minimum(maximum(x, lower, out=x), upper, out=x)
            elif clamped is not None:
                x = clamped  # the step stays inside the limits: x + step, clamped already
            else:
                x += step
                minimum(maximum(x, lower, out=x), upper, out=x)
        full[idx] = x
        return False

    def _descend_batch(self, base: np.ndarray, starts: np.ndarray, budgets: np.ndarray, target: pin.SE3,
                       position_only: bool) -> tuple[np.ndarray, np.ndarray]:
        """The same damped Gauss-Newton as _descend, for several starts at once, dropping the
        starts that are still far off after ABORT_ITERATION steps.

        Each start's kinematics is still one Pinocchio call per iteration, but the 6x6 algebra
        (convergence test, damped solve, step clamp, limits) runs once per iteration for the
        whole batch; that halves the cost of the restarts ComputeIK runs by the dozen. Returns
        the final group vectors and which of them met the tolerance; start k takes at most
        budgets[k] steps, as in its own descent.
        """
        if self._kernels is not None:
            xs = np.array(starts, dtype=float)
            converged = self._kernels.descend_batch(
                xs, budgets, self.model.to_q(base).copy(), np.ascontiguousarray(target.rotation),
                np.ascontiguousarray(target.translation), position_only, ABORT_ITERATION)
            return xs, converged
        model, opts = self.model, self.options
        pmodel, pdata, fid = model.pin_model, self._data, self.frame_id
        idx, columns, jmap, slots = self._indices, self._columns, self._jmap, self._q_slots
        m, n = starts.shape
        x = np.array(starts, dtype=float)
        rows = 3 if position_only else 6
        errors = np.empty((m, rows))
        jacobians = np.empty((m, rows, n))
        damping = self._damping3 if position_only else self._damping6
        converged = np.zeros(m, dtype=bool)
        active = np.arange(m)
        full = base.copy()
        q = model.to_q(full).copy() if slots is not None else None
        compute_jacobians, frame_placement, frame_jacobian = (
            pin.computeJointJacobians, pin.updateFramePlacement, pin.getFrameJacobian)
        log6, jlog6 = pin.log6, pin.Jlog6
        local, world = pin.ReferenceFrame.LOCAL, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        target_inverse = target.inverse()
        pos_tol2, rot_tol2 = opts.position_tolerance**2, opts.orientation_tolerance**2
        for iteration in range(int(budgets.max()) + 1):
            for k in active.tolist():
                if slots is None:
                    full[idx] = x[k]
                    q = model.to_q(full)
                else:
                    q[slots] = x[k]
                compute_jacobians(pmodel, pdata, q)
                current = frame_placement(pmodel, pdata, fid)
                if position_only:
                    errors[k] = target.translation - current.translation
                    jac = frame_jacobian(pmodel, pdata, fid, world)[:3]
                else:
                    errors[k] = log6(current.actInv(target)).vector
                    jac = jlog6(target_inverse * current) @ frame_jacobian(pmodel, pdata, fid, local)
                jacobians[k] = jac[:, columns] if columns is not None else jac @ jmap
            err = errors[active]
            lin2 = np.einsum("ij,ij->i", err[:, :3], err[:, :3])
            done = lin2 < pos_tol2
            if not position_only:
                done &= np.einsum("ij,ij->i", err[:, 3:], err[:, 3:]) < rot_tol2
            converged[active[done]] = True
            keep = ~done & (budgets[active] > iteration)
            if iteration == ABORT_ITERATION:
                keep &= (lin2 + (0.0 if position_only else np.einsum("ij,ij->i", err[:, 3:], err[:, 3:]))
                         <= ABORT_ERROR**2)
            active, err = active[keep], err[keep]
            if not active.size:
                break
            jac = jacobians[active]
            jac_t = jac.transpose(0, 2, 1)
            try:
                y = np.linalg.solve(jac @ jac_t + damping, err[..., None])
            except np.linalg.LinAlgError:
                break  # a singular damped system: these starts end unconverged, like _descend
            step = (jac_t @ y)[..., 0]
            largest = np.abs(step).max(axis=1)
            step *= np.minimum(1.0, opts.max_step / np.maximum(largest, 1e-300))[:, None]
            moved = x[active] + step
            if self._has_continuous:
                mask = self._continuous
                moved[:, mask] = (moved[:, mask] + math.pi) % (2 * math.pi) - math.pi
            x[active] = np.minimum(np.maximum(moved, self._lower), self._upper)
        return x, converged

    # ------------------------------------------------------------------ public
    def solve(
        self,
        target_pose: np.ndarray,
        seed: RobotState | None = None,
        timeout: float | None = None,
        max_solutions: int = 1,
        min_solution_distance: float = 0.1,
        position_only: bool = False,
        validity: StateValidity | Callable[[RobotState], bool] | None = None,
        rng: np.random.Generator | int | None = None,
        attempts: int | None = None,
        give_up_after: int | None = None,
        saturation: int | None = None,
    ) -> list[RobotState]:
        """Up to max_solutions states placing the frame at target_pose, at least min_solution_distance
        apart (sum of joint distances), first from the seed, then from random restarts until the
        timeout (kinematics.yaml's kinematics_solver_timeout by default). Variables outside the
        group keep the seed's values. An empty list means no solution was found in time.

        The search also ends after ``attempts`` descents; when none of the first
        ``give_up_after`` converges (the target is out of reach); or when ``saturation``
        descents in a row found no configuration at least min_solution_distance from every one
        found before, valid or not (every IK branch found already).
        """
        try:
            target = _target_pose(target_pose, "IK target pose")
        except ValueError as exc:
            raise KinematicsError(str(exc)) from None
        if max_solutions < 1:
            raise KinematicsError(f"max_solutions must be >= 1, got {max_solutions}")
        if not min_solution_distance >= 0:
            raise KinematicsError(f"min_solution_distance must be >= 0, got {min_solution_distance}")
        if self.offset_inv is not None:
            target = target @ self.offset_inv
        target_se3 = pin.SE3(target[:3, :3].copy(), target[:3, 3].copy())
        cfg = self.model.kinematics(self.group.name)
        if timeout is None:
            timeout = float(cfg["kinematics_solver_timeout"])
        if not timeout > 0:
            raise KinematicsError(f"IK timeout must be > 0, got {timeout}")
        if seed is not None and seed.model is not self.model:
            raise KinematicsError("IK seed state belongs to a different robot model")
        check = validity.is_state_valid if hasattr(validity, "is_state_valid") else validity
        base = (seed.positions if seed is not None else self.model.default_positions()).copy()
        solutions: list[RobotState] = []
        deadline = time.perf_counter() + timeout
        starts = self._start_points(base, target_se3, position_only, rng)
        seen: list[np.ndarray] = []  # every distinct converged configuration, valid or not
        since_new = 0
        tries = 0
        chunk = 1  # the best start alone first: it usually converges, and one solution may be all we need
        while len(solutions) < max_solutions:
            if attempts is not None:
                chunk = min(chunk, attempts - tries)
                if chunk < 1:
                    break
            if give_up_after is not None and not seen and tries < give_up_after:
                chunk = min(chunk, give_up_after - tries)  # decide exactly at give_up_after
            batch = [next(starts) for _ in range(chunk)]
            tries += chunk
            fulls = None  # the descents' full vectors, when descended one by one
            if chunk <= SEQUENTIAL_BELOW:
                fulls, converged = [], []
                for x, iterations in batch:
                    full = base.copy()
                    full[self._indices] = x
                    converged.append(self._descend(full, target_se3, position_only, iterations, abort=True,
                                                   limit_pass=True))
                    fulls.append(full)
                final = [full[self._indices] for full in fulls]
            else:
                final, converged = self._descend_batch(
                    base, np.array([x for x, _ in batch]), np.array([i for _, i in batch]), target_se3, position_only)
            for k in range(chunk):
                if not converged[k]:
                    since_new += 1
                    continue
                x = final[k]
                if all(state_distance(x, other) >= min_solution_distance for other in seen):
                    seen.append(x.copy())
                    since_new = 0
                else:
                    since_new += 1
                distinct = all(
                    state_distance(x, s.positions[self._indices]) >= min_solution_distance for s in solutions
                )
                if distinct:
                    if fulls is not None:
                        full = fulls[k]  # base with x in the group, as the descent left it
                    else:
                        full = base.copy()
                        full[self._indices] = x
                    state = RobotState(self.model, full)
                    if check is None or check(state):
                        solutions.append(state)
                        if len(solutions) >= max_solutions:
                            break
            if attempts is not None and tries >= attempts:
                break
            if give_up_after is not None and not seen and tries >= give_up_after:
                break
            if saturation is not None and seen and since_new >= saturation:
                break
            if time.perf_counter() > deadline:
                break
            if len(solutions) + 1 == max_solutions and tries < SEQUENTIAL_STARTS:
                # One solution to go: one descent at a time. Each converges three times in four
                # (the limits handled, a far one dropped after ABORT_ITERATION steps), and a
                # batch would carry its other starts to the end for nothing.
                chunk = 1
            else:
                chunk = min(4 * chunk, BATCH_SIZE)  # 1, 4, 16, 32: little waste when a few more starts suffice
        return solutions


    def refine(
        self,
        target_pose: np.ndarray,
        seed: RobotState,
        position_only: bool = False,
        max_iterations: int | None = None,
    ) -> RobotState | None:
        """One Gauss-Newton descent from the seed only, or None if it does not converge.

        For consecutive small steps (Cartesian paths, LIN): the answer must stay on the seed's
        branch, so no table seeds or random restarts are tried, and nothing is spent on them.
        """
        try:
            target = _target_pose(target_pose, "IK target pose")
        except ValueError as exc:
            raise KinematicsError(str(exc)) from None
        if seed.model is not self.model:
            raise KinematicsError("IK seed state belongs to a different robot model")
        if self.offset_inv is not None:
            target = target @ self.offset_inv
        full = seed.positions.copy()
        iterations = self.options.max_iterations if max_iterations is None else max_iterations
        if self._descend(full, pin.SE3(target[:3, :3].copy(), target[:3, 3].copy()), position_only, iterations):
            return RobotState(self.model, full)
        return None


#: solvers a thread keeps per model (the least recently used beyond this are dropped)
THREAD_SOLVERS_KEPT = 16


def thread_ik_solver(model: RobotModel, group: str, link: str | None = None,
                     ik_frame_offset: np.ndarray | None = None, options: IKOptions = IKOptions()) -> IKSolver:
    """The calling thread's IKSolver for these arguments, built on first use (~0.2 ms: chain
    tables, compiled-descent buffers, Pinocchio data) and kept while the model lives, for code
    that needs a solver per call (a plan's pose goal, a Cartesian path's fallback descent). Its
    answers are those of a new solver (what it keeps between calls is a cache); like any
    solver it serves one computation of its thread at a time."""
    offset = None if ik_frame_offset is None else np.asarray(ik_frame_offset, dtype=float)
    key = (group, link, None if offset is None else offset.tobytes(), options)
    kept = thread_store(model).setdefault("ik_solvers", {})
    solver = kept.pop(key, None)
    if solver is None:
        solver = IKSolver(model, group, link, offset, options)
        while len(kept) >= THREAD_SOLVERS_KEPT:
            kept.pop(next(iter(kept)))
    kept[key] = solver  # the most recently used last
    return solver


def solve_ik(
    model: RobotModel,
    group: str,
    target_pose: np.ndarray,
    link: str | None = None,
    ik_frame_offset: np.ndarray | None = None,
    seed: RobotState | None = None,
    timeout: float | None = None,
    max_solutions: int = 1,
    min_solution_distance: float = 0.1,
    position_only: bool = False,
    scene: StateValidity | None = None,
    rng: np.random.Generator | int | None = None,
) -> list[RobotState]:
    """One-shot IK (builds an IKSolver); keep an IKSolver for repeated queries."""
    solver = IKSolver(model, group, link, ik_frame_offset)
    return solver.solve(
        target_pose,
        seed=seed,
        timeout=timeout,
        max_solutions=max_solutions,
        min_solution_distance=min_solution_distance,
        position_only=position_only,
        validity=scene,
        rng=rng,
    )
