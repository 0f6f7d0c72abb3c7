"""Benchmark scenarios. Scenario names and summary keys are a contract: keep them stable."""
from __future__ import annotations

from typing import Callable

import numpy as np

from interfaces_py.msgs import CollisionObject
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.kinematics import IKSolver
from mycobot_planning.core.transforms import make_pose

from .common import emit, machine, spread, stats, timed


def random_arm_states(
    model: RobotModel, count: int, rng: np.random.Generator, scene: PlanningScene | None = None
) -> list[RobotState]:
    """Uniform random arm states within the joint limits (and valid in `scene`, when given)."""
    jmg = model.group("arm")
    low, high = model.lower_limits[jmg.variable_indices], model.upper_limits[jmg.variable_indices]
    states: list[RobotState] = []
    while len(states) < count:
        state = RobotState(model)
        state.set_group_positions("arm", rng.uniform(low, high))
        if scene is None or scene.is_state_valid(state):
            states.append(state)
    return states


def seeds_table_scene(model: RobotModel) -> PlanningScene:
    """The seeds' scene: table 0.10 x 0.20 x 0.03 with its top at z = 0 centred at (0.22, 0.12),
    and a cylinder of height 0.35, radius 0.0125 standing on it."""
    scene = PlanningScene(model)
    scene.add_object(CollisionObject.box("table", [0.10, 0.20, 0.03], make_pose([0.22, 0.12, -0.015])))
    scene.add_object(CollisionObject.cylinder("cylinder", 0.35, 0.0125, make_pose([0.22, 0.12, 0.175])))
    return scene


def bench_collision(repeat: int, seed: int) -> None:
    """Validity (limits + self + world collision) of random arm states in the seeds' scene."""
    model = RobotModel.mycobot()
    scene = seeds_table_scene(model)
    rng = np.random.default_rng(seed)
    medians = []
    all_samples, colliding = [], 0
    for index in range(repeat):
        samples, hits = [], 0
        for state in random_arm_states(model, 5000, rng):
            positions = state.positions
            elapsed, valid = timed(lambda: scene.is_valid_positions(positions))
            samples.append(elapsed)
            hits += not valid
        record = {"scenario": "collision", "repeat": index, "states": len(samples), "invalid_fraction": hits / len(samples)}
        record.update(stats(samples, 1e6, "us"))
        medians.append(record["median_us"])
        emit(record)
        all_samples += samples
        colliding += hits
    summary = {"scenario": "collision", "summary": True, "invalid_fraction": colliding / len(all_samples)}
    summary.update({k: v for k, v in stats(all_samples, 1e6, "us").items() if k in ("median_us", "p90_us")})
    emit({**summary, **spread(medians), **machine()})


def bench_fk(repeat: int, seed: int) -> None:
    """Forward kinematics of the flange: one Pinocchio call per state."""
    model = RobotModel.mycobot()
    rng = np.random.default_rng(seed)
    medians = []
    for index in range(repeat):
        samples = []
        for state in random_arm_states(model, 2000, rng):
            elapsed, _ = timed(lambda: state.frame_pose("link6_flange"))
            samples.append(elapsed)
        record = {"scenario": "fk", "repeat": index, "states": len(samples), **stats(samples, 1e6, "us")}
        medians.append(record["median_us"])
        emit(record)
    emit({"scenario": "fk", "summary": True, "median_us": float(np.median(medians)), **spread(medians), **machine()})


def bench_ik(repeat: int, seed: int) -> None:
    """IK round trip: 1000 flange poses from FK of random valid (self-collision-free) arm states,
    solved from the home state."""
    model = RobotModel.mycobot()
    empty_scene = PlanningScene(model)
    solver = IKSolver(model, "arm")
    solver.solve(RobotState(model).frame_pose("link6_flange"))  # builds the seed table once, untimed
    rng = np.random.default_rng(seed)
    all_samples, successes, medians = [], 0, []
    for index in range(repeat):
        samples, ok = [], 0
        for state in random_arm_states(model, 1000, rng, empty_scene):
            target = state.frame_pose("link6_flange")
            elapsed, solutions = timed(lambda: solver.solve(target, rng=rng))
            samples.append(elapsed)
            ok += bool(solutions)
        record = {"scenario": "ik", "repeat": index, "poses": len(samples), "success_rate": ok / len(samples)}
        record.update(stats(samples, 1e3, "ms"))
        medians.append(record["median_ms"])
        emit(record)
        all_samples += samples
        successes += ok
    summary = {"scenario": "ik", "summary": True, "success_rate": successes / len(all_samples)}
    summary.update({k: v for k, v in stats(all_samples, 1e3, "ms").items() if k in ("median_ms", "p90_ms")})
    emit({**summary, **spread(medians), **machine()})


SCENARIOS: dict[str, Callable[..., None]] = {
    "collision": bench_collision,
    "fk": bench_fk,
    "ik": bench_ik,
}
