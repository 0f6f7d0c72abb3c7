"""The task demo nodes (modular, fallbacks_move_to, ik_clearance_cost) as real processes.

mock_controllers and planning_server run for the whole module; an in-test probe node records
the task topics, /display_planned_path and /joint_states. Each demo runs as a user would run it
(`exit_when_done` for scripts, or left spinning and driven through `ros2 param set` and its
Trigger services), and the test checks what the seeds promise: printState with the seed's stage
names and counts, the stage summary, a published TaskSolution whose every sub-trajectory passes
the core validator in the scene replayed from its start scene and diffs, the display path, and
execution ending where the solution ends.
"""
from __future__ import annotations

import re
import subprocess
import time

import numpy as np
import pytest
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory as JointTrajectoryMsg

from interfaces_py.msgs import TaskDescription, TaskSolution, TaskStatistics
from mycobot_planning.core import RobotModel
from mycobot_planning.paths import use_fast_discovery
from mycobot_planning.ros.task.task_node import EXIT_PLANNING_FAILED
from mycobot_planning.ros.task.task_topics import task_topics
from ros_testing import PYTHON, REPO, NodeProcess, TaskProbe, robot_processes, ros_env, use_session_domain, wait_until
from task_helpers import replay_task_solution

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
NODES = {"modular": "modular_demo", "fallbacks_move_to": "fallbacks_move_to_demo",
         "ik_clearance_cost": "ik_clearance_cost_demo"}


class Probe(TaskProbe):
    """In-test node (private context): task topics of the three demos, display path, joint states."""

    def __init__(self) -> None:
        super().__init__("task_nodes_test_probe", NODES.values())
        self.display: list[JointTrajectoryMsg] = []
        self.joint_history: list[tuple[float, dict[str, float]]] = []
        self.node.create_subscription(JointTrajectoryMsg, "/planned_path", self._on_display, LATCHED)
        self.node.create_subscription(JointState, "/joint_states", self._on_js, 10)
        self.spin_in_background()

    def _on_display(self, msg: JointTrajectoryMsg) -> None:
        with self.lock:
            self.display.append(msg)

    def _on_js(self, msg: JointState) -> None:
        with self.lock:
            self.joint_history.append((time.monotonic(), dict(zip(msg.name, msg.position))))
            del self.joint_history[:-10000]

    def joints(self) -> dict[str, float]:
        with self.lock:
            return dict(self.joint_history[-1][1]) if self.joint_history else {}

    def history(self, since: float) -> list[dict[str, float]]:
        with self.lock:
            return [js for t, js in self.joint_history if t >= since]

    def displays(self) -> list[JointTrajectoryMsg]:
        with self.lock:
            return list(self.display)


@pytest.fixture(scope="module")
def model() -> RobotModel:
    return RobotModel.mycobot()


@pytest.fixture(scope="module")
def system():
    use_session_domain()
    # The probe announces itself as often as our nodes do (0.25 s, not Fast DDS's 3 s), so a
    # short-lived demo node discovers it before exiting.
    use_fast_discovery()
    with robot_processes("trajectory_execution.allowed_goal_duration_margin:=3.0", params_file=True) as (_, server):
        probe = Probe()
        try:
            assert wait_until(lambda: bool(probe.joints()), 20.0)
            yield {"probe": probe, "server": server}
        finally:
            probe.close()


def _run(module: str, *params: str, linger: float = 6.0, timeout: float = 90.0) -> tuple[int, str]:
    """Run a demo with exit_when_done; (exit code, log). ``linger``: exit_linger, long enough
    for the probe to receive the latched topics of a fast demo (0 when they do not matter).
    The demos plan in tens of milliseconds; 3 s once proved too short for discovery on a loaded
    machine (nothing received from ik_clearance_cost)."""
    node = NodeProcess(f"mycobot_planning.nodes.{module}",
                       ["--ros-args", "-p", "exit_when_done:=true", "-p", f"exit_linger:={linger}",
                        *[a for p in params for a in ("-p", p)]])
    try:
        assert wait_until(lambda: not node.alive(), timeout), node.output()
        return node.proc.returncode, node.output()
    finally:
        node.stop()


def _print_state(log: str) -> list[str]:
    """The printState lines of the log (the block after "Task state:")."""
    block = log.split("Task state:\n", 1)[1]
    lines = []
    for line in block.splitlines():
        if not re.match(r"^\s+(\d+|-)\s+(\d+|-) ", line):
            break
        lines.append(line)
    return lines


def _state_line(lines: list[str], name: str) -> list[str]:
    """The count columns of every printState line of stage ``name``."""
    return [line.split(" / ", 1)[0].split() for line in lines if line.split(" / ", 1)[1] == name]


def _replay_and_validate(model: RobotModel, msg: TaskSolution) -> np.ndarray:
    """Validate every sub-trajectory in the scene replayed from the start scene and the diffs
    (each must start where the previous one ended); returns the final joint positions."""
    scene, moved = replay_task_solution(model, msg)
    assert moved > 0
    return scene.current_state.positions.copy()


def _check_published(probe: Probe, model: RobotModel, node: str, before: dict[str, int], started: float,
                     motion: bool = True) -> tuple[TaskSolution, JointTrajectoryMsg]:
    topics = task_topics(node)
    for topic in (topics.description, topics.statistics, topics.solution):
        assert wait_until(lambda t=topic: probe.count(t) > before[t], 10.0), f"nothing on {topic}"
    description = TaskDescription.from_json(probe.latest(topics.description))
    statistics = TaskStatistics.from_json(probe.latest(topics.statistics))
    assert len(description.stages) == len(statistics.stages)
    solution = TaskSolution.from_json(probe.latest(topics.solution))
    end = _replay_and_validate(model, solution) if motion else None
    # The display path of this solution: published by the node after `started`
    names = None
    for sub in solution.sub_trajectory:
        names = names or sub.trajectory.joint_trajectory.joint_names
    display = [d for d in probe.displays() if d.header.stamp.sec + d.header.stamp.nanosec * 1e-9 >= started - 1.0]
    assert display, "nothing on /display_planned_path"
    shown = display[-1]
    assert shown.points and all(not p.accelerations for p in shown.points)
    if end is not None:
        last = dict(zip(shown.joint_names, shown.points[-1].positions))
        for name in last:
            assert abs(last[name] - end[model.variable_index(name)]) < 1e-6
    return solution, shown


def _counts(probe: Probe, node: str) -> dict[str, int]:
    topics = task_topics(node)
    return {t: probe.count(t) for t in (topics.description, topics.statistics, topics.solution)}


# ---------------------------------------------------------------------------- exit_when_done runs
def test_modular_plans_one_solution_from_the_current_state(system, model):
    probe = system["probe"]
    before, started = _counts(probe, "modular_demo"), time.time()
    code, log = _run("modular")
    assert code == 0, log
    lines = _print_state(log)
    assert lines[0].split() == ["1", "-", "←", "1", "→", "-", "1", "/", "Reusable", "Containers"]
    assert _state_line(lines, "current") == [["1", "-", "←", "1", "→", "-", "0"]]
    assert _state_line(lines, "move to ready") == [["-", "0", "→", "1", "→", "-", "1"]]
    assert len(_state_line(lines, "Cartesian Path")) == 5
    for stage in ("x +0.05", "y -0.02", "rz -18°"):
        assert _state_line(lines, stage) == [["-", "0", "→", "1", "→", "-", "0"]] * 5
    assert _state_line(lines, "moveTo ready") == [["-", "0", "→", "1", "→", "-", "1"]] * 5
    assert _state_line(lines, "move to home") == [["-", "0", "→", "1", "→", "-", "1"]]
    assert "Found 1 solutions" in log
    summary = log.split("Stage summary:\n", 1)[1].splitlines()[:8]
    assert summary == ["  current: 1 solutions, 0 failures", "  move to ready: 1 solutions, 0 failures"] + \
        ["  Cartesian Path: 1 solutions, 0 failures"] * 5 + ["  move to home: 1 solutions, 0 failures"]
    solution, _ = _check_published(probe, model, "modular_demo", before, started)
    assert solution.task_id == "Reusable Containers"
    assert [s.info.stage_name for s in solution.sub_trajectory][:3] == ["current", "move to ready", "x +0.05"]
    assert "modular demo completed" in log


def test_fallbacks_cartesian_fails_pilz_solves_two_ompl_the_box(system, model):
    probe = system["probe"]
    before, started = _counts(probe, "fallbacks_move_to_demo"), time.time()
    code, log = _run("fallbacks_move_to")
    assert code == 0, log
    lines = _print_state(log)
    assert _state_line(lines, "fallback strategies in MoveTo") == [["3", "-", "←", "3", "→", "-", "3"]]
    for name in ("90 degree offset from target goal", "directly reachable without collision",
                 "getting to target requires collision avoidance"):
        assert _state_line(lines, name) == [["3", "-", "←", "1", "→", "-", "3"]]
    assert _state_line(lines, "move to other side") == [["-", "0", "→", "3", "→", "-", "3"]]
    assert _state_line(lines, "Cartesian path") == [["-", "0", "→", "0", "→", "-", "3"]]
    assert _state_line(lines, "Pilz path") == [["-", "0", "→", "2", "→", "-", "3"]]
    assert _state_line(lines, "OMPL path") == [["-", "0", "→", "1", "→", "-", "3"]]
    assert "  initial states: 3 solutions, 0 failures" in log
    assert "  move to other side: 3 solutions, 0 failures" in log
    # the expensive OMPL detour around the box comes last
    costs = [float(c) for c in re.findall(r"solution \d+: cost ([\d.]+)", log)]
    assert len(costs) == 3 and costs == sorted(costs)
    assert "getting to target requires collision avoidance → OMPL path" in log
    solution, _ = _check_published(probe, model, "fallbacks_move_to_demo", before, started)
    assert [s.info.stage_name for s in solution.sub_trajectory][-1] == "Pilz path"


def test_ik_clearance_ranks_ik_solutions_by_clearance(system, model):
    probe = system["probe"]
    before, started = _counts(probe, "ik_clearance_cost_demo"), time.time()
    code, log = _run("ik_clearance_cost", "execute:=false")
    assert code == 0, log
    assert "Parameters loaded: cumulative=false, with_world=true" in log
    lines = _print_state(log)
    top = _state_line(lines, "clearance IK")[0]
    n = int(top[3])
    assert n >= 2 and top == [str(n), "-", "←", str(n), "→", "-", str(n)]
    assert _state_line(lines, "IK") == [[str(n), "-", "←", str(n), "→", "-", str(n)]]
    assert _state_line(lines, "initial state") == [["1", "-", "←", "1", "→", "-", "1"]]
    found = re.findall(r"solution \d+: cost ([\d.]+), IK \(IK: Clearance: distance ([\d.e-]+) between '(\w+)' and '(\w+)'\)",
                       log)
    assert len(found) == n
    costs = [float(c) for c, *_ in found]
    assert costs == sorted(costs)
    for _cost, _distance, a, b in found:
        assert "obstacle" in (a, b) and model.has_link(b if a == "obstacle" else a)
    assert f"  IK: {n} solutions" in log and "IK Clearance Cost Demo completed" in log
    solution, shown = _check_published(probe, model, "ik_clearance_cost_demo", before, started, motion=False)
    assert solution.sub_trajectory[0].info.stage_name == "IK"
    assert len(shown.points) == 1  # an IK solution is a state: shown as one point


def test_ik_clearance_execute_refuses_a_solution_without_motion(system):
    code, log = _run("ik_clearance_cost", "execute:=true", "cumulative:=true", linger=0.0)
    assert code == 3, log
    assert "Parameters loaded: cumulative=true, with_world=true" in log
    assert "contains no motion" in log


def test_unreachable_planning_server_fails_planning_with_an_explanation(system):
    code, log = _run("modular", "planning_server:=/no_such_server", "server_timeout:=1.0", linger=0.0)
    assert code == EXIT_PLANNING_FAILED, log
    assert "Failure explanation" in log and "failed to acquire current PlanningScene" in log
    assert "no server '/no_such_server'" in log


def test_bad_configuration_exits_1_with_one_line(system):
    code, log = _run("modular", "max_solutions:=-1", linger=0.0)
    assert code == 1
    assert "max_solutions" in log and "Traceback" not in log


# ---------------------------------------------------------------------------- execution
def _final_positions(solution: TaskSolution) -> dict[str, float]:
    end: dict[str, float] = {}
    for sub in solution.sub_trajectory:
        jt = sub.trajectory.joint_trajectory
        if jt.points:
            end.update(zip(jt.joint_names, jt.points[-1].positions))
    return end


def _at(probe: Probe, target: dict[str, float], tol: float = 0.01) -> bool:
    joints = probe.joints()
    return bool(joints) and all(abs(joints[n] - v) <= tol for n, v in target.items())


def _visited(probe: Probe, target: dict[str, float], since: float, tol: float = 0.02) -> bool:
    return any(all(abs(js[n] - v) <= tol for n, v in target.items()) for js in probe.history(since))


def test_modular_executes_at_start_on_param_set_and_on_trigger(system, model):
    """A spinning node (exit_when_done false) with execute:=true: executes after the start-up
    planning, again after `ros2 param set ... execute true`, re-plans on ~/plan without executing,
    executes on ~/execute; bad parameter values are refused with a reason meanwhile."""
    probe = system["probe"]
    before, started = _counts(probe, "modular_demo"), time.time()
    since = time.monotonic()
    node = NodeProcess("mycobot_planning.nodes.modular", ["--ros-args", "-p", "execute:=true", "-p", "modules:=1"])
    try:
        assert node.wait_for_output("modular demo completed", 90), node.output()
        assert "Execution succeeded" in node.output(), node.output()
        solution, _ = _check_published(probe, model, "modular_demo", before, started)
        assert [s.info.stage_name for s in solution.sub_trajectory].count("Cartesian Path") == 0  # primitive steps
        end = _final_positions(solution)
        assert wait_until(lambda: _at(probe, end), 10.0), (probe.joints(), end)
        ready = model.named_state("ready", "arm")
        assert _visited(probe, ready, since), "the arm never passed through 'ready'"

        # refused: wrong type, out of range, not finite; the node keeps running
        result = probe.set_param("modular_demo", Parameter("execute", value="yes"))
        assert not result.successful and "type" in result.reason.lower(), result.reason
        result = probe.set_param("modular_demo", Parameter("max_solutions", value=-3))
        assert not result.successful and "max_solutions" in result.reason
        result = probe.set_param("modular_demo", Parameter("planning_timeout", value=float("nan")))
        assert not result.successful and "planning_timeout" in result.reason
        assert node.alive()
        assert node.output().count("Executing the best solution") == 1

        # `ros2 param set /modular_demo execute true` executes the solution again (it starts and
        # ends at 'home', where the robot now is)
        since = time.monotonic()
        cli = subprocess.run([PYTHON, "-m", "mycobot_planning.ros2cli", "param", "set", "/modular_demo", "execute", "true"],
                             cwd=REPO, env=ros_env(), capture_output=True, text=True, timeout=30)
        assert cli.returncode == 0 and "successful" in cli.stdout, cli.stdout + cli.stderr
        assert wait_until(lambda: node.output().count("Execution succeeded") == 2, 60), node.output()
        assert _visited(probe, ready, since), "the second execution never passed through 'ready'"
        assert wait_until(lambda: _at(probe, end), 10.0)

        # the Trigger re-plans from the current state and publishes again, without executing
        count = probe.count(task_topics("modular_demo").solution)
        response = probe.trigger("/modular_demo/plan")
        assert response.success and "1 solutions" in response.message, response.message
        assert node.output().count("Starting task planning") == 2
        assert node.output().count("Executing the best solution") == 2
        assert wait_until(lambda: probe.count(task_topics("modular_demo").solution) > count, 10.0)
        response = probe.trigger("/modular_demo/execute")
        assert response.success and "SUCCESS" in response.message, response.message
        assert node.output().count("Execution succeeded") == 3
        assert node.alive()
    finally:
        node.stop()
