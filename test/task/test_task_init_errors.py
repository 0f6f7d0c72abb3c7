"""Misconfigured tasks fail at init() with an InitStageException naming each stage and property,
before any planning (MTC's InitStageException)."""
from __future__ import annotations

import pytest

from mycobot_planning.task import (
    CartesianPath,
    InitStageException,
    JointInterpolationPlanner,
    PoseStamped,
    SerialContainer,
    Stage,
    Task,
    TaskError,
    Vector3Stamped,
    stages,
)
from task_helpers import scene_at


def _task(model, *children) -> Task:
    task = Task("task", model, scene_at(model, "home"))
    task.add(stages.CurrentState("current"), *children)
    return task


def _errors(task: Task) -> list[tuple[str, str]]:
    with pytest.raises(InitStageException) as info:
        task.init()
    text = str(info.value)
    assert text.startswith("Error initializing stage")
    for name, message in info.value.errors:
        assert f"{name}: {message}" in text
    return info.value.errors


def test_missing_group(mycobot):
    move = stages.MoveTo("move to ready", JointInterpolationPlanner())
    move.setGoal("ready")
    assert _errors(_task(mycobot, move)) == [
        ("move to ready", "property 'group' is undefined; set it on the stage or configure it to inherit from the "
                          "parent (configureInitFrom)")]


def test_group_inherited_from_a_parent_that_has_none(mycobot):
    def module(declare_group: bool) -> SerialContainer:
        container = SerialContainer("Cartesian Path")
        if declare_group:
            container.properties.declare("group", type=str)
        move = stages.MoveRelative("x +0.05", CartesianPath())
        move.properties.configureInitFrom(Stage.PARENT, ["group"])
        move.setDirection(Vector3Stamped("base_link", [0.05, 0, 0]))
        container.add(move)
        return container

    errors = _errors(_task(mycobot, module(False)))
    assert errors == [("x +0.05", "property 'group' is undefined; inherits from parent 'Cartesian Path', which does "
                                  "not declare it")]
    errors = _errors(_task(mycobot, module(True)))
    assert errors == [("x +0.05", "property 'group' is undefined; inherits from parent 'Cartesian Path', where it is "
                                  "undefined")]


def test_unknown_group_and_named_state(mycobot):
    bad_group = stages.MoveTo("to ready", JointInterpolationPlanner())
    bad_group.group = "arms"
    bad_group.setGoal("ready")
    bad_goal = stages.MoveTo("to redy", JointInterpolationPlanner())
    bad_goal.group = "arm"
    bad_goal.setGoal("redy")
    errors = _errors(_task(mycobot, bad_group, bad_goal))
    assert errors[0] == ("to ready", "property 'group': unknown planning group 'arms'; known: arm, gripper, arm_with_gripper")
    assert errors[1] == ("to redy", "property 'goal': unknown named state 'redy' for group 'arm'; known: home, ready")


def test_goal_joints_outside_the_group(mycobot):
    move = stages.MoveTo("open", JointInterpolationPlanner())
    move.group = "arm"
    move.setGoal({"gripper_controller": 0.0})
    (name, message), = _errors(_task(mycobot, move))
    assert name == "open" and message.startswith("property 'goal': goal joints ['gripper_controller'] are not part of group 'arm'")


def test_monitored_stage_missing_or_unknown(mycobot):
    generator = stages.GenerateGraspPose("generate grasp pose")
    generator.eef = "gripper"
    generator.object = "object"
    generator.pregrasp = "open"
    ik = stages.ComputeIK("grasp pose IK", generator)
    ik.group = "arm"
    ik.properties.configureInitFrom(Stage.INTERFACE, ["target_pose"])
    task = _task(mycobot, stages.Connect("connect", [("arm", JointInterpolationPlanner())]), ik)
    assert ("generate grasp pose", "no monitored stage defined (call setMonitoredStage)") in _errors(task)
    generator.setMonitoredStage("curent")
    assert ("generate grasp pose", "monitored stage 'curent' not found in the task") in _errors(task)
    generator.setMonitoredStage("current")
    task.init()  # found by name
    assert generator.monitored_stage is None and task["current"] is not None


def test_grasp_generator_properties(mycobot):
    generator = stages.GenerateGraspPose("grasp")
    generator.setMonitoredStage(stages.CurrentState("elsewhere"))
    generator.eef = "hand"
    generator.angle_delta = 0.0
    ik = stages.ComputeIK("IK", generator)
    ik.group = "arm"
    ik.properties.configureInitFrom(Stage.INTERFACE, ["target_pose"])
    errors = dict()
    for name, message in _errors(_task(mycobot, stages.Connect("c", [("arm", JointInterpolationPlanner())]), ik)):
        errors.setdefault(name, []).append(message)
    assert "property 'angle_delta' must be non-zero" in errors["grasp"]
    assert any(m.startswith("property 'object' is undefined") for m in errors["grasp"])
    assert "property 'eef': unknown end effector 'hand'; known: gripper" in errors["grasp"]
    assert "monitored stage 'elsewhere' is not part of this task" in errors["grasp"]

    ik.parent.remove(ik)
    generator.eef = "gripper"
    generator.angle_delta = 0.3
    generator.object = "object"
    generator.pregrasp = "wide open"
    generator.setMonitoredStage("current")
    errors = _errors(_task(mycobot, stages.Connect("c", [("arm", JointInterpolationPlanner())]), ik))
    assert any(m.startswith("property 'pregrasp': invalid pregrasp: unknown named state 'wide open' for group "
                            "'gripper'") for _, m in errors)


def test_empty_container(mycobot):
    assert _errors(_task(mycobot, SerialContainer("empty"))) == [
        ("empty", "no children (an empty container cannot produce solutions)")]


def test_wrong_property_type_inherited_from_the_parent(mycobot):
    module = SerialContainer("module")
    module.setProperty("group", 3)
    move = stages.MoveTo("move", JointInterpolationPlanner())
    move.properties.configureInitFrom(Stage.PARENT, ["group"])
    move.setGoal("ready")
    module.add(move)
    (name, message), = _errors(_task(mycobot, module))
    assert name == "move"
    assert message == ("property 'group': value inherited from parent has the wrong type: type int doesn't match "
                       "declared type str")


def test_every_problem_is_reported_at_once(mycobot):
    no_group = stages.MoveTo("no group", JointInterpolationPlanner())
    no_group.setGoal("ready")
    no_planner = stages.MoveRelative("no planner")
    no_planner.group = "arm"
    no_planner.setDirection(Vector3Stamped("base_link", [0, 0, 0.1]))
    no_goal = stages.MoveTo("no goal", JointInterpolationPlanner())
    no_goal.group = "arm"
    names = [name for name, _ in _errors(_task(mycobot, no_group, no_planner, no_goal))]
    assert names == ["no group", "no planner", "no goal"]


def test_connect_and_compute_ik_configuration(mycobot):
    connect = stages.Connect("connect", [("hand", JointInterpolationPlanner()), ("arm", None)])
    ik = stages.ComputeIK("IK", stages.GeneratePose("pose", "current"))
    errors = _errors(_task(mycobot, connect, ik))
    assert ("connect", "invalid group: hand; known: arm, gripper, arm_with_gripper") in errors
    assert ("connect", "invalid planner for group: arm") in errors
    assert any(name == "IK" and message.startswith("neither property 'eef' nor property 'group' is defined")
               for name, message in errors)
    assert any(name == "IK" and message.startswith("property 'target_pose' is undefined") for name, message in errors)
    assert any(name == "pose" and message.startswith("property 'pose' is undefined") for name, message in errors)


def test_interfaces_that_cannot_connect(mycobot):
    # a task must end with something that writes forward; a Connect reads its end
    task = _task(mycobot, stages.Connect("dangling", [("arm", JointInterpolationPlanner())]))
    errors = _errors(task)
    assert ("task", "end interface (←) of 'dangling' does not match mine (→)") in errors
    # two generators in a row cannot be joined
    task = Task("two starts", mycobot)
    task.add(stages.FixedState("a", scene_at(mycobot)), stages.FixedState("b", scene_at(mycobot)))
    assert _errors(task) == [("two starts", "cannot connect end interface of 'a' (→) to start interface of 'b' (←)")]


def test_missing_state_planner_or_model(mycobot):
    assert _errors(_task(mycobot, stages.FixedState("nothing"))) == [
        ("nothing", "no state given (call setState with a PlanningScene)")]
    move = stages.MoveTo("no planner")
    move.group = "arm"
    move.setGoal("home")
    assert _errors(_task(mycobot, move)) == [("no planner", "needs a planner (a PlannerInterface), got NoneType")]
    with pytest.raises(TaskError, match="no robot model"):
        Task("no model").init()


def test_plan_raises_the_same_exception_before_planning(mycobot):
    move = stages.MoveTo("move", JointInterpolationPlanner())
    task = _task(mycobot, move)
    with pytest.raises(InitStageException, match="move: property 'group' is undefined"):
        task.plan()
    assert task.numSolutions() == 0


def test_compute_ik_target_from_the_stage_itself_is_enough(mycobot):
    ik = stages.ComputeIK("IK", stages.FixedState("s", scene_at(mycobot)))
    ik.group = "arm"
    ik.setTargetPose(PoseStamped("world", scene_at(mycobot).current_state.frame_pose("link6_flange")))
    task = Task("ok", mycobot)
    task.add(ik)
    task.init()
