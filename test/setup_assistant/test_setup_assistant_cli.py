"""`python -m mycobot_planning.setup_assistant` as a user runs it: files out, clear errors, no tracebacks."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from mycobot_planning.core.robot_model.robot_config import RobotConfig
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.robot_model.srdf import parse_srdf
from mycobot_planning.paths import example_robot_data_dir

ROBOTS = example_robot_data_dir()
FILES = {"joint_limits.yaml", "kinematics.yaml", "ompl_planning.yaml", "moveit_controllers.yaml",
         "ros2_controllers.yaml", "setup_assistant.yaml"}

XACRO = """<?xml version="1.0"?>
<robot name="twolink" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="length" default="0.3"/>
  <xacro:property name="L" value="$(arg length)"/>
  <xacro:macro name="segment" params="name parent z">
    <joint name="${name}_joint" type="revolute">
      <parent link="${parent}"/><child link="${name}"/>
      <origin xyz="0 0 ${z}"/><axis xyz="0 1 0"/>
      <limit lower="-2.0" upper="2.0" velocity="1.5" effort="10"/>
    </joint>
    <link name="${name}">
      <collision><origin xyz="0 0 ${L/2}"/><geometry><box size="0.04 0.04 ${L}"/></geometry></collision>
    </link>
  </xacro:macro>
  <link name="base"><collision><geometry><box size="0.1 0.1 0.05"/></geometry></collision></link>
  <joint name="yaw" type="revolute"><parent link="base"/><child link="turntable"/><origin xyz="0 0 0.05"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="1.5" effort="10"/></joint>
  <link name="turntable"><collision><geometry><cylinder radius="0.04" length="0.04"/></geometry></collision></link>
  <xacro:segment name="upper" parent="turntable" z="0.02"/>
  <xacro:segment name="lower" parent="upper" z="${L}"/>
</robot>
"""


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mycobot_planning.setup_assistant", *map(str, args)],
                          capture_output=True, text=True, timeout=300)


def test_ur5_with_its_srdf_and_a_group(tmp_path: Path) -> None:
    out = tmp_path / "ur5_config"
    done = run(ROBOTS / "ur_description/urdf/ur5_robot.urdf", "--srdf", ROBOTS / "ur_description/srdf/ur5.srdf",
               "--group", "manipulator:base_link:tool0", "--samples", "1000", "-o", out)
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    assert "sampling self-collisions: 1000/1000 states" in done.stderr  # progress on the terminal
    assert "self-collision matrix from 1000 states" in done.stdout
    assert {p.name for p in out.iterdir()} == FILES | {"ur5.urdf", "ur5.srdf"}
    srdf = parse_srdf((out / "ur5.srdf").read_text())
    reasons = {reason for _, _, reason in srdf.disabled_collisions}
    assert {"Adjacent", "Never"} <= reasons and reasons <= {"Adjacent", "Default", "Always", "Never", "User"}
    model = RobotModel.from_config(out, strict=True)
    assert model.group("manipulator").variable_count == 6
    assert model.group("manipulator").tip_link == "tool0"
    assert model.named_state("home", "manipulator") == {j: 0.0 for j in model.group("manipulator").joint_names}
    controllers = yaml.safe_load((out / "moveit_controllers.yaml").read_text())["moveit_simple_controller_manager"]
    assert controllers["controller_names"] == ["manipulator_controller"]
    assert controllers["manipulator_controller"]["joints"] == list(model.group("manipulator").joint_names)
    ompl = yaml.safe_load((out / "ompl_planning.yaml").read_text())
    assert ompl["manipulator"]["default_planner_config"] == "RRTConnectkConfigDefault"
    limits = yaml.safe_load((out / "joint_limits.yaml").read_text())["joint_limits"]
    assert set(limits) == set(model.variable_names)
    assert RobotConfig.load(out).ros2_controllers == out / "ros2_controllers.yaml"


def test_panda_keeps_its_srdf_and_gets_home(tmp_path: Path) -> None:
    out = tmp_path / "panda"
    done = run(ROBOTS / "panda_description/urdf/panda.urdf", "--srdf", ROBOTS / "panda_description/srdf/panda.srdf",
               "--samples", "500", "-o", out)
    assert done.returncode == 0, done.stderr
    shipped = RobotModel.from_files(ROBOTS / "panda_description/urdf/panda.urdf",
                                    ROBOTS / "panda_description/srdf/panda.srdf")
    model = RobotModel.from_config(out)
    assert model.group_names == shipped.group_names  # kept, none added
    for group in shipped.group_names:
        for name in shipped.named_state_names(group):
            assert model.named_state(name, group) == pytest.approx(shipped.named_state(name, group))
        assert "home" in model.named_state_names(group)
    assert shipped.disabled_collision_pairs <= model.disabled_collision_pairs
    assert list(model.end_effectors) == list(shipped.end_effectors)


def test_xacro_input_and_default_group(tmp_path: Path) -> None:
    source = tmp_path / "twolink.urdf.xacro"
    source.write_text(XACRO)
    out = tmp_path / "twolink"
    done = run(source, "--xacro-arg", "length:=0.25", "--samples", "300", "-o", out)
    assert done.returncode == 0, done.stderr
    model = RobotModel.from_config(out)
    assert model.group_names == ["arm"]
    assert model.group("arm").joint_names == ("yaw", "upper_joint", "lower_joint")
    assert model.group("arm").tip_link == "lower"
    assert 'size="0.04 0.04 0.25"' in (out / "twolink.urdf").read_text()  # the xacro argument was applied
    # upper and base are never adjacent: the turntable is between them, with its own geometry
    pairs = {tuple(sorted(p)) for p in model.disabled_collision_pairs}
    assert ("base", "turntable") in pairs and ("lower", "upper") in pairs


def test_default_groups_split_a_gripper_off_the_arm(tmp_path: Path) -> None:
    out = tmp_path / "panda_plain"
    done = run(ROBOTS / "panda_description/urdf/panda.urdf", "--samples", "200", "-o", out)
    assert done.returncode == 0, done.stderr
    model = RobotModel.from_config(out)
    assert model.group("arm").variable_count == 7
    assert model.group("gripper").joint_names == ("panda_finger_joint1",)  # joint2 mimics it
    assert set(model.group("gripper").all_joint_names) == {"panda_finger_joint1", "panda_finger_joint2"}
    assert model.end_effector("gripper").parent_group == "arm"
    controllers = yaml.safe_load((out / "ros2_controllers.yaml").read_text())
    assert controllers["controller_manager"]["ros__parameters"]["arm_controller"]["type"].startswith(
        "joint_trajectory_controller")
    assert controllers["controller_manager"]["ros__parameters"]["gripper_controller"]["type"] == \
        "position_controllers/GripperActionController"


@pytest.mark.parametrize("args,message,code", [
    (["--group", "arm:base_link:no_such_link"], "no_such_link", 1),
    (["--group", "arm"], "expected NAME:BASE_LINK:TIP_LINK", 2),
    (["--end-effector", "hand:tool0"], "expected NAME:PARENT_LINK:GROUP", 2),
    (["--end-effector", "hand:tool0:no_group"], "no_group", 1),
    (["--samples", "-5"], "--samples must be >= 0", 2),
    (["--srdf", "/nonexistent.srdf"], "cannot read SRDF file", 1),
])
def test_bad_input_is_a_clear_error_and_writes_nothing(tmp_path: Path, args: list[str], message: str,
                                                       code: int) -> None:
    out = tmp_path / "never_written"
    done = run(ROBOTS / "ur_description/urdf/ur5_robot.urdf", *args, "-o", out)
    assert done.returncode == code, done.stdout + done.stderr
    assert message in done.stderr
    assert "Traceback" not in done.stderr
    assert not out.exists()


def test_missing_robot_file(tmp_path: Path) -> None:
    done = run(tmp_path / "nothing.urdf", "-o", tmp_path / "out")
    assert done.returncode == 1 and "does not exist" in done.stderr and "Traceback" not in done.stderr


def test_ros2_run_finds_it() -> None:
    done = subprocess.run([sys.executable, "-m", "mycobot_planning.ros2cli", "run", "mycobot_planning",
                           "setup_assistant", "--help"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert "--end-effector NAME:PARENT_LINK:GROUP" in done.stdout
