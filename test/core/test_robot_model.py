"""RobotModel and RobotState: semantics from URDF + SRDF, limits, mimic joints, bad input."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mycobot_planning.core import RobotModel, RobotModelError, RobotState, StateError
from mycobot_planning.paths import config_file

from test_robot_description import full_positions, numpy_fk

ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6", "link6_to_link6_flange"]


def test_groups_and_tips(mycobot: RobotModel):
    assert mycobot.group_names == ["arm", "gripper", "arm_with_gripper"]
    arm = mycobot.group("arm")
    assert list(arm.joint_names) == ARM
    assert arm.tip_link == "link6_flange"
    assert "gripper_base" in arm.link_names  # the fixed flange→gripper_base joint is in the group
    gripper = mycobot.group("gripper")
    assert gripper.joint_names == ("gripper_controller",)
    assert set(gripper.link_names) == {f"gripper_{s}{i}" for s in ("left", "right") for i in (1, 2, 3)}
    both = mycobot.group("arm_with_gripper")
    assert list(both.joint_names) == ARM + ["gripper_controller"]
    assert both.subgroups == ("arm", "gripper")
    assert mycobot.end_effector("gripper").parent_link == "link6_flange"
    assert arm.end_effector == "gripper"


def test_variables_exclude_mimic_joints(mycobot: RobotModel):
    assert mycobot.variable_names == ARM + ["gripper_controller"]
    assert len(mycobot.mimic_joint_names) == 5


def test_limits_from_joint_limits_yaml(mycobot: RobotModel):
    assert np.allclose(mycobot.velocity_limits[:6], 2.792527)
    assert np.allclose(mycobot.acceleration_limits[:6], 5.0)
    assert np.allclose(mycobot.upper_limits[:5], 2.879793)
    assert mycobot.joint("link6_to_link6_flange").upper == pytest.approx(3.05)
    assert mycobot.joint("gripper_controller").lower == pytest.approx(-0.7)


def test_joint_limits_yaml_overrides_urdf():
    model = RobotModel.from_files(
        config_file("mycobot_280.urdf"),
        config_file("mycobot_280.srdf"),
        joint_limits_path=None,
    )
    # Without joint_limits.yaml, velocity comes from the URDF and acceleration is MoveIt's default.
    assert model.joint("link1_to_link2").max_acceleration == pytest.approx(1.0)
    overridden = RobotModel.from_strings(
        model.urdf_xml,
        model.srdf_xml,
        joint_limits={"joint_limits": {"link1_to_link2": {"has_velocity_limits": True, "max_velocity": 0.5}}},
    )
    assert overridden.joint("link1_to_link2").max_velocity == 0.5


@pytest.mark.parametrize(
    "arm_state,gripper_state",
    [("home", "open"), ("ready", "open"), ("ready", "closed"), ("home", "half_closed")],
)
def test_named_state_fk_matches_independent_fk(mycobot: RobotModel, arm_state: str, gripper_state: str):
    state = RobotState(mycobot)
    state.set_named(arm_state, "arm")
    state.set_named(gripper_state, "gripper")
    arm_values = mycobot.named_state(arm_state, "arm")
    expected = numpy_fk(full_positions(arm_values, mycobot.named_state(gripper_state, "gripper")["gripper_controller"]))
    for link in ("link6_flange", "gripper_base", "gripper_left1", "gripper_right1"):
        assert np.allclose(state.frame_pose(link), expected[link], atol=1e-9), link


def test_ready_flange_position(mycobot: RobotModel):
    state = RobotState(mycobot)
    state.set_named("ready")
    assert np.allclose(state.frame_pose("link6_flange")[:3, 3], [0.06062, -0.14159946, 0.16777931], atol=1e-6)


def test_jacobian_matches_finite_differences(mycobot: RobotModel):
    rng = np.random.default_rng(3)
    state = RobotState(mycobot, rng.uniform(mycobot.lower_limits, mycobot.upper_limits) * 0.8)
    jac = state.jacobian("gripper_left1", "arm_with_gripper")
    eps = 1e-7
    base = state.frame_pose("gripper_left1")[:3, 3]
    for column, joint in enumerate(mycobot.group("arm_with_gripper").joint_names):
        moved = state.copy()
        moved.set_joint_positions({joint: state.joint_position(joint) + eps})
        numeric = (moved.frame_pose("gripper_left1")[:3, 3] - base) / eps
        assert np.allclose(jac[:3, column], numeric, atol=1e-5), joint


def test_mimic_joint_values(mycobot: RobotModel):
    state = RobotState(mycobot)
    state.set_named("closed", "gripper")
    values = state.to_joint_dict()
    assert values["gripper_controller"] == pytest.approx(-0.5)
    assert values["gripper_base_to_gripper_left2"] == pytest.approx(-0.5)
    assert values["gripper_base_to_gripper_right3"] == pytest.approx(0.5)
    assert values["gripper_left3_to_gripper_left1"] == pytest.approx(0.5)


def test_state_copy_is_independent(mycobot: RobotModel):
    a = RobotState(mycobot)
    b = a.copy()
    b.set_named("ready")
    assert not np.array_equal(a.positions, b.positions)
    assert a.model is b.model


def test_group_views(mycobot: RobotModel):
    state = RobotState(mycobot)
    state.set_group_positions("arm", [0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    assert np.allclose(state.group_positions("arm"), [0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    assert state.joint_position("gripper_controller") == 0.0


@pytest.mark.parametrize(
    "call,message",
    [
        (lambda m, s: m.group("legs"), "unknown planning group 'legs'"),
        (lambda m, s: s.set_named("dance"), "unknown named state 'dance'"),
        (lambda m, s: s.set_named("open", "arm"), "unknown named state 'open' for group 'arm'"),
        (lambda m, s: s.frame_pose("link99"), "unknown link or frame 'link99'"),
        (lambda m, s: s.set_group_positions("arm", [0.0] * 5), "expected 6 values, got 5"),
        (lambda m, s: s.set_positions([0.0] * 6 + [math.nan]), "NaN"),
        (lambda m, s: s.set_joint_positions({"elbow": 1.0}), "unknown or non-active joint 'elbow'"),
        (lambda m, s: m.joint("elbow"), "unknown joint 'elbow'"),
    ],
)
def test_bad_input_names_the_problem(mycobot: RobotModel, call, message: str):
    state = RobotState(mycobot)
    before = state.positions.copy()
    with pytest.raises((RobotModelError, StateError)) as info:
        call(mycobot, state)
    assert message in str(info.value)
    assert np.array_equal(state.positions, before)


def test_malformed_descriptions(mycobot: RobotModel):
    with pytest.raises(RobotModelError, match="URDF is not well-formed XML"):
        RobotModel.from_strings("<robot name='x'><link", mycobot.srdf_xml)
    with pytest.raises(RobotModelError, match="SRDF is not well-formed XML"):
        RobotModel.from_strings(mycobot.urdf_xml, "<robot><group")
    bad_group = mycobot.srdf_xml.replace('<joint name="link1_to_link2"/>', '<joint name="nope"/>', 1)
    assert bad_group != mycobot.srdf_xml
    with pytest.raises(RobotModelError, match="unknown joint 'nope'"):
        RobotModel.from_strings(mycobot.urdf_xml, bad_group, strict=True)
    bad_pair = mycobot.srdf_xml.replace('link1="base_link"', 'link1="ghost_link"', 1)
    with pytest.raises(RobotModelError, match="ghost_link"):
        RobotModel.from_strings(mycobot.urdf_xml, bad_pair, strict=True)
    with pytest.raises(RobotModelError, match="cannot read URDF file"):
        RobotModel.from_files("/nonexistent.urdf", config_file("mycobot_280.srdf"))
    with pytest.raises(RobotModelError, match="unknown joints"):
        RobotModel.from_strings(mycobot.urdf_xml, mycobot.srdf_xml, joint_limits={"joint_limits": {"nope": {}}})


def test_disabled_pairs_from_srdf(mycobot: RobotModel):
    assert frozenset(("base_link", "link1")) in mycobot.disabled_collision_pairs
    assert frozenset(("link1", "link4")) not in mycobot.disabled_collision_pairs


def test_link_collision_geometry_is_coal(mycobot: RobotModel):
    import coal

    shapes = mycobot.link_collision_geometry("link3")
    assert len(shapes) == 1
    geometry, placement = shapes[0]
    assert isinstance(geometry, coal.Cylinder)
    assert geometry.radius == pytest.approx(0.025)
    assert np.allclose(placement[:3, 3], [-0.058, 0, 0.059])


def test_panda_loads_with_meshes(panda: RobotModel):
    assert panda.group("arm").variable_count == 7
    assert panda.group("arm").tip_link == "panda_hand_tcp"
    state = RobotState(panda)
    state.set_named("default")
    assert state.satisfies_bounds()
    assert panda.pin_collision_model.ngeoms > 10


def test_a_link_named_like_a_joint_is_the_link():
    """z1's URDF names a link and its fixed joint 'gripperStator': frame lookups (poses, attached
    objects) take the link instead of failing on the ambiguous name."""
    import pinocchio as pin

    from interfaces_py.msgs import CollisionObject
    from mycobot_planning.core import PlanningScene
    from mycobot_planning.paths import example_robot_data_dir

    robots = example_robot_data_dir()
    z1 = RobotModel.from_files(robots / "z1_description/urdf/z1.urdf", robots / "z1_description/srdf/z1.srdf",
                               package_dirs=[str(robots.parent.parent)])
    frame = z1.frame_id("gripperStator")
    assert z1.pin_model.frames[frame].type == pin.FrameType.BODY
    scene = PlanningScene(z1)
    pose = scene.current_state.frame_pose("gripperStator")
    scene.add_object(CollisionObject.box("part", [0.01, 0.01, 0.01], pose))
    scene.attach_object("part", "gripperStator")
    assert scene.is_attached("part")


_THREE_KINDS_URDF = """<robot name="three_kinds">
  <link name="base"/><link name="a"/><link name="b"/><link name="c"/>
  <joint name="j_rev" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j_cont" type="continuous"><parent link="a"/><child link="b"/><axis xyz="0 1 0"/>
    <origin xyz="0 0 0.1"/><limit effort="1" velocity="1"/></joint>
  <joint name="j_mimic" type="revolute"><parent link="b"/><child link="c"/><axis xyz="0 1 0"/>
    <origin xyz="0 0 0.1"/><limit lower="-2" upper="2" effort="1" velocity="1"/>
    <mimic joint="j_rev" multiplier="2" offset="0"/></joint>
</robot>"""


def _plain_q_slots(model: RobotModel, indices: np.ndarray) -> np.ndarray | None:
    """q_slots' rule written out: slots only for variables that are neither continuous nor a
    mimic source, by writing each alone through to_q."""
    base = model.to_q(model.default_positions())
    slots = []
    for index in indices:
        values = model.default_positions()
        values[index] += 0.25
        changed = np.flatnonzero(~np.isclose(model.to_q(values), base))
        if changed.size != 1:
            return None  # a mimic source (several slots) or a continuous joint (cos, sin)
        slots.append(int(changed[0]))
    return np.array(slots)


def test_q_slots_memoised_match_the_plain_rule_and_stay_private(mycobot: RobotModel, panda: RobotModel):
    """RobotModel.q_slots is memoised per index set: on robots with mimic followers (myCobot's
    gripper), a continuous joint and plain chains, every subset answers as the plain rule, the
    same on a second ask, and a caller writing into its answer changes no later one."""
    three = RobotModel.from_strings(_THREE_KINDS_URDF, '<robot name="three_kinds"><group name="all"><chain base_link="base" tip_link="c"/></group></robot>')
    rng = np.random.default_rng(7)
    for model in (mycobot, panda, three):
        n = len(model.variable_names)
        subsets = [np.arange(n)] + [np.sort(rng.choice(n, size=int(rng.integers(1, n + 1)), replace=False))
                                    for _ in range(12)]
        for indices in subsets:
            plain = _plain_q_slots(model, indices)
            for _ in range(2):
                slots = model.q_slots(indices)
                if plain is None:
                    assert slots is None, (model.name, indices)
                else:
                    assert slots is not None and np.array_equal(slots, plain), (model.name, indices, slots, plain)
                    slots[:] = -1  # the caller's copy: the next answer is unaffected
    assert three.q_slots(np.array([0])) is None and three.q_slots(np.array([1])) is None
