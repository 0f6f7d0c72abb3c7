"""PlanningSceneStorage: scenes and their queries in the warehouse's SQLite file, beside the robot
states; read-only opening changes nothing and refuses what is not a planning-scene warehouse."""
from __future__ import annotations

import sqlite3

import pytest

from mycobot_planning.core.warehouse.planning_scene_storage import PlanningSceneStorage
from mycobot_planning.core.warehouse.robot_state_storage import RobotStateStorage, WarehouseError

SCENE = {"name": "table", "world": {"collision_objects": [{"id": "box", "primitives": [
    {"type": 1, "dimensions": [0.1, 0.1, 0.1]}], "primitive_poses": [{"position": [0.2, 0.0, 0.05]}]}]}}


def test_scenes_and_queries_round_trip_beside_the_robot_states(tmp_path):
    path = tmp_path / "warehouse.sqlite"
    states = RobotStateStorage(path)
    states.save("ready", "mycobot_280", b"\x01\x02")
    storage = PlanningSceneStorage(path)
    storage.add_planning_scene("table", SCENE)
    storage.add_planning_scene("empty", {})
    storage.add_planning_query("table", "reach", {"goal": {"named": "ready"}})
    storage.add_planning_query("table", "home", {"goal": {"named": "home"}})
    assert storage.planning_scene_names() == ["empty", "table"]
    assert storage.planning_scene_names("^ta") == ["table"]
    assert storage.planning_scene("table") == SCENE
    assert storage.planning_query_names("table") == ["home", "reach"]
    assert storage.planning_query_names("table", "ea") == ["reach"]
    assert storage.planning_query("table", "reach") == {"goal": {"named": "ready"}}
    storage.add_planning_query("table", "reach", {"goal": {"named": "home"}})  # replaces, as MoveIt does
    assert storage.planning_query("table", "reach") == {"goal": {"named": "home"}}
    storage.close()
    reader = PlanningSceneStorage(path, read_only=True)
    assert reader.planning_scene_names() == ["empty", "table"]
    with pytest.raises(WarehouseError, match="read-only"):
        reader.add_planning_scene("other", {})
    reader.close()
    assert states.names() == ["ready"]  # one file, both stores
    storage = PlanningSceneStorage(path)
    assert storage.remove_planning_scene("table") == 3  # the scene and its two queries
    assert storage.planning_scene_names() == ["empty"] and storage.planning_query_names("table") == []


def test_bad_names_values_and_regexes_are_refused(tmp_path):
    storage = PlanningSceneStorage()
    with pytest.raises(WarehouseError, match="must not be empty"):
        storage.add_planning_scene(" ", {})
    with pytest.raises(WarehouseError, match="no planning scene named 'nowhere'"):
        storage.add_planning_query("nowhere", "q", {})
    with pytest.raises(WarehouseError, match="cannot be stored as JSON"):
        storage.add_planning_scene("nan", {"x": float("nan")})
    with pytest.raises(WarehouseError, match="must be a JSON object"):
        storage.add_planning_scene("list", [1, 2])
    with pytest.raises(WarehouseError, match="bad regex"):
        storage.planning_scene_names("(")
    with pytest.raises(WarehouseError, match="no planning scene named 'x'"):
        storage.planning_scene("x")
    assert storage.planning_scene_names() == []


def test_read_only_refuses_missing_corrupt_and_foreign_files_and_changes_none(tmp_path):
    with pytest.raises(WarehouseError, match="does not exist"):
        PlanningSceneStorage(tmp_path / "missing.sqlite", read_only=True)
    assert not (tmp_path / "missing.sqlite").exists()
    corrupt = tmp_path / "corrupt.sqlite"
    corrupt.write_bytes(b"not a database at all" * 50)
    with pytest.raises(WarehouseError, match="cannot open warehouse database"):
        PlanningSceneStorage(corrupt, read_only=True)
    foreign = tmp_path / "foreign.sqlite"
    with sqlite3.connect(foreign) as db:
        db.execute("CREATE TABLE planning_scenes (name TEXT, scene TEXT)")
    before = foreign.read_bytes()
    with pytest.raises(WarehouseError, match="no motion_plan_requests table"):
        PlanningSceneStorage(foreign, read_only=True)
    assert foreign.read_bytes() == before
    damaged = tmp_path / "damaged.sqlite"
    PlanningSceneStorage(damaged).add_planning_scene("s", {})
    with sqlite3.connect(damaged) as db:
        db.execute("UPDATE planning_scenes SET scene = 'not json'")
    with pytest.raises(WarehouseError, match="planning scene 's' .* is not JSON"):
        PlanningSceneStorage(damaged, read_only=True).planning_scene("s")
