"""The move_group workflow as a user types it: `ros2 run` the nodes, `ros2 param set` a goal,
`ros2 service call` the plan Trigger, `ros2 topic echo /display_planned_path`."""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time

import pytest

from ros_testing import REPO, ros_env

ROS2 = [sys.executable, "-m", "mycobot_planning.ros2cli"]
CONSOLE_SCRIPTS = re.findall(r'f"(\w+) = \{PACKAGE\}', (REPO / "setup.py").read_text())


def ros2(*args: str, timeout: float = 60.0) -> subprocess.CompletedProcess:
    result = subprocess.run([*ROS2, *args], cwd=REPO, env=ros_env(), capture_output=True, text=True, timeout=timeout)
    assert "Traceback" not in result.stdout + result.stderr, result.stderr
    return result


def node_listed(name: str, tries: int = 5) -> bool:
    """`ros2 node list` shows the node (each call discovers the graph afresh, so ask again)."""
    return any(name in ros2("node", "list").stdout.split() for _ in range(tries))


@pytest.fixture(scope="module")
def robot(tmp_path_factory):
    """mock_controllers and planning_server started with `ros2 run`, as a user would."""
    log_dir = tmp_path_factory.mktemp("ros_workflow")
    procs = []
    try:
        for name in ("mock_controllers", "planning_server"):
            log = open(log_dir / f"{name}.log", "w")
            procs.append((subprocess.Popen([*ROS2, "run", "mycobot_planning", name], cwd=REPO, env=ros_env(),
                                           stdout=log, stderr=subprocess.STDOUT, start_new_session=True), log))
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            listed = ros2("node", "list").stdout
            if "/planning_server" in listed and "/controller_manager" in listed:
                break
            time.sleep(0.5)
        yield log_dir
    finally:
        for proc, log in procs:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGINT)
                try:
                    proc.wait(15)
                except subprocess.TimeoutExpired:
                    os.killpg(proc.pid, signal.SIGKILL)
                    proc.wait(5)
            log.close()


def test_every_console_script_is_a_ros2_executable():
    listed = ros2("pkg", "executables", "mycobot_planning").stdout.split("\n")
    for name in CONSOLE_SCRIPTS:
        if name == "ros2":
            continue
        assert f"mycobot_planning {name}" in listed, name


def test_plan_from_parameters_and_echo_the_planned_path(robot):
    assert node_listed("/controller_manager")
    result = ros2("param", "set", "/planning_server", "goal.named_target", "ready")
    assert "Set parameter successful" in result.stdout, result.stdout + result.stderr
    # Subscribe first, then plan: the echo must print the JointTrajectory of that plan.
    echo = subprocess.Popen(
        [*ROS2, "topic", "echo", "/planned_path", "trajectory_msgs/msg/JointTrajectory", "--once"],
        cwd=REPO, env=ros_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    try:
        time.sleep(3.0)  # let the echo's subscription be discovered
        call = ros2("service", "call", "/planning_server/plan", "std_srvs/srv/Trigger")
        assert "success=True" in call.stdout, call.stdout + call.stderr
        out, err = echo.communicate(timeout=60)
    finally:
        if echo.poll() is None:
            echo.kill()
    assert "joint_names:" in out and "- link1_to_link2" in out, out + err
    assert "points:" in out and "time_from_start:" in out


def test_refused_parameter_keeps_the_server_alive(robot):
    result = ros2("param", "set", "/planning_server", "goal.group", "legs")
    assert "Setting parameter failed" in result.stdout + result.stderr
    assert node_listed("/planning_server")


# ------------------------------------------------------------------ the MoveIt face with our `ros2`
def test_interface_show_a_moveit_action():
    out = ros2("interface", "show", "moveit_msgs/action/MoveGroup").stdout
    assert out.startswith("MotionPlanRequest request\n")
    assert "\tWorkspaceParameters workspace_parameters" in out
    assert "\nMoveItErrorCodes error_code\n" in out and "\nstring state" in out
    assert out.count("\n---\n") == 2


def test_action_list_info_type_and_send_goal(robot):
    listed = ""
    expected = ("/move_action", "/execute_trajectory", "/grip_action_controller/gripper_cmd",
                "/arm_controller/follow_joint_trajectory")
    for _ in range(10):  # each call discovers the graph afresh; on a loaded machine ask again
        listed = ros2("action", "list", "-t").stdout
        if all(name in listed for name in expected):
            break
    assert "/move_action [moveit_msgs/action/MoveGroup]" in listed
    assert "/execute_trajectory [moveit_msgs/action/ExecuteTrajectory]" in listed
    assert "/arm_controller/follow_joint_trajectory [control_msgs/action/FollowJointTrajectory]" in listed
    info = ros2("action", "info", "/move_action").stdout
    assert "Action servers: 1\n    /move_group" in info
    assert ros2("action", "type", "/execute_trajectory").stdout.strip() == "moveit_msgs/action/ExecuteTrajectory"
    sent = ros2("action", "send_goal", "/grip_action_controller/gripper_cmd", "control_msgs/action/GripperCommand",
                "{command: {position: -0.3, max_effort: 5.0}}")
    assert "Goal accepted with ID:" in sent.stdout, sent.stdout + sent.stderr
    assert "reached_goal: true" in sent.stdout and "Goal finished with status: SUCCEEDED" in sent.stdout


def test_service_call_compute_fk(robot):
    call = ros2("service", "call", "/compute_fk", "moveit_msgs/srv/GetPositionFK",
                "{fk_link_names: [link6_flange], robot_state: {joint_state: {name: [link1_to_link2], position: [0.5]}}}")
    assert "fk_link_names=['link6_flange']" in call.stdout, call.stdout + call.stderr
    assert "MoveItErrorCodes(val=1" in call.stdout


def test_echo_display_planned_path_as_moveit_displays_it(robot):
    echo = subprocess.Popen([*ROS2, "topic", "echo", "/display_planned_path", "--once"], cwd=REPO, env=ros_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        time.sleep(3.0)
        call = ros2("service", "call", "/plan_kinematic_path", "moveit_msgs/srv/GetMotionPlan",
                    "{motion_plan_request: {group_name: arm, goal_constraints: [{joint_constraints: "
                    "[{joint_name: link1_to_link2, position: 0.4, tolerance_above: 0.001, tolerance_below: 0.001}]}]}}")
        assert "MoveItErrorCodes(val=1" in call.stdout, call.stdout + call.stderr
        out, err = echo.communicate(timeout=60)
    finally:
        if echo.poll() is None:
            echo.kill()
    assert out.startswith("model_id: mycobot_280\n"), out + err
    assert "trajectory:\n- joint_trajectory:" in out and "- link1_to_link2" in out
