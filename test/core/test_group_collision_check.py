"""The planners' group validity checker (PlanningScene.validity_checker with a group) against the
plain all-pairs Pinocchio/Coal check (test_collision_cross_check's reference, built from the
URDF and SRDF text alone).

The group checker decides once, when it is built, every pair whose kinematic path holds no joint
the group moves (CompiledScene.group_collides), and leaves those pairs out of the per-state
check. That is exact only for states that differ from the reference state in the group's
variables, which is all a planner of that group checks; so here the other joints sit at random
values away from their defaults and only the group's variables are sampled. Scenes: the bare
robot, a world box near a moving link plus a cylinder attached to a link, and a box through a
link the group does not move (every state collides, by a pair the checker decided once).
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
import zlib

import numpy as np
import pinocchio as pin
import pytest

from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.collision_detection.collision import CompiledScene
from mycobot_planning.core.transforms import make_pose
from test_collision_cross_check import Extras, PlainCheck, Robot, _joint_values, _scene, load_robot

#: Group states per robot, group and scene (random within the limits, and along segments).
RANDOM_STATES = 150
SEGMENT_STATES = 50

#: (robot as test_collision_cross_check names it, group, SRDF group element to add or None).
CASES = [
    ("tiago_description/tiago", "arm",
     '<group name="arm"><chain base_link="torso_lift_link" tip_link="arm_tool_link"/></group>'),
    ("tiago_description/tiago", "hand",
     '<group name="hand"><joint name="hand_thumb_joint"/><joint name="hand_index_joint"/>'
     '<joint name="hand_mrl_joint"/></group>'),
    ("config/panda", "hand", None),
    ("config/panda", "panda_arm", None),
    # every pair of the UR5 has a group joint between its links (the base's pairs with the
    # world box are on one joint: decided when the scene is compiled): nothing is decided once
    ("ur_description/ur5_gripper", "arm",
     '<group name="arm"><chain base_link="base_link" tip_link="tool0"/></group>'),
    ("ur_description/ur5_gripper", "wrist",
     '<group name="wrist"><chain base_link="forearm_link" tip_link="tool0"/></group>'),
    ("config/mycobot", "gripper", None),
    ("config/mycobot", "arm", None),
]

#: Cases where no pair can be decided once (the checker is then the scene's own).
NOTHING_FIXED = {("ur_description/ur5_gripper", "arm")}


def _robot(name: str, group_xml: str | None) -> Robot:
    """The robot as test_collision_cross_check loads it, with the group added to its SRDF; where
    that SRDF is the adjacent pairs only (Tiago), the pairs in contact in the default state are
    disabled too (the setup assistant's "Default" rule): Tiago's hand_safety_box encloses the
    fingers, so otherwise every state would collide and the comparison would prove little."""
    robot = load_robot(name)
    srdf = robot.srdf_xml
    if robot.srdf_source == "adjacent":
        plain = PlainCheck(robot)
        q = plain.q(_joint_values(robot.model, robot.model.default_positions()))
        pin.computeCollisions(plain.model, plain.data, plain.geometry, plain.geometry_data, q, False)
        touching = sorted({tuple(sorted((plain.link_of(pair.first), plain.link_of(pair.second))))
                           for pair, result in zip(plain.geometry.collisionPairs, plain.geometry_data.collisionResults)
                           if result.isCollision()})
        srdf = srdf.replace("</robot>", "".join(f'<disable_collisions link1="{a}" link2="{b}" reason="Default"/>'
                                                for a, b in touching) + "</robot>")
    if group_xml is not None:
        srdf = srdf.replace("</robot>", group_xml + "</robot>")
    if srdf == robot.srdf_xml:
        return robot
    model = RobotModel.from_strings(robot.urdf_xml, srdf, package_dirs=robot.package_dirs)
    return Robot(robot.name, model, robot.urdf_xml, srdf, robot.package_dirs, robot.srdf_source)


def _limits(model: RobotModel) -> tuple[np.ndarray, np.ndarray]:
    lower = np.where(np.isfinite(model.lower_limits), model.lower_limits, -np.pi)
    upper = np.where(np.isfinite(model.upper_limits), model.upper_limits, np.pi)
    return lower, upper


def _reference_and_rows(robot: Robot, group: str, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A collision-free reference state with every variable at a random value inside its limits
    (not the default), and group rows: random ones, then states along straight segments."""
    model = robot.model
    lower, upper = _limits(model)
    plain = PlainCheck(robot)
    for _ in range(500):
        reference = rng.uniform(lower, upper)
        if not plain.collides(plain.q(_joint_values(model, reference))):
            break
    else:
        raise AssertionError(f"{robot.name}: no free reference state in 500 samples")
    indices = model.group(group).variable_indices
    low, high = lower[indices], upper[indices]
    random = rng.uniform(low, high, (RANDOM_STATES, len(indices)))
    ends = rng.uniform(low, high, (SEGMENT_STATES // 10, 2, len(indices)))
    t = np.linspace(0.0, 1.0, 10)[None, :, None]
    along = (ends[:, :1] + t * (ends[:, 1:] - ends[:, :1])).reshape(-1, len(indices))
    return reference, np.vstack([random, along])


def _box_near_group_tip(robot: Robot, group: str, reference: np.ndarray, rows: np.ndarray) -> Extras:
    """A box where the group's last link with geometry is in one of the rows, and a cylinder
    held 15 cm off that link (clear of its neighbours, so not every state collides)."""
    model = robot.model
    indices = model.group(group).variable_indices
    with_geometry = {model.pin_model.frames[g.parentFrame].name for g in model.pin_collision_model.geometryObjects}
    links = [link for link in model.group(group).link_names if link in with_geometry]
    link = links[-1]
    state = np.array(reference)
    state[indices] = rows[len(rows) // 3]
    position = RobotState(model, state).frame_pose(link)[:3, 3]
    return Extras((0.12, 0.12, 0.12), make_pose(position + np.array([0.04, 0.0, 0.0])), link, (0.06, 0.01),
                  make_pose((0.15, 0.0, 0.0)))


def _box_through_still_link(robot: Robot, group: str, reference: np.ndarray) -> tuple | None:
    """The pose of a box around the centre of a link the group does not move (None if none)."""
    model = robot.model
    moved = set(model.group(group).updated_link_names)
    data = model.pin_model.createData()
    pin.forwardKinematics(model.pin_model, data, model.to_q(reference))
    for geom in model.pin_collision_model.geometryObjects:
        link = model.pin_model.frames[geom.parentFrame].name
        if link in moved:
            continue
        aabb = geom.geometry.aabb_local
        world = (data.oMi[geom.parentJoint] * geom.placement).act(np.asarray(aabb.center()))
        # as large as the geometry's box: it holds the whole geometry whatever the placement's
        # rotation (a mesh is its triangles: a small box inside a hollow mesh touches nothing)
        size = float(np.linalg.norm(np.asarray(aabb.max_) - np.asarray(aabb.min_)))
        return link, make_pose(world), (size, size, size)
    return None


def _wrong(robot: Robot, scene: PlanningScene, plain: PlainCheck, group: str, reference: np.ndarray,
           rows: np.ndarray) -> tuple[int, list[str]]:
    """(states colliding for the plain check, disagreements) for both forms of the group
    checker: collisions only (OMPL's unconstrained space) and with the joint limits."""
    model = robot.model
    indices = model.group(group).variable_indices
    start = RobotState(model, reference)
    free_only = scene.validity_checker(group, start, check_bounds=False)
    with_limits = scene.validity_checker(group, start, check_bounds=True)
    colliding, wrong = 0, []
    for row in rows:
        state = np.array(reference)
        state[indices] = row
        truth = plain.collides(plain.q(_joint_values(model, state)))
        colliding += truth
        for what, verdict in (("collisions only", free_only(row)), ("with limits", with_limits(row))):
            if verdict == truth:
                wrong.append(f"{what}: {'colliding' if truth else 'free'} for the plain check, "
                             f"{'valid' if verdict else 'invalid'} for the group checker: "
                             f"{np.round(row, 4).tolist()}")
    return colliding, wrong


def _compare_group(name: str, group: str, group_xml: str | None) -> list[str]:
    robot = _robot(name, group_xml)
    rng = np.random.default_rng(zlib.crc32(f"{name}/{group}".encode()))
    reference, rows = _reference_and_rows(robot, group, rng)
    bare = PlainCheck(robot)
    fixed = bare.fixed_overlaps(robot)  # allowed in the scene, as in test_collision_cross_check
    extras = _box_near_group_tip(robot, group, reference, rows)
    cases = [("bare", None, bare), ("box + attached cylinder", extras, bare.with_extras(extras))]
    failures = []
    indices = robot.model.group(group).variable_indices
    total_colliding = decided_once = 0
    for what, scene_extras, plain in cases:
        scene = _scene(robot, scene_extras, fixed)
        colliding, wrong = _wrong(robot, scene, plain, group, reference, rows)
        failures += [f"{name} {group} ({what}): {w}" for w in wrong[:5]]
        total_colliding += colliding
        if wrong:
            failures.append(f"{name} {group} ({what}): {len(wrong)} verdicts differ ({colliding} colliding)")
        decided_once += len(scene._compiled().fixed_pairs(scene.moving_joints(indices)))
    assert bool(decided_once) == ((name, group) not in NOTHING_FIXED), f"{name} {group}: {decided_once} pairs decided once"
    assert 0 < total_colliding < 2 * len(rows), f"{name} {group}: {total_colliding} of {2 * len(rows)} colliding"
    still = _box_through_still_link(robot, group, reference)
    if still is not None:
        link, pose, size = still
        box = Extras(size, pose, extras.link, extras.cylinder, extras.cylinder_pose)
        plain = bare.with_extras(box)
        assert plain.collides(plain.q(_joint_values(robot.model, reference))), f"{name}: the box misses '{link}'"
        scene = _scene(robot, box, fixed)
        colliding, wrong = _wrong(robot, scene, plain, group, reference, rows[:20])
        assert colliding == 20  # a pair decided once collides: every state
        failures += [f"{name} {group} (box through '{link}'): {w}" for w in wrong[:5]]
        report = scene.check_collision(RobotState(robot.model, reference))
        assert any(c.involves("box") and c.involves(link) for c in report.contacts), str(report)
    return failures


@pytest.mark.parametrize("name, group, group_xml", CASES, ids=[f"{c[0].split('/')[-1]}-{c[1]}" for c in CASES])
def test_group_checker_verdicts_equal_the_plain_all_pairs_check(name, group, group_xml):
    failures = _compare_group(name, group, group_xml)
    assert not failures, "\n".join(failures)


# ---------------------------------------------------------------------------------------------
# Which pairs are decided once: exactly those whose path holds no moving joint
# ---------------------------------------------------------------------------------------------


def _urdf_tree(urdf_xml: str) -> tuple[dict[str, tuple[str, str]], dict[str, str]]:
    """child link -> (joint, parent link), and mimic joint -> its source joint, from the text."""
    root = ET.fromstring(urdf_xml)
    parents, mimics = {}, {}
    for joint in root.findall("joint"):  # not the <joint> of a <transmission>
        parents[joint.find("child").get("link")] = (joint.get("name"), joint.find("parent").get("link"))
        mimic = joint.find("mimic")
        if mimic is not None:
            mimics[joint.get("name")] = mimic.get("joint")
    return parents, mimics


def _chain(link: str | None, parents: dict[str, tuple[str, str]]) -> set[str]:
    joints = set()
    while link in parents:
        joint, link = parents[link]
        joints.add(joint)
    return joints


@pytest.mark.parametrize("name, group, group_xml", CASES, ids=[f"{c[0].split('/')[-1]}-{c[1]}" for c in CASES])
def test_pairs_decided_once_are_exactly_those_no_group_joint_moves(name, group, group_xml):
    """From the URDF text: the joints between two bodies are those on one body's chain to the
    root and not on the other's; a pair is left out of the per-state check only when none of
    them is a group joint or a mimic joint driven (through any chain of mimics) by one."""
    robot = _robot(name, group_xml)
    model = robot.model
    parents, mimics = _urdf_tree(robot.urdf_xml)
    moving = set(model.group(group).joint_names)
    for _ in range(len(mimics)):
        moving |= {joint for joint, source in mimics.items() if source in moving}
    rng = np.random.default_rng(3)
    reference, rows = _reference_and_rows(robot, group, rng)
    extras = _box_near_group_tip(robot, group, reference, rows)
    scene = _scene(robot, extras, PlainCheck(robot).fixed_overlaps(robot))
    compiled = scene._compiled()
    names = compiled.geometry_names
    attached = compiled.attached_links

    def link_of(body: str) -> str | None:
        if body in attached:
            return attached[body]
        return body if model.has_link(body) else None  # a world object hangs on the world

    decided_once = set(compiled.fixed_pairs(scene.moving_joints(model.group(group).variable_indices)))
    assert bool(decided_once) == ((name, group) not in NOTHING_FIXED)
    for k in compiled.active_pairs:
        a, b = (names[g] for g in compiled.pairs[k])
        path = _chain(link_of(a), parents) ^ _chain(link_of(b), parents)
        expected = not (path & moving)
        assert (k in decided_once) == expected, (
            f"pair '{a}'-'{b}' (path {sorted(path)}) {'is' if k in decided_once else 'is not'} decided once")


def test_leaving_out_a_pair_a_group_joint_moves_is_caught(monkeypatch):
    """The comparison above fails when the checker leaves out a pair the group moves: here every
    pair is decided once at the reference state, as if no joint moved."""
    monkeypatch.setattr(CompiledScene, "fixed_pairs", lambda self, moving: list(self.active_pairs))
    failures = _compare_group("config/panda", "panda_arm", None)
    assert any("verdicts differ" in f for f in failures), failures
