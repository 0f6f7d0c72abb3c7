"""Property and PropertyMap behave as MTC's Python bindings document them: MTC's properties demo
script (demo/scripts/properties.py) reads the same here, call for call."""
from __future__ import annotations

import pytest
from geometry_msgs.msg import PoseStamped

from mycobot_planning.task import core, stages


def test_mtc_properties_demo_calls_give_mtc_results():
    currentState = stages.CurrentState("Current State")
    p = core.Property()
    p.setDescription("Foo Property")
    p.setValue("Bar")  # MTC: sets the current and the default value
    assert p.defined()
    assert (p.value(), p.defaultValue(), p.description()) == ("Bar", "Bar", "Foo Property")

    pm = core.PropertyMap()
    props = {"prop1": "test", "prop2": 21, "prop3": PoseStamped(), "prop4": 5.4}
    pm.update(props)
    pm["prop5"] = 2
    assert pm["prop5"] == 2
    assert pm.property("prop5").value() == 2
    assert [(name, pm[name]) for name in pm] == [*props.items(), ("prop5", 2)]

    pm2 = core.PropertyMap()
    pm.exposeTo(pm2, ["prop2", "prop4"])
    assert [(name, pm2[name]) for name in pm2] == [("prop2", 21), ("prop4", 5.4)]
    assert isinstance(currentState.properties, core.PropertyMap) and "timeout" in currentState.properties


def test_set_value_survives_reset_and_current_value_does_not():
    p = core.Property("speed", float)
    p.setCurrentValue(0.5)
    p.reset()
    assert not p.defined() and p.value() is None
    p.setValue(0.25)
    p.setCurrentValue(0.75)
    assert p.value() == 0.75 and p.defaultValue() == 0.25


def test_expose_under_another_name_and_configure_all_with_an_empty_list():
    pm, other = core.PropertyMap(), core.PropertyMap()
    pm.declare("group", "arm", "planning group", str)
    pm.exposeTo(other, "group", "arm_group")  # MTC's exposeTo(other, name, other_name)
    assert list(other) == ["arm_group"] and other["arm_group"] == "arm"
    assert other.property("arm_group").description() == "planning group"
    pm.declare("eef", None, "end effector", str)
    pm.configureInitFrom(core.Stage.PARENT, [])  # MTC: an empty list means every property
    assert all(pm.property(name).initsFrom(core.Stage.PARENT) for name in ("group", "eef"))


def test_a_wrongly_typed_value_is_refused_naming_the_property():
    pm = core.PropertyMap()
    pm.declare("group", "arm", "planning group", str)
    pm.declare("timeout", 1.0, "seconds", float)
    with pytest.raises(Exception, match="group"):
        pm.update({"timeout": 2.0, "group": 3})
    assert pm["group"] == "arm" and pm["timeout"] == 1.0  # nothing half-applied


def test_solution_is_failure_is_a_property_as_in_mtc():
    ok, failed = core.SubTrajectory(cost=1.0), core.SubTrajectory.failure("no IK")
    assert ok.isFailure is False and failed.isFailure is True


def test_print_state_and_explain_failure_follow_a_redirected_stdout(mycobot):
    import contextlib
    import io

    from mycobot_planning.core import PlanningScene

    task = core.Task("redirect", mycobot, PlanningScene(mycobot))
    task.add(stages.CurrentState("current"))
    assert task.plan()
    captured = io.StringIO()
    with contextlib.redirect_stdout(captured):
        printed = task.printState()
        task.explainFailure()
    assert printed and captured.getvalue().startswith(printed)
