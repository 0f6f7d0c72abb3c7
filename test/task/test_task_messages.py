"""Task-constructor messages in interfaces_py.msgs: exact JSON round trips and validation."""
from __future__ import annotations

import json

import pytest

from interfaces_py.msgs import (
    AttachedCollisionObject,
    CollisionObject,
    JointTrajectory,
    JointTrajectoryPoint,
    MessageError,
    PlanningScene,
    PlanningSceneWorld,
    Pose,
    RobotState,
    RobotTrajectory,
    SolutionInfo,
    StageDescription,
    StageStatistics,
    SubTrajectory,
    TaskDescription,
    TaskSolution,
    TaskStatistics,
    TrajectoryExecutionInfo,
)
from task_helpers import float_bits

AWKWARD = [0.1, 1e-300, -0.0, 1 / 3, 5e-324, 123456789.123456789]


def _bits(msg) -> list[str]:
    return float_bits(msg.to_dict())


def _sub(index: int) -> SubTrajectory:
    points = [
        JointTrajectoryPoint(positions=[AWKWARD[k % 6], 1 / 3], velocities=[0.0, -0.0], accelerations=[1e-300, 0.5],
                             time_from_start=0.1 * k)
        for k in range(3)
    ]
    attached = AttachedCollisionObject(
        link_name="link6_flange",
        object=CollisionObject.cylinder("object", 0.35, 0.0125, Pose.from_xyz_rpy([1 / 3, 0.0, 0.096], [1.5708, 0, 0]),
                                        frame_id="link6_flange"),
    )
    diff = PlanningScene(
        robot_model_name="mycobot_280",
        robot_state=RobotState(attached_collision_objects=[attached], is_diff=True),
        world=PlanningSceneWorld(collision_objects=[CollisionObject(id="gone", operation=CollisionObject.REMOVE)]),
        is_diff=True,
    )
    return SubTrajectory(
        info=SolutionInfo(id=index, cost=1 / 3 + index, comment=f"step {index}", stage_id=index + 1,
                          stage_name="lift object", planner_id="CartesianPath"),
        execution_info=TrajectoryExecutionInfo(controller_names=["arm_controller", "grip_action_controller"]),
        trajectory=RobotTrajectory(JointTrajectory(["link1_to_link2", "gripper_controller"], points), group_name="arm"),
        scene_diff=diff,
    )


def _solution() -> TaskSolution:
    start = PlanningScene(name="start", robot_model_name="mycobot_280",
                          robot_state=RobotState.from_joint_positions({"link1_to_link2": 1e-300, "link2_to_link3": -0.0}))
    return TaskSolution(task_id="pick_place_task", start_scene=start, sub_trajectory=[_sub(1), _sub(2), SubTrajectory()],
                        cost=0.1 + 0.2, comment="best")


@pytest.mark.parametrize("make", [
    lambda: TrajectoryExecutionInfo(controller_names=["arm_controller"]),
    lambda: SolutionInfo(id=7, cost=5e-324, comment="Clearance: distance 0.015 between 'obstacle' and 'gripper_left1'"),
    lambda: _sub(3),
    lambda: SubTrajectory(),
    _solution,
    lambda: TaskDescription(task_id="t", stages=[StageDescription(id=1, name="root", flags=12, type="SerialContainer"),
                                                 StageDescription(id=2, parent_id=1, name="current", flags=12)]),
    lambda: TaskStatistics(task_id="t", stages=[StageStatistics(id=1, solved=[3, 4], failed=[5], cost=[1 / 3, 1e-300],
                                                                num_failed=2, total_compute_time=0.1)]),
])
def test_round_trip_is_exact(make):
    msg = make()
    text = msg.to_json()
    back = type(msg).from_json(text)
    assert back == msg
    assert _bits(back) == _bits(msg)
    assert back.to_json() == text
    assert type(msg).from_dict(json.loads(text)) == msg


def test_sub_trajectory_defaults_are_an_empty_step():
    sub = SubTrajectory()
    assert not sub.has_trajectory
    assert sub.duration == 0.0
    assert sub.scene_diff.is_diff
    assert sub.trajectory.joint_trajectory.joint_names == []


def test_task_solution_helpers():
    solution = _solution()
    assert solution.duration == pytest.approx(0.4)
    assert solution.controller_names() == ["arm_controller", "grip_action_controller"]


def test_hand_written_json_fills_defaults():
    msg = TaskSolution.from_json('{"task_id": "x", "sub_trajectory": [{"info": {"id": 4, "stage_name": "open gripper"}}]}')
    assert msg.sub_trajectory[0].info.stage_name == "open gripper"
    assert msg.sub_trajectory[0].scene_diff.is_diff
    assert not msg.start_scene.is_diff


@pytest.mark.parametrize("build,field", [
    (lambda: TrajectoryExecutionInfo(controller_names=["a", "a"]), "TrajectoryExecutionInfo.controller_names"),
    (lambda: TrajectoryExecutionInfo(controller_names=[""]), "TrajectoryExecutionInfo.controller_names[0]"),
    (lambda: SolutionInfo(id=-1), "SolutionInfo.id"),
    (lambda: SolutionInfo(stage_id=-2), "SolutionInfo.stage_id"),
    (lambda: SubTrajectory(scene_diff=PlanningScene()), "SubTrajectory.scene_diff.is_diff"),
    (lambda: SubTrajectory(scene_diff=PlanningScene(
        robot_state=RobotState.from_joint_positions({"a": 1.0}), is_diff=True)), "SubTrajectory.scene_diff.robot_state.joint_names"),
    (lambda: TaskSolution(start_scene=PlanningScene(is_diff=True)), "TaskSolution.start_scene.is_diff"),
    (lambda: TaskSolution(sub_trajectory=[_sub(1), _sub(1)]), "TaskSolution.sub_trajectory"),
    (lambda: StageDescription(id=0), "StageDescription.id"),
    (lambda: StageDescription(id=2, parent_id=2), "StageDescription.parent_id"),
    (lambda: StageDescription(id=2, flags=16), "StageDescription.flags"),
    (lambda: TaskDescription(stages=[StageDescription(id=2, parent_id=3)]), "TaskDescription.stages[0].parent_id"),
    (lambda: TaskDescription(stages=[StageDescription(id=1), StageDescription(id=1)]), "TaskDescription.stages[1].id"),
    (lambda: StageStatistics(id=1, solved=[1, 2], cost=[0.5]), "StageStatistics.cost"),
    (lambda: StageStatistics(id=1, failed=[1, 2], num_failed=1), "StageStatistics.num_failed"),
    (lambda: StageStatistics(id=1, total_compute_time=-1.0), "StageStatistics.total_compute_time"),
    (lambda: TaskStatistics(stages=[StageStatistics(id=1), StageStatistics(id=1)]), "TaskStatistics.stages"),
])
def test_invalid_messages_name_the_field(build, field):
    with pytest.raises(MessageError) as info:
        build()
    assert info.value.field == field


def test_unknown_keys_and_bad_types_are_rejected():
    with pytest.raises(MessageError, match="SubTrajectory.infos"):
        SubTrajectory.from_dict({"infos": {}})
    with pytest.raises(MessageError) as info:
        TaskSolution.from_dict({"sub_trajectory": [{"info": {"cost": "cheap"}}]})
    assert info.value.field == "TaskSolution.sub_trajectory[0].info.cost"
    with pytest.raises(MessageError, match="must be finite"):
        SolutionInfo(cost=float("inf"))


def test_task_messages_are_listed():
    import interfaces_py.msgs as msgs

    assert set(msgs.TASK_MESSAGES) == {"TrajectoryExecutionInfo", "SolutionInfo", "SubTrajectory", "TaskSolution",
                                       "StageDescription", "TaskDescription", "StageStatistics", "TaskStatistics"}
    for name in msgs.TASK_MESSAGES:
        assert issubclass(getattr(msgs, name), msgs._Message)
