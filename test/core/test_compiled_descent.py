"""IKSolver's compiled descents (kinematics/compiled_descent.py) are its Pinocchio descents.

On the myCobot, the Panda, the xArm7 and a gantry with a prismatic joint, from random starts
toward random reachable poses: the one-by-one descent in every mode (full pose and position
only; with and without the early abort and the active-set pass at the limits) and the batch
descent reach the same verdicts and the same states as the Pinocchio loops; IKSolver.solve finds
the same number of solutions, each on the target.
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from mycobot_planning.core import RobotModel, RobotState
from mycobot_planning.core.collision_detection.batch_check import numba_available
from mycobot_planning.core.kinematics.ik_solver import IKSolver
from mycobot_planning.paths import example_robot_data_dir

from gantry_robot import GANTRY_SRDF, GANTRY_URDF

pytestmark = pytest.mark.skipif(not numba_available(), reason="numba is not installed (scripts/requirements.txt)")

ROBOTS = ["mycobot", "panda", "xarm7", "gantry"]


def _model(robot: str, mycobot: RobotModel, panda: RobotModel) -> tuple[RobotModel, str]:
    if robot == "mycobot":
        return mycobot, "arm"
    if robot == "panda":
        return panda, "arm"
    if robot == "xarm7":
        root = example_robot_data_dir() / "xarm_description"
        model = RobotModel.from_files(root / "urdf" / "xarm7.urdf", root / "srdf" / "xarm7.srdf")
        return model, model.group_names[0]
    return RobotModel.from_strings(GANTRY_URDF, GANTRY_SRDF), "arm"


def _random_state(model: RobotModel, group: str, rng: np.random.Generator) -> RobotState:
    idx = model.group(group).variable_indices
    state = RobotState(model)
    state.set_group_positions(group, rng.uniform(model.lower_limits[idx], model.upper_limits[idx]))
    return state


def _target(solver: IKSolver, model: RobotModel, group: str, rng: np.random.Generator) -> pin.SE3:
    pose = _random_state(model, group, rng).frame_pose(solver.link)
    return pin.SE3(pose[:3, :3].copy(), pose[:3, 3].copy())


@pytest.mark.parametrize("robot", ROBOTS)
def test_descents_are_the_pinocchio_descents(robot, mycobot, panda):
    model, group = _model(robot, mycobot, panda)
    solver = IKSolver(model, group)
    kernels = solver._kernels
    assert kernels is not None
    idx = model.group(group).variable_indices
    rng = np.random.default_rng(len(robot))
    compared = converged = 0
    for position_only in (False, True):
        for abort, limit_pass in ((False, False), (True, True), (True, False)):
            for _ in range(60):
                target = _target(solver, model, group, rng)
                start = _random_state(model, group, rng).positions
                outcomes = []
                for use in (kernels, None):
                    solver._kernels = use
                    full = start.copy()
                    ok = solver._descend(full, target, position_only, 20, abort=abort, limit_pass=limit_pass)
                    outcomes.append((ok, full))
                solver._kernels = kernels
                (ok, full), (ref_ok, ref_full) = outcomes
                assert ok == ref_ok
                assert np.array_equal(np.delete(full, idx), np.delete(ref_full, idx))  # others untouched
                if ok:
                    assert np.allclose(full[idx], ref_full[idx], rtol=0.0, atol=1e-5)
                    converged += 1
                compared += 1
    assert converged > 0.2 * compared  # the comparison covers converging descents, not only failures


@pytest.mark.parametrize("robot", ROBOTS)
@pytest.mark.parametrize("position_only", [False, True])
def test_batch_descents_are_the_pinocchio_batch(robot, position_only, mycobot, panda):
    model, group = _model(robot, mycobot, panda)
    solver = IKSolver(model, group)
    kernels = solver._kernels
    idx = model.group(group).variable_indices
    rng = np.random.default_rng(7 + len(robot))
    total = 0
    for _ in range(4):
        target = _target(solver, model, group, rng)
        starts = np.array([_random_state(model, group, rng).positions[idx] for _ in range(32)])
        budgets = rng.integers(3, 20, size=32)
        base = model.default_positions()
        xs, converged = solver._descend_batch(base, starts, budgets, target, position_only)
        solver._kernels = None
        ref_xs, ref_converged = solver._descend_batch(base, starts, budgets, target, position_only)
        solver._kernels = kernels
        assert np.array_equal(converged, ref_converged)
        assert np.allclose(xs[converged], ref_xs[converged], rtol=0.0, atol=1e-5)
        total += int(converged.sum())
    assert total > 0


@pytest.mark.parametrize("robot", ["mycobot", "panda"])
def test_solve_finds_what_the_pinocchio_descents_find(robot, mycobot, panda):
    model, group = _model(robot, mycobot, panda)
    compiled, reference = IKSolver(model, group), IKSolver(model, group)
    reference._kernels = None
    rng = np.random.default_rng(3)
    for i in range(15):
        pose = _random_state(model, group, rng).frame_pose(compiled.link)
        seed = _random_state(model, group, rng)
        found = [solver.solve(pose, seed=seed, rng=i, max_solutions=4, attempts=120) for solver in (compiled,
                                                                                                 reference)]
        assert len(found[0]) == len(found[1]) > 0
        for ours, theirs in zip(*found):
            assert np.allclose(ours.positions, theirs.positions, rtol=0.0, atol=1e-5)
            assert np.allclose(ours.frame_pose(compiled.link), pose, atol=1e-4)
