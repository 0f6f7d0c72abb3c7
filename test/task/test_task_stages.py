"""Stages on small tasks: directions (forward, backward, connect), goals, relative motions,
scene modifications, IK, filters and cost terms."""
from __future__ import annotations

import io
import math

import numpy as np
import pytest

from interfaces_py.msgs import CollisionObject
from mycobot_planning.core.transforms import make_pose
from mycobot_planning.task import (
    CartesianPath,
    Clearance,
    Constant,
    JointInterpolationPlanner,
    LinkMotion,
    PathLength,
    PipelinePlanner,
    PointStamped,
    PoseStamped,
    Stage,
    Task,
    TrajectoryDuration,
    TwistStamped,
    Vector3Stamped,
    stages,
)
from task_helpers import assert_solution_valid, chain_is_continuous, current_state_task, scene_at


def _lines(task: Task) -> list[str]:
    return task.printState(stream=None).splitlines()


def test_forward_move_to_from_the_current_state(mycobot):
    task = current_state_task(mycobot, "forward")
    move = stages.MoveTo("move to ready", JointInterpolationPlanner())
    move.group = "arm"
    move.setGoal("ready")
    task.add(move)
    assert task.plan()
    assert task.numSolutions() == 1
    solution = task.solutions[0]
    end = solution.end.scene.current_state
    assert np.allclose(end.group_positions("arm"), list(mycobot.named_state("ready", "arm").values()))
    assert solution.cost == pytest.approx(2 * 1.5708, abs=1e-9)  # path length: two joints by 1.5708
    assert _lines(task) == [
        "  1  - ←   1 →   -  1 / forward",
        "    1  - ←   1 →   -  0 / current",
        "    -  0 →   1 →   -  1 / move to ready",
    ]
    assert assert_solution_valid(solution) == 1


def test_backward_propagation_plans_into_a_fixed_goal(mycobot):
    task = Task("backward", mycobot)
    move = stages.MoveTo("come from ready", JointInterpolationPlanner())
    move.group = "arm"
    move.setGoal("ready")
    task.add(move)
    task.add(stages.FixedState("goal", scene_at(mycobot, "home")))
    assert task.plan()
    lines = _lines(task)
    assert lines[1] == "    1  - ←   1 ←   0  - / come from ready"  # a backward propagator: ← ←
    solution = task.solutions[0]
    sub = solution.sub_trajectories()[0]
    ready = list(mycobot.named_state("ready", "arm").values())
    assert np.allclose(sub.trajectory.positions[0], ready)
    assert np.allclose(sub.trajectory.positions[-1], 0.0)
    assert np.allclose(solution.start.scene.current_state.group_positions("arm"), ready)
    assert_solution_valid(solution)


def test_connect_plans_between_two_generators(mycobot):
    task = Task("connect", mycobot)
    task.add(stages.FixedState("start", scene_at(mycobot, "ready")))
    task.add(stages.Connect("connect", [("arm", JointInterpolationPlanner())]))
    task.add(stages.FixedState("goal", scene_at(mycobot, "home", link1_to_link2=0.5)))
    assert task.plan()
    assert _lines(task)[2] == "    -  1 →   1 ←   1  - / connect"  # a connector: → ←
    solution = task.solutions[0]
    assert len(solution.sub_trajectories()) == 3  # spawn, connect, spawn
    chain_is_continuous(solution)
    assert_solution_valid(solution)


def test_connect_ignores_pairs_with_different_objects(mycobot):
    goal = scene_at(mycobot, "home")
    goal.add_object(CollisionObject.box("box", [0.05, 0.05, 0.05], make_pose([0.3, 0.3, 0.3])))
    task = Task("incompatible", mycobot)
    task.add(stages.FixedState("start", scene_at(mycobot, "ready")))
    connect = stages.Connect("connect", [("arm", JointInterpolationPlanner())])
    task.add(connect)
    task.add(stages.FixedState("goal", goal))
    result = task.plan()
    assert not result
    assert connect.numFailures() == 0 and not connect.solutions  # nothing was even attempted


def _flange(solution):
    return solution.end.scene.current_state.frame_pose("link6_flange")


def _relative_task(model, direction, **props) -> tuple[Task, Stage]:
    task = Task("relative", model, scene_at(model, "ready"))
    task.add(stages.CurrentState("current"))
    move = stages.MoveRelative("move", CartesianPath())
    move.group = "arm"
    move.setDirection(direction)
    for key, value in props.items():
        move.properties[key] = value
    task.add(move)
    return task, move


def test_move_relative_translates_and_rotates_the_tip(mycobot):
    start = scene_at(mycobot, "ready").current_state.frame_pose("link6_flange")
    task, _ = _relative_task(mycobot, Vector3Stamped("base_link", [0.05, 0.0, 0.0]))
    assert task.plan()
    end = _flange(task.solutions[0])
    assert np.allclose(end[:3, 3] - start[:3, 3], [0.05, 0.0, 0.0], atol=1e-5)
    assert np.allclose(end[:3, :3], start[:3, :3], atol=1e-5)
    assert_solution_valid(task.solutions[0])

    task, _ = _relative_task(mycobot, TwistStamped("base_link", angular=[0.0, 0.0, -math.pi / 10]))
    assert task.plan()
    end = _flange(task.solutions[0])
    assert np.allclose(end[:3, 3], start[:3, 3], atol=1e-5)  # rotation about the tip's origin
    rz = end[:3, :3] @ start[:3, :3].T
    assert math.atan2(rz[1, 0], rz[0, 0]) == pytest.approx(-math.pi / 10, abs=1e-5)


def test_move_relative_max_distance_scales_the_direction(mycobot):
    start = scene_at(mycobot, "ready").current_state.frame_pose("link6_flange")
    task, _ = _relative_task(mycobot, Vector3Stamped("base_link", [0.0, 0.0, 7.0]), max_distance=0.02)
    assert task.plan()
    assert _flange(task.solutions[0])[2, 3] - start[2, 3] == pytest.approx(0.02, abs=1e-5)


@pytest.mark.parametrize("min_distance,succeeds,comment", [
    (0.01, True, ""),
    (-1.0, False, "failed to move full distance"),
    (0.9, False, "min_distance not reached"),
])
def test_move_relative_min_distance(mycobot, min_distance, succeeds, comment):
    # 1 m straight up is out of reach: the Cartesian path stops part-way.
    task, move = _relative_task(mycobot, Vector3Stamped("base_link", [0.0, 0.0, 1.0]),
                                min_distance=min_distance, max_distance=1.0)
    assert bool(task.plan()) == succeeds
    if succeeds:
        achieved = _flange(task.solutions[0])[2, 3] - scene_at(mycobot).current_state.frame_pose("link6_flange")[2, 3]
        assert min_distance <= achieved < 1.0
        assert_solution_valid(task.solutions[0])
    else:
        assert move.numFailures() == 1
        assert comment in move.failures[0].comment
        assert comment in task.explainFailure(stream=None)


def test_move_relative_backward_ends_at_the_generated_state(mycobot):
    goal = scene_at(mycobot, "ready")
    task = Task("approach", mycobot)
    approach = stages.MoveRelative("approach", CartesianPath())
    approach.group = "arm"
    approach.setDirection(Vector3Stamped("link6_flange", [0.0, 0.0, 1.0]))
    approach.setMinMaxDistance(0.01, 0.03)
    task.add(approach)
    task.add(stages.FixedState("grasp", goal))
    assert task.plan()
    solution = task.solutions[0]
    target = goal.current_state.frame_pose("link6_flange")
    begin = solution.start.scene.current_state.frame_pose("link6_flange")
    # the approach starts 3 cm back along the flange's z and moves forward onto the target
    assert np.allclose(target[:3, 3] - begin[:3, 3], 0.03 * target[:3, 2], atol=1e-5)
    assert_solution_valid(solution)


def test_move_relative_joint_offsets(mycobot):
    task = Task("offsets", mycobot, scene_at(mycobot, "ready"))
    task.add(stages.CurrentState("current"))
    move = stages.MoveRelative("turn", JointInterpolationPlanner())
    move.group = "arm"
    move.setDirection({"link1_to_link2": 0.3, "link4_to_link5": -0.2})
    task.add(move)
    assert task.plan()
    end = task.solutions[0].end.scene.current_state
    assert end.joint_position("link1_to_link2") == pytest.approx(0.3)
    assert end.joint_position("link4_to_link5") == pytest.approx(1.5708 - 0.2)
    assert_solution_valid(task.solutions[0])


def test_move_to_pose_and_point_goals(mycobot):
    scene = scene_at(mycobot, "ready")
    reached = scene_at(mycobot, "ready", link1_to_link2=0.2, link2_to_link3=-0.1).current_state
    pose = reached.frame_pose("link6_flange")
    task = Task("pose", mycobot, scene)
    task.add(stages.CurrentState("current"))
    move = stages.MoveTo("to pose", JointInterpolationPlanner())
    move.group = "arm"
    move.setGoal(PoseStamped("world", pose))
    task.add(move)
    assert task.plan()
    assert np.allclose(_flange(task.solutions[0]), pose, atol=1e-4)

    start_pose = scene.current_state.frame_pose("link6_flange")
    point = start_pose[:3, 3] + [0.0, 0.02, -0.01]
    move.setGoal(PointStamped("base_link", point))
    assert task.plan()
    end = _flange(task.solutions[0])
    assert np.allclose(end[:3, 3], point, atol=1e-4)
    assert np.allclose(end[:3, :3], start_pose[:3, :3], atol=1e-4)  # orientation kept
    assert_solution_valid(task.solutions[0])


def test_modify_planning_scene_forward_and_inverted_backward(mycobot):
    scene = scene_at(mycobot, "ready")
    flange = scene.current_state.frame_pose("link6_flange")
    scene.add_object(CollisionObject.box("object", [0.01, 0.01, 0.01], flange @ make_pose([0, 0, 0.08])))
    forward = Task("attach", mycobot, scene)
    forward.add(stages.CurrentState("current"))
    attach = stages.ModifyPlanningScene("attach object")
    attach.attachObject("object", "link6_flange")
    attach.allowCollisions("object", "gripper", True)
    forward.add(attach)
    assert forward.plan()
    end = forward.solutions[0].end.scene
    assert end.attached_object_ids() == ["object"] and end.world_object_ids() == []
    assert end.acm.is_allowed("object", "gripper_left1")

    # backward: the same stage before a generator applies the inverse change to reach its start
    backward = Task("attach backward", mycobot)
    attach_b = stages.ModifyPlanningScene("attach object")
    attach_b.attachObject("object", "link6_flange")
    attach_b.allowCollisions("object", "gripper", True)
    backward.add(attach_b)
    backward.add(stages.FixedState("holding", end))
    assert backward.plan()
    start = backward.solutions[0].start.scene
    assert start.world_object_ids() == ["object"] and start.attached_object_ids() == []
    assert not start.acm.is_allowed("object", "gripper_left1")
    assert np.allclose(start.frame_pose("object"), scene.frame_pose("object"), atol=1e-9)


def test_modify_planning_scene_reports_a_new_collision(mycobot):
    task = current_state_task(mycobot, "add")
    modify = stages.ModifyPlanningScene("add box on the arm")
    modify.addObject(CollisionObject.box("box", [0.1, 0.1, 0.1], make_pose([0.0, 0.0, 0.2])))
    task.add(modify)
    assert not task.plan()
    assert "colliding with" in modify.failures[0].comment
    assert "box" in modify.failures[0].comment


def _ik_task(model, max_solutions=8, cost=None, target=None) -> tuple[Task, Stage]:
    scene = scene_at(model, "ready")
    if target is None:
        target = scene_at(model, "ready", link1_to_link2=0.4, link2_to_link3=-0.3).current_state.frame_pose("link6_flange")
    task = Task("ik", model, seed=3)
    ik = stages.ComputeIK("IK", stages.FixedState("initial state", scene))
    ik.group = "arm"
    ik.setTargetPose(PoseStamped("world", target))
    ik.setMaxIKSolutions(max_solutions)
    ik.setTimeout(0.5)
    if cost is not None:
        ik.setCostTerm(cost)
    task.add(ik)
    return task, ik


def test_compute_ik_spawns_distinct_solutions_sorted_by_cost(mycobot):
    task, ik = _ik_task(mycobot)
    target = scene_at(mycobot, "ready", link1_to_link2=0.4, link2_to_link3=-0.3).current_state.frame_pose("link6_flange")
    assert task.plan()
    solutions = task.solutions
    assert len(solutions) >= 2
    costs = [s.cost for s in solutions]
    assert costs == sorted(costs)
    positions = [s.end.scene.current_state.group_positions("arm") for s in solutions]
    for i, p in enumerate(positions):
        assert np.allclose(solutions[i].end.scene.current_state.frame_pose("link6_flange"), target, atol=1e-4)
        assert solutions[i].end.scene.is_state_valid()
        # default cost: joint distance to the current ('ready') state
        assert solutions[i].cost == pytest.approx(np.sum(np.abs(p - scene_at(mycobot).current_state.group_positions("arm"))))
        for q in positions[i + 1:]:
            assert np.sum(np.abs(p - q)) >= 0.1
    for failure in ik.failures:
        assert failure.comment.startswith("Collision between '")


def test_compute_ik_max_solutions_one(mycobot):
    task, _ = _ik_task(mycobot, max_solutions=1)
    assert task.plan() and task.numSolutions() == 1


def test_compute_ik_with_an_ik_frame_offset(mycobot):
    tcp = make_pose([0.0, 0.0, 0.096], rpy=[1.5708, 0.0, 0.0])
    state = scene_at(mycobot, "ready", link1_to_link2=0.3).current_state
    target = state.frame_pose("link6_flange") @ tcp
    task, ik = _ik_task(mycobot, max_solutions=2, target=target)
    ik.setIKFrame(tcp, "link6_flange")
    assert task.plan()
    for solution in task.solutions:
        assert np.allclose(solution.end.scene.current_state.frame_pose("link6_flange") @ tcp, target, atol=1e-4)


def test_compute_ik_unreachable_target_is_explained(mycobot):
    task, ik = _ik_task(mycobot, target=make_pose([1.0, 1.0, 1.0]))
    ik.setTimeout(0.05)
    assert not task.plan()
    assert ik.failures[0].comment.endswith("no IK found")
    assert "IK (0/1)" in task.explainFailure(stream=None)


def test_generate_pose_feeds_compute_ik_and_connect(mycobot):
    scene = scene_at(mycobot, "ready")
    target = scene_at(mycobot, "ready", link1_to_link2=0.25).current_state.frame_pose("link6_flange")
    task = Task("reach", mycobot, scene, seed=1)
    current = stages.CurrentState("current")
    task.add(current)
    task.add(stages.Connect("connect", [("arm", JointInterpolationPlanner())]))
    generator = stages.GeneratePose("pose")
    generator.setPose(PoseStamped("world", target))
    generator.setMonitoredStage(current)
    ik = stages.ComputeIK("pose IK", generator)
    ik.group = "arm"
    ik.setMaxIKSolutions(2)
    ik.properties.configureInitFrom(Stage.INTERFACE, ["target_pose"])
    task.add(ik)
    assert task.plan()
    assert np.allclose(_flange(task.solutions[0]), target, atol=1e-4)
    assert_solution_valid(task.solutions[0])
    chain_is_continuous(task.solutions[0])


def test_predicate_filter_turns_rejected_solutions_into_failures(mycobot):
    def build(limit):
        task = current_state_task(mycobot, "filter")
        move = stages.MoveTo("move", JointInterpolationPlanner())
        move.group = "arm"
        move.setGoal("ready")
        task.add(stages.PredicateFilter(
            "short moves only", move, lambda s: (s.cost < limit, f"path length {s.cost:.2f} vs limit {limit}")))
        return task

    task = build(10.0)
    assert task.plan()
    strict = build(1.0)
    assert not strict.plan()
    assert strict["short moves only"].failures[0].comment == "path length 3.14 vs limit 1.0"
    assert "short moves only (0/1): path length 3.14" in strict.explainFailure(stream=None)


def test_cost_terms(mycobot):
    task, move = _relative_task(mycobot, Vector3Stamped("base_link", [0.05, 0.0, 0.0]))
    move.setCostTerm(LinkMotion("link6_flange"))
    assert task.plan()
    solution = task.solutions[0]
    sub = solution.sub_trajectories()[1]
    assert solution.cost == pytest.approx(0.05, rel=0.02)  # a straight Cartesian line
    assert TrajectoryDuration()(sub) == pytest.approx(sub.trajectory.duration)
    assert PathLength()(sub) == pytest.approx(np.abs(np.diff(sub.trajectory.positions, axis=0)).sum())
    assert PathLength({"link1_to_link2": 2.0})(sub) == pytest.approx(
        2.0 * np.abs(np.diff(sub.trajectory.positions[:, 0])).sum())
    assert Constant(4.0)(sub) == 4.0

    move.setCostTerm(lambda s: (1.5, "custom"))
    assert task.plan()
    assert task.solutions[0].cost == pytest.approx(1.5)
    assert task["move"].solutions[0].comment.endswith("custom")

    move.setCostTerm(lambda s: math.inf)  # an infinite cost makes the solution a failure
    assert not task.plan()


def test_clearance_cost_names_the_closest_bodies(mycobot):
    scene = scene_at(mycobot, "ready")
    tip = scene.current_state.frame_pose("link6_flange")
    scene.add_object(CollisionObject.sphere("ball", 0.02, tip @ make_pose([0.1, 0.0, 0.0])))
    task = Task("clear", mycobot)
    fixed = stages.FixedState("here", scene)
    ik = stages.ComputeIK("IK", fixed)
    ik.group = "arm"
    ik.setTargetPose(PoseStamped("world", tip))
    ik.setCostTerm(Clearance())
    task.add(ik)
    assert task.plan()
    best = ik.solutions[0]
    report = best.end.scene.distance(include_self=False, links="arm")
    assert best.cost == pytest.approx(1.0 / (report.min_distance + 1e-5))
    assert task.solutions[0].cost == pytest.approx(best.cost)
    assert best.comment == f"Clearance: distance {report.min_distance} between 'ball' and '{report.body_b}'"


def test_current_state_uses_the_scene_provider(mycobot):
    calls = []

    def provider(timeout):
        calls.append(timeout)
        return scene_at(mycobot, "ready")

    task = Task("provided", mycobot)
    task.setSceneProvider(provider)
    current = stages.CurrentState("current")
    current.setTimeout(2.0)
    task.add(current)
    assert task.plan()
    assert calls == [2.0]
    assert np.allclose(task.solutions[0].start.scene.current_state.group_positions("arm"),
                       list(mycobot.named_state("ready", "arm").values()))

    def broken(timeout):
        raise TimeoutError("planning_server did not answer in 2 s")

    task.setSceneProvider(broken)
    assert not task.plan()
    assert "failed to acquire current PlanningScene: planning_server did not answer" in current.failures[0].comment


def test_fixed_state_in_collision_fails_unless_ignored(mycobot):
    scene = scene_at(mycobot, "home")
    scene.add_object(CollisionObject.box("box", [0.1, 0.1, 0.1], make_pose([0.0, 0.0, 0.2])))
    task = Task("fixed", mycobot)
    fixed = stages.FixedState("colliding", scene)
    task.add(fixed)
    assert not task.plan()
    assert fixed.failures[0].comment.startswith("in collision: contact between 'box'")
    fixed.setIgnoreCollisions(True)
    assert task.plan()


def test_pipeline_planner_ompl_and_ptp(mycobot):
    for planner in (PipelinePlanner("ompl", "RRTConnectkConfigDefault"), PipelinePlanner({"pilz_industrial_motion_planner": "PTP"})):
        task = Task("pipeline", mycobot, scene_at(mycobot, "home"), seed=4)
        task.add(stages.CurrentState("current"))
        move = stages.MoveTo("move", planner)
        move.group = "arm"
        move.setGoal({"link1_to_link2": 0.5, "link3_to_link4": 1.0})
        task.add(move)
        assert task.plan(), task.explainFailure(stream=None)
        end = task.solutions[0].end.scene.current_state
        assert end.joint_position("link1_to_link2") == pytest.approx(0.5, abs=1e-4)
        assert_solution_valid(task.solutions[0])


def test_print_state_writes_to_a_stream(mycobot):
    task = current_state_task(mycobot, "stream")
    task.plan()
    out = io.StringIO()
    text = task.printState(out)
    assert out.getvalue() == text and "current" in text


def test_compute_ik_derives_group_and_link_from_the_end_effector(mycobot):
    scene = scene_at(mycobot, "ready")
    target = scene_at(mycobot, "ready", link1_to_link2=-0.3).current_state.frame_pose("link6_flange")
    task = Task("eef only", mycobot, seed=1)
    ik = stages.ComputeIK("IK", stages.FixedState("s", scene))
    ik.eef = "gripper"  # parent group 'arm', parent link 'link6_flange'
    ik.setTargetPose(PoseStamped("world", target))
    task.add(ik)
    assert task.plan()
    assert np.allclose(task.solutions[0].end.scene.current_state.frame_pose("link6_flange"), target, atol=1e-4)


@pytest.mark.parametrize("size,flip,expected", [((0.02, 0.02, 0.05), False, 4), ((0.02, 0.03, 0.05), False, 2),
                                                ((0.02, 0.03, 0.05), True, 4)])
def test_place_pose_rotations_follow_the_object_shape(mycobot, size, flip, expected):
    holding = scene_at(mycobot, "ready")
    tip = holding.current_state.frame_pose("link6_flange")
    holding.add_object(CollisionObject.box("part", list(size), tip @ make_pose([0, 0, 0.1])))
    holding.attach_object("part", "link6_flange")
    task = Task("place", mycobot)
    fixed = stages.FixedState("holding", holding)
    task.add(fixed)
    task.add(stages.Connect("connect", [("arm", JointInterpolationPlanner())]))
    generator = stages.GeneratePlacePose("place pose")
    generator.setObject("part")
    generator.setPose(PoseStamped("base_link", make_pose([0.2, 0.0, 0.1])))
    generator.allow_z_flip = flip
    generator.setMonitoredStage(fixed)
    ik = stages.ComputeIK("place IK", generator)
    ik.group = "arm"
    ik.setTimeout(0.01)
    ik.properties.configureInitFrom(Stage.INTERFACE, ["target_pose", "ik_frame"])
    task.add(ik)
    task.plan()
    assert len(generator.solutions) == expected
    poses = [s.end.properties["target_pose"].pose for s in generator.solutions]
    assert all(np.allclose(p[:3, 3], [0.2, 0.0, 0.1]) for p in poses)
    assert all(s.end.properties["ik_frame"] == PoseStamped("part", np.eye(4)) for s in generator.solutions)
    # every placed pose puts the part's frame at the target: check the IK solutions found
    for solution in ik.solutions:
        state = solution.end.scene
        placed = state.frame_pose("part")
        assert np.allclose(placed[:3, 3], [0.2, 0.0, 0.1], atol=1e-4)


def test_place_pose_needs_an_attached_object(mycobot):
    scene = scene_at(mycobot, "ready")
    scene.add_object(CollisionObject.box("part", [0.02, 0.02, 0.02], make_pose([0.2, 0.0, 0.0])))
    task = Task("not held", mycobot)
    fixed = stages.FixedState("s", scene)
    task.add(fixed, stages.Connect("c", [("arm", JointInterpolationPlanner())]))
    generator = stages.GeneratePlacePose("place pose", fixed)
    generator.setObject("part")
    generator.setPose(PoseStamped("world", make_pose([0.2, 0.0, 0.1])))
    ik = stages.ComputeIK("IK", generator)
    ik.group = "arm"
    ik.properties.configureInitFrom(Stage.INTERFACE, ["target_pose"])
    task.add(ik)
    assert not task.plan()
    assert generator.failures[0].comment == "frame 'part' is not attached to the robot"


def test_compute_ik_ignore_collisions_keeps_colliding_solutions(mycobot):
    from mycobot_planning.demos.mtc_demos import ik_clearance_cost_scene

    target = make_pose([-0.183, 0.0175, 0.15], rpy=[math.pi / 4, 0.0, 0.0])

    def run(ignore):
        task = Task("ik", mycobot, seed=0)
        fixed = stages.FixedState("initial state", ik_clearance_cost_scene(mycobot))
        ik = stages.ComputeIK("IK", fixed)
        ik.group = "arm"
        ik.setTargetPose(PoseStamped("", target))
        ik.setMaxIKSolutions(10)
        ik.setTimeout(1.0)  # the group's default IK timeout (0.05 s) may stop before all branches are found
        ik.setIgnoreCollisions(ignore)
        task.add(ik)
        task.plan()
        return ik

    checked, ignored = run(False), run(True)
    assert len(ignored.solutions) == len(checked.solutions) + checked.numFailures()
    assert ignored.numFailures() == 0
    assert any(not s.end.scene.is_state_valid() for s in ignored.solutions)


def test_pipeline_planner_industrial_lin_to_a_pose(mycobot):
    scene = scene_at(mycobot, "ready")
    start = scene.current_state.frame_pose("link6_flange")
    goal = start.copy()
    goal[:3, 3] += [0.02, -0.03, 0.01]
    task = Task("lin", mycobot, scene)
    task.add(stages.CurrentState("current"))
    planner = PipelinePlanner({"pilz_industrial_motion_planner": "LIN"})
    planner.max_velocity_scaling_factor = 0.05  # scales the Cartesian limits of LIN
    planner.max_acceleration_scaling_factor = 0.03
    move = stages.MoveTo("line", planner)
    move.group = "arm"
    move.setGoal(PoseStamped("world", goal))
    task.add(move)
    assert task.plan(), task.explainFailure(stream=None)
    assert np.allclose(_flange(task.solutions[0]), goal, atol=1e-3)
    assert_solution_valid(task.solutions[0])


def test_spread_order_visits_every_target_once_and_covers_the_range_early():
    from mycobot_planning.task.stages.compute_ik import spread_order

    for n in (1, 2, 3, 7, 24, 33):
        order = spread_order(n)
        assert sorted(order) == list(range(n))
    assert spread_order(24)[:4] == [0, 16, 8, 4]
    # Any run of 6 neighbouring targets out of 24 (e.g. the reachable grasp angles) is hit
    # within the first 8 tries.
    order = spread_order(24)
    for first in range(24 - 6 + 1):
        assert min(order.index(i) for i in range(first, first + 6)) < 8


def test_compute_ik_gives_up_on_an_unreachable_target_after_the_first_attempts(mycobot, monkeypatch):
    from mycobot_planning.core.kinematics.ik_solver import IKSolver
    from mycobot_planning.task.stages.compute_ik import UNREACHABLE_ATTEMPTS

    task, ik = _ik_task(mycobot, target=make_pose([1.0, 1.0, 1.0]))
    ik.setTimeout(10.0)  # the attempt count ends the search, not the time
    descents = []
    original = IKSolver._descend_batch

    def counting(self, base, starts, *args):
        descents.append(len(starts))
        return original(self, base, starts, *args)

    monkeypatch.setattr(IKSolver, "_descend_batch", counting)
    assert not task.plan()
    assert 1 + sum(descents) == UNREACHABLE_ATTEMPTS  # the first start runs alone
    assert ik.failures[0].comment.endswith("no IK found")
