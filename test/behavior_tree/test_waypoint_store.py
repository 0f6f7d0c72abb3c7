"""The waypoint store (MoveIt Pro's waypoint file): save, list, rename, erase; names, duplicates
and joint values checked; every write atomic."""
from __future__ import annotations

import math

import pytest
import yaml

from mycobot_planning.behavior_tree.behaviors import Waypoint, WaypointError, WaypointStore
from mycobot_planning.core.warehouse import names as names_module

LIMITS = {"a": (-1.0, 1.0), "b": (-2.0, 2.0)}


def _store(tmp_path, limits=LIMITS):
    path = tmp_path / "waypoints.yaml"
    path.write_text("[]\n")
    return WaypointStore(path, limits), path


def test_save_list_rename_erase_round_trip_through_the_file_in_moveit_pro_s_form(tmp_path):
    store, path = _store(tmp_path)
    store.save(Waypoint("Home", ["a", "b"], [0.0, 0.5], "at rest", True, ["arm"]))
    store.save(Waypoint("Up", ["a", "b"], [0.5, -1.0]))
    assert yaml.safe_load(path.read_text())[0] == {
        "name": "Home", "description": "at rest", "favorite": True, "joint_group_names": ["arm"],
        "joint_state": {"name": ["a", "b"], "position": [0.0, 0.5]}}
    store.rename("Home", "Rest")
    store.erase("Up")
    reloaded = WaypointStore(path)
    assert reloaded.names() == ["Rest"]
    rest = reloaded.get("Rest")
    assert (rest.positions, rest.description, rest.favorite, rest.joint_group_names) == ([0.0, 0.5], "at rest", True,
                                                                                         ["arm"])


@pytest.mark.parametrize("mode", [0o640, 0o604])
def test_a_rewrite_keeps_the_file_s_permissions(tmp_path, mode):
    store, path = _store(tmp_path)
    path.chmod(mode)
    store.save(Waypoint("w", ["a"], [0.0]))
    assert path.stat().st_mode & 0o777 == mode


@pytest.mark.parametrize("name, why", [
    ("", "must not be empty"), ("   ", "must not be empty"), ("bad\x00name", "control characters"),
    ("two\nlines", "control characters"), ("esc\x1b[31m", "control characters"), ("x" * 300, "at most"),
])
def test_a_bad_name_is_refused_and_nothing_is_written(tmp_path, name, why):
    store, path = _store(tmp_path)
    with pytest.raises(WaypointError, match=why):
        store.save(Waypoint(name, ["a"], [0.0]))
    store.save(Waypoint("ok", ["a"], [0.0]))
    with pytest.raises(WaypointError, match=why):
        store.rename("ok", name)
    assert WaypointStore(path).names() == ["ok"]


def test_saving_an_existing_name_is_refused_unless_overwrite(tmp_path):
    store, path = _store(tmp_path)
    store.save(Waypoint("w", ["a"], [0.1]))
    with pytest.raises(WaypointError, match="exists already"):
        store.save(Waypoint("w", ["a"], [0.2]))
    assert WaypointStore(path).get("w").positions == [0.1]
    store.save(Waypoint("w", ["a"], [0.2]), overwrite=True)
    assert WaypointStore(path).get("w").positions == [0.2]
    store.save(Waypoint("v", ["a"], [0.3]))
    with pytest.raises(WaypointError, match="exists already"):
        store.rename("v", "w")
    with pytest.raises(WaypointError, match="no waypoint named 'nope'"):
        store.rename("nope", "x")
    with pytest.raises(WaypointError, match="no waypoint named 'nope'"):
        store.erase("nope")


@pytest.mark.parametrize("names, positions, why", [
    (["a"], [math.nan], "not finite"), (["a"], [math.inf], "not finite"), (["a"], [1.5], "outside its limits"),
    (["a", "b"], [0.0], "2 joint names but 1 positions"), ([], [], "0 joint names"), (["a", "a"], [0, 0], "twice"),
    (["a"], ["x"], "not a number"),
])
def test_bad_joint_values_are_refused(tmp_path, names, positions, why):
    store, _ = _store(tmp_path)
    with pytest.raises(WaypointError, match=why):
        store.save(Waypoint("w", names, positions))
    assert store.names() == []


def test_a_crash_between_write_and_rename_leaves_the_old_file_whole(tmp_path, monkeypatch):
    store, path = _store(tmp_path)
    store.save(Waypoint("first", ["a"], [0.1]))
    before = path.read_text()

    def crash(src, dst):
        raise KeyboardInterrupt("power cut")  # the process dies after the temp file is written

    monkeypatch.setattr(names_module.os, "replace", crash)
    with pytest.raises(KeyboardInterrupt):
        store.save(Waypoint("second", ["a"], [0.2]))
    monkeypatch.undo()
    assert path.read_text() == before
    assert store.names() == ["first"]  # the store did not take what the file did not get
    assert [p.name for p in tmp_path.iterdir()] == ["waypoints.yaml"]  # no temp file left behind
    store.save(Waypoint("second", ["a"], [0.2]))
    assert WaypointStore(path).names() == ["first", "second"]


def test_the_shipped_waypoints_are_inside_the_mycobot_limits():
    from mycobot_planning.core.robot_model.robot_model import RobotModel
    from mycobot_planning.paths import config_dir
    model = RobotModel.mycobot()
    limits = {n: (lo, hi) for n, lo, hi in zip(model.variable_names, model.lower_limits, model.upper_limits)}
    store = WaypointStore(config_dir() / "waypoints" / "mycobot_waypoints.yaml", limits)
    assert len(store.list()) == 7
    for waypoint in store.list():
        store.check(waypoint)


def test_two_stores_on_one_file_see_each_other_s_changes(tmp_path):
    """The objective_server and the planning_server share the waypoints file: neither loses what
    the other saved."""
    first, path = _store(tmp_path)
    second = WaypointStore(path, LIMITS)
    first.save(Waypoint("from first", ["a"], [0.1]))
    assert second.names() == ["from first"]
    second.save(Waypoint("from second", ["a"], [0.2]))
    first.rename("from second", "renamed")
    assert WaypointStore(path).names() == ["from first", "renamed"] == second.names()
