"""MTC's 14 demo scripts, as fetched, byte for byte, through ``mtc_script`` against the Panda bring-up.

The scripts (test/third_party/mtc_demo_scripts/, moveit_task_constructor's demo/scripts at 8e76def8, see its
SOURCE.md) import ``moveit.task_constructor``, ``rclcpp`` and (pickplace.py) ``moveit_commander``,
which the runner serves. Each runs in its own process through test/mtc_script_runner.py (the
runner, with ``time.sleep`` capped: the scripts end by sleeping up to an hour for RViz), which
afterwards checks every solution with the core trajectory validator and the spacing of its
waypoints (at most 0.1 rad per joint, Cartesian moves at most their step). Each run must exit 0,
and this test receives the published solution on MTC's ``/solution`` and checks it again as it
arrived: the validator, and the spacing of the points on the wire.
"""
from __future__ import annotations

import json
import subprocess
from pathlib import Path
from typing import Any, Iterator

import numpy as np
import pytest
import yaml
from moveit_task_constructor_msgs.msg import Solution

from interfaces_py.json_rpc import JsonRpcClient
from interfaces_py.msgs import TaskSolution
from interfaces_py.moveit_conversions import planning_scene_from_msg
from interfaces_py.mtc_conversions import task_solution_from_msg
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.paths import use_fast_discovery
from mycobot_planning.ros.task.task_topics import MTC_LATCHED_QOS, MTC_SOLUTION_TOPIC
from mycobot_planning.task import TaskError, core, stages
from ros_testing import (
    PANDA_READY,
    PYTHON,
    REPO,
    NodeProcess,
    ProbeNode,
    panda_parameters,
    panda_processes,
    ros_env,
    use_session_domain,
    wait_until,
)
from task_helpers import MAX_WAYPOINT_GAP, replay_task_solution

SCRIPTS = REPO / "test" / "third_party" / "mtc_demo_scripts"
RUNNER = REPO / "test" / "mtc_script_runner.py"
ALL_SCRIPTS = sorted(p.stem for p in SCRIPTS.glob("*.py"))
#: scripts that plan (properties.py only exercises the property API)
PLANNING_SCRIPTS = ["alternatives", "cartesian", "compute_ik", "constrained", "current_state", "fallbacks",
                    "fix_collision_objects", "fixed_state", "generate_pose", "merger", "modify_planning_scene",
                    "multi_planner", "pickplace_top_grasp"]
#: pickplace.py was written for ROS 1, where a message's quaternion starts as (0, 0, 0, 0): its
#: ``ik_frame.pose.orientation.x = 1.0`` meant a flip about x ("grasp from top"). In ROS 2, w
#: starts at 1, so the same line gives (1, 0, 0, 1): a 90 degree turn about x, a side grasp whose
#: lower finger sits under the box and cannot lift away. The script as published therefore finds
#: no pick (MTC's own failure, tested below); the one derived variant adds the line that restores
#: the ROS 1 meaning, and plans.
TOP_GRASP_LINE = "ik_frame.pose.orientation.x = 1.0  # grasp from top\n"
#: planning scripts whose solutions hold no motion (a state, an IK solution, a scene change)
NO_MOTION = {"current_state", "fix_collision_objects", "fixed_state", "generate_pose", "modify_planning_scene"}


def test_the_scripts_are_mtcs_own_14() -> None:
    assert len(ALL_SCRIPTS) == 14, ALL_SCRIPTS
    assert set(PLANNING_SCRIPTS) - {"pickplace_top_grasp"} | {"pickplace", "properties"} == set(ALL_SCRIPTS)
    for name in ALL_SCRIPTS:  # written against MTC's bindings, as published
        text = (SCRIPTS / f"{name}.py").read_text()
        assert "from moveit.task_constructor import core, stages" in text and "rclcpp.init()" in text, name
        assert "mycobot_planning" not in text and "rclpy" not in text, name


@pytest.fixture(scope="module")
def panda_system(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[NodeProcess, NodeProcess]]:
    use_session_domain()
    use_fast_discovery()  # this process's probes announce often: a short-lived script finds them at once
    with panda_processes(tmp_path_factory.mktemp("panda")) as processes:
        yield processes


@pytest.fixture(scope="module")
def solution_probe(panda_system: Any) -> Iterator[tuple[ProbeNode, list[Any]]]:
    """A probe on MTC's /solution, alive for the whole module: a participant that has been up a
    while discovers a new script's publisher at once (a fresh one may miss a short-lived script)."""
    probe = ProbeNode("mtc_script_probe")
    try:
        published = probe.collect(Solution, MTC_SOLUTION_TOPIC, MTC_LATCHED_QOS)
        probe.spin_in_background()
        yield probe, published
    finally:
        probe.close()


@pytest.fixture(scope="module")
def panda() -> RobotModel:
    return RobotModel.panda()


def script_path(name: str, directory: Path) -> Path:
    """The script's file; ``pickplace_top_grasp``: pickplace.py plus the line after TOP_GRASP_LINE
    that sets the quaternion's w to 0, as ROS 1 had it."""
    if name != "pickplace_top_grasp":
        return SCRIPTS / f"{name}.py"
    text = (SCRIPTS / "pickplace.py").read_text()
    assert text.count(TOP_GRASP_LINE) == 1
    path = directory / "pickplace_top_grasp.py"
    path.write_text(text.replace(TOP_GRASP_LINE, TOP_GRASP_LINE + "ik_frame.pose.orientation.w = 0.0\n"))
    return path


def run_script(name: str, script: Path, timeout: float = 150.0) -> tuple[int, dict, str]:
    """Run the script through the runner to its end: (exit code, its MTC_SCRIPT_RESULT, output)."""
    process = NodeProcess(str(RUNNER), [str(script)], name=f"mtc_{name}")
    try:
        assert wait_until(lambda: not process.alive(), timeout), f"{name} did not finish:\n{process.output()}"
        code = process.proc.returncode
    finally:
        process.stop()
    output = process.output()
    lines = [line for line in output.splitlines() if line.startswith("MTC_SCRIPT_RESULT ")]
    assert lines, f"{name} reported nothing (exit code {code}):\n{output}"
    return code, json.loads(lines[-1].split(" ", 1)[1]), output


def test_pickplace_as_published_finds_no_pick_with_its_ros2_quaternion(panda_system: Any) -> None:
    """MTC's own failure, not ours: the ROS 1 quaternion habit (see TOP_GRASP_LINE). The script
    still exits 0, as it does under MTC: it publishes only when planning succeeded."""
    code, result, output = run_script("pickplace", SCRIPTS / "pickplace.py")
    assert code == 0, output
    assert "error" not in result and result["solutions"] == 0, output
    assert "not normalized" in output or "not a unit quaternion" in output, output  # the warning


def published_solution(msg: Any) -> TaskSolution:
    """A moveit_task_constructor_msgs/Solution as our TaskSolution, with its start scene."""
    data = task_solution_from_msg(msg)
    data["start_scene"] = planning_scene_from_msg(msg.start_scene)
    return TaskSolution.from_dict(data)


def wire_gaps(msg: Any) -> list[str]:
    """Sub-trajectories of a received Solution whose consecutive points are too far apart."""
    problems = []
    for sub in msg.sub_trajectory:
        points = sub.trajectory.joint_trajectory.points
        if len(points) > 1:
            gap = float(np.max(np.abs(np.diff([list(p.positions) for p in points], axis=0))))
            if gap > MAX_WAYPOINT_GAP + 1e-9:
                problems.append(f"{sub.info.stage_name}: {gap:.4f} rad between points")
    return problems


@pytest.mark.parametrize("name", PLANNING_SCRIPTS)
def test_mtc_demo_script_plans_dense_valid_solutions(name: str, solution_probe: Any, panda: RobotModel,
                                                     tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    probe, published = solution_probe
    with probe.lock:
        published.clear()
    # the runner lingers after the script (its latched /solution stays up on a busy machine)
    monkeypatch.setenv("MTC_SCRIPT_LINGER", "15")
    code, result, output = run_script(name, script_path(name, tmp_path))
    assert code == 0 and "error" not in result, f"{name} exited {code}: {result.get('error')}\n{output}"
    assert result["solutions"] >= 1, f"{name} found no solution:\n{output}"
    assert result["valid"] == result["solutions"], f"{name}: invalid solutions {result['problems']}"
    assert bool(result["spacing"]) == (name not in NO_MOTION), result["spacing"]
    assert not result["spacing_problems"], f"{name}: {result['spacing_problems']}"
    # the solution the script published, as RViz's panel and our task viewer receive it
    assert wait_until(lambda: bool(published), 10.0), f"{name}: nothing on {MTC_SOLUTION_TOPIC}\n{output}"
    with probe.lock:
        msg = published[-1]
    assert not wire_gaps(msg), wire_gaps(msg)
    # Collisions, continuity and start states of the message as received. Not its limits: on
    # the wire, times are whole nanoseconds and accelerations re-derived from the received
    # points come out up to 1.0001x the limit (seen: 3.7504 for 3.75 rad/s^2); the runner
    # checked the planned trajectories against the exact limits.
    replay_task_solution(panda, published_solution(msg), check_limits=False)


def test_properties_script_through_ros2_run_prints_what_mtc_prints(panda_system: Any) -> None:
    """properties.py as a user runs it, ``ros2 run mycobot_planning mtc_script properties.py``:
    Property and PropertyMap calls, printed as MTC's bindings print them, and exit code 0."""
    run = subprocess.run([PYTHON, "-m", "mycobot_planning.ros2cli", "run", "mycobot_planning", "mtc_script",
                          str(SCRIPTS / "properties.py")], cwd=REPO, env=ros_env(), capture_output=True, text=True,
                         timeout=120)
    output = run.stdout + run.stderr
    assert run.returncode == 0, output
    lines = [line.strip() for line in run.stdout.splitlines()]
    assert lines.count("Bar") == 2 and "Foo Property" in lines, output  # value, default, description
    assert "2" in lines, output  # pm["prop5"]
    table = {line.split()[0]: line.split(None, 1)[1] for line in lines if line.startswith("prop")}
    assert {"prop1", "prop2", "prop3", "prop4", "prop5"} <= set(table), output
    assert table["prop1"] == "test" and table["prop2"] == "21" and table["prop4"] == "5.4", output


def test_runner_as_python_module_and_its_errors(panda_system: Any, tmp_path: Path) -> None:
    """``python -m mycobot_planning.nodes.mtc_script``: a script's exception and exit code are its
    own; a missing script is a usage error (2); the hook serves nothing outside the runner."""
    failing = tmp_path / "failing.py"
    failing.write_text("import rclcpp\nfrom moveit.task_constructor import core\nraise SystemExit(3)\n")
    broken = tmp_path / "broken.py"
    broken.write_text("import moveit.no_such_module\n")

    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([PYTHON, "-m", "mycobot_planning.nodes.mtc_script", *args], cwd=REPO, env=ros_env(),
                              capture_output=True, text=True, timeout=60)

    assert run(str(failing)).returncode == 3
    result = run(str(broken))
    assert result.returncode == 1 and "ModuleNotFoundError" in result.stderr, result.stderr
    assert "no_such_module" in result.stderr
    missing = run(str(tmp_path / "nope.py"))
    assert missing.returncode == 2 and "no such script" in missing.stderr
    plain = subprocess.run([PYTHON, "-c", "import moveit"], cwd=REPO, env=ros_env(), capture_output=True, text=True)
    assert plain.returncode == 1 and "No module named 'moveit'" in plain.stderr, plain.stderr


def test_published_solution_appears_in_the_task_viewer(panda_system: Any, monkeypatch: pytest.MonkeyPatch,
                                                       tmp_path: Path) -> None:
    """cartesian.py publishes its solution and sleeps; meanwhile our task viewer (given the
    Panda) shows the task with its solution, under the script's node name."""
    server_file, _ = panda_parameters(tmp_path)
    params = yaml.safe_load(server_file.read_text())["planning_server"]["ros__parameters"]
    viewer_file = tmp_path / "viewer.yaml"
    viewer_file.write_text(yaml.safe_dump({"task_viewer": {"ros__parameters": {
        "robot_description": params["robot_description"],
        "robot_description_semantic": params["robot_description_semantic"], "port": 0}}}))
    viewer = NodeProcess("mycobot_planning.nodes.task_viewer", ["--ros-args", "--params-file", str(viewer_file)])
    monkeypatch.setenv("MTC_SCRIPT_MAX_SLEEP", "60")
    script = NodeProcess(str(RUNNER), [str(SCRIPTS / "cartesian.py")], name="mtc_cartesian_viewer")
    probe = ProbeNode("mtc_viewer_probe")
    try:
        assert viewer.wait_for_output("task_viewer: open http://127.0.0.1:", 60), viewer.output()
        rpc = JsonRpcClient(probe.node, "/task_viewer")
        probe.spin_in_background()
        assert rpc.wait_for_server(30.0), viewer.output()

        def shown() -> list[dict]:
            return [t for t in rpc.call("get_state", timeout=15.0)["tasks"] if t["key"] == "/mtc_tutorial: cartesian"]

        assert wait_until(lambda: bool(shown()) and shown()[0]["solutions"] >= 1, 90.0, period=0.5), \
            f"{rpc.call('get_state', timeout=15.0)['tasks']}\n{script.output()}\n{viewer.output()}"
        names = [s["name"] for s in shown()[0]["stages"]]
        assert ["current state", "x +0.2", "y -0.3", "rz +45°", "joint offset", "moveTo ready"] == names[1:], names
    finally:
        probe.close()
        script.stop()
        viewer.stop()


def test_task_execute_moves_the_mock_robot(panda_system: Any) -> None:
    """MTC's flow in a script: Task(), loadRobotModel(node), plan, execute(solution): the mock
    Panda ends at the goal, and the task's CurrentState then starts from there."""
    probe = ProbeNode("mtc_execute_probe")
    try:
        probe.listen_to_joint_states()
        probe.spin_in_background()
        goal = {"panda_joint1": 0.4, "panda_joint2": -0.6, "panda_joint3": 0.2, "panda_joint4": -2.0,
                "panda_joint5": 0.1, "panda_joint6": 1.6, "panda_joint7": 0.9}

        def task_to(target: Any) -> Any:
            task = core.Task()
            task.name = "execute"
            task.loadRobotModel(probe.node)
            task.add(stages.CurrentState("current state"))
            move = stages.MoveTo("move", core.PipelinePlanner(probe.node, "ompl", "RRTConnectkConfigDefault"))
            move.group = "panda_arm"
            move.setGoal(target)
            task.add(move)
            assert task.plan(), task.explainFailure(stream=None)
            return task

        task = task_to(goal)
        code = task.execute(task.solutions[0])
        assert code, f"{code.name}: {code.message}"
        assert wait_until(lambda: all(abs(probe.joints().get(j, 9.0) - v) < 0.01 for j, v in goal.items()), 10.0), \
            probe.joints()
        back = task_to("ready")  # plans from where the robot now is
        start = next(s for s in back.solutions[0].sub_trajectories() if s.trajectory is not None).trajectory.positions[0]
        assert start == pytest.approx(list(goal.values()), abs=0.01)
        assert back.execute(back.solutions[0])
        assert wait_until(lambda: abs(probe.joints().get("panda_joint4", 0.0) - PANDA_READY[3]) < 0.01, 10.0)
        with pytest.raises(TaskError, match="no solution"):
            core.Task().execute()
    finally:
        probe.close()
