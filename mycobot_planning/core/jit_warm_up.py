"""Compile the core's numba kernels once, ahead of the first plan (``python -m
mycobot_planning.core.jit_warm_up``; scripts/setup.sh runs it after installing).

numba compiles a kernel at its first call and caches the machine code next to the sources
(``cache=True``); on a fresh install the first IK, Cartesian path and validation would each wait
seconds for it (about 16 s in all, measured on the 2-core machine), in whichever process came
first: a node answering its first request, or both test workers at once. This runs each kernel
once on the myCobot instead. Without numba it does nothing.

``warm_up(model)`` does the same on a node's own robot, each of its groups: besides loading the
kernels from that cache (about 0.35 s in a fresh process), it builds what is made once per model
(the links' enclosing spheres of the batch test: 0.28 s on the UR5). The planning_server runs it
before it says it is ready, so its first plan has its whole allowed_planning_time: pymoveit2's
0.5 s pose goal on a fresh UR5 server had lost ~0.6 s to this and sometimes failed.
"""
from __future__ import annotations

import time

import numpy as np

from .jit import numba_available
from .kinematics.ik_solver import IKSolver
from .planners.cartesian.cartesian_path import compute_cartesian_path
from .planners.cartesian.step_solver import step_solver
from .planning_scene.planning_scene import PlanningScene
from .robot_model.robot_model import RobotModel
from .robot_state.robot_state import RobotState
from .robot_trajectory.robot_trajectory import max_steps
from .trajectory_processing.time_parameterization import time_parameterize
from .trajectory_processing.trajectory_validator import dense_samples

__all__ = ["warm_up"]


def warm_up(model: RobotModel | None = None) -> float:
    """Run every compiled kernel once (loading it from the cache, or compiling and caching it)
    on ``model`` (default: the myCobot), with the per-model work of each of its groups; the
    seconds it took."""
    started = time.perf_counter()
    if not numba_available():
        return 0.0
    model = model if model is not None else RobotModel.mycobot()
    state = RobotState(model)
    if "ready" in model.named_state_names():
        state.set_named("ready")
    scene = PlanningScene(model, state)
    for group in model.group_names:
        _warm_up_group(scene, state, group)
    t = np.linspace(0.0, 1.0, 200)[:, None]
    dense = 0.3 * np.sin(2.0 * t + np.arange(6)[None, :])
    trajectory = time_parameterize(dense, 1.0, 2.0, method="smooth")  # the TOPP passes
    samples = trajectory.sample(np.linspace(trajectory.times[0], trajectory.times[-1], 50))[0]  # the evaluation
    max_steps(samples)  # the validator's step sizes
    dense_samples(trajectory, 0.005)  # the validator's first sampling
    return time.perf_counter() - started


def _warm_up_group(scene: PlanningScene, state: RobotState, group: str) -> None:
    """The batch sphere test and the one-state check of a group; IK, the Cartesian path and the
    step solver too where the group is a chain with an IK solver."""
    free = scene.batch_free_checker(group, state)
    if free is not None:  # built at its first call: the links' enclosing spheres, made once per model
        free(np.repeat(state.group_positions(group)[None, :], 4, axis=0))
    scene.validity_checker(group, state, check_bounds=False)(state.group_positions(group))
    try:
        solver = IKSolver(scene.model, group)
    except Exception:  # no chain to solve for (a gripper, a group of several chains)
        return
    pose = state.frame_pose(solver.link)
    solver.solve(pose, seed=state, rng=0)  # one-by-one descents
    solver.solve(pose, seed=state, rng=0, max_solutions=4, attempts=40)  # batched descents
    target = pose.copy()
    target[:3, 3] += (0.0, 0.02, 0.01)
    # the step solver, the batch sphere test, the validity checker's one-state test
    compute_cartesian_path(scene, group, state, [target], eef_step=0.001)
    steps = step_solver(scene.model, scene.model.group(group), solver.link, state.positions.copy())
    steps.correct(target[:3, 3].copy(), target[:3, :3].copy())  # as the fallback calls it, from Python


if __name__ == "__main__":
    print(f"[setup] numba kernels ready in {warm_up():.1f} s")
