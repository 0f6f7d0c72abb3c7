"""TimedTrajectory.sample's compiled evaluation gives exactly NumPy's (robot_trajectory.py).

Bit for bit, since the kernel performs the same operations in the same order: on random
trajectories of both interpolations (intervals from 0.1 ms to 0.5 s, 1 to 7 joints) and on
trajectories time_parameterize makes from paths (Ruckig's segments and the smooth method).
"""
from __future__ import annotations

import numpy as np
import pytest

from mycobot_planning.core.jit import numba_available
from mycobot_planning.core.robot_trajectory import robot_trajectory
from mycobot_planning.core.robot_trajectory.robot_trajectory import TimedTrajectory
from mycobot_planning.core.trajectory_processing.time_parameterization import time_parameterize

pytestmark = pytest.mark.skipif(not numba_available(), reason="numba is not installed (scripts/requirements.txt)")


def _both(trajectory: TimedTrajectory, ts: np.ndarray, monkeypatch) -> tuple[tuple, tuple]:
    compiled = trajectory.sample(ts)
    with monkeypatch.context() as patch:
        patch.setattr(robot_trajectory, "_EVALUATE_COMPILED", False)
        reference = trajectory.sample(ts)
    return compiled, reference


def test_random_trajectories_evaluate_bit_for_bit(monkeypatch):
    rng = np.random.default_rng(4)
    for interpolation in ("cubic", "quintic"):
        for _ in range(150):
            n, d = int(rng.integers(2, 40)), int(rng.integers(1, 8))
            times = np.cumsum(rng.uniform(1e-4, 0.5, n))
            trajectory = TimedTrajectory([f"j{i}" for i in range(d)], times, rng.normal(size=(n, d)),
                                         rng.normal(size=(n, d)), rng.normal(size=(n, d)),
                                         interpolation=interpolation)
            ts = np.concatenate([rng.uniform(times[0] - 0.1, times[-1] + 0.1, 200), times])  # stored points too
            compiled, reference = _both(trajectory, ts, monkeypatch)
            for ours, theirs in zip(compiled, reference):
                assert np.array_equal(ours, theirs)


@pytest.mark.parametrize("method", ["segments", "smooth"])
def test_timed_paths_evaluate_bit_for_bit(method, monkeypatch):
    rng = np.random.default_rng(9)
    for _ in range(10):
        path = np.cumsum(rng.normal(scale=0.3, size=(6, 6)), axis=0)
        trajectory = time_parameterize(path, 2.0, 4.0, method=method)
        ts = np.linspace(trajectory.times[0], trajectory.times[-1], 2000)
        compiled, reference = _both(trajectory, ts, monkeypatch)
        for ours, theirs in zip(compiled, reference):
            assert np.array_equal(ours, theirs)
        assert not np.array_equal(compiled[0][0], compiled[0][-1])  # the motion moves


def test_max_steps_are_numpys():
    """The compiled step sizes are NumPy's max(|diff|, axis=1), NaN rows included."""
    from mycobot_planning.core.robot_trajectory.robot_trajectory import max_steps

    rng = np.random.default_rng(5)
    for _ in range(100):
        n, d = int(rng.integers(2, 60)), int(rng.integers(1, 8))
        positions = rng.normal(size=(n, d))
        if rng.random() < 0.3:
            positions[rng.integers(n), rng.integers(d)] = np.nan
        expected = np.max(np.abs(np.diff(positions, axis=0)), axis=1)
        assert np.array_equal(max_steps(positions), expected, equal_nan=True)
    assert max_steps(np.zeros((1, 3))).shape == (0,)


def test_nan_times_are_refused_and_one_point_trajectories_sample(monkeypatch):
    from mycobot_planning.core.errors import TimeParameterizationError

    trajectory = time_parameterize(np.array([[0.0, 0.0], [0.5, -0.2]]), 1.0, 1.0)
    for compiled_evaluation in (True, False):
        monkeypatch.setattr(robot_trajectory, "_EVALUATE_COMPILED", compiled_evaluation)
        with pytest.raises(TimeParameterizationError, match="NaN"):
            trajectory.sample(np.array([0.1, np.nan]))
        with pytest.raises(TimeParameterizationError, match="NaN"):
            trajectory.sample(float("nan"))
        still = TimedTrajectory(["a"], np.array([0.0]), np.array([[0.3]]), np.zeros((1, 1)), np.zeros((1, 1)))
        assert np.array_equal(still.sample(np.array([-1.0, 0.0, 2.0]))[0], np.full((3, 1), 0.3))
