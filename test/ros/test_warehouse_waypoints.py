"""MoveIt's warehouse robot-state services and the planning_server's waypoint methods, end to end
on one bring-up (mock_controllers + planning_server, real processes): save a robot state, list it
by regex, rename, get it back, delete it, refuse a bad name with a log line; save the arm's state
as a waypoint, move away, move back to it through plan_and_execute."""
from __future__ import annotations

import shutil

import pytest
import yaml
from moveit_msgs.msg import MoveItErrorCodes, RobotState
from moveit_msgs.srv import (
    CheckIfRobotStateExistsInWarehouse,
    DeleteRobotStateFromWarehouse,
    GetRobotStateFromWarehouse,
    ListRobotStatesInWarehouse,
    RenameRobotStateInWarehouse,
    SaveRobotStateToWarehouse,
)

from interfaces_py.json_rpc import JsonRpcClient, RpcError
from mycobot_planning.paths import config_dir
from ros_testing import ProbeNode, robot_processes, wait_until

ROBOT = "firefighter"


@pytest.fixture(scope="module")
def system(tmp_path_factory):
    folder = tmp_path_factory.mktemp("warehouse")
    database, waypoints = folder / "warehouse.sqlite", folder / "waypoints.yaml"
    shutil.copy(config_dir() / "waypoints" / "mycobot_waypoints.yaml", waypoints)
    with robot_processes(f"warehouse_host:={database}", f"waypoints_file:={waypoints}") as (_, server):
        probe = ProbeNode("warehouse_test")
        probe.listen_to_joint_states()
        rpc = JsonRpcClient(probe.node, "/planning_server")
        probe.spin_in_background()
        try:
            assert wait_until(lambda: bool(probe.joints()), 15.0)
            yield probe, rpc, server, database, waypoints
        finally:
            probe.close()


def _state(positions: dict[str, float]) -> RobotState:
    state = RobotState()
    state.joint_state.name = list(positions)
    state.joint_state.position = list(positions.values())
    return state


def test_warehouse_services_save_list_rename_get_delete_and_refuse_a_bad_name(system):
    probe, _, server, database, _ = system
    saved = {"link1_to_link2": 0.25, "link2_to_link3": -0.5}
    assert probe.call(SaveRobotStateToWarehouse, "/save_robot_state", SaveRobotStateToWarehouse.Request(
        name="pre grasp", robot=ROBOT, state=_state(saved))).success
    assert probe.call(SaveRobotStateToWarehouse, "/save_robot_state", SaveRobotStateToWarehouse.Request(
        name="retreat", robot=ROBOT, state=_state({"link1_to_link2": 0.0}))).success
    listed = probe.call(ListRobotStatesInWarehouse, "/list_robot_states",
                        ListRobotStatesInWarehouse.Request(regex="^pre", robot=ROBOT)).states
    assert list(listed) == ["pre grasp"]
    assert sorted(probe.call(ListRobotStatesInWarehouse, "/list_robot_states",
                             ListRobotStatesInWarehouse.Request()).states) == ["pre grasp", "retreat"]
    probe.call(RenameRobotStateInWarehouse, "/rename_robot_state", RenameRobotStateInWarehouse.Request(
        old_name="pre grasp", new_name="approach", robot=ROBOT))
    got = probe.call(GetRobotStateFromWarehouse, "/get_robot_state",
                     GetRobotStateFromWarehouse.Request(name="approach", robot=ROBOT)).state
    assert dict(zip(got.joint_state.name, got.joint_state.position)) == saved
    has = CheckIfRobotStateExistsInWarehouse
    assert probe.call(has, "/has_robot_state", has.Request(name="approach", robot=ROBOT)).exists
    assert not probe.call(has, "/has_robot_state", has.Request(name="pre grasp", robot=ROBOT)).exists
    probe.call(DeleteRobotStateFromWarehouse, "/delete_robot_state",
               DeleteRobotStateFromWarehouse.Request(name="approach", robot=ROBOT))
    assert not probe.call(has, "/has_robot_state", has.Request(name="approach", robot=ROBOT)).exists

    bad = probe.call(SaveRobotStateToWarehouse, "/save_robot_state", SaveRobotStateToWarehouse.Request(
        name="evil\x1b[2Jname", robot=ROBOT, state=_state(saved)))
    assert not bad.success
    assert wait_until(lambda: "/save_robot_state: refused" in server.output()
                      and "control characters" in server.output(), 5.0), server.output()[-2000:]
    assert list(probe.call(ListRobotStatesInWarehouse, "/list_robot_states",
                           ListRobotStatesInWarehouse.Request(robot=ROBOT)).states) == ["retreat"]
    assert database.exists()  # the file the user chose holds them


def test_waypoints_save_list_rename_erase_and_move_to_through_plan_and_execute(system):
    probe, rpc, server, _, waypoints = system
    start = probe.joints()
    rpc.call("save_waypoint", {"name": "Start", "description": "where the test began"})
    with pytest.raises(RpcError, match="exists already"):
        rpc.call("save_waypoint", {"name": "Start"})
    with pytest.raises(RpcError, match="control characters"):
        rpc.call("save_waypoint", {"name": "bad\x00name"})
    assert wait_until(lambda: "save_waypoint: waypoint name" in server.output(), 5.0), server.output()[-2000:]
    rpc.call("rename_waypoint", {"old_name": "Start", "new_name": "Begin"})
    names = [w["name"] for w in rpc.call("list_waypoints")["waypoints"]]
    assert "Begin" in names and "Start" not in names
    on_file = {w["name"]: w for w in yaml.safe_load(waypoints.read_text())}
    assert on_file["Begin"]["joint_group_names"] == ["arm"] and on_file["Begin"]["description"] == "where the test began"

    away = rpc.call("move_to_waypoint", {"name": "Look at Table"}, timeout=60.0)
    assert away["error_code"]["val"] == MoveItErrorCodes.SUCCESS, away
    back = rpc.call("move_to_waypoint", {"name": "Begin"}, timeout=60.0)
    assert back["error_code"]["val"] == MoveItErrorCodes.SUCCESS, back
    target = dict(zip(on_file["Begin"]["joint_state"]["name"], on_file["Begin"]["joint_state"]["position"]))
    assert wait_until(lambda: all(abs(probe.joints()[j] - v) < 0.02 for j, v in target.items()), 10.0)
    assert all(abs(probe.joints()[j] - start[j]) < 0.02 for j in on_file["Begin"]["joint_state"]["name"])
    rpc.call("erase_waypoint", {"name": "Begin"})
    with pytest.raises(RpcError, match="no waypoint named 'Begin'"):
        rpc.call("move_to_waypoint", {"name": "Begin"})
