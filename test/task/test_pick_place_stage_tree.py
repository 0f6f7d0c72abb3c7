"""A pick-and-place on the myCobot with the seed's stage tree (mtc_node): grasp generation with
a TCP ik_frame, attach / detach, allowed collisions, Connect with arm + gripper planners,
place generation monitoring the attach stage; the exported TaskSolution replays to the planned
scenes."""
from __future__ import annotations


import numpy as np
import pytest

from interfaces_py.msgs import TaskSolution
from mycobot_planning.core import PlanningScene
from task_helpers import CONTROLLERS, GRASP_FRAME, GRIPPER_FRAME, PLACE, assert_solution_valid, planned_pick_place, chain_is_continuous





@pytest.fixture(scope="module")
def planned(mycobot):
    return planned_pick_place(mycobot)


def _step(solution, path):
    return next(s for s in solution.sub_trajectories() if s.creator.path == path)


def test_interfaces_resolve_like_the_seed(planned):
    arrows = {row["path"]: row["interface"] for row in planned.stage_summary()}
    assert arrows["move to pick"] == "→ ←"
    assert arrows["pick object"] == "← →"
    assert arrows["pick object/approach object"] == "← ←"  # planned backward from the grasp
    assert arrows["pick object/grasp pose IK"] == "← →"
    assert arrows["pick object/grasp pose IK/generate grasp pose"] == "← →"
    assert arrows["pick object/lift object"] == "→ →"
    assert arrows["place object/lower object"] == "← ←"
    assert arrows["move home"] == "→ →"


def test_every_step_is_valid_and_continuous(planned):
    solution = planned.solutions[0]
    assert assert_solution_valid(solution) >= 9
    chain_is_continuous(solution)
    groups = {s.creator.path: s.group for s in solution.sub_trajectories() if s.trajectory is not None}
    assert groups["move to pick"] == "arm_with_gripper"  # arm and gripper plans merged
    assert groups["pick object/close gripper"] == "gripper"


def test_grasp_and_place_stages(planned, mycobot):
    solution = planned.solutions[0]
    grasp = _step(solution, "pick object/grasp pose IK")
    state = grasp.end.scene.current_state
    tcp = state.frame_pose(GRIPPER_FRAME) @ GRASP_FRAME
    object_pose = grasp.end.scene.frame_pose("object")
    assert np.allclose(tcp[:3, 3], object_pose[:3, 3], atol=1e-4)  # TCP at the object's centre
    assert np.allclose(tcp[:3, 2], [0.0, 0.0, 1.0], atol=1e-4)  # grasp frame z = object z (rotated about it)
    assert grasp.end.scene.current_state.joint_position("gripper_controller") == 0.0  # pregrasp 'open'
    generator = planned["pick object/grasp pose IK/generate grasp pose"]
    assert len(generator.solutions) == 24  # a full turn in steps of 0.2618
    ik = planned["pick object/grasp pose IK"]
    assert all(f.comment.endswith("no IK found") or f.comment.startswith(("Collision", "0.", "1.", "2.", "3.", "4.",
                                                                          "5.", "6."))
               for f in ik.failures)

    attach = _step(solution, "pick object/attach object")
    assert attach.end.scene.attached_object_ids() == ["object"]
    assert attach.start.scene.attached_object_ids() == []
    lift = _step(solution, "pick object/lift object")
    assert lift.end.scene.frame_pose("object")[2, 3] - lift.start.scene.frame_pose("object")[2, 3] >= 0.005
    assert lift.start.scene.acm.is_allowed("object", "table")
    assert not _step(solution, "pick object/forbid collision (object,surface)").end.scene.acm.is_allowed("object", "table")

    placed = _step(solution, "place object/detach object").end.scene
    assert placed.world_object_ids() == ["table", "object"] or sorted(placed.world_object_ids()) == ["object", "table"]
    pose = placed.frame_pose("object")
    assert np.allclose(pose[:3, 3], PLACE[:3, 3], atol=1e-3)
    assert np.allclose(pose[:3, 2], [0.0, 0.0, 1.0], atol=1e-3)  # standing upright
    end = solution.end.scene
    assert np.allclose(end.current_state.group_positions("arm"), 0.0, atol=1e-4)  # back home
    assert np.allclose(end.frame_pose("object"), pose)


def test_exported_solution_replays_to_the_planned_scenes(planned, mycobot):
    solution = planned.solutions[0]
    msg = planned.to_msg()
    assert TaskSolution.from_json(msg.to_json()) == msg
    steps = solution.sub_trajectories()
    assert [s.info.stage_name for s in msg.sub_trajectory] == [s.creator.name for s in steps]
    by_name = {s.info.stage_name: s for s in msg.sub_trajectory}
    assert by_name["move to pick"].execution_info.controller_names == CONTROLLERS  # inherited from the task
    assert msg.sub_trajectory[1].info.stage_name == "open gripper"
    assert msg.sub_trajectory[1].execution_info.controller_names == CONTROLLERS  # set on the stage
    assert by_name["lift object"].execution_info.controller_names == []  # not configured: executor's choice
    attach_diff = by_name["attach object"].scene_diff
    assert [(a.object.id, a.link_name, a.object.operation_name) for a in attach_diff.robot_state.attached_collision_objects] \
        == [("object", GRIPPER_FRAME, "ADD")]
    detach_diff = by_name["detach object"].scene_diff
    assert [a.object.operation_name for a in detach_diff.robot_state.attached_collision_objects] == ["REMOVE"]
    assert [o.id for o in detach_diff.world.collision_objects] == ["object"]

    # Replay as the planning_server executes it: run each trajectory, then apply its diff.
    replay = PlanningScene.from_msg(mycobot, msg.start_scene)
    for step, sub in zip(msg.sub_trajectory, steps):
        points = step.trajectory.joint_trajectory.points
        if points:
            replay.set_current_state(dict(zip(step.trajectory.joint_trajectory.joint_names, points[-1].positions)))
        replay.apply_planning_scene_msg(step.scene_diff)
        planned_scene = sub.end.scene
        assert sorted(replay.attached_object_ids()) == sorted(planned_scene.attached_object_ids()), sub.creator.path
        assert sorted(replay.world_object_ids()) == sorted(planned_scene.world_object_ids()), sub.creator.path
        names = list(mycobot.link_names) + ["object", "table"]
        assert all(replay.acm.is_allowed(a, b) == planned_scene.acm.is_allowed(a, b) for a in names for b in names), \
            sub.creator.path
        assert np.allclose(replay.current_state.positions, planned_scene.current_state.positions, atol=1e-9)
        for object_id in planned_scene.world_object_ids() + planned_scene.attached_object_ids():
            assert np.allclose(replay.frame_pose(object_id), planned_scene.frame_pose(object_id), atol=1e-6)


def test_concatenated_joint_trajectory(planned, mycobot):
    solution = planned.solutions[0]
    trajectory = planned.joint_trajectory()
    assert trajectory.joint_names == [n for n in mycobot.variable_names]  # arm and gripper joints
    times = [p.time_from_start for p in trajectory.points]
    assert times[0] == 0.0 and all(b > a for a, b in zip(times, times[1:]))
    durations = sum(s.trajectory.duration for s in solution.sub_trajectories() if s.trajectory is not None)
    assert trajectory.duration == pytest.approx(durations)
    start = solution.start.scene.current_state
    assert np.allclose(trajectory.points[0].positions, start.positions)
    assert np.allclose(trajectory.points[-1].positions, solution.end.scene.current_state.positions)
    assert np.allclose(trajectory.points[-1].velocities, 0.0)
