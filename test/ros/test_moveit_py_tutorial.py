"""MoveItPy's tutorial scripts, as fetched, byte for byte, through ``mtc_script`` with the
tutorial's own configuration YAML, against the Panda bring-up.

moveit2_tutorials' motion_planning_python_api_tutorial.py plans five times (named states, a random
RobotState, a PoseStamped, joint constraints, three pipelines at once) and executes each plan;
motion_planning_python_api_planning_scene.py adds boxes through ``read_write()``, plans around
them, checks a state for collisions in ``read_only()``, removes them and goes back to 'ready'.
Both run through test/mtc_script_runner.py (the runner with ``time.sleep`` capped) and
``--ros-args --params-file config/motion_planning_python_api_tutorial.yaml``, as the tutorial's
launch file hands that file to the node. MTC_SCRIPT_SEED fixes the tutorial's random goal: MoveIt
draws it from an unseeded generator, so about one run in ten would ask for a colliding state
(MoveIt then reports "Planning failed", as it would here); seed 1 gives a valid one.
"""
from __future__ import annotations

from typing import Any, Iterator

import pytest

from mycobot_planning.paths import use_fast_discovery
from ros_testing import PANDA_READY, REPO, NodeProcess, ProbeNode, panda_processes, use_session_domain, wait_until

TUTORIAL = REPO / "test" / "third_party" / "moveit_py_tutorial"
CONFIG = TUTORIAL / "config" / "motion_planning_python_api_tutorial.yaml"
RUNNER = REPO / "test" / "mtc_script_runner.py"
SUCCEEDED = "Completed trajectory execution with status SUCCEEDED"


@pytest.fixture(scope="module")
def panda_system(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[NodeProcess, NodeProcess]]:
    use_session_domain()
    use_fast_discovery()
    with panda_processes(tmp_path_factory.mktemp("panda")) as processes:
        yield processes


@pytest.fixture(scope="module")
def joint_probe(panda_system: Any) -> Iterator[ProbeNode]:
    probe = ProbeNode("moveit_py_tutorial_probe")
    try:
        probe.listen_to_joint_states()
        probe.spin_in_background()
        yield probe
    finally:
        probe.close()


def run_tutorial(script: str, monkeypatch: pytest.MonkeyPatch, timeout: float = 240.0) -> tuple[int, str]:
    """(exit code, output) of a tutorial script run to its end through the runner."""
    monkeypatch.setenv("MTC_SCRIPT_SEED", "1")
    process = NodeProcess(str(RUNNER), [str(TUTORIAL / "scripts" / script), "--ros-args", "--params-file",
                                        str(CONFIG)], name=script.removesuffix(".py"))
    try:
        assert wait_until(lambda: not process.alive(), timeout), f"{script} did not finish:\n{process.output()}"
        return process.proc.returncode, process.output()
    finally:
        process.stop()


def at_ready(probe: ProbeNode) -> bool:
    joints = probe.joints()
    return all(abs(joints.get(f"panda_joint{i + 1}", 9.0) - v) < 0.01 for i, v in enumerate(PANDA_READY))


def test_the_tutorial_files_are_as_published() -> None:
    tutorial = (TUTORIAL / "scripts" / "motion_planning_python_api_tutorial.py").read_text()
    assert "from moveit.planning import (\n    MoveItPy,\n    MultiPipelinePlanRequestParameters,\n)" in tutorial
    assert '["ompl_rrtc", "pilz_lin", "chomp_planner"]' in tutorial
    assert "planning_scene_monitor.read_write() as scene" in \
        (TUTORIAL / "scripts" / "motion_planning_python_api_planning_scene.py").read_text()
    assert "ros__parameters" not in CONFIG.read_text()  # MoveIt's plain configuration YAML


def test_motion_planning_python_api_tutorial_plans_and_executes_every_goal(
        joint_probe: ProbeNode, monkeypatch: pytest.MonkeyPatch) -> None:
    code, output = run_tutorial("motion_planning_python_api_tutorial.py", monkeypatch)
    assert code == 0, output
    assert "MoveItPy instance created" in output, output
    # five plans (named states, a random RobotState, a PoseStamped, joint constraints, three
    # pipelines at once), each found and executed
    assert output.count("Planning trajectory") == 5, output
    assert "Planning failed" not in output, output
    assert output.count("Executing plan") == 5 and output.count(SUCCEEDED) == 5, output
    # the configuration's three pipelines load, and each of OMPL, the industrial planner and CHOMP plans
    assert "Failed to load planning pipeline" not in output, output
    assert "No planning pipeline available" not in output, output
    for pipeline in ("ompl", "pilz_industrial_motion_planner", "chomp"):
        assert f"Planning with '{pipeline}' failed" not in output, output
    assert wait_until(lambda: at_ready(joint_probe), 10.0), joint_probe.joints()  # the last goal: 'ready'


def test_motion_planning_python_api_planning_scene_script(joint_probe: ProbeNode,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    code, output = run_tutorial("motion_planning_python_api_planning_scene.py", monkeypatch)
    assert code == 0, output
    assert output.count("Planning trajectory") == 2 and "Planning failed" not in output, output
    # each plan was checked against MoveItPy's own scene (the boxes) before it was sent: both ran
    assert output.count(SUCCEEDED) == 2, output
    # the IK state for the hand at (0.25, 0.25, 0.5) puts the arm into the boxes: the verbose check
    # names the contacts, and every one of them is with the boxes
    assert "Robot is in collision: True" in output, output
    contacts = [line for line in output.splitlines() if "Collision: contact between" in line]
    assert contacts and all("'boxes' (Object)" in line for line in contacts), output
    assert wait_until(lambda: at_ready(joint_probe), 10.0), joint_probe.joints()
