"""Bugs found against the ROS ecosystem's expectations, each pinned by a test: an install
elsewhere than the checkout finds its config through the ament index; `ros2 topic info` counts
settle before it answers; empty-list parameters have their real type; planner ids are checked
when they are set."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

from mycobot_planning.core.planning_interface.planning_pipeline import PlanningPipeline
from mycobot_planning.ros.workflow_runtime import PLANNING_SPECS
from ros_testing import REPO, NodeProcess, ros_env, use_session_domain

ROS2 = [sys.executable, "-m", "mycobot_planning.ros2cli"]


def ros2(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([*ROS2, *args], cwd=REPO, env=ros_env(), capture_output=True, text=True, timeout=60)


def test_an_install_with_a_prefix_finds_its_config_and_runs_a_node(tmp_path):
    """As colcon installs without --symlink-install: the package in <prefix>/lib/.../site-packages,
    its config in <prefix>/share/mycobot_planning, found through AMENT_PREFIX_PATH."""
    prefix = tmp_path / "install"
    # Built from a copy: setuptools writes build/ and an egg-info into the tree it builds, and a
    # stale egg-info in the checkout would shadow the venv's own metadata (entry points) later.
    source = tmp_path / "source"
    shutil.copytree(REPO, source, ignore=shutil.ignore_patterns(
        ".git", ".venv", ".venv-peers", "build", "*.egg-info", "__pycache__", "bench_results", ".pytest_cache"))
    build = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--disable-pip-version-check", "--no-deps",
         "--no-build-isolation", "--ignore-installed", "--prefix", str(prefix), str(source)],
        capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert build.returncode == 0, build.stderr[-2000:]
    own = subprocess.run([sys.executable, "-c", "import mycobot_planning; print(mycobot_planning.__file__)"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert Path(own.stdout.strip()).is_relative_to(REPO), "the test's install must leave the venv's own alone"
    relative = Path(sysconfig.get_path("purelib")).relative_to(sysconfig.get_path("data"))
    site = prefix / relative
    assert (site / "mycobot_planning" / "paths.py").is_file()
    assert (prefix / "share" / "mycobot_planning" / "config" / "mycobot_280.urdf").is_file()
    env = ros_env()
    env["PYTHONPATH"] = str(site)
    env["AMENT_PREFIX_PATH"] = os.pathsep.join(p for p in (str(prefix), env.get("AMENT_PREFIX_PATH", "")) if p)
    found = subprocess.run([sys.executable, "-c", "from mycobot_planning.paths import config_dir; "
                                                  "import mycobot_planning; print(config_dir()); "
                                                  "print(mycobot_planning.__file__)"],
                           env=env, cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert found.returncode == 0, found.stderr
    config, module = found.stdout.split()
    assert Path(module).is_relative_to(site)  # the installed copy, not the checkout
    assert Path(config) == prefix / "share" / "mycobot_planning" / "config"
    started = subprocess.Popen([sys.executable, "-m", "mycobot_planning.nodes.robot_state_publisher"], env=env,
                               cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                               start_new_session=True)
    try:
        line = ""
        for line in started.stdout:  # the node loads the default URDF from the installed config
            if "robot_state_publisher ready" in line or "ERROR" in line:
                break
        assert "robot_state_publisher ready: robot 'mycobot_280'" in line, line
    finally:
        os.killpg(started.pid, 2)
        started.wait(10)


@pytest.fixture(scope="module")
def mock():
    use_session_domain()
    node = NodeProcess("mycobot_planning.nodes.mock_controllers")
    server = NodeProcess("mycobot_planning.nodes.planning_server")
    try:
        assert node.wait_for_output("controller_manager ready", 30), node.output()
        assert server.wait_for_output("planning_server ready", 60), server.output()
        yield node
    finally:
        server.stop()
        node.stop()


def test_topic_info_counts_the_publisher_every_time(mock):
    """It used to answer at first sight of the topic, often before its publisher was known."""
    for _ in range(3):
        info = ros2("topic", "info", "/joint_states")
        assert "Publisher count: 1" in info.stdout, info.stdout + info.stderr


def test_empty_list_parameters_have_their_real_type(mock):
    described = ros2("param", "describe", "/planning_server", "goal.pose")
    assert "Type: double array" in described.stdout, described.stdout + described.stderr
    accepted = ros2("param", "set", "/planning_server", "goal.pose", "[0.15, 0.0, 0.25, 0.0, 1.0, 0.0, 0.0]")
    assert "Set parameter successful" in accepted.stdout, accepted.stdout + accepted.stderr
    reset = ros2("param", "set", "/planning_server", "goal.pose", "[]")
    assert "Set parameter successful" in reset.stdout, reset.stdout + reset.stderr


def test_unknown_planner_ids_are_refused_when_set(mock):
    refused = ros2("param", "set", "/planning_server", "planner_id", "Magic")
    assert refused.returncode == 0  # as ros2cli: the refusal is reported on stderr
    assert "Setting parameter failed: unknown planner id 'Magic'" in refused.stderr
    spec = next(s for s in PLANNING_SPECS if s.name == "planner_id")  # the move_group workflow nodes
    assert "unknown planner id 'Teleport'" in spec.check("Teleport")
    for known in ("", "RRTConnectkConfigDefault", "PTP", "arm[RRTConnectkConfigDefault]"):
        assert spec.check(known) is None, known
    assert PlanningPipeline().planner_id_problem("LIN") is None
