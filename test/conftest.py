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


#: Names whose presence in a test module means it talks ROS (nodes, processes, rclpy contexts).
_ROS_NAMES = ("rclpy", "NodeProcess", "ros_env", "use_session_domain", "session_domain_id", "RobotProcesses")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "ros: starts ROS nodes or processes, or uses rclpy "
                                       "(`./scripts/test.sh -m 'not ros'` runs the fast rest)")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Mark every test of a module that uses ROS, so the fast unit set is one option away."""
    for item in items:
        module = getattr(item, "module", None)
        if module is not None and any(name in vars(module) for name in _ROS_NAMES):
            item.add_marker(pytest.mark.ros)
