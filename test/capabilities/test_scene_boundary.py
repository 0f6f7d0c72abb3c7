"""Scene updates carrying values that cannot be right are refused at the boundary with the
reason, and leave the scene as it was (issue 13). MoveGroupCapabilities, no ROS."""
from __future__ import annotations

import pytest

from interfaces_py.msgs import MAX_NAME_LENGTH, MessageError, printable
from mycobot_planning.core.planning_interface.planning_pipeline import PlanningPipeline
from mycobot_planning.capabilities.move_group_capabilities import RequestError

from test_request_budgets import _core

BOX = {"primitives": [{"type": 1, "dimensions": [0.1, 0.1, 0.1]}], "primitive_poses": [{}],
       "pose": {"position": [0.3, 0.2, 0.05]}}


def _box(**change):
    return {"id": "box", **BOX, **change}


@pytest.fixture()
def core(mycobot):
    core = _core(mycobot, PlanningPipeline())
    core.apply_collision_objects([_box(id="table")])
    return core


OBJECTS = [
    (_box(id="bad\x00id"), "must not contain NUL"),
    (_box(id="bell\x07"), "must not contain control characters"),
    (_box(id="t\ud800x"), "lone surrogate"),
    (_box(id=""), "must be a non-empty string"),
    (_box(id="x" * (MAX_NAME_LENGTH + 1)), f"at most {MAX_NAME_LENGTH}"),
    (_box(frame_id="base\nlink"), "control characters"),
    (_box(primitives=[{"type": 1, "dimensions": [1e9, 0.1, 0.1]}]), "larger than the bound"),
    (_box(primitives=[{"type": 1, "dimensions": [1e300, 0.1, 0.1]}]), "larger than the bound"),
    (_box(primitives=[{"type": 1, "dimensions": [0.1, -1.0, 0.1]}]), "must be > 0"),
    (_box(primitives=[{"type": 1, "dimensions": [0.1, 0.0, 0.1]}]), "must be > 0"),
    (_box(primitives=[{"type": 2, "dimensions": [float("nan")]}]), "finite"),
    (_box(pose={"position": [1e9, 0.0, 0.0]}), "workspace bound"),
    (_box(pose={"position": [0.0, -1e300, 0.0]}), "workspace bound"),
    (_box(primitive_poses=[{"position": [0.0, 0.0, 2e3]}]), "workspace bound"),
    ({"id": "mesh", "meshes": [{"vertices": [[0, 0, 0], [1e6, 0, 0], [0, 1, 0]], "triangles": [[0, 1, 2]]}],
      "mesh_poses": [{}]}, "workspace bound"),
]


def _unchanged(core, before):
    assert core.scene_msg().to_dict() == before


@pytest.mark.parametrize("obj, words", OBJECTS)
@pytest.mark.parametrize("route", ["collision_object", "planning_scene"])
def test_bad_objects_are_refused_naming_the_problem(core, obj, words, route):
    before = core.scene_msg().to_dict()
    with pytest.raises(RequestError) as info:
        if route == "collision_object":
            core.apply_collision_objects([obj])
        else:
            core.apply_planning_scene({"is_diff": True, "world": {"collision_objects": [_box(id="ok"), obj]}})
    assert words in info.value.message, info.value.message
    info.value.message.encode("utf-8")  # safe to log
    _unchanged(core, before)


@pytest.mark.parametrize("scene, words", [
    ({"allowed_collision_matrix": {"entry_names": ["ghost", "link1"], "entry_values": [[False, True], [True, False]]}},
     "['ghost']"),
    ({"allowed_collision_matrix": {"default_entry_names": ["nowhere"], "default_entry_values": [True]}},
     "['nowhere']"),
    ({"robot_state": {"joint_names": ["link2_to_link3"], "positions": [9.0], "is_diff": True}},
     "link2_to_link3=9 outside"),
    ({"robot_state": {"joint_names": ["elbow_of_mars"], "positions": [0.0], "is_diff": True}}, "elbow_of_mars"),
    ({"robot_state": {"is_diff": True, "attached_collision_objects": [{"link_name": "nolink", "object": _box()}]}},
     "nolink"),
])
def test_scene_diffs_naming_nothing_or_beyond_the_limits_are_refused(core, scene, words):
    before = core.scene_msg().to_dict()
    with pytest.raises(RequestError) as info:
        core.apply_planning_scene({"is_diff": True, **scene})
    assert words in info.value.message, info.value.message
    _unchanged(core, before)


def test_acm_entries_for_objects_of_the_same_message_or_already_known_are_accepted(core):
    core.apply_planning_scene({"is_diff": True, "world": {"collision_objects": [_box(id="cup")]},
                               "allowed_collision_matrix": {"entry_names": ["cup", "link6_flange"],
                                                            "entry_values": [[False, True], [True, False]]}})
    core.apply_collision_objects([{"id": "cup", "operation": 1}])
    core.apply_planning_scene(core.scene_msg().to_dict())  # a scene read back (stale 'cup' entry) goes back in


def test_attached_objects_need_a_real_link_and_touch_links(core):
    before = core.scene_msg().to_dict()
    with pytest.raises(RequestError):
        core.apply_attached_collision_object({"link_name": "link6_flange", "object": _box(id="held"),
                                              "touch_links": ["finger\x00"]})
    _unchanged(core, before)


def test_printable_escapes_what_logs_cannot_take():
    assert printable("a\ud800b\x00c\n") == "a\\ud800b\\x00c\\n"
    assert printable("a\nb", keep="\n") == "a\nb"
    with pytest.raises(MessageError) as info:
        from interfaces_py.msgs import CollisionObject
        CollisionObject.from_dict(_box(id="t\ud800x"))
    info.value.args[0].encode("utf-8")
