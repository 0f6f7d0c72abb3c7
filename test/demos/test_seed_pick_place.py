"""The seeds' pick and place (mtc_node / pick_place_demo), ROS-free: parameters, scene, stage
tree, and plans checked the way the planning_server executes them (replayed from the exported
TaskSolution, every trajectory through the core validator)."""
from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from interfaces_py.msgs import MoveItErrorCode, SolidPrimitive, TaskSolution
from mycobot_planning.core import PlanningScene, RobotModel
from mycobot_planning.paths import config_file
from mycobot_planning.demos.pick_place import (
    MTC_NODE_PARAMETER_NAMES,
    PARAMETERS,
    PICK_PLACE_DEMO_PARAMETERS,
    PickPlaceParameters,
    build_pick_place_task,
    expected_place_pose,
    load_parameters,
    parameter_problem,
    pick_place_scene,
    seed_scene_objects,
    vector_to_pose,
)
from task_helpers import replay_task_solution

#: The seed's mtc_node parameters and defaults (mtc_node.cpp / mtc_node_params.yaml), in order.
SEED_DEFAULTS = {
    "execute": False, "max_solutions": 10, "spawn_table": True,
    "controller_names": ["arm_controller", "grip_action_controller"],
    "arm_group_name": "arm", "gripper_group_name": "gripper", "gripper_frame": "link6_flange",
    "gripper_open_pose": "open", "gripper_close_pose": "half_closed", "arm_home_pose": "home",
    "world_frame": "base_link",
    "table_name": "table", "table_reference_frame": "base_link", "table_dimensions": [0.10, 0.20, 0.03],
    "table_pose": [0.22, 0.12, 0.0, 0.0, 0.0, 0.0],
    "object_name": "object", "object_reference_frame": "base_link", "object_dimensions": [0.35, 0.0125],
    "object_pose": [0.22, 0.12, 0.0, 0.0, 0.0, 0.0],
    "grasp_frame_transform": [0.0, 0.0, 0.096, 1.5708, 0.0, 0.0], "place_pose": [-0.183, -0.14, 0.0, 0.0, 0.0, 0.0],
    "place_surface_offset": -0.03,
    "approach_object_min_dist": 0.0015, "approach_object_max_dist": 0.3, "lift_object_min_dist": 0.005,
    "lift_object_max_dist": 0.3, "lower_object_min_dist": 0.005, "lower_object_max_dist": 0.4,
    "move_to_pick_timeout": 5.0, "move_to_place_timeout": 10.0,
    "grasp_pose_angle_delta": 0.2618, "grasp_pose_max_ik_solutions": 8, "grasp_pose_min_solution_distance": 1.0,
    "place_pose_max_ik_solutions": 2,
    "cartesian_max_velocity_scaling": 1.0, "cartesian_max_acceleration_scaling": 1.0, "cartesian_step_size": 0.00025,
    "approach_object_direction_z": 1.0, "lift_object_direction_z": 1.0, "lower_object_direction_z": -1.0,
    "retreat_direction_z": -1.0,
    "place_pose_z_offset_factor": 0.5, "retreat_min_distance": 0.025, "retreat_max_distance": 0.25,
}

#: The seed's stage tree: (depth, name) in pre-order.
SEED_TREE = [
    (0, "pick_place_task"),
    (1, "current state"), (1, "open gripper"), (1, "move to pick"),
    (1, "pick object"),
    (2, "approach object"), (2, "grasp pose IK"), (3, "generate grasp pose"), (2, "allow collision (gripper,object)"),
    (2, "close gripper"), (2, "attach object"), (2, "allow collision (object,support)"), (2, "lift object"),
    (2, "forbid collision (object,surface)"),
    (1, "move to place"),
    (1, "place object"),
    (2, "lower object"), (2, "place pose IK"), (3, "generate place pose"), (2, "open gripper"),
    (2, "forbid collision (gripper,object)"), (2, "detach object"), (2, "retreat after place"),
    (1, "move home"),
]
CONTROLLERS = ["arm_controller", "grip_action_controller"]


@pytest.fixture(scope="module")
def model() -> RobotModel:
    return RobotModel.mycobot()


# ---------------------------------------------------------------------------- helpers




def replay(model: RobotModel, msg: TaskSolution) -> PlanningScene:
    scene, moved = replay_task_solution(model, msg)
    assert moved >= 10  # open, move to pick, approach, close, lift, move to place, lower, open, retreat, home
    return scene


def assert_placed(scene: PlanningScene, params: PickPlaceParameters, tolerance: float = 0.01) -> None:
    """The object stands upright at the expected place pose, in the world, nothing attached."""
    assert scene.attached_object_ids() == []
    pose = scene.frame_pose(params.object_name)
    expected = expected_place_pose(params)
    assert np.linalg.norm(pose[:3, 3] - expected[:3, 3]) <= tolerance, (pose[:3, 3], expected[:3, 3])
    assert abs(float(pose[:3, 2] @ expected[:3, 2])) > math.cos(math.radians(2.0))  # axis as at the target


def plan(model, params: PickPlaceParameters, scene: PlanningScene | None = None, seed: int = 1):
    task = build_pick_place_task(model, params, scene if scene is not None else pick_place_scene(model, params),
                                 seed=seed)
    return task, task.plan(params.max_solutions)


# ---------------------------------------------------------------------------- parameters
def test_parameters_are_the_seeds_with_its_defaults():
    assert list(MTC_NODE_PARAMETER_NAMES) == list(SEED_DEFAULTS)
    defaults = PickPlaceParameters().as_dict()
    assert {k: defaults[k] for k in SEED_DEFAULTS} == SEED_DEFAULTS
    assert set(defaults) - set(SEED_DEFAULTS) == {"eef_name", "surface_link"}  # Example 1's two
    for name in PARAMETERS:
        assert PARAMETERS[name].description


def test_parameter_files(model):
    with open(config_file("mtc_node_params.yaml"), encoding="utf-8") as handle:
        mtc = yaml.safe_load(handle)["mtc_node"]["ros__parameters"]
    assert {k: mtc[k] for k in SEED_DEFAULTS} == SEED_DEFAULTS
    assert set(mtc) - set(SEED_DEFAULTS) <= {"exit_when_done", "seed", "planning_timeout"}  # the task node's own
    assert load_parameters(config_file("mtc_node_params.yaml")) == PickPlaceParameters()

    with open(config_file("pick_place_demo_params.yaml"), encoding="utf-8") as handle:
        demo = yaml.safe_load(handle)["pick_place_demo"]["ros__parameters"]
    assert list(demo) == list(PICK_PLACE_DEMO_PARAMETERS)  # Example 1's file, in its order
    params = load_parameters(config_file("pick_place_demo_params.yaml"))
    assert (params.eef, params.support_surface) == ("gripper", "table")
    assert all(demo[k] == SEED_DEFAULTS[k] for k in demo if k in SEED_DEFAULTS)


@pytest.mark.parametrize("changes, message", [
    ({"table_dimensions": (0.1, 0.2)}, "table_dimensions must have exactly 3 values, got 2"),
    ({"object_pose": (0.2, 0.1, 0.0)}, "object_pose must have exactly 6 values, got 3"),
    ({"grasp_frame_transform": (0, 0, 0.1, 0, 0, 0, 1)}, "grasp_frame_transform must have exactly 6 values"),
    ({"object_dimensions": (0.35, 0.0)}, "object_dimensions must contain positive sizes"),
    ({"object_name": ""}, "object_name must not be empty"),
    ({"arm_group_name": "  "}, "arm_group_name must not be empty"),
    ({"controller_names": ()}, "controller_names must not be empty"),
    ({"controller_names": ("arm_controller", "")}, "controller_names must not be empty or contain empty names"),
    ({"max_solutions": -1}, "max_solutions must be within [0, 1000]"),
    ({"grasp_pose_angle_delta": 0.0}, "grasp_pose_angle_delta must be within"),
    ({"cartesian_step_size": 0.0}, "cartesian_step_size must be > 0"),
    ({"cartesian_max_velocity_scaling": 1.5}, "cartesian_max_velocity_scaling must be within [0, 1]"),
    ({"lift_object_direction_z": 0.0}, "lift_object_direction_z must not be 0"),
    ({"place_surface_offset": float("nan")}, "place_surface_offset must be a finite number"),
    ({"approach_object_min_dist": 0.5}, "approach_object_min_dist (0.5) must not exceed approach_object_max_dist (0.3)"),
    ({"max_solutions": 2.5}, "max_solutions must be an integer"),
    ({"spawn_table": "yes"}, "spawn_table must be true or false"),
    ({"table_pose": ("a", 0, 0, 0, 0, 0)}, "table_pose must be a list of numbers"),
])
def test_invalid_parameters_are_refused_naming_the_problem(changes, message):
    with pytest.raises(ValueError) as info:
        PickPlaceParameters(**changes)
    assert message in str(info.value)


def test_parameter_problem_checks_one_value_as_the_nodes_do():
    assert parameter_problem("table_dimensions", [0.1, 0.2]) == "table_dimensions must have exactly 3 values, got 2"
    assert parameter_problem("gripper_frame", "") == "gripper_frame must not be empty"
    assert parameter_problem("retreat_direction_z", 0.0).startswith("retreat_direction_z must not be 0")
    assert parameter_problem("object_pose", [0.2, 0.1, 0.0, 0.0, 0.0, 0.0]) is None
    assert parameter_problem("object_hight", 0.3) == "unknown parameter 'object_hight'"


def test_unknown_names_and_names_the_robot_lacks(model):
    with pytest.raises(ValueError, match="unknown pick-and-place parameter"):
        PickPlaceParameters.from_mapping({"object_hight": 0.3})
    with pytest.raises(ValueError, match="no planning group 'arms'"):
        build_pick_place_task(model, PickPlaceParameters(arm_group_name="arms"))
    with pytest.raises(ValueError) as info:
        build_pick_place_task(model, PickPlaceParameters(gripper_close_pose="shut", gripper_frame="flange",
                                                         eef_name="hand"))
    text = str(info.value)
    assert "has no named state 'shut'" in text and "open, half_closed, closed" in text
    assert "no link 'flange'" in text and "no end effector 'hand'" in text


# ---------------------------------------------------------------------------- scene
def test_vector_to_pose_rotates_about_x_then_y_then_z():
    r, p, y = 0.3, -0.4, 1.1
    pose = vector_to_pose([0.1, 0.2, 0.3, r, p, y])

    def axis(k, a):
        m = np.eye(3)
        c, s = math.cos(a), math.sin(a)
        i, j = [(1, 2), (0, 2), (0, 1)][k]
        m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
        if k == 1:
            m[i, j], m[j, i] = s, -s
        return m

    assert np.allclose(pose[:3, :3], axis(0, r) @ axis(1, p) @ axis(2, y))
    assert np.allclose(pose[:3, 3], [0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match="6 finite numbers"):
        vector_to_pose([0, 0, 0, 0, 0])


def test_scene_objects_are_posed_as_the_seed_computes_them():
    table, cylinder = seed_scene_objects(PickPlaceParameters())
    assert table.id == "table" and table.frame_id == "base_link"
    assert table.primitives[0].type == SolidPrimitive.BOX and table.primitives[0].dimensions == [0.10, 0.20, 0.03]
    assert np.allclose(table.pose.to_matrix()[:3, 3], [0.22, 0.12, -0.015])  # top at z = 0
    assert cylinder.id == "object" and cylinder.primitives[0].type == SolidPrimitive.CYLINDER
    assert cylinder.primitives[0].dimensions == [0.35, 0.0125]
    assert np.allclose(cylinder.pose.to_matrix()[:3, 3], [0.22, 0.12, 0.175])  # standing on the table
    assert np.allclose(expected_place_pose(PickPlaceParameters())[:3, 3], [-0.183, -0.14, 0.145])  # 0.175 - 0.03

    params = PickPlaceParameters(spawn_table=False, object_pose=(0.2, 0.1, 0.05, 0.0, 0.0, 0.7),
                                 place_pose_z_offset_factor=0.25, object_dimensions=(0.2, 0.02))
    table, cylinder = seed_scene_objects(params)
    assert table is None
    expected = vector_to_pose([0.2, 0.1, 0.05, 0.0, 0.0, 0.7])
    expected[2, 3] += 0.25 * 0.2
    assert np.allclose(cylinder.pose.to_matrix(), expected)


# ---------------------------------------------------------------------------- the task
def test_the_stage_tree_is_the_seeds(model):
    task = build_pick_place_task(model)
    assert [(depth, stage.name) for stage, depth in task.traverse()] == SEED_TREE
    assert task["move to pick"].timeout == 5.0 and task["move to place"].timeout == 10.0
    assert [g for g, _ in task["move to pick"].planners] == ["arm", "gripper"]


@pytest.fixture(scope="module")
def planned(model):
    params = PickPlaceParameters()
    task, code = plan(model, params)
    assert code, task.explainFailure(stream=None)
    return task, params


def test_plans_max_solutions_with_ascending_costs(planned):
    task, params = planned
    assert task.numSolutions() == params.max_solutions == 10
    costs = [s.cost for s in task.solutions]
    assert all(math.isfinite(c) for c in costs) and costs == sorted(costs)
    rows = {row["path"]: row for row in task.stage_summary()}
    assert rows["pick object/grasp pose IK/generate grasp pose"]["solutions"] == 24  # 2 pi / 0.2618
    assert rows["pick object/grasp pose IK"]["solutions"] >= 1


def test_every_solution_replays_validly_and_places_the_object(planned, model):
    task, params = planned
    for solution in task.solutions:
        msg = task.to_msg(solution)
        end = replay(model, msg)
        assert_placed(end, params)
        assert np.allclose(end.current_state.group_positions("arm"), 0.0, atol=1e-3)  # 'home'
        assert end.current_state.joint_position("gripper_controller") == pytest.approx(0.0, abs=1e-6)  # 'open'
        assert sorted(end.world_object_ids()) == ["object", "table"]
        steps = [s.info.stage_name for s in msg.sub_trajectory]
        assert steps[:3] == ["current state", "open gripper", "move to pick"] and steps[-1] == "move home"


def test_steps_carry_the_seeds_settings(planned, model):
    task, params = planned
    msg = task.to_msg()
    steps = {s.info.stage_name: s for s in msg.sub_trajectory}
    for name in ("approach object", "close gripper", "lift object", "lower object", "retreat after place", "move home"):
        assert steps[name].execution_info.controller_names == CONTROLLERS, name
    assert steps["move to pick"].trajectory.group_name == "arm_with_gripper"  # arm (OMPL) + gripper merged
    assert steps["close gripper"].trajectory.group_name == "gripper"
    solution = task.solutions[0]
    by_path = {s.creator.path: s for s in solution.sub_trajectories()}
    grasp = by_path["pick object/grasp pose IK"].end.scene
    tcp = grasp.current_state.frame_pose(params.gripper_frame) @ vector_to_pose(params.grasp_frame_transform)
    assert np.allclose(tcp[:3, 3], grasp.frame_pose("object")[:3, 3], atol=1e-4)  # TCP at the object's centre
    lift = by_path["pick object/lift object"]
    rise = lift.end.scene.frame_pose("object")[2, 3] - lift.start.scene.frame_pose("object")[2, 3]
    assert params.lift_object_min_dist <= rise <= params.lift_object_max_dist + 1e-6
    assert lift.start.scene.acm.is_allowed("object", "table")
    assert not by_path["pick object/forbid collision (object,surface)"].end.scene.acm.is_allowed("object", "table")
    retreat = by_path["place object/retreat after place"]
    moved = np.linalg.norm(retreat.end.scene.current_state.frame_pose(params.gripper_frame)[:3, 3]
                           - retreat.start.scene.current_state.frame_pose(params.gripper_frame)[:3, 3])
    assert params.retreat_min_distance - 1e-6 <= moved <= params.retreat_max_distance + 1e-6


# ---------------------------------------------------------------------------- parameters change the plan
def test_a_different_object_pose_is_picked_there(model):
    params = PickPlaceParameters(object_pose=(0.20, 0.15, 0.0, 0.0, 0.0, 0.0), table_pose=(0.20, 0.15, 0.0, 0.0, 0.0, 0.0),
                                 max_solutions=1)
    task, code = plan(model, params)
    assert code, task.explainFailure(stream=None)
    by_path = {s.creator.path: s for s in task.solutions[0].sub_trajectories()}
    attach = by_path["pick object/attach object"].start.scene
    assert np.allclose(attach.frame_pose("object")[:3, 3], [0.20, 0.15, 0.175], atol=1e-9)
    tcp = attach.current_state.frame_pose(params.gripper_frame) @ vector_to_pose(params.grasp_frame_transform)
    assert np.allclose(tcp[:3, 3], [0.20, 0.15, 0.175], atol=1e-4)
    assert_placed(replay(model, task.to_msg()), params)


def test_a_different_place_pose_places_the_object_there(model):
    params = PickPlaceParameters(place_pose=(-0.183, 0.14, 0.0, 0.0, 0.0, 0.0), max_solutions=1)
    task, code = plan(model, params)
    assert code, task.explainFailure(stream=None)
    end = replay(model, task.to_msg())
    assert_placed(end, params)
    assert np.allclose(end.frame_pose("object")[:3, 3], [-0.183, 0.14, 0.145], atol=0.01)


def test_table_size_shapes_the_scene_and_the_plan(model):
    # a bigger, thicker table: its top stays at table_pose, every motion avoids the larger box
    params = PickPlaceParameters(table_dimensions=(0.20, 0.30, 0.05), max_solutions=1)
    scene = pick_place_scene(model, params)
    table = scene.get_object("table")
    assert table.primitives[0].dimensions == [0.20, 0.30, 0.05]
    assert np.allclose(table.pose.to_matrix()[:3, 3], [0.22, 0.12, -0.025])
    task, code = plan(model, params, scene)
    assert code, task.explainFailure(stream=None)
    assert_placed(replay(model, task.to_msg()), params)

    # a table under the place location: the object cannot go 3 cm into it ...
    under = dict(table_pose=(-0.183, -0.14, 0.0, 0.0, 0.0, 0.0), table_dimensions=(0.15, 0.15, 0.03), max_solutions=1)
    task, code = plan(model, PickPlaceParameters(**under))
    assert not code and code.val == MoveItErrorCode.PLANNING_FAILED
    assert "place pose IK" in task.explainFailure(stream=None)
    # ... but stands on it when placed at its surface
    params = PickPlaceParameters(**under, place_surface_offset=0.002)
    task, code = plan(model, params)
    assert code, task.explainFailure(stream=None)
    end = replay(model, task.to_msg())
    assert_placed(end, params)
    assert end.frame_pose("object")[2, 3] == pytest.approx(0.177, abs=0.005)


def test_without_table_the_scene_holds_only_the_object(model):
    params = PickPlaceParameters(spawn_table=False, max_solutions=1)
    scene = pick_place_scene(model, params)
    assert scene.world_object_ids() == ["object"]
    task, code = plan(model, params, scene)
    assert code, task.explainFailure(stream=None)
    end = replay(model, task.to_msg())
    assert end.world_object_ids() == ["object"]
    assert_placed(end, params)


def test_an_unreachable_object_fails_at_the_grasp_and_gives_nothing_to_execute(model):
    params = PickPlaceParameters(object_pose=(0.5, 0.0, 0.0, 0.0, 0.0, 0.0), table_pose=(0.5, 0.0, 0.0, 0.0, 0.0, 0.0))
    task, code = plan(model, params)
    assert not code and code.val == MoveItErrorCode.PLANNING_FAILED
    explanation = task.explainFailure(stream=None)
    assert "grasp pose IK" in explanation and "no IK found" in explanation
    assert "grasp pose IK" in code.message
    assert task.numSolutions() == 0 and task.solutions == []


def test_a_seeded_plan_is_the_same_with_the_threads_kept_ik_solvers_and_in_a_new_thread(model):
    """Tasks take their IK solvers from the planning thread (kept across tasks): the same seed
    gives the same solutions again in this thread (solvers reused) and in a new thread (solvers
    built afresh)."""
    import threading

    params = PickPlaceParameters()

    def solutions() -> list:
        task = build_pick_place_task(model, params, pick_place_scene(model, params), seed=7)
        assert task.plan(3)
        return [(s.cost, [sub.trajectory.positions for sub in s.sub_trajectories() if sub.trajectory is not None])
                for s in task.solutions]

    first, again = solutions(), solutions()
    elsewhere: list = []
    thread = threading.Thread(target=lambda: elsewhere.append(solutions()))
    thread.start()
    thread.join(120.0)
    assert len(first) == 3 and elsewhere
    for other in (again, elsewhere[0]):
        assert [cost for cost, _ in other] == [cost for cost, _ in first]
        for (_, mine), (_, reference) in zip(other, first):
            assert len(mine) == len(reference) and all(np.array_equal(a, b) for a, b in zip(mine, reference))
