"""Collision truth of PlanningScene: self and world contacts, SRDF pairs, attached objects, the
allowed collision matrix, distances, and the Panda (mesh geometry) for generality."""
from __future__ import annotations

import math

import numpy as np
import pytest

from interfaces_py.msgs import CollisionObject, Mesh, Pose
from mycobot_planning.core import RobotModel, RobotState
from mycobot_planning.core.collision_detection.collision_common import OBJECT, ROBOT_ATTACHED, ROBOT_LINK
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.transforms import make_pose
from mycobot_planning.paths import example_robot_data_dir

GRIPPER_LINKS = {
    "gripper_base", "gripper_left1", "gripper_left2", "gripper_left3",
    "gripper_right1", "gripper_right2", "gripper_right3",
}


@pytest.fixture(scope="module")
def model() -> RobotModel:
    return RobotModel.mycobot()


def named(model: RobotModel, name: str) -> RobotState:
    state = RobotState(model)
    state.set_joint_positions(model.named_state(name, "arm"))
    return state


def seeds_scene(model: RobotModel) -> PlanningScene:
    """The tutorials' scene: a small table whose top is at z=0 and a cylinder standing on it."""
    scene = PlanningScene(model)
    scene.add_object(CollisionObject.box("table", [0.10, 0.20, 0.03], make_pose((0.22, 0.12, -0.015))))
    scene.add_object(CollisionObject.cylinder("cylinder", 0.35, 0.0125, make_pose((0.22, 0.12, 0.175))))
    return scene


def gripper_tool_scene(model: RobotModel) -> tuple[PlanningScene, np.ndarray]:
    """Arm in 'ready'; a flat 'tool' box (world object) between the fingers, touching two of them."""
    scene = PlanningScene(model, named(model, "ready"))
    pose = scene.current_state.frame_pose("gripper_base") @ make_pose((0.0, 0.035, 0.0))
    pose[:3, :3] = np.eye(3)
    scene.add_object(CollisionObject.box("tool", [0.09, 0.02, 0.2], pose))
    return scene, pose


# ----------------------------------------------------------------------------------- self collision
def test_home_and_ready_are_collision_free(model):
    scene = seeds_scene(model)
    for name in ("home", "ready"):
        report = scene.check_collision(named(model, name))
        assert not report.collision and report.contacts == [] and not report
        assert scene.is_state_valid(named(model, name))


def test_folded_arm_reports_the_self_colliding_links(model):
    scene = PlanningScene(model)
    state = RobotState(model)
    state.set_joint_positions({"link4_to_link5": 2.879793})  # wrist folded back onto the upper arm
    report = scene.check_collision(state)
    assert report.collision and report
    assert report.pairs() == {frozenset({"link3", "link6"})}
    (contact,) = report.contacts
    assert contact.kind_a == contact.kind_b == ROBOT_LINK
    assert contact.depth > 0.0
    assert str(contact) == "contact between 'link3' (Robot link) and 'link6' (Robot link)"
    assert not scene.is_state_valid(state)
    assert scene.is_state_colliding(state)


def test_srdf_disabled_pairs_are_not_reported_although_they_overlap(model):
    scene = PlanningScene(model)
    home = RobotState(model)
    assert model.disabled_collision_pairs >= {frozenset({"link1", "link2"})}
    assert not scene.check_collision(home).collision
    # The same pair, re-enabled, does overlap at home: the SRDF entry is what hides it.
    scene.acm.forbid("link1", "link2")
    assert scene.check_collision(home).pairs() == {frozenset({"link1", "link2"})}


def test_is_state_valid_checks_joint_limits(model):
    scene = PlanningScene(model)
    state = RobotState(model)
    state.set_joint_positions({"link1_to_link2": 3.0})  # limit is 2.879793, and no collision there
    assert not scene.is_state_colliding(state)
    assert not scene.is_state_valid(state)
    positions = state.positions.copy()
    assert not scene.is_valid_positions(positions)
    positions[0] = math.nan
    assert not scene.is_valid_positions(positions)


def test_is_valid_positions_agrees_with_is_state_valid(model):
    scene = seeds_scene(model)
    rng = np.random.default_rng(7)
    verdicts = []
    for _ in range(300):
        p = rng.uniform(model.lower_limits, model.upper_limits)
        verdict = scene.is_valid_positions(p)
        assert verdict == scene.is_state_valid(RobotState(model, p))
        assert verdict == (not scene.check_collision(RobotState(model, p)).collision)
        verdicts.append(verdict)
    assert 0 < sum(verdicts) < len(verdicts)  # the sample has both kinds


def test_group_validity_checker_fills_the_reference_state(model):
    scene = seeds_scene(model)
    reference = RobotState(model)
    reference.set_joint_positions({"gripper_controller": -0.3})
    check = scene.validity_checker("arm", reference)
    arm = model.group("arm").variable_indices
    rng = np.random.default_rng(4)
    for _ in range(100):
        values = rng.uniform(model.lower_limits[arm], model.upper_limits[arm])
        full = reference.positions.copy()
        full[arm] = values
        assert check(values) == scene.is_valid_positions(full)
    assert scene.validity_checker() == scene.is_valid_positions


@pytest.mark.parametrize("broad_phase", [True, False], ids=["broad_phase", "plain_pairs"])
def test_collision_verdict_matches_signed_distance_along_a_random_walk(model, broad_phase):
    """Consecutive nearby states (what planners check) must not fool the narrow phase: every state
    whose signed distance says penetrating is colliding and every clearly separated one is free.

    Regression: without the 1 µm security margin, Coal 3.0's GJK sometimes ends with "collision"
    at a tiny positive distance and the pair is reported free; on the plain (no broad phase) path
    this walk then misses penetrations of millimetres. A flat mesh (zero-volume AABB, which the
    broad phase cannot handle) forces the plain path.
    """
    scene = seeds_scene(model)
    if not broad_phase:
        sheet = Mesh.from_triangles([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0]], [[0, 1, 2]])
        scene.add_object(CollisionObject(id="sheet", pose=Pose.from_xyz_rpy((2, 2, 2)), meshes=[sheet], mesh_poses=[Pose()]))
    assert (scene._compiled().manager is not None) == broad_phase
    rng = np.random.default_rng(1)
    p = rng.uniform(model.lower_limits, model.upper_limits)
    for step in range(5000):
        if step % 150 == 0:
            p = rng.uniform(model.lower_limits, model.upper_limits)
        p = np.clip(p + rng.normal(0.0, 0.03, p.shape), model.lower_limits, model.upper_limits)
        colliding = not scene.is_valid_positions(p)
        d = scene.distance(RobotState(model, p)).min_distance
        if d < -1e-5:
            assert colliding, f"step {step}: state {p} penetrates by {-d} m but was reported free"
        elif d > 1e-5:
            assert not colliding, f"step {step}: state {p} is {d} m clear but was reported colliding"


# ----------------------------------------------------------------------------------- world collision
def test_flange_inside_the_cylinder_names_the_cylinder_and_a_gripper_link(model):
    scene = PlanningScene(model, named(model, "ready"))
    flange = scene.current_state.frame_pose("link6_flange")[:3, 3]
    scene.add_object(CollisionObject.cylinder("cylinder", 0.35, 0.0125, make_pose(flange)))
    report = scene.check_collision()
    assert report.collision
    cylinder_contacts = [c for c in report.contacts if c.body_a == "cylinder"]
    assert cylinder_contacts and all(c.kind_a == OBJECT and c.kind_b == ROBOT_LINK for c in cylinder_contacts)
    touched = {c.body_b for c in cylinder_contacts}
    assert touched & (GRIPPER_LINKS | {"link6_flange"})
    assert "contact between 'cylinder' (Object) and 'link6_flange' (Robot link)" in {str(c) for c in report.contacts}
    assert all(c.depth >= 0.0 for c in report.contacts)


def test_seeds_scene_contacts_when_the_arm_reaches_into_the_cylinder(model):
    scene = seeds_scene(model)
    free = named(model, "ready")
    assert scene.is_state_valid(free)
    scene.move_object("cylinder", make_pose(free.frame_pose("gripper_base")[:3, 3]))
    report = scene.check_collision(free)
    assert report.collision and any(c.involves("cylinder") for c in report.contacts)
    assert report.contacts[0].kind_a == OBJECT


def test_max_contacts_limits_the_report(model):
    scene = PlanningScene(model)
    state = RobotState(model)
    state.set_joint_positions({"link3_to_link4": -2.879793})
    assert len(scene.check_collision(state).contacts) > 1
    assert len(scene.check_collision(state, max_contacts=1).contacts) == 1


def test_object_frame_in_link_is_placed_with_the_current_state(model):
    scene = PlanningScene(model, named(model, "ready"))
    # A small sphere 2 cm in front of the flange, given in the flange frame.
    scene.add_object(CollisionObject.sphere("ball", 0.005, make_pose((0, 0, 0.2)), frame_id="link6_flange"))
    expected = scene.current_state.frame_pose("link6_flange") @ make_pose((0, 0, 0.2))
    got = scene.get_object("ball").pose.to_matrix()
    assert np.allclose(got, expected, atol=1e-9)
    # It stays in the world when the arm moves (it is a world object, not attached).
    scene.set_current_state(named(model, "home"))
    assert np.allclose(scene.get_object("ball").pose.to_matrix(), expected, atol=1e-9)


# ----------------------------------------------------------------------------------- attached objects
def test_attached_object_touch_links_world_contact_and_detach(model):
    scene, pose = gripper_tool_scene(model)
    before = scene.check_collision()
    assert before.pairs() == {frozenset({"tool", "gripper_left2"}), frozenset({"tool", "gripper_right2"})}
    assert all(c.body_a == "tool" and c.kind_a == OBJECT for c in before.contacts)

    scene.attach_object("tool", "gripper_base", touch_links=["gripper"])  # group name -> finger links
    assert scene.attached_object_ids() == ["tool"] and scene.world_object_ids() == []
    assert not scene.check_collision().collision  # fingers are touch links

    scene.add_object(CollisionObject.box("table", [0.1, 0.1, 0.05], make_pose((pose[0, 3], pose[1, 3], 0.06))))
    report = scene.check_collision()
    assert [str(c) for c in report.contacts] == ["contact between 'table' (Object) and 'tool' (Robot attached)"]
    assert report.contacts[0].kind_b == ROBOT_ATTACHED

    # Moving the arm carries the tool with it (it is posed relative to gripper_base).
    home = named(model, "home")
    assert not scene.check_collision(home).collision
    scene.set_current_state(home)
    carried = scene.get_object("tool").pose.to_matrix()
    assert np.allclose(carried, home.frame_pose("gripper_base") @ np.linalg.inv(
        named(model, "ready").frame_pose("gripper_base")) @ pose, atol=1e-9)

    # Detach at home: the tool stays where it now is, in the world.
    scene.detach_object("tool")
    assert scene.world_object_ids() == ["table", "tool"] and scene.attached_object_ids() == []
    assert np.allclose(scene.get_object("tool").pose.to_matrix(), carried, atol=1e-9)
    # Now a world object again: the fingers it is wedged between touch it, nothing else does.
    assert scene.check_collision().pairs() == {
        frozenset({"tool", "gripper_left2"}), frozenset({"tool", "gripper_right2"})
    }


def test_detached_object_collides_with_the_fingers_again(model):
    scene, pose = gripper_tool_scene(model)
    scene.attach_object("tool", "gripper_base", touch_links="gripper")
    assert scene.is_state_valid()
    scene.detach_object("tool")
    assert np.allclose(scene.get_object("tool").pose.to_matrix(), pose, atol=1e-9)
    assert {c.kind_b for c in scene.check_collision().contacts} == {ROBOT_LINK}
    assert not scene.is_state_valid()


def test_attached_object_without_touch_links_collides_with_the_fingers(model):
    scene, _ = gripper_tool_scene(model)
    scene.attach_object("tool", "gripper_base")
    report = scene.check_collision()
    assert report.pairs() == {frozenset({"tool", "gripper_left2"}), frozenset({"tool", "gripper_right2"})}
    assert all(c.kind_a == ROBOT_ATTACHED and c.kind_b == ROBOT_LINK for c in report.contacts)
    # The ACM can allow what touch links did not.
    scene.allow_collisions("tool", ["gripper_left2", "gripper_right2"])
    assert not scene.check_collision().collision


def test_attach_from_message_adds_and_attaches(model):
    from interfaces_py.msgs import AttachedCollisionObject

    scene = PlanningScene(model, named(model, "ready"))
    obj = CollisionObject.box("held", [0.02, 0.02, 0.02], make_pose((0, 0, 0.06)), frame_id="gripper_base")
    scene.apply_attached_collision_object(AttachedCollisionObject(link_name="gripper_base", object=obj, touch_links=["gripper"]))
    assert scene.attached_object_ids() == ["held"]
    attached = scene.get_attached_object("held")
    assert attached.link_name == "gripper_base" and attached.object.frame_id == "gripper_base"
    assert np.allclose(attached.object.pose.to_matrix(), make_pose((0, 0, 0.06)), atol=1e-9)
    assert set(attached.touch_links) >= {"gripper_left1", "gripper_right1"}
    # REMOVE through the message detaches into the world where the object is.
    scene.apply_attached_collision_object(
        AttachedCollisionObject(link_name="gripper_base", object=CollisionObject(id="held", operation=CollisionObject.REMOVE))
    )
    assert scene.world_object_ids() == ["held"]
    expected = scene.current_state.frame_pose("gripper_base") @ make_pose((0, 0, 0.06))
    assert np.allclose(scene.get_object("held").pose.to_matrix(), expected, atol=1e-9)


def test_attached_object_against_another_attached_object(model):
    scene = PlanningScene(model, named(model, "ready"))
    state = scene.current_state
    for name, dx in (("a", 0.0), ("b", 0.01)):
        pose = state.frame_pose("gripper_base") @ make_pose((dx, 0.08, 0.0))
        scene.add_object(CollisionObject.box(name, [0.03, 0.03, 0.03], pose))
    scene.attach_object("a", "gripper_base", touch_links="gripper")
    scene.attach_object("b", "link6_flange", touch_links="gripper")
    report = scene.check_collision()
    assert report.pairs() == {frozenset({"a", "b"})}
    assert {report.contacts[0].kind_a, report.contacts[0].kind_b} == {ROBOT_ATTACHED}
    scene.allow_collisions("a", "b")
    assert not scene.check_collision().collision


# ----------------------------------------------------------------------------------- ACM
def test_acm_allow_and_forbid_by_object_name_and_group(model):
    scene, _ = gripper_tool_scene(model)
    assert scene.check_collision().collision
    scene.allow_collisions("tool", "gripper")  # group name: all its finger links
    assert not scene.check_collision().collision
    assert scene.acm.is_allowed("tool", "gripper_left2") and scene.acm.is_allowed("gripper_right1", "tool")
    scene.allow_collisions("tool", "gripper", allowed=False)
    assert scene.check_collision().pairs() == {frozenset({"tool", "gripper_left2"}), frozenset({"tool", "gripper_right2"})}
    scene.acm.allow("tool", ["gripper_left2", "gripper_right2"])  # by link names
    assert scene.is_state_valid()
    scene.acm.forbid("tool", "gripper_left2")
    assert scene.check_collision().pairs() == {frozenset({"tool", "gripper_left2"})}


def test_acm_default_entry_allows_an_object_with_everything(model):
    scene, _ = gripper_tool_scene(model)
    scene.acm.set_default("tool", True)
    assert not scene.check_collision().collision
    scene.acm.forbid("tool", "gripper_left2")  # an explicit entry beats the default
    assert scene.check_collision().pairs() == {frozenset({"tool", "gripper_left2"})}
    scene.acm.remove_default("tool")
    assert scene.check_collision().pairs() == {frozenset({"tool", "gripper_left2"}), frozenset({"tool", "gripper_right2"})}


def test_acm_allow_group_with_itself_disables_its_self_collisions(model):
    scene = PlanningScene(model)
    state = RobotState(model)
    state.set_joint_positions({"link4_to_link5": 2.879793})
    assert scene.check_collision(state).collision
    scene.allow_collisions("arm", "arm")
    assert not scene.check_collision(state).collision


# ----------------------------------------------------------------------------------- distance
def test_distance_between_a_sphere_and_the_base_box_is_analytic(model):
    scene = PlanningScene(model)
    # base_link box 0.105 x 0.14 x 0.02 centred at z=-0.015; link1 box 0.08 x 0.12 x 0.075 at (0, -0.01, 0.034).
    scene.add_object(CollisionObject.sphere("ball", 0.02, make_pose((0.2, 0.0, -0.015))))
    report = scene.distance(include_self=False)
    assert report.body_a == "ball" and report.kind_a == OBJECT
    assert report.body_b == "base_link" and report.kind_b == ROBOT_LINK
    assert report.min_distance == pytest.approx(0.2 - 0.0525 - 0.02, abs=1e-6)
    assert report.per_link["base_link"][0] == pytest.approx(0.1275, abs=1e-6)
    assert report.per_link["base_link"][1] == "ball"
    # link1's box bottom is at z = 0.034 - 0.0375 = -0.0035, above the ball's centre: edge distance.
    link1_distance = math.hypot(0.2 - 0.04, -0.0035 + 0.015) - 0.02
    assert report.per_link["link1"][0] == pytest.approx(link1_distance, abs=1e-6)
    assert np.allclose(report.point_a, (0.18, 0.0, -0.015), atol=1e-6)
    assert np.allclose(report.point_b, (0.0525, 0.0, -0.015), atol=1e-6)
    # Restricting to a link keeps only its pairs.
    only_link1 = scene.distance(include_self=False, links="link1")
    assert set(only_link1.per_link) == {"link1"}
    assert only_link1.min_distance == pytest.approx(link1_distance, abs=1e-6)


def test_distance_self_and_world_are_separate(model):
    scene = PlanningScene(model)
    scene.add_object(CollisionObject.sphere("ball", 0.02, make_pose((0.2, 0.0, -0.015))))
    world = scene.distance(include_self=False)
    self_only = scene.distance(include_world=False)
    both = scene.distance()
    assert "ball" in (world.body_a, world.body_b)
    assert self_only.kind_a == self_only.kind_b == ROBOT_LINK
    assert both.min_distance == pytest.approx(min(world.min_distance, self_only.min_distance))
    none = scene.distance(include_self=False, include_world=False)
    assert none.min_distance == math.inf and none.body_a is None


def test_distance_is_negative_when_penetrating(model):
    scene = PlanningScene(model)
    scene.add_object(CollisionObject.sphere("ball", 0.02, make_pose((0.06, 0.0, -0.015))))
    report = scene.distance(include_self=False)
    assert report.min_distance < 0
    assert report.min_distance == pytest.approx(0.06 - 0.0525 - 0.02, abs=1e-5)


def test_distance_ignores_allowed_pairs(model):
    scene = PlanningScene(model)
    scene.add_object(CollisionObject.sphere("ball", 0.02, make_pose((0.2, 0.0, -0.015))))
    scene.allow_collisions("ball", "base_link")
    report = scene.distance(include_self=False)
    assert "base_link" not in report.per_link
    assert report.body_b == "link1"


# ----------------------------------------------------------------------------------- constant pairs
def test_object_overlapping_the_fixed_base_makes_every_state_collide(model):
    scene = PlanningScene(model)
    scene.add_object(CollisionObject.box("plate", [0.3, 0.3, 0.01], make_pose((0, 0, -0.02))))
    for name in ("home", "ready"):
        report = scene.check_collision(named(model, name))
        assert report.pairs() == {frozenset({"plate", "base_link"})}
    scene.allow_collisions("plate", "base_link")
    assert scene.is_state_valid(named(model, "home"))


# ----------------------------------------------------------------------------------- Panda (meshes)
def test_panda_scene_with_mesh_geometry(panda):
    scene = PlanningScene(panda)
    state = RobotState(panda)
    state.set_joint_positions(panda.named_state("default", "arm_and_hand"))
    assert scene.is_state_valid(state)
    mesh = example_robot_data_dir() / "panda_description" / "meshes" / "collision" / "link0.stl"
    hand = state.frame_pose("panda_hand")[:3, 3]
    scene.add_object(CollisionObject.mesh("bin", str(mesh), make_pose(hand)))
    report = scene.check_collision(state)
    assert report.collision
    assert {c.body_a for c in report.contacts} == {"bin"}
    assert any(c.body_b in ("panda_hand", "panda_leftfinger", "panda_rightfinger", "panda_link7") for c in report.contacts)
    scene.move_object("bin", make_pose((1.5, 1.5, 0.0)))
    assert scene.is_state_valid(state)
    assert scene.distance(state, include_self=False).min_distance > 1.0


def test_panda_self_collision_with_meshes(panda):
    scene = PlanningScene(panda)
    rng = np.random.default_rng(1)
    found = None
    for _ in range(500):
        p = rng.uniform(panda.lower_limits, panda.upper_limits)
        if not scene.is_valid_positions(p):
            found = p
            break
    assert found is not None
    report = scene.check_collision(RobotState(panda, found))
    assert report.collision and report.contacts
    assert all(c.kind_a == c.kind_b == ROBOT_LINK for c in report.contacts)
    for c in report.contacts:  # SRDF-disabled pairs are never reported
        assert frozenset((c.body_a, c.body_b)) not in panda.disabled_collision_pairs


def test_mesh_from_triangles(model):
    scene = PlanningScene(model, named(model, "ready"))
    centre = scene.current_state.frame_pose("link6_flange")[:3, 3]
    s = 0.03
    vertices = [[-s, -s, -s], [s, -s, -s], [-s, s, -s], [s, s, -s], [-s, -s, s], [s, -s, s], [-s, s, s], [s, s, s]]
    triangles = [[0, 1, 2], [1, 3, 2], [4, 6, 5], [5, 6, 7], [0, 4, 1], [1, 4, 5],
                 [2, 3, 6], [3, 7, 6], [0, 2, 4], [2, 6, 4], [1, 5, 3], [3, 5, 7]]
    obj = CollisionObject(id="cube", pose=Pose.from_matrix(make_pose(centre)),
                          meshes=[Mesh.from_triangles(vertices, triangles)], mesh_poses=[Pose()])
    scene.add_object(obj)
    assert any(c.body_a == "cube" for c in scene.check_collision().contacts)


def _exact_verdicts(scene: PlanningScene, rows: np.ndarray) -> list[bool]:
    """The meshes alone (the compiled scene's exact broad phase, no hull pre-test)."""
    import pinocchio as pin

    compiled = scene._compiled()
    full = RobotState(scene.robot_model).positions
    out = []
    for row in rows:
        q = compiled.robot.to_q(np.concatenate([row, full[len(row):]]))
        out.append(bool(pin.computeCollisions(compiled.pin_model, compiled.data, compiled.manager, q, True)))
    return out


def test_panda_hull_pre_test_keeps_the_mesh_verdict(panda):
    """Link meshes are first tested as convex hulls: a state the hulls find free is free, any
    other is decided by the meshes, so every verdict is the meshes' own."""
    scene = PlanningScene(panda)
    scene.add_object(CollisionObject.box("box", [0.1, 0.1, 0.1], make_pose([0.5, 0.0, 0.5])))
    compiled = scene._compiled()
    assert compiled.hull_manager is not None
    jmg = panda.group("arm")
    rng = np.random.default_rng(4)
    rows = rng.uniform(panda.lower_limits[jmg.variable_indices], panda.upper_limits[jmg.variable_indices], (400, 7))
    check = scene.validity_checker("arm", RobotState(panda), check_bounds=False)
    verdicts = [not check(row) for row in rows]
    assert verdicts == _exact_verdicts(scene, rows)
    assert 0 < sum(verdicts) < len(rows)
    assert list(scene.colliding_rows("arm", RobotState(panda), rows)) == verdicts


def test_a_verdict_does_not_depend_on_the_states_checked_before(model):
    """A myCobot state 1.04 µm from contact (link3 and link6, cylinders; the margin is 1 µm)
    from the seeds' pick and place: Pinocchio's requests warm-started GJK from each pair's last
    answer, so the all-pairs check of a nearby state first turned this one's verdict to
    'colliding', and the validator rejected what the planner had accepted."""
    end = [0.13615659108822725, -1.1493759242194637, -1.2999217657363873, 2.4493073418585474,
           -1.9687418711556544, -8.90221767628182e-06, 0.0]
    near = [0.13588619873102425, -1.1470933871569668, -1.2973402608117435, 2.4444432807037657,
            -1.9648321613794961, -8.884538828694748e-06, 0.0]
    indices = np.arange(len(model.variable_names))
    scene = PlanningScene(model)
    assert 1e-6 < scene.distance(RobotState(model, end)).min_distance < 1.1e-6
    fresh = scene.is_state_colliding(RobotState(model, end))
    for first in (near, end, near):
        for all_pairs in (True, False):
            other = PlanningScene(model)
            other.colliding_rows(indices, RobotState(model), np.array([first]), all_pairs=all_pairs)
            assert other.is_state_colliding(RobotState(model, end)) == fresh
            assert other.colliding_rows(indices, RobotState(model), np.array([end]), all_pairs=True)[0] == fresh


def _mesh_geometries(model: RobotModel) -> list:
    import coal

    return [g.geometry for g in model.pin_collision_model.geometryObjects if isinstance(g.geometry, coal.BVHModelBase)]


def _vertices_missed_by(shape, mesh) -> int:
    """Mesh vertices a 1 mm sphere (its centre 0.9 mm outside the vertex, away from the mesh's
    centre, so the sphere holds the vertex) touches without GJK finding the shape in contact:
    zero for any shape that contains the mesh."""
    import coal

    vertices = np.asarray(mesh.vertices(), dtype=float)
    centre = vertices.mean(axis=0)
    request, missed = coal.CollisionRequest(), 0
    for v in vertices:
        away = (v - centre) / np.linalg.norm(v - centre)
        result = coal.CollisionResult()
        if not coal.collide(shape, coal.Transform3s(), coal.Sphere(1e-3),
                            coal.Transform3s(np.eye(3), v + 0.9e-3 * away), request, result):
            missed += 1
    return missed


def test_link_hulls_contain_their_mesh_as_gjk_sees_it(monkeypatch, panda):
    """The pre-test's premise, on the UR5's concave meshes (their hulls made although the scene
    does not use them) and the Panda's convex ones: every vertex of a mesh is inside its hull for
    GJK. A mesh's own vertices and triangles wrapped as a Convex (what the pre-test used before
    issue 25) fail this: GJK's support function stops at local maxima of a concave mesh."""
    import coal

    from mycobot_planning.core.collision_detection import collision

    robots = example_robot_data_dir()
    ur5 = RobotModel.from_strings((robots / "ur_description/urdf/ur5_robot.urdf").read_text(), '<robot name=""/>',
                                  package_dirs=[str(robots.parent.parent)])
    assert all(collision._convex_hull(m) is None for m in _mesh_geometries(ur5))  # concave: no pre-test
    assert all(collision._convex_hull(m) is not None for m in _mesh_geometries(panda))
    monkeypatch.setattr(collision, "_HULL_TIGHTNESS", math.inf)
    for mesh in _mesh_geometries(ur5) + _mesh_geometries(panda):
        hull = collision._convex_hull(mesh)
        assert hull is not None and _vertices_missed_by(hull, mesh) == 0
    wrapped = _mesh_geometries(ur5)[2].clone()  # upper_arm_link
    wrapped.buildConvexRepresentation(False)
    assert isinstance(wrapped.convex, coal.ConvexBase) and _vertices_missed_by(wrapped.convex, wrapped) > 100


def test_hulls_that_always_touch_leave_every_verdict_to_the_meshes(monkeypatch):
    """With every link's 'hull' a 3 m sphere, the hulls find every state in collision, and the
    meshes still decide: the verdicts are the plain mesh scene's."""
    import coal

    from mycobot_planning.core.collision_detection import collision

    def huge(geometry):
        sphere = coal.Sphere(3.0)
        sphere.computeLocalAABB()
        return sphere

    d = example_robot_data_dir() / "panda_description"
    monkeypatch.setattr(collision, "_convex_hull", huge)
    inflated = RobotModel.from_files(d / "urdf" / "panda.urdf", d / "srdf" / "panda.srdf")
    scene = PlanningScene(inflated)
    scene.add_object(CollisionObject.box("box", [0.1, 0.1, 0.1], make_pose([0.5, 0.0, 0.5])))
    assert scene._compiled().hull_manager is not None
    jmg = inflated.group("arm")
    rng = np.random.default_rng(5)
    rows = rng.uniform(inflated.lower_limits[jmg.variable_indices], inflated.upper_limits[jmg.variable_indices], (150, 7))
    verdicts = list(scene.colliding_rows("arm", RobotState(inflated), rows))
    assert verdicts == _exact_verdicts(scene, rows)
    assert 0 < sum(verdicts) < len(rows)


def test_a_scene_with_a_mesh_without_hull_is_not_pre_tested(panda):
    """The hull pre-test runs only when every mesh of the scene has a hull: a hull against a
    mesh is tested triangle by triangle (slower than the meshes alone, e.g. Tiago's mixed
    links). A world mesh has no hull, so the Panda with a mesh cube is checked by the meshes
    alone, and its verdicts are still the exact ones."""
    s = 0.05
    vertices = [[-s, -s, -s], [s, -s, -s], [-s, s, -s], [s, s, -s], [-s, -s, s], [s, -s, s], [-s, s, s], [s, s, s]]
    triangles = [[0, 1, 2], [1, 3, 2], [4, 6, 5], [5, 6, 7], [0, 4, 1], [1, 4, 5],
                 [2, 3, 6], [3, 7, 6], [0, 2, 4], [2, 6, 4], [1, 5, 3], [3, 5, 7]]
    scene = PlanningScene(panda)
    assert scene._compiled().hull_manager is not None
    scene.add_object(CollisionObject(id="cube", pose=Pose.from_matrix(make_pose([0.5, 0.0, 0.5])),
                                     meshes=[Mesh.from_triangles(vertices, triangles)], mesh_poses=[Pose()]))
    assert scene._compiled().hull_manager is None
    jmg = panda.group("arm")
    rng = np.random.default_rng(6)
    rows = rng.uniform(panda.lower_limits[jmg.variable_indices], panda.upper_limits[jmg.variable_indices], (150, 7))
    verdicts = list(scene.colliding_rows("arm", RobotState(panda), rows))
    assert verdicts == _exact_verdicts(scene, rows) and 0 < sum(verdicts) < len(rows)
