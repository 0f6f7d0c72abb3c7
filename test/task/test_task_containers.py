"""Containers: nesting and property inheritance, Alternatives, Fallbacks (generator, propagator,
connector), Merger; max_solutions, ordering, reproducibility, explainFailure."""
from __future__ import annotations

import numpy as np
import pytest

from interfaces_py.msgs import CollisionObject
from mycobot_planning.core.transforms import make_pose
from mycobot_planning.task import (
    Alternatives,
    CartesianPath,
    Fallbacks,
    JointInterpolationPlanner,
    Merger,
    PipelinePlanner,
    SerialContainer,
    Stage,
    Task,
    Vector3Stamped,
    stages,
)
from task_helpers import assert_solution_valid, chain_is_continuous, current_state_task, scene_at


def _move(name, goal, planner=None, group=None):
    move = stages.MoveTo(name, planner or JointInterpolationPlanner())
    if group:
        move.group = group
    move.setGoal(goal)
    return move


def test_nested_serial_containers_inherit_the_group(mycobot):
    task = Task("nested", mycobot, scene_at(mycobot, "home"))
    task.setProperty("group", "arm")
    task.add(stages.CurrentState("current"))
    outer = SerialContainer("outer")
    task.properties.exposeTo(outer.properties, ["group"])
    outer.properties.configureInitFrom(Stage.PARENT, ["group"])
    inner = SerialContainer("inner")
    inner.setProperty("group", "arm")
    first = _move("to ready", "ready")
    first.properties.configureInitFrom(Stage.PARENT, ["group"])
    second = _move("to home", "home")
    second.properties.configureInitFrom(Stage.PARENT)
    inner.add(first, second)
    outer.add(inner)
    up = stages.MoveRelative("up", CartesianPath())
    up.properties.configureInitFrom(Stage.PARENT, ["group"])
    up.setDirection(Vector3Stamped("base_link", [0.0, 0.0, -0.02]))
    outer.add(_move("ready again", "ready", group="arm"), up)
    task.add(outer)
    assert task.plan()
    assert first.group == "arm" and second.group == "arm" and up.group == "arm"
    solution = task.solutions[0]
    assert [s.creator.name for s in solution.sub_trajectories()] == ["current", "to ready", "to home", "ready again", "up"]
    chain_is_continuous(solution)
    assert assert_solution_valid(solution) == 4
    assert task.printState(stream=None).splitlines()[2:5] == [
        "    -  1 →   1 →   -  1 / outer",
        "      -  1 →   1 →   -  0 / inner",
        "        -  0 →   1 →   -  0 / to ready",
    ]


def test_alternatives_pass_on_every_child_solution_sorted_by_cost(mycobot):
    task = current_state_task(mycobot, "alternatives")
    choices = Alternatives("targets")
    choices.add(_move("far", "ready", group="arm"), _move("near", {"link1_to_link2": 0.2}, group="arm"),
                _move("gripper", "closed", group="gripper"))
    task.add(choices)
    assert task.plan()
    assert [s.sub_trajectories()[1].creator.name for s in task.solutions] == ["near", "gripper", "far"]
    costs = [s.cost for s in task.solutions]
    assert costs == sorted(costs) and costs[0] == pytest.approx(0.2)
    assert task.printState(stream=None).splitlines()[2] == "    -  1 →   3 →   -  3 / targets"


def test_max_solutions_is_respected_and_zero_means_all(mycobot):
    def build():
        task = Task("many", mycobot)
        initial = Alternatives("initial")
        for k in range(4):
            initial.add(stages.FixedState(f"s{k}", scene_at(mycobot, "home", link1_to_link2=0.1 * k)))
        task.add(initial)
        task.add(_move("to ready", "ready", group="arm"))
        return task

    task = build()
    assert task.plan(max_solutions=2) and task.numSolutions() == 2
    assert task.plan(max_solutions=0) and task.numSolutions() == 4
    assert task.plan() and task.numSolutions() == 4  # plan() resets: no solutions pile up
    with pytest.raises(Exception, match="max_solutions"):
        task.plan(-1)


def _blocked_scene(model):
    """Home state with a box in the way of the straight joint-space line to 'ready'."""
    scene = scene_at(model, "home")
    mid = scene_at(model, "ready", link3_to_link4=0.785, link4_to_link5=0.785).current_state.frame_pose("link6_flange")
    scene.add_object(CollisionObject.box("wall", [0.04, 0.04, 0.04], make_pose(mid[:3, 3])))
    return scene


def test_fallbacks_try_the_next_child_per_state(mycobot):
    task = Task("fallbacks", mycobot, seed=2)
    initial = Alternatives("initial states")
    initial.add(stages.FixedState("blocked", _blocked_scene(mycobot)), stages.FixedState("free", scene_at(mycobot, "home")))
    task.add(initial)
    fallbacks = Fallbacks("to ready")
    straight = _move("straight", "ready", group="arm")
    planned = _move("planned", "ready", PipelinePlanner("ompl"), group="arm")
    planned.setTimeout(2.0)
    fallbacks.add(straight, planned)
    task.add(fallbacks)
    assert task.plan()
    assert task.numSolutions() == 2
    assert (len(straight.solutions), straight.numFailures()) == (1, 1)  # free: straight line works
    assert (len(planned.solutions), planned.numFailures()) == (1, 0)  # blocked: only OMPL was asked
    assert "in collision: contact between 'wall'" in straight.failures[0].comment
    for solution in task.solutions:
        assert_solution_valid(solution)
    assert task.printState(stream=None).splitlines()[4:7] == [
        "    -  0 →   2 →   -  2 / to ready",
        "      -  0 →   1 →   -  2 / straight",
        "      -  0 →   1 →   -  2 / planned",
    ]


def test_fallbacks_as_generator_stop_at_the_first_successful_child(mycobot):
    colliding = scene_at(mycobot, "home")
    colliding.add_object(CollisionObject.box("box", [0.1, 0.1, 0.1], make_pose([0.0, 0.0, 0.2])))
    task = Task("start", mycobot)
    starts = Fallbacks("start")
    bad, good, unused = (stages.FixedState("colliding", colliding), stages.FixedState("free", scene_at(mycobot, "home")),
                         stages.FixedState("never", scene_at(mycobot, "ready")))
    starts.add(bad, good, unused)
    task.add(starts)
    task.add(_move("to ready", "ready", group="arm"))
    assert task.plan()
    assert task.numSolutions() == 1
    assert bad.numFailures() == 1 and len(good.solutions) == 1 and len(unused.solutions) == 0


def test_fallbacks_of_connect_stages(mycobot):
    task = Task("connect fallbacks", mycobot, seed=5)
    task.add(stages.FixedState("start", _blocked_scene(mycobot)))
    connect = Fallbacks("connect")
    straight = stages.Connect("straight", [("arm", JointInterpolationPlanner())])
    planned = stages.Connect("planned", [("arm", PipelinePlanner("ompl"))])
    planned.setTimeout(2.0)
    connect.add(straight, planned)
    task.add(connect)
    goal = _blocked_scene(mycobot)
    goal.set_current_state({name: value for name, value in mycobot.named_state("ready", "arm").items()})
    task.add(stages.FixedState("goal", goal))
    assert task.plan()
    assert straight.numFailures() == 1 and not straight.solutions
    assert len(planned.solutions) == 1
    assert_solution_valid(task.solutions[0])


def test_merger_moves_arm_and_gripper_together(mycobot):
    task = current_state_task(mycobot, "merge")
    merger = Merger("arm and gripper")
    merger.add(_move("arm to ready", "ready", group="arm"), _move("close gripper", "closed", group="gripper"))
    task.add(merger)
    assert task.plan()
    solution = task.solutions[0]
    merged = solution.sub_trajectories()[1]
    assert merged.group == "arm_with_gripper"
    assert merged.trajectory.joint_names[-1] == "gripper_controller"
    end = solution.end.scene.current_state
    assert end.joint_position("gripper_controller") == pytest.approx(-0.5)
    assert end.joint_position("link3_to_link4") == pytest.approx(1.5708)
    assert_solution_valid(solution)


def test_connect_merges_several_groups(mycobot):
    task = Task("connect two groups", mycobot)
    task.add(stages.FixedState("start", scene_at(mycobot, "home")))
    task.add(stages.Connect("move", [("arm", JointInterpolationPlanner()), ("gripper", JointInterpolationPlanner())]))
    goal = scene_at(mycobot, "ready")
    goal.set_current_state({"gripper_controller": -0.34})
    task.add(stages.FixedState("goal", goal))
    assert task.plan()
    merged = task.solutions[0].sub_trajectories()[1]
    assert merged.group == "arm_with_gripper" and merged.planner_id == "JointInterpolation, JointInterpolation"
    assert_solution_valid(task.solutions[0])

    task[1].properties["merge_mode"] = stages.Connect.SEQUENTIAL
    assert task.plan()
    steps = task.solutions[0].sub_trajectories()
    assert [s.group for s in steps[1:3]] == ["arm", "gripper"]
    chain_is_continuous(task.solutions[0])
    assert_solution_valid(task.solutions[0])


def test_explain_failure_names_the_first_failing_stage(mycobot):
    task = Task("blocked", mycobot, _blocked_scene(mycobot))
    task.add(stages.CurrentState("current"))
    task.add(_move("straight to ready", "ready", group="arm"))
    task.add(_move("home", "home", group="arm"))
    result = task.plan()
    assert not result
    text = task.explainFailure(stream=None)
    assert text.startswith("Failing stage(s):\nstraight to ready (0/1): ")
    assert "contact between 'wall' (Object)" in text
    assert "straight to ready (0/1)" in result.message


def test_reproducible_with_a_seed(mycobot):
    def run(seed):
        task = Task("ompl", mycobot, _blocked_scene(mycobot), seed=seed)
        task.add(stages.CurrentState("current"))
        task.add(_move("planned", "ready", PipelinePlanner("ompl"), group="arm"))
        assert task.plan()
        return task.solutions[0].sub_trajectories()[1].trajectory.positions

    first, again = run(11), run(11)
    assert np.array_equal(first, again)


def test_task_level_properties_reach_stages_configured_to_inherit(mycobot):
    task = Task("props", mycobot, scene_at(mycobot, "home"))
    task.setProperty("group", "arm")
    task.setProperty("trajectory_execution_info", ["arm_controller"])
    task.add(stages.CurrentState("current"))
    move = _move("to ready", "ready")
    move.properties.configureInitFrom(Stage.PARENT, ["group", "trajectory_execution_info"])
    task.add(move)
    assert task.plan()
    msg = task.to_msg()
    assert msg.sub_trajectory[1].execution_info.controller_names == ["arm_controller"]
    assert msg.sub_trajectory[0].execution_info.controller_names == []  # CurrentState does not inherit


def test_description_statistics_and_summary(mycobot):
    task = current_state_task(mycobot, "intro")
    module = SerialContainer("module")
    module.add(_move("to ready", "ready", group="arm"), _move("to home", "home", group="arm"))
    task.add(module)
    assert task.plan()
    description = task.description()
    assert [(s.id, s.parent_id, s.name) for s in description.stages] == [
        (1, 0, "intro"), (2, 1, "current"), (3, 1, "module"), (4, 3, "to ready"), (5, 3, "to home")]
    assert description.stages[1].flags == 0x0C and description.stages[3].flags == 0x05  # ← → and → →
    statistics = task.statistics()
    root = statistics.stages[0]
    assert root.solved == [s.id for s in task.solutions] and root.cost == [s.cost for s in task.solutions]
    assert all(s.total_compute_time >= 0 for s in statistics.stages)
    from mycobot_planning.task.introspection import summary_text

    text = summary_text(task)
    assert "  current: 1 solutions, 0 failures" in text and "    to home: 1 solutions, 0 failures" in text
    rows = task.stage_summary()
    assert [r["path"] for r in rows] == ["", "current", "module", "module/to ready", "module/to home"]
    assert rows[3]["best_cost"] == pytest.approx(2 * 1.5708)


def test_preempt_and_timeout(mycobot):
    from interfaces_py.msgs import MoveItErrorCode

    def two_step_task(name):
        # one stage computes per step: the generator, then the two moves; a solution needs 3 steps
        task = Task(name, mycobot)
        task.add(_move("from ready", "ready", group="arm"), stages.FixedState("s", scene_at(mycobot, "home")),
                 _move("to ready", "ready", group="arm"))
        return task

    task = two_step_task("stop")
    steps = []
    task.addTaskCallback(lambda t: steps.append(t.numSolutions()))
    assert task.plan() and steps == [0, 0, 1]
    task.addTaskCallback(lambda t: t.preempt())
    result = task.plan()
    assert result.val == MoveItErrorCode.PREEMPTED and task.numSolutions() == 0
    task = Task("slow", mycobot, scene_at(mycobot, "home"))
    task.add(stages.CurrentState("current"), _move("to ready", "ready", group="arm"))
    task.setTimeout(1e-9)
    assert task.plan().val == MoveItErrorCode.TIMED_OUT


def test_connect_keeps_the_arm_trajectory_when_the_gripper_does_not_move(mycobot):
    """A lone moving group is merged without re-checking or re-timing: the merged trajectory is
    the arm's, state for state (dense: waypoints at most 0.1 rad apart), with the gripper held
    where it was."""
    from mycobot_planning.core.robot_trajectory.robot_trajectory import limit_waypoint_distance
    from mycobot_planning.task.trajectories import merge_trajectories, single_point, time_path

    start = scene_at(mycobot, "home")
    goal = scene_at(mycobot, "ready")
    arm = mycobot.group("arm")
    path = np.array([start.current_state.group_positions("arm"), goal.current_state.group_positions("arm")])
    arm_traj = limit_waypoint_distance(time_path(mycobot, arm, path))
    gripper = mycobot.group("gripper")
    held = single_point(gripper.joint_names, start.current_state.group_positions("gripper"))
    merged, group, message = merge_trajectories(start, start.current_state, [("arm", arm_traj), ("gripper", held)])
    assert group == "arm_with_gripper" and message == ""
    assert np.array_equal(merged.times, arm_traj.times)
    names = merged.joint_names
    for k, name in enumerate(arm_traj.joint_names):
        assert np.array_equal(merged.positions[:, names.index(name)], arm_traj.positions[:, k])
        assert np.array_equal(merged.velocities[:, names.index(name)], arm_traj.velocities[:, k])
    for k, name in enumerate(gripper.joint_names):
        assert np.all(merged.positions[:, names.index(name)] == held.positions[0, k])
        assert np.all(merged.velocities[:, names.index(name)] == 0.0)
    # A held group somewhere else than the start state is a real merge: checked and re-timed.
    moved = single_point(gripper.joint_names, start.current_state.group_positions("gripper") - 0.2)
    remerged, _, _ = merge_trajectories(start, start.current_state, [("arm", arm_traj), ("gripper", moved)])
    assert remerged is not None and not np.array_equal(remerged.positions[0], merged.positions[0])
