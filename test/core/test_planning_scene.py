"""PlanningScene bookkeeping: object operations with MoveIt semantics, all-or-nothing validation,
copies and diffs, the allowed collision matrix, and conversions to/from interfaces_py messages."""
from __future__ import annotations

import math

import numpy as np
import pytest

from interfaces_py.msgs import (
    AllowedCollisionMatrix as AcmMsg,
    AttachedCollisionObject,
    CollisionObject,
    Mesh,
    PlanningScene as PlanningSceneMsg,
    PlanningSceneWorld,
    Pose,
    RobotState as RobotStateMsg,
    SolidPrimitive,
)
from mycobot_planning.core import RobotModel, RobotState, SceneError
from mycobot_planning.core.collision_detection.acm import AllowedCollisionMatrix
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.transforms import make_pose


@pytest.fixture(scope="module")
def model() -> RobotModel:
    return RobotModel.mycobot()


def ready(model: RobotModel) -> RobotState:
    state = RobotState(model)
    state.set_joint_positions(model.named_state("ready", "arm"))
    return state


def table_scene(model: RobotModel) -> PlanningScene:
    scene = PlanningScene(model, ready(model), name="tutorial")
    scene.add_object(CollisionObject.box("table", [0.10, 0.20, 0.03], make_pose((0.22, 0.12, -0.015))))
    scene.add_object(CollisionObject.cylinder("cylinder", 0.35, 0.0125, make_pose((0.22, 0.12, 0.175))))
    return scene


def snapshot(scene: PlanningScene) -> str:
    """Everything a scene holds, as deterministic JSON (for 'unchanged' assertions)."""
    return scene.get_planning_scene_msg().to_json()


def pose_of(scene: PlanningScene, object_id: str) -> np.ndarray:
    return scene.get_object(object_id).pose.to_matrix()


# ----------------------------------------------------------------------------------- operations
def test_add_replace_move_append_remove(model):
    scene = table_scene(model)
    assert scene.world_object_ids() == ["table", "cylinder"]
    assert np.allclose(pose_of(scene, "cylinder"), make_pose((0.22, 0.12, 0.175)))

    # ADD of an existing id replaces it (MoveIt semantics).
    scene.add_object(CollisionObject.sphere("cylinder", 0.01, make_pose((0.3, 0.0, 0.1))))
    replaced = scene.get_object("cylinder")
    assert [p.type for p in replaced.primitives] == [SolidPrimitive.SPHERE]
    assert scene.world_object_ids() == ["table", "cylinder"]

    # MOVE keeps the shapes, changes the pose.
    scene.apply_collision_object(
        CollisionObject(id="cylinder", pose=Pose.from_xyz_rpy((0.3, 0.1, 0.2)), operation=CollisionObject.MOVE)
    )
    assert np.allclose(pose_of(scene, "cylinder"), make_pose((0.3, 0.1, 0.2)))
    assert scene.get_object("cylinder").primitives[0].dimensions == [0.01]
    scene.move_object("cylinder", make_pose((0.0, 0.3, 0.2), rpy=(0, 0, 1.0)))
    assert np.allclose(pose_of(scene, "cylinder"), make_pose((0.0, 0.3, 0.2), rpy=(0, 0, 1.0)))

    # APPEND adds a shape; given in world, stored relative to the object's pose.
    scene.apply_collision_object(
        CollisionObject(
            id="table", pose=Pose.from_xyz_rpy((0.22, 0.12, 0.05)), operation=CollisionObject.APPEND,
            primitives=[SolidPrimitive.box(0.01, 0.01, 0.01)], primitive_poses=[Pose()],
        )
    )
    table = scene.get_object("table")
    assert len(table.primitives) == 2
    assert np.allclose(table.pose.to_matrix(), make_pose((0.22, 0.12, -0.015)))
    assert np.allclose(table.primitive_poses[1].to_matrix(), make_pose((0.0, 0.0, 0.065)))
    # APPEND to an unknown id creates it.
    scene.apply_collision_object(
        CollisionObject(id="new", operation=CollisionObject.APPEND, primitives=[SolidPrimitive.sphere(0.01)],
                        primitive_poses=[Pose()])
    )
    assert "new" in scene.world_object_ids()

    scene.apply_collision_object(CollisionObject(id="new", operation=CollisionObject.REMOVE))
    scene.remove_object("cylinder")
    assert scene.world_object_ids() == ["table"]


def test_world_objects_are_returned_in_world_frame(model):
    scene = PlanningScene(model, ready(model))
    offset = make_pose((0.0, 0.0, 0.05))
    scene.add_object(CollisionObject.box("cap", [0.01, 0.01, 0.01], offset, frame_id="gripper_base"))
    (obj,) = scene.world_objects()
    assert obj.frame_id == "world" and obj.operation == CollisionObject.ADD
    assert np.allclose(obj.pose.to_matrix(), ready(model).frame_pose("gripper_base") @ offset, atol=1e-9)


def test_object_pose_relative_to_another_object(model):
    scene = table_scene(model)
    scene.add_object(CollisionObject.box("lid", [0.01, 0.01, 0.01], make_pose((0, 0, 0.18)), frame_id="cylinder"))
    assert np.allclose(pose_of(scene, "lid")[:3, 3], (0.22, 0.12, 0.355))


def test_multi_shape_object_checks_every_shape(model):
    scene = PlanningScene(model, ready(model))
    flange = scene.current_state.frame_pose("link6_flange")[:3, 3]
    far = Pose.from_xyz_rpy((0.0, 0.0, 1.0))
    near = Pose.from_matrix(make_pose(flange - np.array([0.3, 0.3, 0.0])))
    obj = CollisionObject(
        id="pair", pose=near,
        primitives=[SolidPrimitive.sphere(0.01), SolidPrimitive.sphere(0.02)],
        primitive_poses=[far, Pose.from_xyz_rpy((0.3, 0.3, 0.0))],
    )
    scene.add_object(obj)
    assert any(c.involves("pair") for c in scene.check_collision().contacts)
    stored = scene.get_object("pair")
    assert [p.dimensions for p in stored.primitives] == [[0.01], [0.02]]
    assert np.allclose(stored.primitive_poses[0].to_matrix(), far.to_matrix())


def test_mesh_object_keeps_its_resource(model):
    from mycobot_planning.paths import example_robot_data_dir

    path = str(example_robot_data_dir() / "panda_description" / "meshes" / "collision" / "hand.stl")
    scene = PlanningScene(model)
    scene.add_object(CollisionObject.mesh("hand", path, make_pose((0.5, 0, 0)), scale=(0.5, 0.5, 0.5)))
    (mesh,) = scene.get_object("hand").meshes
    assert mesh.resource == path and mesh.scale == [0.5, 0.5, 0.5]
    scene.add_object(CollisionObject.mesh("uri", "file://" + path, make_pose((0.5, 0.5, 0))))
    assert scene.world_object_ids() == ["hand", "uri"]


# ----------------------------------------------------------------------------------- bad input
def rejects(scene: PlanningScene, action, *words: str) -> SceneError:
    """Run an action that must be refused: SceneError naming the problem, scene untouched."""
    before = snapshot(scene)
    before_valid = scene.is_state_valid()
    with pytest.raises(SceneError) as info:
        action()
    message = str(info.value)
    for word in words:
        assert word in message, f"'{word}' not in error message: {message}"
    assert snapshot(scene) == before
    assert scene.is_state_valid() == before_valid
    return info.value


def test_unknown_ids_are_refused(model):
    scene = table_scene(model)
    rejects(scene, lambda: scene.remove_object("ghost"), "ghost", "table")
    rejects(scene, lambda: scene.move_object("ghost", np.eye(4)), "ghost")
    rejects(scene, lambda: scene.attach_object("ghost", "gripper_base"), "ghost")
    rejects(scene, lambda: scene.detach_object("ghost"), "ghost")
    rejects(scene, lambda: scene.detach_object("table"), "table", "not attached")
    rejects(scene, lambda: scene.get_object("ghost"), "ghost")
    rejects(scene, lambda: scene.apply_collision_object(CollisionObject(id="ghost", operation=CollisionObject.REMOVE)), "ghost")
    rejects(scene, lambda: scene.apply_collision_object(CollisionObject(id="ghost", operation=CollisionObject.MOVE)), "ghost")


def test_bad_dimensions_are_refused(model):
    scene = table_scene(model)
    as_dict = CollisionObject.box("bad", [0.1, 0.1, 0.1]).to_dict()
    as_dict["primitives"][0]["dimensions"] = [0.1, -0.1, 0.1]
    rejects(scene, lambda: scene.add_object(as_dict), "dimensions")
    as_dict["primitives"][0]["dimensions"] = [0.1, 0.0, 0.1]
    rejects(scene, lambda: scene.apply_collision_object(as_dict), "dimensions")
    # A message mutated after construction is re-checked by the scene.
    msg = CollisionObject.cylinder("bad", 0.1, 0.02)
    msg.primitives[0].dimensions[1] = -0.02
    rejects(scene, lambda: scene.add_object(msg), "bad", "dimensions")
    msg.primitives[0].dimensions[1] = math.nan
    rejects(scene, lambda: scene.add_object(msg), "dimensions")


def test_nan_poses_are_refused(model):
    scene = table_scene(model)
    msg = CollisionObject.box("bad", [0.1, 0.1, 0.1])
    msg.pose.position[0] = math.nan
    rejects(scene, lambda: scene.add_object(msg), "bad", "NaN")
    msg = CollisionObject.box("bad", [0.1, 0.1, 0.1])
    msg.primitive_poses[0].orientation[3] = math.nan
    rejects(scene, lambda: scene.add_object(msg), "NaN")
    nan_pose = np.eye(4)
    nan_pose[2, 3] = math.nan
    rejects(scene, lambda: scene.move_object("table", nan_pose), "NaN")
    rejects(scene, lambda: scene.move_object("table", np.ones((4, 4))), "rigid")
    as_dict = CollisionObject.box("bad", [0.1, 0.1, 0.1]).to_dict()
    as_dict["pose"]["orientation"] = [0.0, 0.0, 0.0, 0.0]
    rejects(scene, lambda: scene.add_object(as_dict), "orientation")


def test_unknown_frames_links_and_names_are_refused(model):
    scene = table_scene(model)
    rejects(scene, lambda: scene.add_object(CollisionObject.box("b", [0.1, 0.1, 0.1], frame_id="nowhere")), "nowhere")
    rejects(scene, lambda: scene.move_object("table", np.eye(4), frame_id="nowhere"), "nowhere")
    rejects(scene, lambda: scene.attach_object("cylinder", "link99"), "link99")
    rejects(scene, lambda: scene.attach_object("cylinder", "gripper_base", touch_links=["fingerz"]), "fingerz")
    rejects(scene, lambda: scene.add_object(CollisionObject.box("link3", [0.1, 0.1, 0.1])), "link3", "robot link")
    rejects(scene, lambda: scene.add_object(CollisionObject.box("arm", [0.1, 0.1, 0.1])), "arm", "group")
    rejects(scene, lambda: scene.add_object({"id": "x", "primitives": [{"type": 9, "dimensions": [1]}]}), "type")
    rejects(scene, lambda: scene.add_object(42), "CollisionObject")
    rejects(scene, lambda: scene.add_object(CollisionObject.mesh("m", "/no/such/mesh.stl")), "/no/such/mesh.stl")
    rejects(scene, lambda: scene.allow_collisions("table", ""), "name")
    rejects(scene, lambda: scene.distance(links="nolink"), "nolink")


def test_attached_ids_are_protected(model):
    scene = table_scene(model)
    scene.attach_object("cylinder", "gripper_base")
    rejects(scene, lambda: scene.remove_object("cylinder"), "attached", "gripper_base")
    rejects(scene, lambda: scene.move_object("cylinder", np.eye(4)), "attached")
    rejects(scene, lambda: scene.add_object(CollisionObject.box("cylinder", [0.1, 0.1, 0.1])), "attached")
    rejects(
        scene,
        lambda: scene.apply_attached_collision_object(
            AttachedCollisionObject(link_name="link2", object=CollisionObject(id="cylinder", operation=CollisionObject.REMOVE))
        ),
        "gripper_base",
    )


def test_rejected_planning_scene_message_changes_nothing(model):
    scene = table_scene(model)
    good = CollisionObject.box("good", [0.1, 0.1, 0.1], make_pose((0.5, 0, 0)))
    bad = CollisionObject(id="ghost", operation=CollisionObject.REMOVE)
    diff = PlanningSceneMsg(
        is_diff=True,
        robot_state=RobotStateMsg.from_joint_positions({"link1_to_link2": 0.5}, is_diff=True),
        world=PlanningSceneWorld(collision_objects=[good, bad]),
    )
    rejects(scene, lambda: scene.apply_planning_scene_msg(diff), "ghost")
    assert "good" not in scene.world_object_ids()
    bad_joint = PlanningSceneMsg(is_diff=True, robot_state=RobotStateMsg.from_joint_positions({"elbow": 1.0}))
    rejects(scene, lambda: scene.apply_planning_scene_msg(bad_joint), "elbow")
    other_robot = PlanningSceneMsg(robot_model_name="panda")
    rejects(scene, lambda: scene.apply_planning_scene_msg(other_robot), "panda")
    rejects(scene, lambda: scene.apply_planning_scene_msg("{not json"), "planning scene")


def test_state_from_another_robot_is_refused(model):
    from mycobot_planning.paths import example_robot_data_dir

    d = example_robot_data_dir() / "panda_description"
    panda = RobotModel.from_files(d / "urdf" / "panda.urdf", d / "srdf" / "panda.srdf")
    scene = PlanningScene(model)
    with pytest.raises(SceneError, match="panda"):
        scene.is_state_valid(RobotState(panda))


# ----------------------------------------------------------------------------------- copies
def test_copies_do_not_affect_their_parent(model):
    parent = table_scene(model)
    parent_json = snapshot(parent)
    child = parent.copy()
    assert snapshot(child) == parent_json
    child.add_object(CollisionObject.sphere("ball", 0.05, make_pose((0.06, -0.17, 0.17))))
    child.move_object("table", make_pose((0.5, 0.0, 0.0)))
    child.attach_object("cylinder", "gripper_base")
    child.allow_collisions("ball", "gripper")
    child.set_current_state(RobotState(model))
    assert snapshot(parent) == parent_json
    assert parent.is_state_valid(ready(model))
    assert parent.world_object_ids() == ["table", "cylinder"]
    assert not parent.acm.is_allowed("ball", "gripper_left1")
    assert parent.current_state == ready(model)
    # and the child sees its own changes
    assert not child.is_state_valid(ready(model))
    # Changing the parent afterwards does not reach the child either.
    parent.remove_object("table")
    assert "table" in child.world_object_ids()


def test_copies_share_the_compiled_model_until_one_changes(model):
    parent = table_scene(model)
    assert parent.is_state_valid()
    child = parent.copy()
    assert child._slot is parent._slot  # shared until someone changes
    child.set_current_state(RobotState(model))  # the state is not part of the compiled model
    assert child._slot is parent._slot
    child.acm.allow("cylinder", "gripper")
    assert child._slot is not parent._slot and parent._slot.value is not None


def test_acm_change_through_the_property_takes_effect(model):
    scene = PlanningScene(model, ready(model))
    flange = scene.current_state.frame_pose("link6_flange")[:3, 3]
    scene.add_object(CollisionObject.sphere("ball", 0.01, make_pose(flange)))
    assert not scene.is_state_valid()
    scene.acm.allow("ball")  # default entry: ball may touch anything
    assert scene.is_state_valid()
    scene.acm.forbid("ball")
    assert not scene.is_state_valid()



def test_scenes_with_the_same_content_share_one_compiled_model(model):
    """Copies that reach the same objects and allowed collisions by separate edits (a task's
    branches each allowing the same collision) are compiled once; a different content never
    takes another's compiled model, and the verdicts follow each scene's own content."""
    base = PlanningScene(model, ready(model))
    flange = base.current_state.frame_pose("link6_flange")[:3, 3]
    base.add_object(CollisionObject.sphere("ball", 0.01, make_pose(flange)))
    assert not base.is_state_valid()
    first, second, other = base.copy(), base.copy(), base.copy()
    first.acm.allow("ball", "link6_flange")
    second.acm.allow("ball", "link6_flange")
    first.set_current_state(RobotState(model))  # the state is not part of the compiled model
    assert first.is_state_valid(ready(model)) and second.is_state_valid()
    assert first._slot is not second._slot and first._slot.value is second._slot.value
    other.acm.allow("ball", "link1")  # other content: its own model, still colliding
    assert not other.is_state_valid()
    assert other._slot.value is not first._slot.value
    second.acm.forbid("ball", "link6_flange")  # back to the base's content
    assert not second.is_state_valid()
    assert second._slot.value is not first._slot.value


# ----------------------------------------------------------------------------------- messages
def scene_content(scene: PlanningScene) -> dict:
    return {
        "world": {o.id: o.to_dict() for o in scene.world_objects()},
        "attached": {a.object.id: a.to_dict() for a in scene.get_attached_objects()},
        "positions": scene.current_state.positions.tolist(),
    }


def same_content(a: PlanningScene, b: PlanningScene) -> None:
    ca, cb = scene_content(a), scene_content(b)
    assert ca["world"].keys() == cb["world"].keys()
    assert ca["attached"].keys() == cb["attached"].keys()
    for key in ca["world"]:
        assert np.allclose(a.get_object(key).pose.to_matrix(), b.get_object(key).pose.to_matrix(), atol=1e-9)
        assert ca["world"][key]["primitives"] == cb["world"][key]["primitives"]
    for key in ca["attached"]:
        assert ca["attached"][key]["link_name"] == cb["attached"][key]["link_name"]
        assert sorted(ca["attached"][key]["touch_links"]) == sorted(cb["attached"][key]["touch_links"])
    assert np.allclose(ca["positions"], cb["positions"])
    names = sorted(set(a.acm.entry_names) | set(b.acm.entry_names) | set(model_names(a)))
    for i, x in enumerate(names):
        for y in names[i + 1:]:
            assert a.acm.is_allowed(x, y) == b.acm.is_allowed(x, y), (x, y)


def model_names(scene: PlanningScene) -> list[str]:
    return list(scene.robot_model.link_names) + scene.world_object_ids() + scene.attached_object_ids()


def test_full_message_round_trip_through_json(model):
    scene = table_scene(model)
    scene.attach_object("cylinder", "gripper_base", touch_links="gripper")
    scene.allow_collisions("table", "link1")
    scene.acm.set_default("table", False)
    msg = scene.get_planning_scene_msg()
    assert not msg.is_diff and msg.robot_model_name == "mycobot_280" and msg.name == "tutorial"
    assert [o.id for o in msg.world.collision_objects] == ["table"]
    assert [a.object.id for a in msg.robot_state.attached_collision_objects] == ["cylinder"]
    rebuilt = PlanningScene.from_msg(model, PlanningSceneMsg.from_json(msg.to_json()))
    same_content(scene, rebuilt)
    assert rebuilt.name == "tutorial"
    rng = np.random.default_rng(5)
    for _ in range(100):
        p = rng.uniform(model.lower_limits, model.upper_limits)
        assert scene.is_valid_positions(p) == rebuilt.is_valid_positions(p)


def test_full_message_replaces_everything(model):
    scene = table_scene(model)
    empty = PlanningSceneMsg(robot_model_name="mycobot_280")
    scene.apply_planning_scene_msg(empty)
    assert scene.world_object_ids() == [] and scene.attached_object_ids() == []
    assert scene.current_state == RobotState(model)
    # an empty ACM in a full message keeps the SRDF pairs (else adjacent links would collide)
    assert scene.acm.is_allowed("link1", "link2")
    assert scene.is_state_valid()


def test_diff_round_trip_through_the_message(model):
    parent = table_scene(model)
    parent.add_object(CollisionObject.box("gone", [0.02, 0.02, 0.02], make_pose((0.4, 0.4, 0.0))))
    parent.add_object(CollisionObject.box("held_before", [0.02, 0.02, 0.02], make_pose((0.0, -0.25, 0.17))))
    parent.attach_object("held_before", "gripper_base")
    child = parent.diff()
    assert child.has_parent
    child.add_object(CollisionObject.sphere("ball", 0.03, make_pose((0.3, -0.1, 0.05))))
    child.move_object("table", make_pose((0.25, 0.12, -0.015)))
    child.remove_object("gone")
    child.attach_object("cylinder", "gripper_base", touch_links="gripper")
    child.detach_object("held_before")
    child.set_current_state({"link1_to_link2": 0.3})
    child.allow_collisions("ball", "arm")

    diff = child.get_planning_scene_msg(diff=True)
    assert diff.is_diff
    world_ops = {(o.id, o.operation) for o in diff.world.collision_objects}
    assert world_ops == {
        ("ball", CollisionObject.ADD), ("table", CollisionObject.ADD), ("gone", CollisionObject.REMOVE),
        ("held_before", CollisionObject.ADD),
    }
    attached_ops = {(a.object.id, a.object.operation) for a in diff.robot_state.attached_collision_objects}
    assert attached_ops == {("cylinder", CollisionObject.ADD), ("held_before", CollisionObject.REMOVE)}
    assert diff.robot_state.joint_names == ["link1_to_link2"] and diff.robot_state.is_diff
    assert diff.allowed_collision_matrix.entry_names  # the ACM changed, so it travels

    target = parent.copy()
    target.apply_planning_scene_msg(PlanningSceneMsg.from_json(diff.to_json()))
    same_content(child, target)
    rng = np.random.default_rng(11)
    for _ in range(100):
        p = rng.uniform(model.lower_limits, model.upper_limits)
        assert child.is_valid_positions(p) == target.is_valid_positions(p)


def test_unchanged_diff_is_empty(model):
    child = table_scene(model).diff()
    diff = child.get_planning_scene_msg(diff=True)
    assert diff.is_diff
    assert diff.world.collision_objects == [] and diff.robot_state.attached_collision_objects == []
    assert diff.robot_state.joint_names == []
    assert diff.allowed_collision_matrix.entry_names == []
    target = table_scene(model)
    before = snapshot(target)
    target.apply_planning_scene_msg(diff)
    assert snapshot(target) == before


def test_diff_without_parent_is_refused(model):
    with pytest.raises(SceneError, match="diff"):
        PlanningScene(model).get_planning_scene_msg(diff=True)


def test_diff_robot_state_without_is_diff_keeps_attached_objects(model):
    scene = table_scene(model)
    scene.attach_object("cylinder", "gripper_base")
    msg = PlanningSceneMsg(is_diff=True, robot_state=RobotStateMsg.from_joint_positions({"link1_to_link2": 0.2}))
    scene.apply_planning_scene_msg(msg)
    assert scene.attached_object_ids() == ["cylinder"]
    assert scene.current_state.joint_position("link1_to_link2") == pytest.approx(0.2)


def test_attached_object_message_with_full_robot_state(model):
    scene = table_scene(model)
    attached = AttachedCollisionObject(
        link_name="gripper_base",
        object=CollisionObject.box("cup", [0.02, 0.02, 0.04], make_pose((0, 0, 0.05)), frame_id="gripper_base"),
        touch_links=["gripper_left1", "gripper_right1"],
    )
    msg = PlanningSceneMsg(is_diff=True, robot_state=RobotStateMsg(attached_collision_objects=[attached], is_diff=True))
    scene.apply_planning_scene_msg(msg)
    assert scene.attached_object_ids() == ["cup"]
    assert scene.get_attached_object("cup").touch_links == ["gripper_left1", "gripper_right1"]


# ----------------------------------------------------------------------------------- ACM class
def test_acm_semantics_and_message_round_trip(model):
    acm = AllowedCollisionMatrix(model)
    assert acm.is_allowed("link1", "link2") and not acm.is_allowed("link1", "link4")
    acm.allow("box", "gripper")  # expands to the gripper group's links
    assert acm.is_allowed("gripper_left1", "box")
    assert acm.get_entry("box", "link2") is None
    acm.set_default("box", True)
    acm.set_default("cup", False)
    assert acm.is_allowed("box", "link2")  # box's default allows
    assert not acm.is_allowed("box", "cup")  # both defaults: NEVER wins (MoveIt)
    acm.forbid("box", "gripper_left1")
    assert not acm.is_allowed("box", "gripper_left1")  # explicit entry beats the default
    msg = acm.to_msg()
    back = AllowedCollisionMatrix.from_msg(AcmMsg.from_json(msg.to_json()), model)
    names = sorted(set(acm.entry_names) | {"link3", "table"})
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            assert back.is_allowed(a, b) == acm.is_allowed(a, b), (a, b)
    copy = acm.copy()
    copy.forbid("link1", "link2")
    assert acm.is_allowed("link1", "link2")
    with pytest.raises(SceneError):
        acm.allow(["ok", 3])
    assert acm.get_entry("ok", "x") is None


def test_mesh_message_round_trip(model):
    scene = PlanningScene(model)
    tri = Mesh.from_triangles([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]], [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]])
    scene.add_object(CollisionObject(id="tet", pose=Pose.from_xyz_rpy((0.4, 0, 0)), meshes=[tri], mesh_poses=[Pose()]))
    rebuilt = PlanningScene.from_msg(model, scene.get_planning_scene_msg().to_json())
    assert rebuilt.get_object("tet").meshes[0].triangles == tri.triangles
    tri.vertices[0][0] = 5.0  # the scene kept its own copy
    assert scene.get_object("tet").meshes[0].vertices[0][0] == 0.0
