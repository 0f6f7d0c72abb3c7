"""Clients dropped without close(): a script that makes one, uses it once and ends exits 0.

moveit_commander's users never call close(), and neither do MTC's or MoveItPy's scripts. Each
client class runs in a fresh interpreter in each of the three rclpy situations a script can be in
at its end: rclpy initialized by the script ("user"), initialized by us only (the client's own
context, rclcpp's init or MoveItPy's; "ours"), or shut down by the script before it ends
("shut_down"). The process must exit 0 within the timeout, with no abort ("terminate called
without an active exception", 134), no segfault (139) and no traceback. The three situations of a
class run side by side (three processes), against one myCobot bring-up for the module.
"""
from __future__ import annotations

import subprocess
import textwrap
from pathlib import Path
from typing import Iterator

import pytest

from ros_testing import PYTHON, REPO, robot_processes, ros_env, use_session_domain

SITUATIONS = ("user", "ours", "shut_down")
#: s a script may take; a background thread left spinning at exit would hang or crash instead
EXIT_TIMEOUT = 90.0
RUNNER = ["-m", "mycobot_planning.nodes.mtc_script"]

#: How each situation starts and ends. NODE makes the node the task clients need: the script's
#: own rclpy node, or (ours) one of py_binding_tools' rclcpp, which we initialize and spin. The
#: clients that make a context of their own (and MoveItPy, rclcpp) need nothing in "ours".
START = {
    "user": "import rclpy\nrclpy.init()\nNODE = lambda name: rclpy.create_node(name)\n",
    "ours": "import rclcpp\nNODE = lambda name: (rclcpp.init(), rclcpp.Node(name))[1]\n",
    "shut_down": "import rclpy\nrclpy.init()\nNODE = lambda name: rclpy.create_node(name)\n",
}
END = {"user": "", "ours": "", "shut_down": "rclpy.shutdown()\n"}

#: client class -> (the script's body: make it, use it once; run through mtc_script?)
CLIENTS = {
    "PlanningSceneInterface": ("""
        from interfaces_py.clients import PlanningSceneInterface
        psi = PlanningSceneInterface()
        print("objects", psi.get_known_object_names())
        """, False),
    "MoveGroupClient": ("""
        from interfaces_py.clients import MoveGroupClient
        arm = MoveGroupClient("arm")
        print("joints", arm.get_current_joint_values())
        """, False),
    "PerceptionClient": ("""
        from interfaces_py.perception_client import PerceptionClient, RpcTimeout
        client = PerceptionClient(timeout=1.0)
        try:  # no perception_server in this bring-up: the request goes out and times out
            client.get_planning_scene()
        except RpcTimeout as exc:
            print("timed out", exc)
        """, False),
    "TaskRosInterface": ("""
        from mycobot_planning.task import core, stages
        node = NODE("exit_task")
        task = core.Task()
        task.loadRobotModel(node)
        task.add(stages.CurrentState("current"))
        assert task.plan()
        task.publish(task.solutions[0])
        print("published")
        """, True),
    "rclcpp.Node": ("""
        import rclcpp
        rclcpp.init()  # after the script's rclpy.init(): reused, with rclcpp's warning
        node = rclcpp.Node("exit_rclcpp", rclcpp.NodeOptions(automatically_declare_parameters_from_overrides=True))
        print("node", node.name, node.get_parameter("use_sim_time").value)
        """, True),
    "MoveItPy": ("""
        from moveit.planning import MoveItPy
        robot = MoveItPy(node_name="exit_moveit_py", config_dict={"plan_request_params": {"planning_pipeline": "ompl"}})
        arm = robot.get_planning_component("arm")
        arm.set_start_state_to_current_state()
        arm.set_goal_state(configuration_name="home")
        assert arm.plan()
        """, True),
}


@pytest.fixture(scope="module")
def mycobot_system() -> Iterator[None]:
    use_session_domain()
    with robot_processes():
        yield


def script(client: str, situation: str) -> str:
    body, _ = CLIENTS[client]
    start = START[situation] if situation != "ours" or client == "TaskRosInterface" else ""
    return start + textwrap.dedent(body) + END[situation] + "print('end of script')\n"


@pytest.mark.parametrize("client", sorted(CLIENTS))
def test_client_dropped_without_close_exits_0(client: str, mycobot_system: None, tmp_path: Path) -> None:
    drop_in = CLIENTS[client][1]
    processes = {}
    for situation in SITUATIONS:
        path = tmp_path / f"{situation}.py"
        path.write_text(script(client, situation))
        command = [PYTHON, *RUNNER, str(path)] if drop_in else [PYTHON, str(path)]
        processes[situation] = subprocess.Popen(command, cwd=REPO, env=ros_env(), stdout=subprocess.PIPE,
                                                stderr=subprocess.STDOUT, text=True, start_new_session=True)
    failures = []
    for situation, process in processes.items():
        try:
            output, _ = process.communicate(timeout=EXIT_TIMEOUT)
        except subprocess.TimeoutExpired:
            process.kill()
            output, _ = process.communicate()
            failures.append(f"{situation}: hung (killed after {EXIT_TIMEOUT:g} s)\n{output}")
            continue
        bad = [text for text in ("terminate called", "Segmentation fault", "Traceback") if text in output]
        if process.returncode != 0 or bad or "end of script" not in output:
            failures.append(f"{situation}: exit code {process.returncode} {bad}\n{output}")
    assert not failures, "\n\n".join(failures)
