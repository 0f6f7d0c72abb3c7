"""MTC's own demo scripts, run unchanged but for their import and ROS start-up lines, against our
planning_server and mock controllers set up with the Panda as panda_moveit_config names it.

The scripts (test/mtc_demo_scripts/, from moveit_task_constructor's demo/scripts on the ros2
branch) build their task on ``core.Task()`` and ``task.loadRobotModel(node)`` (pickplace.py relies
on the PipelinePlanner's node instead), plan, and ``task.publish(task.solutions[0])``. Each runs
in its own process (test/mtc_script_runner.py), which afterwards checks every solution with the
core trajectory validator; this test also receives the published solution on MTC's ``/solution``
topic and replays it through the validator in the scene it carries.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Iterator

import pytest
import yaml
from moveit_task_constructor_msgs.msg import Solution

from interfaces_py.json_rpc import JsonRpcClient
from interfaces_py.msgs import TaskSolution
from interfaces_py.moveit_conversions import planning_scene_from_msg
from interfaces_py.mtc_conversions import task_solution_from_msg
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.ros.task.task_topics import MTC_LATCHED_QOS, MTC_SOLUTION_TOPIC
from mycobot_planning.paths import config_file, example_robot_data_dir, use_fast_discovery
from mycobot_planning.task import TaskError, core, stages
from ros_testing import REPO, NodeProcess, ProbeNode, robot_processes, use_session_domain, wait_until
from task_helpers import replay_task_solution

SCRIPTS = REPO / "test" / "mtc_demo_scripts"
RUNNER = REPO / "test" / "mtc_script_runner.py"
READY = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]  # panda_moveit_config's initial positions
#: scripts that plan (properties.py only exercises the property API)
PLANNING_SCRIPTS = ["alternatives", "cartesian", "compute_ik", "constrained", "current_state", "fallbacks",
                    "fix_collision_objects", "fixed_state", "generate_pose", "merger", "modify_planning_scene",
                    "multi_planner", "pickplace_top_grasp"]
#: pickplace.py was written for ROS 1, where a message's quaternion starts as (0, 0, 0, 0): its
#: ``ik_frame.pose.orientation.x = 1.0`` meant a flip about x ("grasp from top"). In ROS 2, w
#: starts at 1, so the same line gives (1, 0, 0, 1): a 90 degree turn about x, a side grasp whose
#: lower finger sits under the box and cannot lift away. The script as published therefore finds
#: no pick (tested below); with one added line restoring the ROS 1 meaning it plans.
TOP_GRASP_LINE = "ik_frame.pose.orientation.x = 1.0  # grasp from top\n"


def panda_parameters(directory: Path) -> tuple[Path, Path]:
    """Params files of planning_server and mock_controllers for the Panda config."""
    urdf = (example_robot_data_dir() / "panda_description" / "urdf" / "panda.urdf").read_text()
    srdf = config_file("panda/panda.srdf").read_text()
    server = {"planning_server": {"ros__parameters": {
        "robot_description": urdf, "robot_description_semantic": srdf,
        "joint_limits_file": str(config_file("panda/joint_limits.yaml")),
        "kinematics_file": str(config_file("panda/kinematics.yaml")),
        "controllers_file": str(config_file("panda/controllers.yaml")),
        "goal.group": "panda_arm"}}}
    # the arm at 'ready' (panda_moveit_config's initial positions), the hand 'open': pickplace.py
    # plans its grasp without opening the hand first
    initial = {f"panda_joint{i + 1}": value for i, value in enumerate(READY)} | {"panda_finger_joint1": 0.035}
    controllers = {"controller_manager": {"ros__parameters": {
        "robot_description": urdf, "robot_description_semantic": srdf,
        "controllers_file": str(config_file("panda/controllers.yaml")),
        "joint_limits_file": str(config_file("panda/joint_limits.yaml")),
        "initial_positions": initial}}}
    paths = directory / "panda_server.yaml", directory / "panda_controllers.yaml"
    for path, data in zip(paths, (server, controllers)):
        path.write_text(yaml.safe_dump(data))
    return paths


@pytest.fixture(scope="module")
def panda_system(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[NodeProcess, NodeProcess]]:
    use_session_domain()
    use_fast_discovery()  # this process's probes announce often: a short-lived script finds them at once
    server_file, controllers_file = panda_parameters(tmp_path_factory.mktemp("panda"))
    with robot_processes(params_file=server_file, controllers_file=controllers_file) as processes:
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


def test_pickplace_as_published_finds_no_pick_with_its_ros2_quaternion(panda_system: Any) -> None:
    process = NodeProcess(str(RUNNER), [str(SCRIPTS / "pickplace.py")], name="mtc_pickplace")
    try:
        assert wait_until(lambda: not process.alive(), 150.0), process.output()
        output = process.output()
        result = json.loads(next(line for line in output.splitlines()
                                 if line.startswith("MTC_SCRIPT_RESULT ")).split(" ", 1)[1])
        assert "error" not in result and result["solutions"] == 0, output
        assert "not normalized" in output or "not a unit quaternion" in output, output  # the warning
    finally:
        process.stop()


def published_solution(msg: Any) -> TaskSolution:
    """A moveit_task_constructor_msgs/Solution as our TaskSolution, with its start scene."""
    data = task_solution_from_msg(msg)
    data["start_scene"] = planning_scene_from_msg(msg.start_scene)
    return TaskSolution.from_dict(data)


@pytest.mark.parametrize("name", PLANNING_SCRIPTS)
def test_mtc_demo_script_plans_valid_solutions(name: str, solution_probe: Any, panda: RobotModel,
                                               tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    probe, published = solution_probe
    with probe.lock:
        published.clear()
    # the runner lingers after the script (its latched /solution stays up on a busy machine)
    monkeypatch.setenv("MTC_SCRIPT_LINGER", "15")
    process = NodeProcess(str(RUNNER), [str(script_path(name, tmp_path))], name=f"mtc_{name}")
    try:
        assert process.wait_for_output("MTC_SCRIPT_RESULT", 150.0), f"{name} did not finish:\n{process.output()}"
        output = process.output()
        lines = [line for line in output.splitlines() if line.startswith("MTC_SCRIPT_RESULT ")]
        assert lines, f"{name} reported nothing:\n{output}"
        result = json.loads(lines[-1].split(" ", 1)[1])
        assert "error" not in result, f"{name}: {result['error']}\n{output}"
        assert result["solutions"] >= 1, f"{name} found no solution:\n{output}"
        assert result["valid"] == result["solutions"], f"{name}: invalid solutions {result['problems']}"
        # the solution the script published, as RViz's panel and our task viewer receive it
        assert wait_until(lambda: bool(published), 10.0), f"{name}: nothing on {MTC_SOLUTION_TOPIC}\n{output}"
        with probe.lock:
            msg = published[-1]
        # Collisions, continuity and start states of the message as received. Not its limits: on
        # the wire, times are whole nanoseconds and accelerations re-derived from the received
        # points come out up to 1.0001x the limit (seen: 3.7504 for 3.75 rad/s^2); the runner
        # checked the planned trajectories against the exact limits.
        replay_task_solution(panda, published_solution(msg), check_limits=False)
    finally:
        process.stop()


def test_mtc_properties_script_prints_what_mtc_prints(panda_system: Any) -> None:
    """properties.py: Property and PropertyMap calls, printed as MTC's bindings print them."""
    process = NodeProcess(str(RUNNER), [str(SCRIPTS / "properties.py")], name="mtc_properties")
    try:
        assert wait_until(lambda: not process.alive(), 60.0), process.output()
        output = process.output()
        assert "MTC_SCRIPT_RESULT" in output and '"error"' not in output, output
        lines = [line.strip() for line in output.splitlines()]
        assert lines.count("Bar") == 2 and "Foo Property" in lines, output  # value, default, description
        assert "2" in lines, output  # pm["prop5"]
        table = {line.split()[0]: line.split(None, 1)[1] for line in lines if line.startswith("prop")}
        assert {"prop1", "prop2", "prop3", "prop4", "prop5"} <= set(table), output
        assert table["prop1"] == "test" and table["prop2"] == "21" and table["prop4"] == "5.4", output
    finally:
        process.stop()


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
        assert wait_until(lambda: abs(probe.joints().get("panda_joint4", 0.0) - READY[3]) < 0.01, 10.0)
        with pytest.raises(TaskError, match="no solution"):
            core.Task().execute()
    finally:
        probe.close()
