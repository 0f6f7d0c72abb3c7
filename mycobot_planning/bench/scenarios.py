"""Benchmark scenarios. Scenario names and summary keys are a contract: keep them stable."""
from __future__ import annotations

from typing import Callable

import numpy as np

from mycobot_planning.core import RobotModel, RobotState
from mycobot_planning.core.kinematics import IKSolver

from .common import emit, machine, spread, stats, timed


def random_arm_states(model: RobotModel, count: int, rng: np.random.Generator) -> list[RobotState]:
    """Uniform random arm states within the joint limits."""
    jmg = model.group("arm")
    low, high = model.lower_limits[jmg.variable_indices], model.upper_limits[jmg.variable_indices]
    states = []
    for _ in range(count):
        state = RobotState(model)
        state.set_group_positions("arm", rng.uniform(low, high))
        states.append(state)
    return states


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
    """IK round trip: 1000 flange poses from FK of random arm states, solved from the home state."""
    model = RobotModel.mycobot()
    solver = IKSolver(model, "arm")
    solver.solve(RobotState(model).frame_pose("link6_flange"))  # builds the seed table once, untimed
    rng = np.random.default_rng(seed)
    all_samples, successes, medians = [], 0, []
    for index in range(repeat):
        samples, ok = [], 0
        for state in random_arm_states(model, 1000, rng):
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
    "fk": bench_fk,
    "ik": bench_ik,
}
