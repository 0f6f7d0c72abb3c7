"""Export a task solution: an interfaces_py TaskSolution (for execution through the
planning_server) and one concatenated JointTrajectory (for ``ros2 topic echo`` and simple
controllers).

TaskSolution: ``start_scene`` (full scene of the solution's start) and one SubTrajectory per
primitive step in execution order. Each carries the creating stage's id and name, cost and
comment, the stage's ``trajectory_execution_info`` (controller names), the group trajectory
(empty for pure scene changes such as "attach object"), and ``scene_diff``: what changed in the
scene between the step's start and end, apart from joint values (attached and detached objects,
world objects, the allowed collision matrix). The executor runs the trajectory, then applies the
diff, as MTC's ExecuteTaskSolution does.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Callable, Iterable

import numpy as np

from interfaces_py.msgs import (
    AttachedCollisionObject,
    CollisionObject,
    JointTrajectory,
    JointTrajectoryPoint,
    PlanningScene as PlanningSceneMsg,
    PlanningSceneWorld,
    RobotState as RobotStateMsg,
    RobotTrajectory,
    SolutionInfo,
    SubTrajectory as SubTrajectoryMsg,
    TaskSolution,
    TrajectoryExecutionInfo,
)

from ..core.planning_scene.planning_scene import PlanningScene
from ..core.robot_trajectory.robot_trajectory import timed_to_joint_trajectory
from .errors import TaskError
from .storage import SolutionBase, SubTrajectory

if TYPE_CHECKING:  # pragma: no cover
    from .task import Task

__all__ = ["scene_diff_msg", "solution_joint_trajectory", "solution_to_msg", "timed_to_joint_trajectory"]


def _new_or_changed(start_ids: Iterable[str], end_ids: Iterable[str], start_object: Callable[[str], Any],
                    end_object: Callable[[str], Any]) -> list[Any]:
    """The end scene's objects (``end_object(id)`` of each of ``end_ids``) that the start scene
    has not, or has with other contents."""
    start_set = set(start_ids)
    changed = []
    for object_id in end_ids:
        msg = end_object(object_id)
        if object_id not in start_set or start_object(object_id).to_dict() != msg.to_dict():
            changed.append(msg)
    return changed


def scene_diff_msg(start: PlanningScene, end: PlanningScene) -> PlanningSceneMsg:
    """The changes from ``start`` to ``end`` other than joint values, as a diff message.

    Attached objects that are new or changed come as AttachedCollisionObject ADD (object posed
    in its link frame); detached ones as REMOVE with their link. World objects that appeared or
    changed come as ADD in the world frame, vanished ones (neither in the world nor attached)
    as REMOVE. The ACM is included in full when it changed.
    """
    end_attached = set(end.attached_object_ids())
    attached = _new_or_changed(start.attached_object_ids(), end.attached_object_ids(), start.get_attached_object,
                               end.get_attached_object)
    for object_id in start.attached_object_ids():
        if object_id not in end_attached:
            link = start.get_attached_object(object_id).link_name
            attached.append(AttachedCollisionObject(
                link_name=link, object=CollisionObject(id=object_id, frame_id=link, operation=CollisionObject.REMOVE)))
    end_world = set(end.world_object_ids())
    world = _new_or_changed(start.world_object_ids(), end.world_object_ids(), start.get_object, end.get_object)
    for object_id in start.world_object_ids():
        if object_id not in end_world and object_id not in end_attached:
            world.append(CollisionObject(id=object_id, frame_id="world", operation=CollisionObject.REMOVE))
    kwargs = {}
    if start.acm != end.acm:
        kwargs["allowed_collision_matrix"] = end.acm.to_msg()
    return PlanningSceneMsg(
        name=end.name,
        robot_model_name=end.robot_model.name,
        fixed_frame="world",
        robot_state=RobotStateMsg(attached_collision_objects=attached, is_diff=True),
        world=PlanningSceneWorld(collision_objects=world),
        is_diff=True,
        **kwargs,
    )


def _sub_msg(sub: SubTrajectory, sample_period: float | None) -> SubTrajectoryMsg:
    creator = sub.creator
    info = SolutionInfo(id=sub.id, cost=float(sub.cost), comment=sub.comment,
                        stage_id=creator.id if creator is not None else 0,
                        stage_name=creator.name if creator is not None else "", planner_id=sub.planner_id or "")
    execution = creator.properties.get("trajectory_execution_info") if creator is not None else None
    trajectory = RobotTrajectory(joint_trajectory=timed_to_joint_trajectory(sub.trajectory, sample_period),
                                 group_name=sub.group or "")
    return SubTrajectoryMsg(info=info, execution_info=execution or TrajectoryExecutionInfo(), trajectory=trajectory,
                            scene_diff=scene_diff_msg(sub.start.scene, sub.end.scene))  # type: ignore[union-attr]


def solution_to_msg(task: "Task", solution: SolutionBase, sample_period: float | None = None) -> TaskSolution:
    """The solution as a TaskSolution message (sub-trajectories in execution order)."""
    if solution.is_failure:
        raise TaskError("cannot export a failed solution")
    subs = solution.sub_trajectories()
    if not subs:
        raise TaskError("the solution has no steps")
    return TaskSolution(
        task_id=task.name,
        start_scene=solution.start.scene.get_planning_scene_msg(),  # type: ignore[union-attr]
        sub_trajectory=[_sub_msg(sub, sample_period) for sub in subs],
        cost=float(solution.cost),
        comment=solution.comment,
    )


def solution_joint_trajectory(solution: SolutionBase, sample_period: float | None = None) -> JointTrajectory:
    """All steps of a solution as one JointTrajectory over every joint any step moves.

    Joints a step does not move hold their value (velocity and acceleration 0); times run on
    across steps; the first point of a step that repeats the previous step's last point is
    dropped so time stamps stay strictly increasing.
    """
    subs = [s for s in solution.sub_trajectories() if s.trajectory is not None and len(s.trajectory) > 0]
    start_state = solution.start.scene.current_state  # type: ignore[union-attr]
    model = start_state.model
    moved = {name for s in subs for name in s.trajectory.joint_names}  # type: ignore[union-attr]
    names = [n for n in model.variable_names if n in moved]
    if not names:
        return JointTrajectory(joint_names=[], points=[])
    index = {n: i for i, n in enumerate(names)}
    current = np.array([start_state.positions[model.variable_index(n)] for n in names])
    points: list[JointTrajectoryPoint] = []
    offset = 0.0
    for sub in subs:
        traj = sub.trajectory
        if sample_period is not None and len(traj) > 1:  # type: ignore[arg-type]
            traj = traj.resample(sample_period)  # type: ignore[union-attr]
        columns = np.array([index[n] for n in traj.joint_names], dtype=int)  # type: ignore[union-attr]
        times = np.asarray(traj.times, dtype=float) - float(traj.times[0])  # type: ignore[union-attr]
        for k in range(len(traj)):  # type: ignore[arg-type]
            t = offset + float(times[k])
            if points and t <= points[-1].time_from_start:
                current[columns] = traj.positions[k]  # type: ignore[union-attr]
                continue
            positions = current.copy()
            positions[columns] = traj.positions[k]  # type: ignore[union-attr]
            velocities = np.zeros(len(names))
            accelerations = np.zeros(len(names))
            velocities[columns] = traj.velocities[k]  # type: ignore[union-attr]
            accelerations[columns] = traj.accelerations[k]  # type: ignore[union-attr]
            current = positions
            points.append(JointTrajectoryPoint(positions=positions, velocities=velocities,
                                               accelerations=accelerations, time_from_start=t))
        offset += float(times[-1])
    return JointTrajectory(joint_names=names, points=points)
