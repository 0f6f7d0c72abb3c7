"""The compiled Cartesian step solver (planners/cartesian/step_solver.py) is the Pinocchio one.

Judged by the plain computation: pin.log3 for the rotation logarithm; StepSolver (Pinocchio's
forward kinematics and LOCAL_WORLD_ALIGNED frame Jacobian) for the pose and Jacobian at random
states and for whole followed paths, with and without the fallback, on the myCobot, the Panda
(tip and a link in the middle of the chain), the xArm7, the UR5 and a gantry with a prismatic
joint; and compute_cartesian_path gives the same path with either solver.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pinocchio as pin
import pytest

from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.planners.cartesian import cartesian_path as cartesian_module
from mycobot_planning.core.planners.cartesian.cartesian_path import STOP_COMPLETE, compute_cartesian_path
from mycobot_planning.core.kinematics.chain_kinematics import log3
from mycobot_planning.core.planners.cartesian.step_solver import (CompiledStepSolver, StepSolver,
                                                                   step_solver)
from mycobot_planning.core.collision_detection.batch_check import numba_available
from mycobot_planning.core.transforms import make_pose
from mycobot_planning.paths import example_robot_data_dir

from gantry_robot import GANTRY_SRDF, GANTRY_URDF

pytestmark = pytest.mark.skipif(not numba_available(), reason="numba is not installed (scripts/requirements.txt)")



def _erd(description: str, urdf: str, srdf: str) -> RobotModel:
    root = example_robot_data_dir() / description
    return RobotModel.from_files(root / "urdf" / urdf, root / "srdf" / srdf)


def _case(robot: str, mycobot: RobotModel, panda: RobotModel):
    """(model, group-like object with variable_indices, link)."""
    if robot == "mycobot":
        return mycobot, mycobot.group("arm"), "link6_flange"
    if robot == "panda":
        return panda, panda.group("arm"), "panda_hand_tcp"
    if robot == "panda_link4":  # group joints 5-7 do not move this link: zero columns
        return panda, panda.group("arm"), "panda_link4"
    if robot == "xarm7":
        model = _erd("xarm_description", "xarm7.urdf", "xarm7.srdf")
        return model, model.group(model.group_names[0]), model.group(model.group_names[0]).tip_link
    if robot == "ur5":  # its SRDF has no groups: the six arm joints
        model = _erd("ur_description", "ur5_gripper.urdf", "ur5_gripper.srdf")
        names = [n for n in model.variable_names if n.endswith("_joint") and "gripper" not in n][:6]
        group = SimpleNamespace(variable_indices=np.array([model.variable_names.index(n) for n in names]))
        return model, group, "tool0"
    model = RobotModel.from_strings(GANTRY_URDF, GANTRY_SRDF)
    return model, model.group("arm"), "tool"


def _random_states(model: RobotModel, idx: np.ndarray, count: int, seed: int) -> np.ndarray:
    low = np.where(np.isfinite(model.lower_limits[idx]), model.lower_limits[idx], -np.pi)
    high = np.where(np.isfinite(model.upper_limits[idx]), model.upper_limits[idx], np.pi)
    return np.random.default_rng(seed).uniform(low, high, (count, len(idx)))


ROBOTS = ["mycobot", "panda", "panda_link4", "xarm7", "ur5", "gantry"]


def test_log3_is_pinocchios():
    rng = np.random.default_rng(3)
    rotations = [pin.exp3(v) for v in rng.normal(size=(500, 3))]
    rotations += [pin.exp3(rng.normal(size=3) * 1e-6), np.eye(3)]  # near identity
    for _ in range(50):  # near and at pi, where the axis comes from the symmetric part
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        rotations.append(pin.exp3(axis * (np.pi - 10.0 ** rng.uniform(-12, -2))))
        rotations.append(pin.exp3(axis * np.pi))
    for rotation in rotations:
        ours, theirs = log3(rotation), pin.log3(rotation)
        if np.linalg.norm(theirs) > np.pi - 1e-6:  # at pi, v and -v are the same rotation
            assert np.allclose(pin.exp3(ours), rotation, atol=1e-8)
            assert abs(np.linalg.norm(ours) - np.linalg.norm(theirs)) < 1e-7
        else:
            assert np.allclose(ours, theirs, atol=1e-9), (ours, theirs)


@pytest.mark.parametrize("robot", ROBOTS)
def test_pose_and_jacobian_are_pinocchios(robot, mycobot, panda):
    model, group, link = _case(robot, mycobot, panda)
    full = model.default_positions()
    compiled = step_solver(model, group, link, full.copy())
    reference = StepSolver(model, group, link, full.copy())
    assert isinstance(compiled, CompiledStepSolver)
    for x in _random_states(model, group.variable_indices, 300, seed=len(robot)):
        compiled.update(x.copy())
        reference.update(x.copy())
        assert np.allclose(compiled.position, reference.position, atol=1e-12)
        assert np.allclose(compiled.rotation, reference.rotation, atol=1e-12)
        assert np.allclose(compiled.jacobian, reference.jacobian, atol=1e-12)
    if robot == "panda_link4":
        assert not compiled.jacobian[:, 4:].any()


def _joint_path(model, group, full, seed, jump_at=None):
    """A smooth joint-space path (and, at ``jump_at``, a jump the corrector cannot follow)."""
    idx = group.variable_indices
    low, high = model.lower_limits[idx], model.upper_limits[idx]
    a, b = _random_states(model, idx, 2, seed)
    a, b = low + 0.25 * (high - low) + 0.5 * (a - low) * 0.5, low + 0.25 * (high - low) + 0.5 * (b - low) * 0.5
    t = np.linspace(0.0, 1.0, 121)[:, None]
    xs = a + t * (b - a)
    if jump_at is not None:
        xs[jump_at:] += 0.6 * np.sign(high - low)
        xs = np.clip(xs, low, high)
    return xs


def _targets(model, group, link, full, xs):
    positions, rotations = [], []
    for x in xs[1:]:
        values = full.copy()
        values[group.variable_indices] = x
        pose = RobotState(model, values).frame_pose(link)
        positions.append(pose[:3, 3])
        rotations.append(pose[:3, :3])
    return np.array(positions), np.array(rotations)


@pytest.mark.parametrize("robot", ROBOTS)
@pytest.mark.parametrize("jump", [False, True])
def test_followed_paths_are_the_reference_paths(robot, jump, mycobot, panda):
    """Whole paths step by step: the same states, the same fallback calls, the same stop."""
    model, group, link = _case(robot, mycobot, panda)
    full = model.default_positions()
    xs = _joint_path(model, group, full, seed=len(robot), jump_at=60 if jump else None)
    full[group.variable_indices] = xs[0]
    p_link, r_link = _targets(model, group, link, full, xs)
    outcomes = []
    for solver in (step_solver(model, group, link, full.copy()), StepSolver(model, group, link, full.copy())):
        calls: list[int] = []

        def fallback(previous, s, calls=calls):
            calls.append(s)
            return xs[s + 1].copy() if s == 59 else None  # the jump's true solution, once

        path = np.full((len(xs), len(group.variable_indices)), np.nan)
        path[0] = xs[0]
        reached = solver.follow(p_link, r_link, 0, len(p_link), path, fallback)
        outcomes.append((reached, calls, path, solver.x.copy()))
    (reached, calls, path, x), (ref_reached, ref_calls, ref_path, ref_x) = outcomes
    assert reached == ref_reached and calls == ref_calls
    assert np.allclose(path[:reached + 1], ref_path[:reached + 1], atol=1e-9)
    assert np.allclose(x, ref_x, atol=1e-9)
    if jump:
        assert 59 in calls  # the fallback's candidate was corrected from, in both
    else:
        assert reached == len(p_link) and not calls


def test_cartesian_paths_are_the_same_with_either_solver(mycobot, monkeypatch):
    start = RobotState(mycobot)
    start.set_named("ready")
    scene = PlanningScene(mycobot, start)
    pose = start.frame_pose("link6_flange")
    goals = [pose @ make_pose([0.0, 0.04, 0.03]), pose @ make_pose([-0.03, 0.02, 0.0])]
    compiled = compute_cartesian_path(scene, "arm", start, goals, eef_step=0.001)
    monkeypatch.setattr(cartesian_module, "step_solver", StepSolver)
    reference = compute_cartesian_path(scene, "arm", start, goals, eef_step=0.001)
    assert compiled.stop_reason == reference.stop_reason == STOP_COMPLETE
    assert compiled.path.shape == reference.path.shape and len(compiled.path) > 50
    assert np.allclose(compiled.path, reference.path, atol=1e-9)


def test_models_the_kernel_does_not_cover_get_the_reference(panda):
    """A mimic follower in the group (the Panda's fingers): the Pinocchio solver."""
    solver = step_solver(panda, panda.group("hand"), "panda_leftfinger", panda.default_positions())
    assert type(solver) is StepSolver
