"""MTC's path_constraints on MoveTo, MoveRelative and Connect, handed to every planner.

The centre piece rebuilds MTC's demo/scripts/constrained.py in-process: a Panda carries a box,
attached to its flange, 0.4 m along y around a sphere in the way, keeping the box's orientation
within 0.1 rad about the world's x and y axes (rotation vector tolerances are about the
constraint frame's axes, as in MoveIt 2 Jazzy). Every trajectory is checked here densely, with
the object's pose computed from the attach link (scipy rotations), and with the core validator.
"""
from __future__ import annotations

import math
import time

import numpy as np
import pytest
from geometry_msgs.msg import Pose, Vector3, Vector3Stamped
from moveit_msgs.msg import CollisionObject as CollisionObjectMsg
from moveit_msgs.msg import Constraints, JointConstraint, OrientationConstraint, PositionConstraint
from scipy.spatial.transform import Rotation
from shape_msgs.msg import SolidPrimitive
from std_msgs.msg import Header

from interfaces_py.msgs import CollisionObject
from mycobot_planning.core.kinematic_constraints.constraint_manifold import ConstraintManifold
from mycobot_planning.core.kinematic_constraints.kinematic_constraints import (
    ConstraintError,
    attached_frames,
    constraints_json_from_msg,
    path_constraints_from_json,
)
from mycobot_planning.core.kinematics.ik_solver import solve_ik
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.core.transforms import make_pose
from mycobot_planning.task import InitStageException, PropertyError, Task, core, stages
from mycobot_planning.task.path_constraints import PathConstraintsSpec
from task_helpers import assert_solution_valid, panda_start_scene

ARM = "panda_arm"
FLANGE = "panda_link8"
RX90 = Rotation.from_rotvec([math.pi / 2, 0.0, 0.0])
CHECK_STEP = 0.005  # rad between the states checked along a trajectory


@pytest.fixture(scope="module")
def panda() -> RobotModel:
    return RobotModel.panda()


# ----------------------------------------------------------------------------- builders
def start_scene(model: RobotModel) -> PlanningScene:
    return panda_start_scene(model, ARM)


def orientation_constraint(link: str = "object", quat_xyzw=(0.70711, 0.0, 0.0, 0.70711), tolerances=(0.1, 0.1, 3.14),
                           parameterization: int = OrientationConstraint.ROTATION_VECTOR) -> Constraints:
    """A moveit_msgs/Constraints built field by field, as MTC's scripts do."""
    constraints = Constraints()
    oc = OrientationConstraint()
    oc.parameterization = parameterization
    oc.header.frame_id = "world"
    oc.link_name = link
    oc.orientation.x, oc.orientation.y, oc.orientation.z, oc.orientation.w = quat_xyzw
    oc.absolute_x_axis_tolerance, oc.absolute_y_axis_tolerance, oc.absolute_z_axis_tolerance = tolerances
    oc.weight = 1.0
    constraints.orientation_constraints.append(oc)
    return constraints


def constrained_demo(model: RobotModel, planner=None, constraints=None, seed: int | None = 1, direction=(0.0, 0.4, 0.0)
                     ) -> tuple[Task, stages.MoveRelative]:
    """MTC's demo/scripts/constrained.py, line by line (the node-less planner form)."""
    planner = planner if planner is not None else core.PipelinePlanner(None, "ompl", "RRTConnectkConfigDefault")
    task = Task("constrained", model, start_scene(model), seed=seed)
    task.add(stages.CurrentState("current state"))

    co = CollisionObjectMsg()
    co.header.frame_id = "world"
    co.id = "obstacle"
    sphere = SolidPrimitive()
    sphere.type = sphere.SPHERE
    sphere.dimensions.insert(sphere.SPHERE_RADIUS, 0.1)
    pose = Pose()
    pose.position.x, pose.position.y, pose.position.z = 0.3, 0.2, 0.5
    pose.orientation.w = 1.0
    co.primitives.append(sphere)
    co.primitive_poses.append(pose)
    co.operation = co.ADD
    mps = stages.ModifyPlanningScene("modify planning scene")
    mps.addObject(co)

    co.id = "object"
    co.primitives[0].type = SolidPrimitive.BOX
    co.primitives[0].dimensions = [0.1, 0.05, 0.03]
    pose = co.primitive_poses[0]
    pose.position.x, pose.position.y, pose.position.z = 0.30702, 0.0, 0.485
    pose.orientation.x = pose.orientation.w = 0.70711  # 90° about x
    mps.addObject(co)
    mps.attachObjects(["object"], FLANGE)
    mps.allowCollisions("object", ["panda_leftfinger", "panda_rightfinger"], True)
    task.add(mps)

    move = stages.MoveRelative("y +0.4", planner)
    move.timeout = 5
    move.group = ARM
    move.setDirection(Vector3Stamped(header=Header(frame_id="world"), vector=Vector3(x=direction[0], y=direction[1],
                                                                                      z=direction[2])))
    move.path_constraints = orientation_constraint() if constraints is None else constraints
    task.add(move)
    return task, move


def carrying_scene(model: RobotModel) -> PlanningScene:
    """pickplace.py after the pick: the box 'object' lying flat (identity orientation) held by the
    hand, attached to the flange."""
    scene = start_scene(model)
    scene.add_object(CollisionObject.box("object", [0.1, 0.05, 0.03], make_pose([0.30702, 0.0, 0.485]),
                                         frame_id="world"))
    scene.attach_object("object", FLANGE, touch_links=["panda_leftfinger", "panda_rightfinger", "panda_hand"])
    return scene


def carried_elsewhere(model: RobotModel, scene: PlanningScene, xyz, yaw: float) -> PlanningScene:
    """The carrying scene with the arm where the flange is at ``xyz``, turned ``yaw`` about the
    world's z axis (so the object is still upright)."""
    start = scene.current_state
    target = start.frame_pose(FLANGE)
    target[:3, :3] = Rotation.from_rotvec([0.0, 0.0, yaw]).as_matrix() @ target[:3, :3]
    target[:3, 3] = xyz
    goal = solve_ik(model, ARM, target, seed=start, scene=scene, timeout=1.0, rng=0)[0]
    end = scene.copy()
    end.set_current_state(goal)
    return end


def upright_connect_task(model: RobotModel, planner, constraints=None) -> tuple[Task, stages.Connect]:
    scene = carrying_scene(model)
    task = Task("transport", model, seed=2)
    task.add(stages.FixedState("holding", scene))
    connect = stages.Connect("connect", [(ARM, planner)])
    connect.path_constraints = orientation_constraint(quat_xyzw=(0, 0, 0, 1), tolerances=(0.1, 0.1, math.pi)) \
        if constraints is None else constraints
    task.add(connect)
    task.add(stages.FixedState("placed", carried_elsewhere(model, scene, [0.35, -0.35, 0.35], -0.9)))
    return task, connect


# ----------------------------------------------------------------------------- the independent check
def worst_tilt(sub, object_id: str, desired: np.ndarray) -> float:
    """Largest |x| or |y| component (world axes) of the rotation vector from ``desired`` to the
    object's orientation along the sub-trajectory, checked every CHECK_STEP rad between its
    samples. The object's pose: the attach link's pose times the object's pose in it."""
    scene = sub.start.scene
    start = scene.current_state
    link = scene.get_attached_object(object_id).link_name
    offset = np.linalg.inv(start.frame_pose(link)) @ scene.frame_pose(object_id)
    indices = start.model.group(sub.group).variable_indices
    rows = np.asarray(sub.trajectory.positions)
    worst = 0.0
    state = start.copy()
    for a, b in zip(rows[:-1], rows[1:]):
        steps = max(1, int(math.ceil(np.max(np.abs(b - a)) / CHECK_STEP)))
        for s in np.arange(steps + 1) / steps:
            values = state.positions.copy()
            values[indices] = a + s * (b - a)
            state.set_positions(values)
            rotation = (state.frame_pose(link) @ offset)[:3, :3]
            error = Rotation.from_matrix(rotation @ desired.T).as_rotvec()
            worst = max(worst, abs(error[0]), abs(error[1]))
    return worst


def object_position(sub, object_id: str, at_end: bool) -> np.ndarray:
    scene = (sub.end if at_end else sub.start).scene
    return scene.frame_pose(object_id)[:3, 3]


# ----------------------------------------------------------------------------- constrained.py
def test_constrained_demo_carries_the_box_around_the_sphere_level(panda):
    task, move = constrained_demo(panda)
    started = time.perf_counter()
    result = task.plan()
    elapsed = time.perf_counter() - started
    assert result, task.explainFailure(stream=None)
    assert len(task.solutions) >= 1
    desired = RX90.as_matrix()
    for solution in task.solutions:
        assert assert_solution_valid(solution) >= 1
        moves = [sub for sub in solution.sub_trajectories() if sub.creator is move]
        assert len(moves) == 1 and moves[0].trajectory is not None
        assert worst_tilt(moves[0], "object", desired) <= 0.1 + 1e-9
        travel = object_position(moves[0], "object", True) - object_position(moves[0], "object", False)
        assert np.allclose(travel, [0.0, 0.4, 0.0], atol=2e-3), travel
    # the straight line runs through the sphere: the planner went around it
    assert elapsed < 10.0  # the stage's timeout is 5 s (generous bound under test-suite load)


def test_the_object_frame_is_its_one_shapes_pose_as_in_moveit(panda):
    """MoveIt places an object of one shape whose pose is unset at the shape's pose: the demo's
    box frame is turned 90° about x, so the start satisfies the constraint exactly."""
    task, move = constrained_demo(panda)
    task.stages.remove(move)
    assert task.plan()
    scene = task.solutions[0].end.scene
    pose = scene.frame_pose("object")
    assert np.allclose(pose[:3, 3], [0.30702, 0.0, 0.485], atol=1e-9)
    assert Rotation.from_matrix(pose[:3, :3].T @ RX90.as_matrix()).magnitude() < 1e-4


def test_a_start_off_the_constraint_is_reported(panda):
    """A desired orientation 0.5 rad off the box's: the start already violates the constraint,
    and the stage says so (MoveIt's START_STATE_VIOLATES_PATH_CONSTRAINTS)."""
    wrong = Rotation.from_rotvec([math.pi / 2 + 0.5, 0.0, 0.0]).as_quat()
    task, move = constrained_demo(panda, constraints=orientation_constraint(quat_xyzw=wrong))
    assert not task.plan()
    assert "START_STATE_VIOLATES_PATH_CONSTRAINTS" in move.failures[0].comment
    assert "orientation of object" in move.failures[0].comment


def test_constrained_demo_with_a_cartesian_path(panda):
    """The straight line keeps the orientation but runs into the sphere: CartesianPath stops
    short; moving the other way (no sphere) it succeeds, level all along."""
    task, move = constrained_demo(panda, planner=core.CartesianPath())
    assert not task.plan()
    assert "min_fraction not met" in move.failures[0].comment
    task, move = constrained_demo(panda, planner=core.CartesianPath(), direction=(0.0, -0.2, 0.0))
    assert task.plan(), task.explainFailure(stream=None)
    sub = [s for s in task.solutions[0].sub_trajectories() if s.creator is move][0]
    assert worst_tilt(sub, "object", RX90.as_matrix()) <= 0.1 + 1e-9
    assert_solution_valid(task.solutions[0])


def test_cartesian_path_stops_where_a_rotation_breaks_the_constraint(panda):
    """A twist tilting the box 0.4 rad about world x: the line leaves the 0.1 rad tolerance."""
    task, move = constrained_demo(panda, planner=core.CartesianPath())
    move.setDirection(core.TwistStamped("world", [0.0, 0.0, 0.0], [0.4, 0.0, 0.0]))
    assert not task.plan()
    comment = move.failures[0].comment
    assert "min_fraction not met" in comment and "violates the path constraints" in comment, comment


# ----------------------------------------------------------------------------- pickplace.py's Connect
def test_connect_keeps_the_held_object_upright(panda):
    task, connect = upright_connect_task(panda, core.PipelinePlanner("ompl", "RRTConnectkConfigDefault"))
    assert task.plan(), task.explainFailure(stream=None)
    for solution in task.solutions:
        assert_solution_valid(solution)
        sub = [s for s in solution.sub_trajectories() if s.creator is connect][0]
        assert worst_tilt(sub, "object", np.eye(3)) <= 0.1 + 1e-9


def test_connect_merges_arm_and_hand_under_the_constraint(panda):
    """Two (group, planner) pairs: each planner keeps the constraint, and the merged motion
    (panda_arm_hand) is checked against it too, as MTC's merge does."""
    scene = carrying_scene(panda)
    task = Task("transport", panda, seed=2)
    task.add(stages.FixedState("holding", scene))
    connect = stages.Connect("connect", [(ARM, core.PipelinePlanner("ompl")),
                                         ("hand", core.JointInterpolationPlanner())])
    connect.setPathConstraints(orientation_constraint(quat_xyzw=(0, 0, 0, 1), tolerances=(0.1, 0.1, math.pi)))
    task.add(connect)
    end = carried_elsewhere(panda, scene, [0.35, -0.35, 0.35], -0.9)
    state = end.current_state.copy()
    state.set_joint_positions({"panda_finger_joint1": 0.03})
    end.set_current_state(state)
    task.add(stages.FixedState("placed", end))
    assert task.plan(), task.explainFailure(stream=None)
    subs = [s for s in task.solutions[0].sub_trajectories() if s.creator is connect]
    assert [s.group for s in subs] == ["panda_arm_hand"]
    assert worst_tilt(subs[0], "object", np.eye(3)) <= 0.1 + 1e-9
    assert_solution_valid(task.solutions[0])


def test_connect_with_joint_interpolation_refuses_a_tilting_line(panda):
    """The straight joint-space line between the two upright states tilts the object: the
    JointInterpolationPlanner fails and names the broken constraint (MTC's ignores them)."""
    task, connect = upright_connect_task(panda, core.JointInterpolationPlanner(),
                                         constraints=orientation_constraint(quat_xyzw=(0, 0, 0, 1),
                                                                            tolerances=(0.02, 0.02, math.pi)))
    assert not task.plan()
    comment = connect.failures[0].comment
    assert "joint interpolation" in comment and "violates the path constraints" in comment, comment
    assert "orientation of object" in comment
    # unconstrained, the same line is fine
    task, connect = upright_connect_task(panda, core.JointInterpolationPlanner(), constraints={})
    assert task.plan(), task.explainFailure(stream=None)


def test_multi_planner_passes_the_constraints_on(panda):
    tight = orientation_constraint(quat_xyzw=(0, 0, 0, 1), tolerances=(0.02, 0.02, math.pi))
    planner = core.MultiPlanner(core.JointInterpolationPlanner(), core.PipelinePlanner("ompl"))
    task, connect = upright_connect_task(panda, planner, constraints=tight)
    assert task.plan(), task.explainFailure(stream=None)
    sub = [s for s in task.solutions[0].sub_trajectories() if s.creator is connect][0]
    assert worst_tilt(sub, "object", np.eye(3)) <= 0.02 + 1e-9
    assert "ompl" in sub.planner_id or "RRTConnect" in sub.planner_id, sub.planner_id


# ----------------------------------------------------------------------------- MoveTo
def test_move_to_joint_goal_under_a_link_constraint(panda):
    """A robot link (not an object) in the constraint; pilz PTP's straight line is checked."""
    scene = start_scene(panda)
    goal = scene.current_state.copy()
    goal.set_joint_positions({"panda_joint1": -0.8})  # a turn about the vertical: the flange stays level
    level = orientation_constraint(link=FLANGE, quat_xyzw=Rotation.from_matrix(
        scene.current_state.frame_pose(FLANGE)[:3, :3]).as_quat(), tolerances=(0.05, 0.05, math.pi))
    for planner in (core.PipelinePlanner("ompl"), core.PipelinePlanner({"pilz_industrial_motion_planner": "PTP"}),
                    core.JointInterpolationPlanner()):
        task = Task("move to", panda, scene, seed=4)
        task.add(stages.CurrentState("current"))
        move = stages.MoveTo("turn", planner)
        move.group = ARM
        move.setGoal({"panda_joint1": -0.8})
        move.setPathConstraints(level)
        task.add(move)
        assert task.plan(), (type(planner).__name__, task.explainFailure(stream=None))
        assert_solution_valid(task.solutions[0])


def test_move_to_pose_goal_with_joint_interpolation_keeps_ik_within_the_constraints(panda):
    """MTC's JointInterpolationPlanner keeps the constraints at IK for pose goals; a goal the
    constraint forbids fails there, with that reason."""
    scene = start_scene(panda)
    flange = scene.current_state.frame_pose(FLANGE)
    tilted = flange.copy()
    tilted[:3, :3] = Rotation.from_rotvec([0.3, 0.0, 0.0]).as_matrix() @ flange[:3, :3]
    level = orientation_constraint(link=FLANGE, quat_xyzw=Rotation.from_matrix(flange[:3, :3]).as_quat(),
                                   tolerances=(0.1, 0.1, math.pi))
    task = Task("move to", panda, scene, seed=4)
    task.add(stages.CurrentState("current"))
    move = stages.MoveTo("tilt", core.JointInterpolationPlanner())
    move.group = ARM
    move.setGoal(core.PoseStamped("world", tilted))
    move.path_constraints = level
    task.add(move)
    assert not task.plan()
    assert "no solution satisfies the path constraints" in move.failures[0].comment


# ----------------------------------------------------------------------------- the forms it takes
def test_every_form_of_constraints_means_the_same(panda):
    scene = carrying_scene(panda)
    message = orientation_constraint(quat_xyzw=(0, 0, 0, 1), tolerances=(0.1, 0.1, math.pi))
    as_dict = {"name": "", "orientation_constraints": [{
        "header": {"frame_id": "world"}, "link_name": "object", "orientation": {"x": 0, "y": 0, "z": 0, "w": 1},
        "absolute_x_axis_tolerance": 0.1, "absolute_y_axis_tolerance": 0.1, "absolute_z_axis_tolerance": math.pi,
        "parameterization": 1}]}
    as_json = {"orientation": [{"link": "object", "frame": "world", "orientation": [0, 0, 0, 1],
                                "tolerance": [0.1, 0.1, math.pi], "parameterization": 1}]}
    resolved = path_constraints_from_json(as_json, scene.current_state, scene.frame_pose, attached_frames(scene))
    specs = []
    for form in (message, as_dict, as_json, resolved):
        connect = stages.Connect("c", [(ARM, core.PipelinePlanner())])
        connect.path_constraints = form
        specs.append(connect.properties["path_constraints"])
        assert isinstance(specs[-1], PathConstraintsSpec) and specs[-1]
    assert specs[0].data == specs[1].data == specs[2].data == constraints_json_from_msg(message)
    states = [scene.current_state.copy() for _ in range(3)]
    states[1].set_joint_positions({"panda_joint6": 1.571 + 0.3})  # tilts the box about the flange's axis
    states[2].set_joint_positions({"panda_joint1": 0.6})  # turns it about the vertical
    for spec in specs:
        constraints = spec.resolve(scene)
        assert [constraints.satisfied(s) for s in states] == [True, False, True]
    assert not PathConstraintsSpec() and not stages.Connect("c", []).properties["path_constraints"]


def test_joint_and_position_constraints_from_a_message(panda):
    """Joint and position constraints (a box region for the object's point) plan on the manifold too."""
    scene = start_scene(panda)
    constraints = Constraints()
    jc = JointConstraint()
    jc.joint_name, jc.position, jc.tolerance_above, jc.tolerance_below = "panda_joint3", 0.0, 0.2, 0.2
    constraints.joint_constraints.append(jc)
    pc = PositionConstraint()
    pc.header.frame_id = "world"
    pc.link_name = FLANGE
    box = SolidPrimitive()
    box.type = SolidPrimitive.BOX
    box.dimensions = [0.3, 0.6, 0.04]  # the flange's height within ±2 cm
    region = Pose()
    region.position.x, region.position.y = 0.3, 0.0
    region.position.z = float(scene.current_state.frame_pose(FLANGE)[2, 3])
    pc.constraint_region.primitives.append(box)
    pc.constraint_region.primitive_poses.append(region)
    constraints.position_constraints.append(pc)
    task = Task("slide", panda, scene, seed=5)
    task.add(stages.CurrentState("current"))
    move = stages.MoveRelative("y -0.2", core.PipelinePlanner("ompl"))
    move.group = ARM
    move.setDirection(core.Vector3Stamped("world", [0.0, -0.2, 0.0]))
    move.path_constraints = constraints
    task.add(move)
    assert task.plan(), task.explainFailure(stream=None)
    sub = [s for s in task.solutions[0].sub_trajectories() if s.creator is move][0]
    state = scene.current_state.copy()
    indices = panda.group(ARM).variable_indices
    z0 = region.position.z
    for q in sub.trajectory.positions:
        values = state.positions.copy()
        values[indices] = q
        state.set_positions(values)
        assert abs(state.frame_pose(FLANGE)[2, 3] - z0) <= 0.02 + 1e-9
        assert abs(state.joint_position("panda_joint3")) <= 0.2 + 1e-9
    assert_solution_valid(task.solutions[0])


# ----------------------------------------------------------------------------- bad input
def test_an_unknown_link_is_reported_at_init(panda):
    task, move = constrained_demo(panda, constraints=orientation_constraint(link="objekt"))
    with pytest.raises(InitStageException) as raised:
        task.init()
    text = str(raised.value)
    assert "y +0.4" in text and "path_constraints" in text and "unknown link 'objekt'" in text
    assert "object" in text  # the objects it knows


def test_with_a_scene_known_only_when_planning_the_name_is_checked_then(panda):
    """A scene provider (move_group's monitored scene) is only asked when planning: init cannot
    know the objects, so the planner reports the unknown name."""
    task, move = constrained_demo(panda, constraints=orientation_constraint(link="objekt"))
    task.setSceneProvider(lambda timeout: start_scene(panda))
    task.init()
    assert not task.plan()
    comment = move.failures[0].comment
    assert "unknown link 'objekt'" in comment and "attached collision object (object)" in comment, comment


def test_bad_constraints_are_refused_with_their_reason(panda):
    move = stages.MoveRelative("m", core.CartesianPath())
    with pytest.raises(PropertyError, match="visibility constraints are not supported"):
        move.path_constraints = {"visibility_constraints": [{}]}
    with pytest.raises(PropertyError, match="expected a moveit_msgs/Constraints"):
        move.path_constraints = "keep it level"
    with pytest.raises(PropertyError, match="keys"):
        move.path_constraints = {"orientations": []}
    # Euler angles on an attached object: refused as MoveIt refuses them
    task, move = constrained_demo(panda, constraints=orientation_constraint(
        parameterization=OrientationConstraint.XYZ_EULER_ANGLES))
    with pytest.raises(InitStageException, match="rotation vector"):
        task.init()
    # a joint that does not exist, tolerances of the wrong shape
    task, move = constrained_demo(panda, constraints={"joints": [{"joint": "elbow", "position": 0.0}]})
    with pytest.raises(InitStageException, match="unknown joint 'elbow'"):
        task.init()
    task, move = constrained_demo(panda, constraints={"orientation": [{"link": FLANGE, "tolerance": [0.1]}]})
    with pytest.raises(InitStageException, match="3 tolerances"):
        task.init()


def test_an_object_not_attached_when_planning_fails_with_a_clear_comment(panda):
    """'obstacle' is a collision object of the task, so init accepts it; it is a world object,
    not attached, so the planner says so."""
    task, move = constrained_demo(panda, constraints=orientation_constraint(link="obstacle"))
    assert not task.plan()
    comment = move.failures[0].comment
    assert "path constraints" in comment and "unknown link 'obstacle'" in comment and "attached" in comment


# ----------------------------------------------------------------------------- the core's pieces
def test_rotation_vector_errors_are_about_the_header_frames_axes(panda):
    """MoveIt 2 Jazzy: resolveConstraintFrames moves an object's constraint to its link, then
    decide() measures the rotation vector in the header frame's axes. Computed here that way,
    step by step, for random frames, objects and states."""
    rng = np.random.default_rng(7)
    model = panda
    for _ in range(5):
        frame = np.eye(4)
        frame[:3, :3] = Rotation.random(random_state=rng).as_matrix()
        offset = np.eye(4)
        offset[:3, :3] = Rotation.random(random_state=rng).as_matrix()
        q = Rotation.random(random_state=rng)
        data = {"orientation": [{"link": "thing", "frame": "f", "orientation": q.as_quat().tolist(),
                                 "tolerance": [0.1, 0.2, 0.3], "parameterization": 1}]}
        state = RobotState(model)
        state.set_positions(model.lower_limits + rng.random(len(model.lower_limits)) *
                            (model.upper_limits - model.lower_limits))
        constraints = path_constraints_from_json(data, state, lambda name: frame, {"thing": ("panda_link7", offset)})
        link_rotation = state.frame_pose("panda_link7")[:3, :3]
        # MoveIt: q' = q * (R_object^T R_link); desired (world) = frame * q'; diff = desired^T R_link
        object_rotation = link_rotation @ offset[:3, :3]
        q_link = q.as_matrix() @ object_rotation.T @ link_rotation
        diff = (frame[:3, :3] @ q_link).T @ link_rotation
        moveit = np.abs(q_link @ Rotation.from_matrix(diff).as_rotvec())
        ours = constraints.orientations[0].error(state.frame_pose("panda_link7"))
        assert np.allclose(ours, moveit, atol=1e-9)


def test_the_manifold_jacobian_is_the_derivative_of_its_function(panda):
    state = RobotState(panda)
    state.set_named("ready", ARM)
    offset = make_pose([0.05, 0.02, 0.1], rpy=[0.3, -0.5, 0.9])
    data = {"orientation": [{"link": "thing", "orientation": [0.3, 0.1, 0.2, 0.9], "tolerance": [0, 0, 0],
                             "parameterization": 1},
                            {"link": FLANGE, "orientation": [0.1, 0.2, 0.3, 0.9], "tolerance": [0, 0, 0]}],
            "position": [{"link": "thing", "offset": [0.01, 0.02, 0.03], "regions": [
                {"type": kind, "dimensions": dims,
                 "pose": {"position": [0.3, 0.1, 0.5], "orientation": [0.1, 0.2, 0.3, 0.9]}}]}
                for kind, dims in (("box", [0.01, 0.02, 0.03]), ("sphere", [0.001]), ("cylinder", [0.001, 0.001]))],
            "joints": [{"joint": "panda_joint3", "position": 0.5}]}
    constraints = path_constraints_from_json(data, state, lambda name: np.eye(4), {"thing": ("panda_link8", offset)})
    manifold = ConstraintManifold(constraints, state, ARM)
    assert manifold.codim == 3 + 3 + 3 + 1 + 2 + 1
    rng = np.random.default_rng(3)
    x0 = state.group_positions(ARM)
    for _ in range(3):
        x = x0 + rng.normal(0.0, 0.3, x0.size)
        numeric = np.column_stack([(manifold.value(x + h) - manifold.value(x - h)) / 2e-6
                                   for h in np.eye(x.size) * 1e-6])
        assert np.allclose(manifold.jacobian(x), numeric, atol=1e-5)


def test_the_manifold_holds_its_references_and_leaves_unions_to_rejection(panda):
    state = RobotState(panda)
    state.set_named("ready", ARM)
    flange = state.frame_pose(FLANGE)
    tilted = Rotation.from_rotvec([0.095, 0.0, 0.0]).as_matrix() @ flange[:3, :3]
    data = {"orientation": [{"link": FLANGE, "orientation": Rotation.from_matrix(tilted).as_quat().tolist(),
                             "tolerance": [0.1, 0.1, math.pi], "parameterization": 1}],
            "position": [{"link": FLANGE, "regions": [
                {"type": "sphere", "dimensions": [0.05], "pose": {"position": flange[:3, 3].tolist()}},
                {"type": "sphere", "dimensions": [0.05], "pose": {"position": (flange[:3, 3] + 0.3).tolist()}}]}]}
    constraints = path_constraints_from_json(data, state, lambda name: np.eye(4))
    assert constraints.satisfied(state)
    manifold = ConstraintManifold(constraints, state, ARM, [state])
    assert manifold.codim == 2  # x and y of the orientation; the two-sphere union is not projected
    # the start is 0.095 rad off about x: beyond the bound shrunk for planning (0.09), yet on the manifold
    assert np.allclose(manifold.value(state.group_positions(ARM)), 0.0)
    with pytest.raises(ConstraintError, match="unknown link"):
        path_constraints_from_json({"orientation": [{"link": "thing", "tolerance": [1, 1, 1]}]}, state,
                                   lambda name: np.eye(4))


# ----------------------------------------------------------------------------- OMPL on a manifold (no robot)
class _Sphere:
    """The unit sphere in R^3 as a manifold f(x) = |x| - 1 (OMPL's constrained planning demo)."""

    codim = 1

    def __init__(self, fail_after: int | None = None) -> None:
        self.calls = 0
        self.fail_after = fail_after

    def value(self, x):
        self.calls += 1
        if self.fail_after is not None and self.calls > self.fail_after:
            raise ValueError("broken manifold")
        return np.array([np.linalg.norm(x) - 1.0])

    def jacobian(self, x):
        return (x / np.linalg.norm(x))[None, :]


def _band_with_a_gap(q: np.ndarray) -> bool:
    """A wall around the equator, open only near +x: paths between the poles must go through it."""
    return not (abs(q[2]) < 0.1 and q[0] < 0.5)


def test_ompl_plans_on_a_manifold_from_either_end():
    from mycobot_planning.core.planners.ompl.solve import plan_joint_space

    low, high = -2.0 * np.ones(3), 2.0 * np.ones(3)
    south, norths = np.array([0.0, 0.0, -1.0]), [np.array([0.0, s, 1.0]) / np.hypot(s, 1.0) for s in (0.0, 0.3, -0.3)]
    for planner in ("geometric::RRTConnect", "geometric::RRT", "geometric::PRM"):
        for seed in (1, 2, 3):
            # several goals: bidirectional planners plan goal -> start; the path must still be
            # walked along the manifold in the direction it was checked
            result = plan_joint_space(low, high, _band_with_a_gap, south, norths, planner_type=planner, timeout=5.0,
                                      interpolate_states=0, seed=seed, manifold=_Sphere(), stop_on_first_solution=True)
            assert result.success, (planner, result.status, result.message)
            path = result.path
            assert np.allclose(path[0], south) and any(np.allclose(path[-1], g) for g in norths)
            assert np.allclose(np.linalg.norm(path, axis=1), 1.0, atol=1e-3)
            assert all(_band_with_a_gap(q) for q in path)
            assert np.max(np.linalg.norm(np.diff(path, axis=0), axis=1)) <= 0.05 * 1.01  # OMPL's step (delta)


def test_ompl_reraises_what_the_manifold_raised():
    from mycobot_planning.core.planners.ompl.solve import OmplConfigError, plan_joint_space

    low, high = -2.0 * np.ones(3), 2.0 * np.ones(3)
    with pytest.raises(ValueError, match="broken manifold"):
        plan_joint_space(low, high, _band_with_a_gap, np.array([0.0, 0.0, -1.0]), [np.array([0.0, 0.0, 1.0])],
                         timeout=5.0, seed=1, manifold=_Sphere(fail_after=50))
    with pytest.raises(OmplConfigError, match="codim"):
        plan_joint_space(low, high, _band_with_a_gap, np.array([0.0, 0.0, -1.0]), [np.array([0.0, 0.0, 1.0])],
                         manifold=type("M", (), {"codim": 3, "value": None, "jacobian": None})())
