"""mtc_node and pick_place_demo as real processes: the seeds' pick and place planned and executed
end to end through mock_controllers and the planning_server.

What a user of the seed expects: the cylinder goes from the table to the place pose in the
planning_server's monitored scene, the arm ends at home, the published solution holds
max_solutions solutions with ascending costs and every step of the best one is valid; bad
parameter values are refused with a reason while the node keeps running; spawn_table false
removes the table; `ros2 param set /mtc_node execute true` executes later; the Trigger re-plans
with changed parameters.
"""
from __future__ import annotations

import subprocess

import numpy as np
import pytest
from rclpy.parameter import Parameter

from interfaces_py.clients import PlanningSceneInterface
from interfaces_py.msgs import TaskSolution, TaskStatistics
from mycobot_planning.core import RobotModel
from mycobot_planning.ros.task.task_node import EXIT_PLANNING_FAILED
from mycobot_planning.ros.task.task_topics import task_topics
from mycobot_planning.paths import config_file
from mycobot_planning.demos.pick_place import PickPlaceParameters, expected_place_pose
from ros_testing import PYTHON, REPO, NodeProcess, TaskProbe, ros_env, wait_until, robot_processes
from task_helpers import replay_task_solution

PARAMS_FILE = str(config_file("mtc_node_params.yaml"))


class Probe(TaskProbe):
    """In-test node (private context): mtc_node's task topics, services and parameters."""

    def __init__(self) -> None:
        super().__init__("mtc_node_test_probe", ("mtc_node", "pick_place_demo"), description=False)
        self.spin_in_background()


@pytest.fixture(scope="module")
def model() -> RobotModel:
    return RobotModel.mycobot()


@pytest.fixture(scope="module")
def system():
    with robot_processes("trajectory_execution.allowed_goal_duration_margin:=3.0", params_file=True):
        yield from _clients()


def _clients():
    probe = scene = None
    try:
        probe = Probe()
        scene = PlanningSceneInterface(timeout=10.0)
        assert scene.wait_for_server(20.0)
        assert wait_until(lambda: scene.call("get_state").get("joint_state_received"), 20.0)
        yield {"probe": probe, "scene": scene}
    finally:
        if scene is not None:
            scene.close()
        if probe is not None:
            probe.close()


def _mtc_node(*params: str, module: str = "mtc_node", params_file: str = PARAMS_FILE) -> NodeProcess:
    return NodeProcess(f"mycobot_planning.nodes.{module}",
                       ["--ros-args", "--params-file", params_file, *[a for p in params for a in ("-p", p)]])






def _object_at(scene: PlanningSceneInterface, name: str, target: np.ndarray, tolerance: float = 0.01) -> bool:
    poses = scene.get_object_poses([name])
    return name in poses and not scene.get_attached_objects([name]) and \
        float(np.linalg.norm(np.asarray(poses[name].position) - target)) <= tolerance


def _joints(scene: PlanningSceneInterface) -> dict[str, float]:
    state = scene.call("get_state")["robot_state"]
    return dict(zip(state["joint_names"], state["positions"]))


def _at_home(scene: PlanningSceneInterface, model: RobotModel, tolerance: float = 0.01) -> bool:
    joints = _joints(scene)
    home = model.named_state("home", "arm")
    return all(abs(joints[name] - value) <= tolerance for name, value in home.items())


def test_mtc_node_plans_executes_and_places_the_object(system, model):
    probe, scene = system["probe"], system["scene"]
    topics = task_topics("mtc_node")
    before = {t: probe.count(t) for t in (topics.statistics, topics.solution)}
    params = PickPlaceParameters()
    node = _mtc_node("execute:=true")
    try:
        assert node.wait_for_output("MTC pick and place completed", 120), node.output()
        log = node.output()
        assert "Found 10 solutions" in log and "Execution succeeded" in log, log
        assert "Task planning succeeded" in log and "Task executed successfully" in log  # the seed's lines
        for line in ("  current state: 1 solutions, 0 failures", "  move to place: 10 solutions, 0 failures"):
            assert line in log
        assert "Added table to planning scene" in log and "Added object to planning scene" in log

        # the published best solution and the statistics
        assert wait_until(lambda: all(probe.count(t) > before[t] for t in before), 10.0)
        statistics = TaskStatistics.from_json(probe.latest(topics.statistics))
        root = statistics.stages[0]
        assert len(root.solved) == 10 and len(root.cost) == 10 and root.cost == sorted(root.cost)
        solution = TaskSolution.from_json(probe.latest(topics.solution))
        assert solution.cost == pytest.approx(root.cost[0])
        planned_end, moved = replay_task_solution(model, solution)
        assert moved >= 10
        assert np.linalg.norm(planned_end.frame_pose("object")[:3, 3] - expected_place_pose(params)[:3, 3]) < 1e-3

        # what execution did to the planning_server's monitored scene
        target = expected_place_pose(params)[:3, 3]
        assert wait_until(lambda: _object_at(scene, "object", target), 10.0), scene.get_object_poses()
        assert _at_home(scene, model), _joints(scene)
        assert abs(_joints(scene)["gripper_controller"]) <= 0.01  # opened again
        assert node.alive()  # stays alive for introspection

        # invalid values are refused with a reason; the node keeps running and keeps its values
        refused = [
            (Parameter("table_dimensions", value=[0.1, 0.2]), "table_dimensions must have exactly 3 values, got 2"),
            (Parameter("object_pose", value=[0.2, 0.1, 0.0]), "object_pose must have exactly 6 values, got 3"),
            (Parameter("object_name", value=""), "object_name must not be empty"),
            (Parameter("controller_names", value=["arm_controller", ""]), "controller_names must not be empty"),
            (Parameter("approach_object_min_dist", value=0.5), "must not exceed approach_object_max_dist (0.3)"),
            (Parameter("cartesian_step_size", value=0.0), "cartesian_step_size must be > 0"),
            (Parameter("lift_object_direction_z", value=0.0), "lift_object_direction_z must not be 0"),
            # names checked against the robot model and the controllers configuration
            (Parameter("arm_group_name", value="legs"), "unknown planning group 'legs'"),
            (Parameter("gripper_frame", value="nolink"), "unknown frame 'nolink'"),
            (Parameter("world_frame", value="mars"), "unknown frame 'mars'"),
            (Parameter("arm_home_pose", value="moon"), "unknown named state 'moon' of group 'arm'"),
            (Parameter("controller_names", value=["nope"]), "unknown controllers ['nope']"),
        ]
        for param, reason in refused:
            result = probe.set_param("mtc_node", param)
            assert not result.successful and reason in result.reason, (param.name, result.reason)
        assert probe.set_param("mtc_node", Parameter("max_solutions", value=3)).successful
        assert node.alive()
        assert "refused table_dimensions: table_dimensions must have exactly 3 values" in node.output()
    finally:
        node.stop()


def test_spawn_table_false_then_execute_on_param_set_and_replan_on_trigger(system, model):
    probe, scene = system["probe"], system["scene"]
    node = _mtc_node("spawn_table:=false", "max_solutions:=1")
    try:
        assert node.wait_for_output("MTC pick and place completed", 90), node.output()
        log = node.output()
        assert "Found 1 solutions" in log
        assert "Removed table 'table' from the planning scene (spawn_table is false)" in log
        assert "table" not in scene.get_objects()
        start = np.array([0.22, 0.12, 0.175])  # the object is back on its start pose (where the table was)
        assert _object_at(scene, "object", start)
        assert "Executing the best solution" not in log  # execute is false

        # `ros2 param set /mtc_node execute true` executes the planned solution
        cli = subprocess.run([PYTHON, "-m", "mycobot_planning.ros2cli", "param", "set", "/mtc_node", "execute", "true"],
                             cwd=REPO, env=ros_env(), capture_output=True, text=True, timeout=30)
        assert cli.returncode == 0 and "successful" in cli.stdout, cli.stdout + cli.stderr
        assert wait_until(lambda: "Execution succeeded" in node.output(), 60), node.output()
        target = expected_place_pose(PickPlaceParameters())[:3, 3]
        assert wait_until(lambda: _object_at(scene, "object", target), 10.0), scene.get_object_poses()
        assert "table" not in scene.get_objects()

        # the Trigger re-plans with changed parameters: the table and the object come back first
        assert probe.set_param("mtc_node", Parameter("spawn_table", value=True)).successful
        response = probe.trigger("/mtc_node/plan")
        assert response.success and response.message.startswith("1 solutions"), response.message
        assert "table" in scene.get_objects() and _object_at(scene, "object", start)
        assert node.output().count("Execution succeeded") == 1  # re-planning does not execute

        # a plan that fails answers with the reason the log has, not an empty "Failing stage(s):"
        assert probe.set_param("mtc_node", Parameter("object_pose", value=[0.5, 0.0, 0.0, 0.0, 0.0, 0.0])).successful
        response = probe.trigger("/mtc_node/plan")
        assert not response.success and "failing stage(s): grasp pose IK" in response.message, response.message
        assert node.alive()
    finally:
        node.stop()


def test_pick_place_demo_plans_with_example_1_parameters(system):
    probe = system["probe"]
    topic = task_topics("pick_place_demo").solution
    before = probe.count(topic)
    # A loaded machine may deliver the latched solution late: the demo lingers 10 s after start.
    node = _mtc_node("exit_when_done:=true", "exit_linger:=10.0", "max_solutions:=2", module="pick_place_demo",
                     params_file=str(config_file("pick_place_demo_params.yaml")))
    try:
        assert wait_until(lambda: not node.alive(), 90), node.output()
        log = node.output()
        assert node.proc.returncode == 0, log
        assert "Found 2 solutions" in log and "[pick_place_demo]" in log and "Planning succeeded" in log
        assert "  pick object: " in log and "  place object: " in log
        assert wait_until(lambda: probe.count(topic) > before, 10.0)
        assert TaskSolution.from_json(probe.latest(topic)).task_id == "pick_place_task"
    finally:
        node.stop()


def test_a_bad_parameter_file_value_stops_the_node_with_one_line(system):
    node = _mtc_node("table_dimensions:=[0.1,0.2]")
    try:
        assert wait_until(lambda: not node.alive(), 30), node.output()
        log = node.output()
        assert node.proc.returncode == 1
        assert "table_dimensions must have exactly 3 values, got 2" in log and "Traceback" not in log
    finally:
        node.stop()


def test_an_unreachable_object_fails_planning_names_the_stage_and_executes_nothing(system):
    scene = system["scene"]
    node = _mtc_node("execute:=true", "exit_when_done:=true", "object_pose:=[0.5,0.0,0.0,0.0,0.0,0.0]")
    try:
        assert wait_until(lambda: not node.alive(), 90), node.output()
        log = node.output()
        assert node.proc.returncode == EXIT_PLANNING_FAILED, log
        assert "Task planning failed" in log and "Failure explanation:\nFailing stage(s):\ngrasp pose IK" in log
        assert "Executing the best solution" not in log
        assert _object_at(scene, "object", np.array([0.5, 0.0, 0.175]))  # set up where asked, never moved
    finally:
        node.stop()
