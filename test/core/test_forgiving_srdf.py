"""The SRDF is read as MoveIt reads it: bad entries are skipped with a warning, the rest loads."""
from __future__ import annotations

import logging
from pathlib import Path

import pytest

from mycobot_planning.core.errors import RobotModelError
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.paths import example_robot_data_dir

ROBOTS = example_robot_data_dir()

#: SRDFs whose URDF has another name (cassie_v2.srdf has no URDF in example-robot-data at all).
URDF_OF = {
    "alexander": "alexander_description/urdf/alexander_v1.lowerBodyOnly.urdf",
    "baxter_manipulation": "baxter_description/urdf/baxter.urdf",
    "hyq": "hyq_description/robots/hyq_no_sensors.urdf",
    "pr2_manipulation": "pr2_description/urdf/pr2.urdf",
    "romeo_moveit": "romeo_description/urdf/romeo.urdf",
    "talos": "talos_data/robots/talos_full_v2.urdf",
    "ur5": "ur_description/urdf/ur5_robot.urdf",
}


def _shipped_pairs() -> list[tuple[str, str]]:
    """(URDF, SRDF) for every SRDF example-robot-data ships with a URDF of its robot: 37 of its
    38 SRDFs. 24 of these were refused before the loader became forgiving."""
    pairs = []
    for srdf in sorted(ROBOTS.glob("*/srdf/*.srdf")):
        package = srdf.parent.parent
        same = [package / folder / f"{srdf.stem}.urdf" for folder in ("urdf", "robots")]
        urdf = next((p for p in same if p.is_file()), None)
        if urdf is None and srdf.stem in URDF_OF:
            urdf = ROBOTS / URDF_OF[srdf.stem]
        if urdf is not None:
            pairs.append((str(urdf.relative_to(ROBOTS)), str(srdf.relative_to(ROBOTS))))
    return pairs


PAIRS = _shipped_pairs()


def test_every_shipped_srdf_with_a_urdf_is_covered() -> None:
    assert len(PAIRS) == 37
    assert all((ROBOTS / urdf).is_file() for urdf, _ in PAIRS)


def _load(urdf: str, srdf: str, **kwargs) -> RobotModel:
    return RobotModel.from_files(ROBOTS / urdf, ROBOTS / srdf, package_dirs=[str(ROBOTS.parent.parent)], **kwargs)


@pytest.mark.parametrize("urdf,srdf", PAIRS, ids=[Path(s).stem for _, s in PAIRS])
def test_shipped_srdf_loads_and_every_named_state_is_usable(urdf: str, srdf: str) -> None:
    model = _load(urdf, srdf)
    for group in model.group_names:
        for name in model.named_state_names(group):
            state = RobotState(model)
            state.set_named(name, group)  # every kept state names only joints the model has
    assert all(isinstance(w, str) and "skipped" in w or "moves on its own" in w for w in model.load_warnings)


def test_z1_group_naming_a_missing_link_is_skipped_with_one_warning(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING):
        model = _load("z1_description/urdf/z1.urdf", "z1_description/srdf/z1.srdf")
    assert "end_effector" not in model.group_names
    warned = [w for w in model.load_warnings if w.startswith("SRDF group 'end_effector'")]
    assert warned == ["SRDF group 'end_effector' skipped: names link 'base' the URDF lacks"]
    assert any(r.getMessage() == warned[0] for r in caplog.records)
    with pytest.raises(RobotModelError, match="chain link 'base' is not in the URDF"):
        _load("z1_description/urdf/z1.urdf", "z1_description/srdf/z1.srdf", strict=True)


def test_floating_root_joint_in_a_state_is_held_not_refused() -> None:
    """b1-z1's 'standing_with_arm_up' sets the floating root_joint (a virtual joint): it loads
    with the base held, the arm's and legs' values kept."""
    model = _load("b1_description/urdf/b1-z1.urdf", "b1_description/srdf/b1-z1.srdf")
    assert [vj.type for vj in model.srdf.virtual_joints] == ["floating"]
    values = model.named_state("standing_with_arm_up", "whole_body")
    assert "root_joint" not in values and len(values) >= 12
    assert model.group("arm").variable_count >= 6
    assert model.load_warnings == []  # nothing was skipped: the virtual joint is modelled, not unknown
    strict = _load("b1_description/urdf/b1-z1.urdf", "b1_description/srdf/b1-z1.srdf", strict=True)
    assert strict.named_state("standing_with_arm_up", "whole_body") == values


def test_dependents_of_a_skipped_group_go_with_it(mycobot: RobotModel) -> None:
    bad = mycobot.srdf_xml.replace('<joint name="link1_to_link2"/>', '<joint name="nope"/>', 1)
    model = RobotModel.from_strings(mycobot.urdf_xml, bad)
    assert "arm" not in model.group_names and "gripper" in model.group_names
    assert "arm_with_gripper" not in model.group_names  # its subgroup 'arm' is gone
    assert model.load_warnings[0] == "SRDF group 'arm' skipped: names joint 'nope' the URDF lacks"
    assert any("group_state 'home' skipped: group 'arm'" in w for w in model.load_warnings)
    assert any("end effector 'gripper' skipped: parent group 'arm'" in w for w in model.load_warnings)


def test_unknown_disabled_pair_and_state_joint_are_skipped_alone(mycobot: RobotModel) -> None:
    srdf = mycobot.srdf_xml.replace('link1="base_link"', 'link1="ghost_link"', 1).replace(
        "</robot>", '<group_state name="odd" group="arm"><joint name="ghost_joint" value="0"/></group_state>'
        "</robot>")
    model = RobotModel.from_strings(mycobot.urdf_xml, srdf)
    assert model.group_names == mycobot.group_names
    assert len(model.disabled_collision_pairs) == len(mycobot.disabled_collision_pairs) - 1
    assert "odd" not in model.named_state_names("arm")
    assert len(model.load_warnings) == 2
    assert "group_state 'odd' of group 'arm' skipped: names joint 'ghost_joint'" in model.load_warnings[0]
    assert "'ghost_link' is not in the URDF" in model.load_warnings[1]


def test_clean_srdf_loads_without_warnings(mycobot: RobotModel) -> None:
    assert mycobot.load_warnings == []
