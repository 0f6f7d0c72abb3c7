"""The groups the setup assistant picks when it is told none."""
from __future__ import annotations

import pytest

from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.paths import example_robot_data_dir
from mycobot_planning.setup_assistant import GroupSpec, default_groups

ROBOTS = example_robot_data_dir()


def _model(urdf: str) -> RobotModel:
    return RobotModel.from_strings((ROBOTS / urdf).read_text(), '<robot name=""/>',
                                   package_dirs=[str(ROBOTS.parent.parent)])


@pytest.mark.parametrize("urdf,base,tip,gripper_joints", [
    ("panda_description/urdf/panda.urdf", "panda_link0", "panda_hand_tcp", {"panda_finger_joint1", "panda_finger_joint2"}),
    ("ur_description/urdf/ur5_robot.urdf", "world", "ee_link", None),  # the longest fixed branch
    ("b1_description/urdf/b1-z1.urdf", "base", "gripperMover", None),  # the arm, not a leg
    ("baxter_description/urdf/baxter.urdf", "base", "right_gripper", {"r_gripper_l_finger_joint",
                                                                       "r_gripper_r_finger_joint"}),
])
def test_default_arm_and_gripper(urdf: str, base: str, tip: str, gripper_joints: set[str] | None) -> None:
    model = _model(urdf)
    groups, eefs = default_groups(model)
    assert groups[0] == GroupSpec("arm", base_link=base, tip_link=tip)
    if gripper_joints is None:
        assert len(groups) == 1 and not eefs
    else:
        assert set(groups[1].joints) == gripper_joints
        assert eefs[0].parent_link == tip and eefs[0].parent_group == "arm" and eefs[0].group == "gripper"


def test_a_hand_ends_the_arm_once_it_has_four_joints() -> None:
    """TIAGo's hand has fingers of several joints each: the arm stops at the hand, torso included."""
    model = _model("tiago_description/robots/tiago.urdf")
    groups, eefs = default_groups(model)
    arm = RobotModel.from_strings(model.urdf_xml, f'<robot name="t"><group name="arm"><chain base_link='
                                  f'"{groups[0].base_link}" tip_link="{groups[0].tip_link}"/></group></robot>',
                                  package_dirs=[str(ROBOTS.parent.parent)]).group("arm")
    assert arm.joint_names == ("torso_lift_joint", *(f"arm_{i}_joint" for i in range(1, 8)))
    assert all(j.startswith("hand_") for j in groups[1].joints) and len(groups[1].joints) >= 3
    assert eefs[0].name == "gripper"


def test_group_specs_parse_and_refuse() -> None:
    assert GroupSpec.parse("arm:base:tool0") == GroupSpec("arm", base_link="base", tip_link="tool0")
    assert GroupSpec.parse("hand:j1,j2") == GroupSpec("hand", joints=("j1", "j2"))
    for bad in ("arm", "arm::tool0", "a:b:c:d", ":j1"):
        with pytest.raises(ValueError, match="expected NAME"):
            GroupSpec.parse(bad)


def test_a_robot_without_moving_joints_has_no_arm() -> None:
    model = RobotModel.from_strings('<robot name="rock"><link name="a"/><link name="b"/><joint name="j" '
                                    'type="fixed"><parent link="a"/><child link="b"/></joint></robot>',
                                    '<robot name="rock"/>')
    with pytest.raises(ValueError, match="no moving joints"):
        default_groups(model)
