"""The warehouse's robot-state storage (moveit_ros_warehouse's RobotStateStorage over SQLite):
save, list by regex and robot, get, has, rename, delete; bad names refused; every change one
transaction."""
from __future__ import annotations

import sqlite3

import pytest

from mycobot_planning.core.warehouse.robot_state_storage import RobotStateStorage, WarehouseError


def test_save_list_get_rename_delete_persist_in_the_file(tmp_path):
    path = tmp_path / "sub" / "warehouse.sqlite"
    store = RobotStateStorage(path)
    store.save("home", "mycobot", b"\x01home")
    store.save("pick", "mycobot", b"\x01pick")
    store.save("home", "panda", b"\x02home")
    assert store.names() == ["home", "pick"]
    assert store.names(robot="mycobot") == ["home", "pick"]
    assert store.names(robot="panda") == ["home"]
    assert store.names(regex="^pi") == ["pick"] and store.names(regex="o") == ["home"]
    assert store.has("pick", "mycobot") and not store.has("pick", "panda") and store.has("pick")
    assert store.get("home", "panda") == b"\x02home"
    store.rename("pick", "grasp", "mycobot")
    store.close()
    again = RobotStateStorage(path)
    assert again.names(robot="mycobot") == ["grasp", "home"]
    assert again.get("grasp", "mycobot") == b"\x01pick"
    assert again.delete("home", "mycobot") == 1
    assert again.names() == ["grasp", "home"] and again.names(robot="mycobot") == ["grasp"]
    assert again.delete("home") == 1 and again.delete("home") == 0


def test_saving_a_name_again_replaces_it_as_moveit_does_unless_overwrite_is_off():
    store = RobotStateStorage(":memory:")
    store.save("s", "r", b"one")
    store.save("s", "r", b"two")
    assert store.get("s", "r") == b"two" and store.names() == ["s"]
    with pytest.raises(WarehouseError, match="exists already"):
        store.save("s", "r", b"three", overwrite=False)
    assert store.get("s", "r") == b"two"
    store.save("t", "r", b"t")
    with pytest.raises(WarehouseError, match="exists already"):
        store.rename("t", "s", "r")
    assert store.get("t", "r") == b"t"


@pytest.mark.parametrize("name, why", [("", "must not be empty"), ("a\x00b", "control characters"),
                                       ("a\nb", "control characters"), ("\t", "must not be empty")])
def test_bad_names_are_refused(name, why):
    store = RobotStateStorage()
    with pytest.raises(WarehouseError, match=why):
        store.save(name, "r", b"x")
    store.save("ok", "r", b"x")
    with pytest.raises(WarehouseError, match=why):
        store.rename("ok", name, "r")
    assert store.names() == ["ok"]


def test_unknown_names_and_bad_regexes_get_clear_errors():
    store = RobotStateStorage()
    with pytest.raises(WarehouseError, match="no robot state named 'x' for robot 'r'"):
        store.get("x", "r")
    with pytest.raises(WarehouseError, match="no robot state named 'x'"):
        store.rename("x", "y")
    with pytest.raises(WarehouseError, match="bad regex"):
        store.names(regex="(")
    with pytest.raises(WarehouseError, match="nothing to store"):
        store.save("x", "r", b"")


def test_a_change_that_fails_midway_is_rolled_back(tmp_path):
    """A statement failing inside the transaction (as a crash would) leaves what was committed."""
    path = tmp_path / "w.sqlite"
    store = RobotStateStorage(path)
    store.save("keep", "r", b"kept")
    with pytest.raises(sqlite3.Error):
        store._transaction("INSERT INTO robot_states (name, robot, state) VALUES (?, ?, ?), (?, ?, NULL)",
                           ["new", "r", b"n", "half", "r"])
    assert store.names() == ["keep"]
    store.close()
    assert RobotStateStorage(path).names() == ["keep"]


def test_a_process_killed_mid_transaction_loses_nothing_committed(tmp_path):
    import subprocess
    import sys
    path = tmp_path / "w.sqlite"
    store = RobotStateStorage(path)
    store.save("keep", "r", b"kept")
    script = (f"from mycobot_planning.core.warehouse.robot_state_storage import RobotStateStorage\n"
              f"import os\ns = RobotStateStorage({str(path)!r})\n"
              "s._db.execute('BEGIN IMMEDIATE')\n"
              "s._db.execute(\"INSERT INTO robot_states VALUES ('half', 'r', x'00')\")\n"
              "os._exit(9)\n")
    assert subprocess.run([sys.executable, "-c", script]).returncode == 9
    assert store.names() == ["keep"] and RobotStateStorage(path).names() == ["keep"]
