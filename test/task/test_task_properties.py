"""Stage properties: types, defaults, inheritance from parent and interface, attribute access."""
from __future__ import annotations

import numpy as np
import pytest

from interfaces_py.msgs import TrajectoryExecutionInfo
from mycobot_planning.task import (
    PoseStamped,
    PropertyError,
    PropertyMap,
    PropertyTypeError,
    PropertyUndeclared,
    SerialContainer,
    Stage,
    stages,
)
from mycobot_planning.task.properties import PropertyInitializerSource
from mycobot_planning.task.solvers import CartesianPath, JointInterpolationPlanner

PARENT = PropertyInitializerSource.PARENT
INTERFACE = PropertyInitializerSource.INTERFACE


def test_declare_default_set_and_reset():
    p = PropertyMap()
    p.declare("timeout", 1.0, type=float)
    p.declare("group", type=str)
    assert p["timeout"] == 1.0 and p["group"] is None
    p["group"] = "arm"
    p.setCurrent("timeout", 2.5)
    p.reset()  # hand-set values survive, current values do not
    assert p["group"] == "arm" and p["timeout"] == 1.0
    p.set("timeout", 5)  # ints are fine for floats and stored as float
    assert p["timeout"] == 5.0 and isinstance(p["timeout"], float)


def test_type_errors_name_the_property_and_the_stage():
    move = stages.MoveTo("move to ready", JointInterpolationPlanner())
    with pytest.raises(PropertyTypeError) as info:
        move.group = 5
    assert info.value.property_name == "group"
    assert info.value.stage_name == "move to ready"
    assert "stage 'move to ready': property 'group': type int doesn't match declared type str" in str(info.value)
    with pytest.raises(PropertyTypeError, match="'timeout'.*bool"):
        move.timeout = True
    with pytest.raises(PropertyTypeError, match="'max_distance'"):
        stages.MoveRelative("lift").properties["max_distance"] = "far"


def test_undeclared_properties_are_errors_not_silent_attributes():
    move = stages.MoveTo("m")
    with pytest.raises(AttributeError, match="has no property 'grup'"):
        move.grup = "arm"
    with pytest.raises(PropertyUndeclared, match="'grup'"):
        move.properties.property("grup")
    with pytest.raises(AttributeError):
        _ = move.grup
    # explicit set declares a new property with the value's type (MTC's PropertyMap::set)
    move.properties.set("marker_color", "red")
    assert move.marker_color == "red"
    with pytest.raises(PropertyTypeError):
        move.properties.set("marker_color", 3)


def test_attribute_and_item_access_are_the_same_property():
    move = stages.MoveRelative("x +0.05", CartesianPath())
    move.group = "arm"
    assert move.properties["group"] == "arm"
    move.properties["min_distance"] = 0.01
    assert move.min_distance == 0.01
    move.setMinMaxDistance(0.02, 0.1)
    assert (move.min_distance, move.max_distance) == (0.02, 0.1)
    assert move.timeout == 1.0  # MoveRelative's default timeout


def test_coercions_for_frames_and_execution_info():
    ik = stages.ComputeIK("IK", stages.FixedState("s"))
    ik.ik_frame = "link6_flange"
    assert ik.ik_frame == PoseStamped("link6_flange", np.eye(4))
    ik.trajectory_execution_info = ["arm_controller"]
    assert ik.trajectory_execution_info == TrajectoryExecutionInfo(controller_names=["arm_controller"])
    with pytest.raises(PropertyTypeError, match="ik_frame"):
        ik.ik_frame = 42


def test_init_from_parent_respects_priorities():
    parent = PropertyMap()
    parent.set("group", "arm")
    parent.set("timeout", 3.0)
    child = PropertyMap()
    child.declare("group", type=str)
    child.declare("timeout", 1.0, type=float)
    child.declare("eef", type=str)
    child.configureInitFrom(PARENT)
    child.set("timeout", 7.0)  # manual beats parent
    child.performInitFrom(PARENT, parent)
    assert child["group"] == "arm"
    assert child["timeout"] == 7.0
    assert child["eef"] is None  # parent does not declare it: ignored, stays undefined
    # interface has lower priority than parent
    child.property("group").source_flags = PARENT | INTERFACE
    child.performInitFrom(INTERFACE, {"group": "gripper"})
    assert child["group"] == "arm"


def test_interface_values_replace_each_other_but_not_manual_ones():
    p = PropertyMap()
    p.declare("target_pose", type=PoseStamped)
    p.configureInitFrom(INTERFACE, ["target_pose"])
    first = PoseStamped("object", np.eye(4))
    second = PoseStamped("world", np.eye(4))
    p.performInitFrom(INTERFACE, {"target_pose": first})
    assert p["target_pose"] is first
    p.performInitFrom(INTERFACE, {"target_pose": second})
    assert p["target_pose"] is second
    with pytest.raises(PropertyTypeError, match="target_pose.*interface"):
        p.performInitFrom(INTERFACE, {"target_pose": "not a pose"} | {"target_pose": 3})


def test_a_property_inits_from_one_source_only():
    p = PropertyMap()
    p.declare("group", type=str)
    p.configureInitFrom(PARENT, ["group"])
    with pytest.raises(PropertyError, match="another source"):
        p.configureInitFrom(INTERFACE, ["group"])


def test_expose_to_declares_with_type_and_default():
    task_props = PropertyMap()
    task_props.set("eef", "gripper")
    task_props.declare("ik_frame", None, type=PoseStamped)
    container = SerialContainer("pick object")
    task_props.exposeTo(container.properties, ["eef", "ik_frame"])
    assert "eef" in container.properties and "ik_frame" in container.properties
    with pytest.raises(PropertyTypeError):
        container.properties["ik_frame"] = 1.5
    with pytest.raises(PropertyUndeclared):
        task_props.exposeTo(container.properties, ["nonexistent"])


def test_stage_level_names_and_configure_init_from():
    stage = stages.MoveTo("moveTo ready")
    stage.properties.configureInitFrom(Stage.PARENT)
    assert stage.properties.property("group").initsFrom(Stage.PARENT)
    assert stage.properties.property("goal").initsFrom(Stage.PARENT)
    assert not stage.properties.property("group").initsFrom(Stage.INTERFACE)


def test_solver_properties_as_attributes():
    cartesian = CartesianPath()
    assert (cartesian.step_size, cartesian.jump_threshold, cartesian.min_fraction) == (0.01, 1.5, 1.0)
    cartesian.setJumpThreshold(2.0)
    cartesian.max_velocity_scaling_factor = 0.5
    assert cartesian.properties["jump_threshold"] == 2.0 and cartesian.max_velocity_scaling_factor == 0.5
    with pytest.raises(AttributeError, match="step"):
        cartesian.step = 0.1
