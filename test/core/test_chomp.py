"""CHOMP as the "chomp" planning pipeline (MoveIt's chomp_interface): covariant gradient descent
bends the initial path around an obstacle, every returned path passes the trajectory validator's
plain check of every pair at its dense resolution, pose goals go through IK, an exhausted budget is
TIMED_OUT, parameters out of range are refused, path constraints are not planned for (as in
MoveIt) so the pipeline refuses a path that leaves them, and it is selectable wherever a pipeline is
(the registry, the JSON face, MTC's PipelinePlanner). Also the two pieces it stands on: the
collision spheres cover the links, and the distance field is the exact distance of primitives."""
from __future__ import annotations

import functools
import threading

import numpy as np
import pytest

from interfaces_py.msgs import CollisionObject, Mesh, MoveItErrorCode, Pose
from mycobot_planning.core.collision_distance_field import WorldDistanceField, group_spheres
from mycobot_planning.core.kinematic_constraints.kinematic_constraints import path_constraints_from_json
from mycobot_planning.core.planners.chomp import DEFAULT_PARAMS, ChompParams, ChompPlanner
from mycobot_planning.core.planning_interface.planning_interface import (
    JointGoal,
    MotionPlanRequest,
    NamedGoal,
)
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.transforms import make_pose
from trajectory_optimizer_testing import (
    LEFT,
    RIGHT,
    TIP,
    arm_state,
    assert_listed_and_selectable,
    assert_parameters_refused,
    assert_plain_valid,
    boxed_scene,
    optimizer_request,
)

@pytest.fixture(scope="module")
def boxed(mycobot):
    return boxed_scene(mycobot)


chomp_request = functools.partial(optimizer_request, "chomp")


def test_a_joint_goal_around_a_box(pipeline, boxed):
    scene, start = boxed
    straight = pipeline.plan(scene, MotionPlanRequest("arm", JointGoal(RIGHT), start_state=start,
                                                      pipeline_id="joint_interpolation"))
    assert straight.error_code.val == MoveItErrorCode.PLANNING_FAILED and "box" in straight.message
    response = pipeline.plan(scene, chomp_request(JointGoal(RIGHT), start, planner_id="CHOMP"))
    assert_plain_valid(scene, response, start)
    assert response.validated and response.planner_id == "chomp" and response.group_name == "arm"
    assert len(response.path) == 101  # MoveIt's 3 s at 0.03 s
    trajectory = response.trajectory
    assert np.allclose(trajectory.positions[0], LEFT) and np.allclose(trajectory.positions[-1], RIGHT, atol=1e-6)
    # the path went around: it left the initial (minimum-jerk) line
    t = np.linspace(0.0, 1.0, len(response.path))
    line = LEFT + (10 * t ** 3 - 15 * t ** 4 + 6 * t ** 5)[:, None] * (RIGHT - LEFT)
    assert np.max(np.abs(response.path - line)) > 0.05


@pytest.mark.parametrize("seed", range(6))
def test_every_seed_and_initialisation_passes_the_validator(pipeline, boxed, seed):
    scene, start = boxed
    method = ("quintic-spline", "linear", "cubic")[seed % 3]
    planner = ChompPlanner({"trajectory_initialization_method": method, "use_stochastic_descent": seed >= 3,
                            "enable_failure_recovery": True})
    response = planner.plan(scene, chomp_request(JointGoal(RIGHT), start, seed=seed))
    assert_plain_valid(scene, response, start)


def test_lowercase_planner_id_named_goal_and_a_free_line(pipeline, mycobot):
    start = arm_state(mycobot, LEFT)
    scene = PlanningScene(mycobot, start)
    response = pipeline.plan(scene, chomp_request(NamedGoal("home"), start, planner_id="chomp"))
    assert_plain_valid(scene, response, start)
    # nothing in the way: the initial path is valid, then only smoothed (max_iterations_after_collision_free)
    assert f"valid after {DEFAULT_PARAMS.max_iterations_after_collision_free} iterations" in response.message
    refused = pipeline.plan(scene, chomp_request(NamedGoal("home"), start, planner_id="RRTConnectkConfigDefault"))
    assert refused.error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN and "CHOMP" in refused.message


def test_a_tiny_budget_times_out_and_too_few_iterations_fail(pipeline, boxed):
    scene, start = boxed
    response = pipeline.plan(scene, chomp_request(JointGoal(RIGHT), start, allowed_planning_time=0.005))
    assert response.error_code.val == MoveItErrorCode.TIMED_OUT, response.error_code
    assert response.trajectory is None
    planner = ChompPlanner({"max_iterations": "1"})
    response = planner.plan(scene, chomp_request(JointGoal(RIGHT), start))
    assert response.error_code.val == MoveItErrorCode.PLANNING_FAILED and "max_iterations" in response.message
    assert response.trajectory is None


def test_cancel_is_preempted(boxed):
    scene, start = boxed
    cancel = threading.Event()
    cancel.set()
    response = ChompPlanner().plan(scene, chomp_request(JointGoal(RIGHT), start, cancel=cancel))
    assert response.error_code.val == MoveItErrorCode.PREEMPTED


@pytest.mark.parametrize("params, words", [
    ({"planning_time_limit": "0"}, "planning_time_limit must be > 0"),
    ({"max_iterations": "0"}, "max_iterations must be >= 1"),
    ({"max_iterations_after_collision_free": "-1"}, "max_iterations_after_collision_free must be >= 0"),
    ({"learning_rate": "-0.01"}, "learning_rate must be > 0"),
    ({"smoothness_cost_weight": "-1"}, "smoothness_cost_weight must be >= 0"),
    ({"obstacle_cost_weight": "-1"}, "obstacle_cost_weight must be >= 0"),
    ({"smoothness_cost_jerk": "-1"}, "smoothness_cost_jerk must be >= 0"),
    ({"ridge_factor": "-0.1"}, "ridge_factor must be >= 0"),
    ({"collision_clearance": "0"}, "collision_clearance must be > 0"),
    ({"collision_threshold": "-1"}, "collision_threshold must be >= 0"),
    ({"joint_update_limit": "0"}, "joint_update_limit must be > 0"),
    ({"max_recovery_attempts": "-2"}, "max_recovery_attempts must be >= 0"),
    ({"smoothness_cost_acceleration": "0"}, "smoothness metric has no inverse"),
    ({"learning_rate": "nan"}, "learning_rate must be a finite number"),
    ({"max_iterations": "4.5"}, "max_iterations must be an integer"),
    ({"max_iterations": "many"}, "max_iterations must be a number"),
    ({"use_stochastic_descent": "maybe"}, "use_stochastic_descent must be true or false"),
    ({"trajectory_initialization_method": "random"}, "trajectory_initialization_method must be one of"),
    ({"max_iterations": "50", "speed": "1"}, "unknown CHOMP parameters ['speed']"),
])
def test_parameters_out_of_range_are_refused(params, words):
    assert_parameters_refused(ChompPlanner, "CHOMP", params, words)


def test_parameters_have_moveits_defaults_and_can_be_set():
    planner = ChompPlanner()
    assert planner.planner_params("CHOMP") == {
        "planning_time_limit": "10.0", "max_iterations": "200", "max_iterations_after_collision_free": "5",
        "smoothness_cost_weight": "0.1", "obstacle_cost_weight": "1.0", "learning_rate": "0.01",
        "smoothness_cost_velocity": "0.0", "smoothness_cost_acceleration": "1.0", "smoothness_cost_jerk": "0.0",
        "ridge_factor": "0.0", "use_pseudo_inverse": "false", "pseudo_inverse_ridge_factor": "0.0001",
        "joint_update_limit": "0.1", "collision_clearance": "0.2", "collision_threshold": "0.07",
        "use_stochastic_descent": "false", "trajectory_initialization_method": "quintic-spline",
        "enable_failure_recovery": "false", "max_recovery_attempts": "5"}
    assert planner.set_planner_params("chomp", {"learning_rate": "0.05", "use_stochastic_descent": "true",
                                                "trajectory_initialization_method": "linear"}) is None
    assert planner.params == ChompParams(learning_rate=0.05, use_stochastic_descent=True,
                                         trajectory_initialization_method="linear")
    assert planner.set_planner_params("CHOMP", {"max_iterations": "40"}, replace=True) is None
    assert planner.params == ChompParams(max_iterations=40)
    assert planner.set_planner_params("PTP", {"max_iterations": "40"}) is not None
    assert planner.planner_params("PTP") == {}


def test_fill_trajectory_is_refused_with_why(boxed):
    scene, start = boxed
    response = ChompPlanner({"trajectory_initialization_method": "fillTrajectory"}).plan(
        scene, chomp_request(JointGoal(RIGHT), start))
    assert response.error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN and "input trajectory" in response.message


def test_listed_and_selectable_where_pipelines_are(mycobot, pipeline):
    assert_listed_and_selectable(mycobot, pipeline, "chomp", "CHOMP", "max_iterations", "200", {"learning_rate": "0"},
                                 "learning_rate must be > 0")


def test_path_constraints_are_not_planned_for_and_a_path_leaving_them_is_refused(pipeline, mycobot):
    """CHOMP (as MoveIt's) ignores path constraints: the pipeline checks the path afterwards. The
    flange must stay in a box around the straight Cartesian segment between its ends, which the
    swing about the base leaves: refused. A region the swing stays in: planned and kept."""
    start = arm_state(mycobot, LEFT)
    scene = PlanningScene(mycobot, start)
    a, b = start.frame_pose(TIP)[:3, 3], arm_state(mycobot, RIGHT).frame_pose(TIP)[:3, 3]

    def region(size):
        return path_constraints_from_json({"position": [{"link": TIP, "regions": [
            {"type": "box", "dimensions": list(size), "pose": {"position": ((a + b) / 2).tolist()}}]}]},
            start, lambda frame: np.eye(4))

    response = pipeline.plan(scene, chomp_request(JointGoal(RIGHT), start, path_constraints=region(np.abs(b - a) + 0.04)))
    assert response.error_code.val == MoveItErrorCode.PLANNING_FAILED, response.error_code
    assert "violates the path constraints" in response.message and response.trajectory is None
    wide = region([0.6, 0.6, 0.6])
    response = pipeline.plan(scene, chomp_request(JointGoal(RIGHT), start, path_constraints=wide))
    assert_plain_valid(scene, response, start)
    for q in response.trajectory.positions:
        assert wide.satisfied(arm_state(mycobot, q))


def cube_mesh(side: float) -> Mesh:
    """A closed triangle mesh of a cube of ``side`` around its centre."""
    h = side / 2.0
    corners = [[x, y, z] for x in (-h, h) for y in (-h, h) for z in (-h, h)]
    faces = [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6],
             [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]
    return Mesh(vertices=corners, triangles=faces)


def test_a_mesh_obstacle(pipeline, mycobot):
    """The box of the first test as a triangle mesh: its voxel field pushes the path around it too."""
    start = arm_state(mycobot, LEFT)
    where = arm_state(mycobot, (LEFT + RIGHT) / 2).frame_pose(TIP)[:3, 3]
    scene = PlanningScene(mycobot, start)
    scene.add_object(CollisionObject(id="cube", meshes=[cube_mesh(0.04)], mesh_poses=[Pose.from_matrix(make_pose(where))]))
    straight = pipeline.plan(scene, MotionPlanRequest("arm", JointGoal(RIGHT), start_state=start,
                                                      pipeline_id="joint_interpolation"))
    assert not straight.success
    response = pipeline.plan(scene, chomp_request(JointGoal(RIGHT), start))
    assert_plain_valid(scene, response, start)


def test_the_panda_around_a_box(panda, pipeline):
    """Any URDF + SRDF robot (meshes): the Panda's 7 joints swing past a box on the straight line's path."""
    a = np.array([-1.2, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
    b = a.copy()
    b[0] = 1.2
    start = arm_state(panda, a)
    middle = arm_state(panda, (a + b) / 2)
    scene = PlanningScene(panda, start)
    scene.add_object(CollisionObject.box("box", [0.08] * 3, make_pose(middle.frame_pose(panda.group("arm").tip_link)[:3, 3])))
    straight = pipeline.plan(scene, MotionPlanRequest("arm", JointGoal(b), start_state=start,
                                                      pipeline_id="joint_interpolation"))
    assert not straight.success
    response = pipeline.plan(scene, chomp_request(JointGoal(b), start))
    assert_plain_valid(scene, response, start)


def test_attached_objects_are_pushed_away_too(pipeline, boxed, mycobot):
    """A rod held by the flange gets spheres: the path keeps the rod off the box as well."""
    scene, start = boxed
    held = scene.copy()
    held.add_object(CollisionObject.cylinder("rod", 0.06, 0.006, make_pose([0.0, 0.0, 0.03]), frame_id=TIP))
    held.attach_object("rod", TIP, touch_links=["gripper", "gripper_base"])
    response = pipeline.plan(held, chomp_request(JointGoal(RIGHT), start))
    assert_plain_valid(held, response, start)


def test_the_spheres_cover_the_links(mycobot):
    """Every point sampled on a link's shape (here: corners and rims) lies inside one of its spheres."""
    from mycobot_planning.core.collision_distance_field.body_decomposition import geometry_points

    spheres = group_spheres(mycobot, "arm")
    assert len(spheres) > 10 and set(spheres.bodies) >= {"link2", "link3", "link4", "link5", "link6"}
    model = mycobot.pin_collision_model
    for geom in model.geometryObjects:
        mine = [k for k, joint in enumerate(spheres.joints) if joint == geom.parentJoint
                and spheres.bodies[k] == mycobot.pin_model.frames[geom.parentFrame].name]
        if not mine:
            continue
        points = geometry_points(geom.geometry)
        points = points @ geom.placement.rotation.T + geom.placement.translation
        gaps = np.linalg.norm(points[:, None] - spheres.centres[mine][None], axis=2) - spheres.radii[mine][None]
        assert np.all(gaps.min(axis=1) <= 1e-9), geom.name


def test_the_distance_field_is_exact_for_primitives_and_close_for_meshes(mycobot):
    scene = PlanningScene(mycobot)
    scene.add_object(CollisionObject.box("box", [0.2, 0.1, 0.4], make_pose([0.5, 0.0, 0.0])))
    scene.add_object(CollisionObject.sphere("ball", 0.05, make_pose([-0.5, 0.0, 0.0])))
    field = WorldDistanceField(scene.world_geometry(), padding=0.2)
    points = np.array([[0.7, 0.0, 0.0], [0.5, 0.0, 0.0], [-0.5, 0.3, 0.0], [0.5, 0.15, 0.3]])
    distance, gradient = field.distance_and_gradient(points)
    assert np.allclose(distance, [0.1, -0.05, 0.25, np.hypot(0.1, 0.1)], atol=1e-9)
    assert np.allclose(gradient[0], [1, 0, 0], atol=1e-6) and np.allclose(gradient[2], [0, 1, 0], atol=1e-6)
    # a box as a triangle mesh: the voxel field agrees with the exact distance within a voxel or so
    mesh = cube_mesh(1.0)
    mesh.scale = [0.2, 0.1, 0.4]
    meshed = PlanningScene(mycobot)
    meshed.add_object(CollisionObject(id="mesh", meshes=[mesh], mesh_poses=[Pose.from_matrix(make_pose([0.5, 0.0, 0.0]))]))
    mesh_field = WorldDistanceField(meshed.world_geometry(), padding=0.2)
    probe = np.array([[0.7, 0.0, 0.0], [0.5, 0.0, 0.0], [0.5, 0.15, 0.3], [0.45, 0.0, 0.35]])
    exact = WorldDistanceField(scene.world_geometry()[:1], padding=0.2).distance(probe)
    assert np.allclose(mesh_field.distance(probe), exact, atol=0.02)
