"""Shared fixtures: the robots every core test runs on (built once per session)."""
from __future__ import annotations

import pytest

from mycobot_planning.core import RobotModel
from mycobot_planning.paths import example_robot_data_dir


@pytest.fixture(scope="session")
def mycobot() -> RobotModel:
    return RobotModel.mycobot()


@pytest.fixture(scope="session")
def panda() -> RobotModel:
    """Franka Panda from example-robot-data: a URDF + SRDF we did not write, with meshes."""
    root = example_robot_data_dir() / "panda_description"
    return RobotModel.from_files(root / "urdf" / "panda.urdf", root / "srdf" / "panda.srdf")
