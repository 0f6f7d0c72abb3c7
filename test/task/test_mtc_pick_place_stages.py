"""MTC's pick/place containers (SimpleGrasp, SimpleUnGrasp, Pick, Place) and FixCollisionObjects,
as the bindings export them: MTC's demo/scripts/pickplace.py rebuilt in-process on the Panda, the
stage trees and property flow, bad input, and fixing objects that overlap the robot."""
from __future__ import annotations

import math

import numpy as np
import pytest

from interfaces_py.msgs import CollisionObject
from mycobot_planning.core import PlanningScene, RobotModel
from mycobot_planning.core.transforms import make_pose
from mycobot_planning.task import (InitStageException, PoseStamped, PropertyTypeError, Task, TaskError, TwistStamped,
                                   Vector3Stamped, core, stages)
from task_helpers import assert_solution_valid, panda_start_scene, replay_task_solution

ARM, EEF, OBJECT = "panda_arm", "hand", "object"
OBJECT_POSE = make_pose([0.30702, 0.0, 0.285])
PLACE_POSE = make_pose([-0.2, -0.6, 0.0])  # the demo's: objectPose with x, y, z replaced
TCP = make_pose([0.0, 0.0, 0.1034], quat_xyzw=[1.0, 0.0, 0.0, 0.0])  # between the fingers, grasp from top


@pytest.fixture(scope="module")
def panda() -> RobotModel:
    return RobotModel.panda()


def demo_scene(model: RobotModel) -> PlanningScene:
    """The demo's start: the box 'object' in front of the Panda, arm 'ready', hand 'open'."""
    scene = panda_start_scene(model, ARM, EEF)
    scene.add_object(CollisionObject.box(OBJECT, [0.1, 0.05, 0.03], OBJECT_POSE, frame_id="world"))
    return scene


def build_demo(model: RobotModel, seed: int = 1) -> Task:
    """MTC's demo/scripts/pickplace.py, line by line (less the second Connect's path constraint)."""
    task = Task("pick + place", model, demo_scene(model), seed=seed)
    task.add(stages.CurrentState("current"))
    pipeline = core.PipelinePlanner("ompl", "RRTConnectkConfigDefault")
    planners = [(ARM, pipeline)]
    task.add(stages.Connect("connect", planners))

    grasp_generator = stages.GenerateGraspPose("Generate Grasp Pose")
    grasp_generator.angle_delta = math.pi / 2
    grasp_generator.pregrasp = "open"
    grasp_generator.grasp = "close"
    grasp_generator.setMonitoredStage(task["current"])

    simple_grasp = stages.SimpleGrasp(grasp_generator, "Grasp")
    simple_grasp.setIKFrame(PoseStamped("panda_hand", TCP))

    pick = stages.Pick(simple_grasp, "Pick")
    pick.eef = EEF
    pick.object = OBJECT
    pick.setApproachMotion(TwistStamped("world", [0.0, 0.0, -1.0]), 0.03, 0.1)
    pick.cartesian_solver.max_velocity_scaling_factor = 0.1
    pick.setLiftMotion(TwistStamped("panda_hand", [0.0, 0.0, -1.0]), 0.03, 0.1)
    task.add(pick)

    task.add(stages.Connect("connect", planners))

    place_generator = stages.GeneratePlacePose("Generate Place Pose")
    place_generator.setMonitoredStage(task["Pick"])
    place_generator.object = OBJECT
    place_generator.pose = PoseStamped("world", PLACE_POSE)

    simple_ungrasp = stages.SimpleUnGrasp(place_generator, "UnGrasp")

    place = stages.Place(simple_ungrasp, "Place")
    place.eef = EEF
    place.object = OBJECT
    place.eef_frame = "panda_link8"
    place.setRetractMotion(TwistStamped("world", [0.0, 0.0, 1.0]), 0.03, 0.1)
    place.setPlaceMotion(TwistStamped("panda_hand", [0.0, 0.0, 1.0]), 0.03, 0.1)
    task.add(place)
    return task


def names(container) -> list[str]:
    return [child.name for child in container.children]


# ---------------------------------------------------------------------------- the demo
@pytest.fixture(scope="module")
def planned_demo(panda):
    task = build_demo(panda)
    result = task.plan()
    assert result, task.explainFailure(stream=None)
    return task


def test_pickplace_demo_plans_valid_solutions(panda, planned_demo):
    task = planned_demo
    assert len(task.solutions) >= 1
    for solution in task.solutions:
        # approach, close, lift, connect, place, open, retract + the first connect: 8 motions
        assert assert_solution_valid(solution) == 8
        final, moved = replay_task_solution(panda, task.to_msg(solution))
        assert moved == 8
        # placed: back in the world, at the place pose, upright; the hand open and clear of it
        assert final.world_object_ids() == [OBJECT] and final.attached_object_ids() == []
        pose = final.frame_pose(OBJECT)
        assert np.allclose(pose[:3, 3], PLACE_POSE[:3, 3], atol=1e-3)
        assert pose[:3, 2] @ np.array([0.0, 0.0, 1.0]) > 0.999
        assert final.current_state.positions[panda.variable_index("panda_finger_joint1")] == pytest.approx(0.035)
        assert not final.acm.is_allowed(OBJECT, "panda_leftfinger")
        assert final.is_state_valid()


def test_pickplace_demo_carries_the_object_attached_between_grasp_and_release(planned_demo):
    subs = planned_demo.solutions[0].sub_trajectories()
    path = [sub.creator.name for sub in subs]
    attach, detach = path.index("attach object"), path.index("detach object")
    assert path[:attach + 1] == ["current", "connect", "approach object", "compute ik", "allow object collision", "close gripper",
                                 "attach object"]
    assert path[attach + 1:] == ["lift object", "connect", "place object", "compute ik", "detach object",
                                 "open gripper", "forbid object collision", "retract"]
    for k, sub in enumerate(subs):
        scene = sub.end.scene
        carried = attach <= k < detach
        assert scene.is_attached(OBJECT) == carried, f"{sub.creator.name}"
        if carried:
            assert scene.get_attached_object(OBJECT).link_name == "panda_link8"
        # the fingers may touch the object from 'allow' to 'forbid object collision'
        allowed = path.index("allow object collision") <= k < path.index("forbid object collision")
        assert scene.acm.is_allowed(OBJECT, "panda_rightfinger") == allowed, f"{sub.creator.name}"
    grasp_state = subs[path.index("close gripper")].end.scene.current_state
    assert grasp_state.positions[grasp_state.model.variable_index("panda_finger_joint1")] == pytest.approx(0.0)


def test_pickplace_demo_with_its_upright_path_constraint(panda):
    """The demo's second Connect keeps the object upright (MTC's path_constraints)."""
    task = build_demo(panda)
    transport = task.stages.children[3]
    assert "path_constraints" in transport.properties
    transport.path_constraints = {  # moveit_msgs/Constraints, field by field as in pickplace.py
        "name": "object:upright",
        "orientation_constraints": [{
            "header": {"frame_id": "world"}, "link_name": OBJECT, "orientation": {"x": 0, "y": 0, "z": 0, "w": 1},
            "absolute_x_axis_tolerance": 0.1, "absolute_y_axis_tolerance": 0.1,
            "absolute_z_axis_tolerance": math.pi, "parameterization": 1, "weight": 1.0}]}
    assert task.plan(max_solutions=1), task.explainFailure(stream=None)
    solution = task.solutions[0]
    assert_solution_valid(solution)
    moves = [sub for sub in solution.sub_trajectories() if sub.creator is transport]
    assert moves and moves[0].trajectory is not None
    scene = moves[0].start.scene
    indices = panda.group(moves[0].group).variable_indices
    for positions in moves[0].trajectory.positions:
        state = scene.current_state.copy()
        values = state.positions.copy()
        values[indices] = positions
        state.set_positions(values)
        assert scene.frame_pose(OBJECT, state)[2, 2] > math.cos(0.15)  # object z axis near world z


def test_pickplace_demo_stage_trees_are_mtcs(planned_demo):
    task = planned_demo
    assert names(task.stages) == ["current", "connect", "Pick", "connect", "Place"]
    assert names(task["Pick"]) == ["approach object", "Grasp", "lift object"]
    assert names(task["Pick/Grasp"]) == ["compute ik", "allow object collision", "close gripper", "attach object"]
    assert names(task["Place"]) == ["place object", "UnGrasp", "retract"]
    # MTC inserts each ungrasp step right after the IK: the reverse of the grasp's order
    assert names(task["Place/UnGrasp"]) == ["compute ik", "detach object", "open gripper", "forbid object collision"]
    assert task["Pick/Grasp/compute ik"].wrapped.name == "Generate Grasp Pose"
    for stage, marker_ns in (("Pick/approach object", "approach"), ("Pick/lift object", "lift"),
                             ("Place/place object", "place"), ("Place/retract", "retract")):
        assert task[stage].properties["marker_ns"] == marker_ns


def test_properties_flow_from_pick_and_place_into_their_stages(planned_demo):
    task = planned_demo
    pick, place = task["Pick"], task["Place"]
    for container in (pick, place):
        assert container.properties["eef_group"] == "hand"
        assert container.properties["eef_parent_group"] == ARM
    # the motions plan the eef's parent group; for Pick (no eef_frame) the group's tip moves
    for stage in ("approach object", "lift object"):
        assert pick[stage].properties["group"] == ARM
        assert pick[stage].properties["ik_frame"] is None
        assert pick[stage].planner is pick.cartesian_solver
    assert pick.cartesian_solver.properties["max_velocity_scaling_factor"] == 0.1
    for stage in ("place object", "retract"):
        assert place[stage].properties["group"] == ARM
        assert place[stage].properties["ik_frame"] == PoseStamped("panda_link8")
        assert place[stage].planner is place.cartesian_solver
    assert pick.cartesian_solver is not place.cartesian_solver
    # eef and object reach the grasp stage and, through it, the IK, the generator and the changes
    for path in ("Pick/Grasp", "Pick/Grasp/compute ik", "Pick/Grasp/Generate Grasp Pose",
                 "Pick/Grasp/allow object collision", "Pick/Grasp/attach object",
                 "Place/UnGrasp", "Place/UnGrasp/compute ik", "Place/UnGrasp/detach object"):
        assert task[path].properties["eef"] == EEF, path
        assert task[path].properties["object"] == OBJECT, path
    # the ik frame set on SimpleGrasp is the IK's; SimpleUnGrasp's comes from the place poses
    assert task["Pick/Grasp/compute ik"].properties["ik_frame"] == PoseStamped("panda_hand", TCP)
    assert task["Place/UnGrasp"].properties["ik_frame"] is None
    assert task["Place/UnGrasp/compute ik"].properties["ik_frame"] == PoseStamped(OBJECT)
    # the gripper moves the eef's group to the postures the grasp generator put in the states
    assert task["Pick/Grasp/close gripper"].properties["group"] == "hand"
    assert task["Pick/Grasp/close gripper"].properties["goal"] == "close"
    assert task["Place/UnGrasp/open gripper"].properties["group"] == "hand"
    assert task["Place/UnGrasp/open gripper"].properties["goal"] == "open"
    # ... and every step forwards them, so the place side still has them
    for stage in ("Pick/lift object", "Place/place object", "Place/retract"):
        assert task[stage].properties["forwarded_properties"] == {"object", "eef", "pregrasp", "grasp"}
    assert task["Pick"].solutions[0].end.properties["pregrasp"] == "open"


def test_postures_set_on_the_container_override_the_generators(panda):
    task = build_demo(panda)
    task["Pick/Grasp"].grasp = {"panda_finger_joint1": 0.02}
    task["Pick/Grasp"].setMaxIKSolutions(2)
    assert task.plan(max_solutions=1)
    assert task["Pick/Grasp/close gripper"].properties["goal"] == {"panda_finger_joint1": 0.02}
    assert task["Pick/Grasp/compute ik"].properties["max_ik_solutions"] == 2
    attached = task["Pick/Grasp/attach object"].solutions[0].end.scene.current_state
    assert attached.positions[panda.variable_index("panda_finger_joint1")] == pytest.approx(0.02)


def test_simple_grasp_alone_with_eef_and_object_set_on_it(panda):
    """Without a Pick: the grasp container needs eef and object itself; MTC's C++ also allows it
    without a generator (the scene changes and the gripper motion only)."""
    task = Task("grasp", panda, demo_scene(panda), seed=2)
    task.add(stages.CurrentState("current"))
    task.add(stages.Connect("connect", [(ARM, core.PipelinePlanner())]))
    generator = stages.GenerateGraspPose("grasps")
    generator.angle_delta = math.pi / 2
    generator.pregrasp, generator.grasp = "open", "close"
    generator.setMonitoredStage(task["current"])
    grasp = stages.SimpleGrasp(generator)
    grasp.setEndEffector(EEF)
    grasp.setObject(OBJECT)
    grasp.setIKFrame("panda_hand")
    assert grasp.ik_frame == PoseStamped("panda_hand")
    grasp.setIKFrame(TCP, "panda_hand")
    task.add(grasp)
    assert grasp.name == "grasp"
    assert task.plan()
    for solution in task.solutions:
        assert_solution_valid(solution)
        assert solution.end.scene.get_attached_object(OBJECT).link_name == "panda_link8"



def test_simple_grasp_without_generator_grasps_a_given_state(panda, planned_demo):
    """MTC's C++ allows no generator: then the container only changes the scene and closes the
    gripper, from whatever state it is given (here a grasp pose IK solution of the demo)."""
    at_grasp = planned_demo["Pick/Grasp/compute ik"].solutions[0].end.scene
    task = Task("grasp here", panda, seed=3)
    task.add(stages.FixedState("at grasp", at_grasp))
    grasp = stages.SimpleGrasp(None, "grasp here")
    grasp.eef, grasp.object, grasp.grasp = EEF, OBJECT, "close"
    task.add(grasp)
    assert names(grasp) == ["allow object collision", "close gripper", "attach object"]
    assert task.plan()
    assert_solution_valid(task.solutions[0])
    assert task.solutions[0].end.scene.get_attached_object(OBJECT).link_name == "panda_link8"
    assert names(stages.SimpleUnGrasp(None)) == ["detach object", "open gripper", "forbid object collision"]
    # the scene changes are ModifyPlanningScene stages, as in MTC's introspection
    change = grasp["attach object"]
    assert isinstance(change, stages.ModifyPlanningScene) and type(change).__name__ == "ModifyPlanningScene"


def test_lift_and_place_motions_take_mtcs_other_forms(panda):
    pick = stages.Pick(stages.SimpleGrasp(pose_generator=stages.GenerateGraspPose()))  # MTC's keywords
    assert pick.name == "pick" and stages.Place(place_generator=stages.SimpleUnGrasp(), name="place").name == "place"
    pick.setLiftMotion({"panda_joint2": -0.1})  # MTC's joint overload: offsets of MoveRelative
    assert pick["lift object"].properties["direction"] == {"panda_joint2": -0.1}
    pick.setLiftMotion(Vector3Stamped("world", [0.0, 0.0, 1.0]), 0.01, 0.05)
    assert pick["lift object"].properties["direction"] == Vector3Stamped("world", [0.0, 0.0, 1.0])
    assert (pick["lift object"].properties["min_distance"], pick["lift object"].properties["max_distance"]) == (0.01, 0.05)
    assert pick.cartesianSolver() is pick.cartesian_solver
    pick.setEndEffector(EEF)
    pick.setObject(OBJECT)
    pick.eef_frame = "panda_hand"
    assert (pick.eef, pick.object, pick.eef_frame) == (EEF, OBJECT, "panda_hand")


# ---------------------------------------------------------------------------- bad input
def _pick_task(model, *, eef=EEF, obj=OBJECT, motions=True) -> Task:
    task = Task("t", model, demo_scene(model))
    task.add(stages.CurrentState("current"))
    generator = stages.GenerateGraspPose("gen")
    generator.pregrasp, generator.grasp = "open", "close"
    generator.setMonitoredStage(task["current"])
    pick = stages.Pick(stages.SimpleGrasp(generator))
    if eef is not None:
        pick.eef = eef
    if obj is not None:
        pick.object = obj
    if motions:
        pick.setApproachMotion(TwistStamped("world", [0.0, 0.0, -1.0]), 0.03, 0.1)
        pick.setLiftMotion(TwistStamped("world", [0.0, 0.0, 1.0]), 0.03, 0.1)
    task.add(pick)
    return task


@pytest.mark.parametrize("kwargs, stage, words", [
    (dict(eef=None), "pick", "property 'eef' is undefined"),
    (dict(eef="gripper"), "pick", "unknown end effector: 'gripper'; known: hand"),
    (dict(obj=None), "grasp", "property 'object' is undefined"),
    (dict(motions=False), "pick", "no motion for 'approach object': call setApproachMotion"),
])
def test_misconfigured_pick_is_reported_at_init(panda, kwargs, stage, words):
    with pytest.raises(InitStageException) as info:
        _pick_task(panda, **kwargs).init()
    assert any(name == stage and words in message for name, message in info.value), str(info.value)
    # reported once, where it can be fixed: not again as the motions' undefined group / direction
    assert not any(message.startswith("property 'direction'") or message.startswith("property 'group'")
                   for _, message in info.value), str(info.value)


def test_bad_arguments_raise_clear_task_errors():
    with pytest.raises(TaskError, match="pose generator must be a Stage, got str"):
        stages.SimpleGrasp("generate grasp pose")
    with pytest.raises(TaskError, match="needs the grasp stage .* got NoneType"):
        stages.Pick(None)
    with pytest.raises(TaskError, match="needs the ungrasp stage"):
        stages.Place(42)
    grasp = stages.SimpleGrasp()
    stages.Pick(grasp)
    with pytest.raises(TaskError, match="already belongs to container 'pick'"):
        stages.Pick(grasp)
    pick = stages.Pick(stages.SimpleGrasp())
    with pytest.raises(PropertyTypeError, match="direction"):
        pick.setApproachMotion("down", 0.03, 0.1)
    with pytest.raises(TaskError, match=r"setApproachMotion\(motion, min_distance, max_distance\) needs both"):
        pick.setApproachMotion(TwistStamped("world", [0.0, 0.0, -1.0]), None, 0.1)
    with pytest.raises(TaskError, match="max_distance must be a number"):
        pick.setLiftMotion(TwistStamped("world", [0.0, 0.0, 1.0]), 0.03, "far")
    with pytest.raises(TaskError, match=r"setLiftMotion\(joints\) takes joint offsets only"):
        pick.setLiftMotion({"panda_joint1": 0.1}, 0.0, 0.1)
    with pytest.raises(AttributeError):
        pick.cartesian_solver = core.CartesianPath()
    with pytest.raises(PropertyTypeError, match="eef"):
        pick.eef = 3
    with pytest.raises(TaskError, match="setIKFrame"):
        grasp.setIKFrame("not a pose", "panda_hand")
    with pytest.raises(PropertyTypeError, match="ik_frame"):
        grasp.setIKFrame(42)


def test_unknown_postures_are_reported_at_init_or_as_failure_comments(panda):
    task = build_demo(panda)
    task["Pick/Grasp"].grasp = "squeeze"  # known at init: checked there
    with pytest.raises(InitStageException, match="close gripper: property 'goal': unknown named state 'squeeze'"):
        task.init()
    task = build_demo(panda)
    task["Pick/Grasp/Generate Grasp Pose"].grasp = "squeeze"  # only in the interface states
    assert not task.plan()
    failures = task["Pick/Grasp/close gripper"].failures
    assert failures and "squeeze" in failures[0].comment


# ---------------------------------------------------------------------------- FixCollisionObjects
def _fix_task(model, scene, fix) -> Task:
    task = Task("fix", model, scene)
    task.add(stages.CurrentState("current"))
    task.add(fix)
    return task


def _mycobot_box_into_link1(model, penetration: float) -> PlanningScene:
    """A 4 cm cube overlapping the myCobot's link1 box (x up to 0.04) by ``penetration`` in x."""
    scene = PlanningScene(model)
    scene.add_object(CollisionObject.box("box", [0.04, 0.04, 0.04], make_pose([0.06 - penetration, -0.01, 0.034]),
                                         frame_id="world"))
    return scene


def test_fix_collision_objects_pushes_a_slightly_penetrating_object_out(mycobot):
    scene = _mycobot_box_into_link1(mycobot, 0.003)
    assert scene.check_collision().pairs() == {frozenset({"box", "link1"})}
    fix = stages.FixCollisionObjects()
    assert fix.name == "fix collisions"
    fix.max_penetration = 0.01
    task = _fix_task(mycobot, scene, fix)
    assert task.plan()
    end = task.solutions[0].end.scene
    assert not end.check_collision().collision
    # along the contact normal (+x, out of link1), by the depth + 1 mm
    assert np.allclose(end.frame_pose("box")[:3, 3], [0.061, -0.01, 0.034], atol=1e-6)
    assert "moved 'box' by 4.0 mm" in fix.solutions[0].comment
    assert task.solutions[0].cost == 0.0
    assert scene.frame_pose("box")[0, 3] == pytest.approx(0.057)  # the start scene is untouched


def test_fix_collision_objects_fails_on_deep_penetration_with_a_comment(mycobot):
    fix = stages.FixCollisionObjects()
    fix.setMaxPenetration(0.01)
    task = _fix_task(mycobot, _mycobot_box_into_link1(mycobot, 0.015), fix)
    assert not task.plan()
    comment = fix.failures[0].comment
    assert "'box' penetrates 'link1' too deeply" in comment and "max_penetration (10.0 mm)" in comment
    assert "fix collisions" in task.explainFailure(stream=None)


def test_fix_collision_objects_on_a_mesh_link_and_with_a_given_direction(panda):
    scene = PlanningScene(panda)
    state = scene.current_state.copy()
    state.set_named("ready", ARM)
    scene.set_current_state(state)
    scene.add_object(CollisionObject.box("box", [0.04, 0.04, 0.04], make_pose([0.08, 0.0, 0.1]), frame_id="world"))
    assert scene.check_collision().collision  # the Panda's link0 is a mesh
    fix = stages.FixCollisionObjects("fix")
    fix.max_penetration = 0.02
    task = _fix_task(panda, scene, fix)
    assert task.plan()
    end = task.solutions[0].end.scene
    assert end.is_state_valid()
    assert 0.0 < end.frame_pose("box")[0, 3] - 0.08 < 0.02  # pushed away from the base, not far

    fix = stages.FixCollisionObjects()
    fix.max_penetration = 0.02
    fix.setDirection([0.0, 0.0, 0.005])  # MTC: each correction moves the object by this vector
    task = _fix_task(panda, scene, fix)
    assert task.plan()
    end = task.solutions[0].end.scene.frame_pose("box")[:3, 3]
    assert end[:2] == pytest.approx([0.08, 0.0]) and end[2] > 0.1


def test_fix_collision_objects_cannot_fix_robot_only_contacts(mycobot):
    scene = PlanningScene(mycobot)
    scene.add_object(CollisionObject.box("tool", [0.03, 0.03, 0.03], make_pose([0.0, 0.0, 0.02]), frame_id="world"))
    scene.attach_object("tool", "link6_flange")  # stays where it is: inside link1, not a touch link
    fix = stages.FixCollisionObjects()
    fix.max_penetration = 0.05
    task = _fix_task(mycobot, scene, fix)
    assert not task.plan()
    assert fix.failures[0].comment == "cannot fix collision between 'tool' and 'link1': no world object to move"


def test_fix_collision_objects_passes_a_free_scene_on_and_works_backward(mycobot):
    fix = stages.FixCollisionObjects()
    fix.max_penetration = 0.01
    task = _fix_task(mycobot, PlanningScene(mycobot), fix)
    assert task.plan() and fix.solutions[0].comment == ""
    backward = stages.FixCollisionObjects()
    backward.max_penetration = 0.01
    task = Task("fix backward", mycobot)
    task.add(backward)
    start = stages.FixedState("start", _mycobot_box_into_link1(mycobot, 0.003))
    start.setIgnoreCollisions(True)
    task.add(start)
    assert task.plan()
    assert not task.solutions[0].start.scene.check_collision().collision


def test_fix_collision_objects_bad_input(mycobot):
    fix = stages.FixCollisionObjects()
    with pytest.raises(InitStageException, match="property 'max_penetration' is undefined"):
        _fix_task(mycobot, PlanningScene(mycobot), fix).init()
    fix = stages.FixCollisionObjects()
    fix.max_penetration = -0.01
    with pytest.raises(InitStageException, match="'max_penetration' must be >= 0"):
        _fix_task(mycobot, PlanningScene(mycobot), fix).init()
    with pytest.raises(PropertyTypeError, match="zero vector"):
        fix.direction = [0.0, 0.0, 0.0]
    with pytest.raises(PropertyTypeError, match="3 finite numbers"):
        fix.setDirection([1.0, 0.0])
    with pytest.raises(PropertyTypeError, match="max_penetration"):
        fix.max_penetration = "deep"
