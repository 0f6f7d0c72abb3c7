"""Fixtures of the simulation tests: the seeds' world with the myCobot, planned once."""
from __future__ import annotations

import pytest

from mycobot_planning.simulation import MujocoSimulator  # first: sets MUJOCO_GL before mujoco loads


@pytest.fixture
def sim(mycobot):
    """The seeds' world (config/mujoco_scene.yaml, config/mujoco_sim.yaml), camera off."""
    with MujocoSimulator(mycobot, camera=False) as simulator:
        yield simulator
