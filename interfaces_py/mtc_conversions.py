"""moveit_task_constructor_msgs <-> the JSON form of interfaces_py.msgs (TaskDescription,
TaskStatistics, TaskSolution): what MTC's introspection topics, its GetSolution service and its
ExecuteTaskSolution action carry, translated once. No rclpy here."""
from __future__ import annotations

from typing import Any, Mapping

from moveit_task_constructor_msgs.msg import (
    Property,
    Solution,
    SolutionInfo,
    StageDescription,
    StageStatistics,
    SubSolution,
    SubTrajectory,
    TaskDescription,
    TaskStatistics,
    TrajectoryExecutionInfo,
)

from interfaces_py.moveit_conversions import (
    ConversionError,
    joint_trajectory_from_msg,
    planning_scene_from_msg,
    planning_scene_to_msg,
    robot_trajectory_to_msg,
)
from interfaces_py.msgs import TaskDescription as TaskDescriptionJson
from interfaces_py.msgs import TaskSolution as TaskSolutionJson
from interfaces_py.msgs import TaskStatistics as TaskStatisticsJson

#: MTC's StageDescription property naming the stage's class (the viewer and RViz show it)
TYPE_PROPERTY = "stage_type"


def task_description_to_msg(description: TaskDescriptionJson) -> TaskDescription:
    msg = TaskDescription(task_id=description.task_id)
    for stage in description.stages:
        entry = StageDescription(id=stage.id, parent_id=stage.parent_id, name=stage.name, flags=stage.flags)
        if stage.type:
            entry.properties = [Property(name=TYPE_PROPERTY, description="the stage's class", type="std::string",
                                         value=stage.type)]
        msg.stages.append(entry)
    return msg


def task_statistics_to_msg(statistics: TaskStatisticsJson) -> TaskStatistics:
    msg = TaskStatistics(task_id=statistics.task_id)
    for stage in statistics.stages:
        msg.stages.append(StageStatistics(id=stage.id, solved=[int(i) for i in stage.solved],
                                          failed=[int(i) for i in stage.failed], num_failed=int(stage.num_failed),
                                          total_compute_time=float(stage.total_compute_time)))
    return msg


def task_solution_to_msg(solution: TaskSolutionJson, solution_id: int = 0, stage_id: int = 1) -> Solution:
    """A complete solution: the root container's SubSolution (id ``solution_id``, listing every
    step) and the steps as SubTrajectory messages, in execution order."""
    msg = Solution(task_id=solution.task_id)
    msg.start_scene = planning_scene_to_msg(solution.start_scene.to_dict())
    for sub in solution.sub_trajectory:
        out = SubTrajectory()
        out.info = SolutionInfo(id=sub.info.id, cost=float(sub.info.cost), comment=sub.info.comment,
                                stage_id=sub.info.stage_id, planner_id=sub.info.planner_id)
        out.execution_info = TrajectoryExecutionInfo(controller_names=list(sub.execution_info.controller_names))
        if sub.has_trajectory:
            out.trajectory = robot_trajectory_to_msg(sub.trajectory.to_dict())
        out.scene_diff = planning_scene_to_msg(sub.scene_diff.to_dict(), diff=True)
        msg.sub_trajectory.append(out)
    msg.sub_solution = [SubSolution(info=SolutionInfo(id=solution_id, cost=float(solution.cost),
                                                      comment=solution.comment, stage_id=stage_id),
                                    sub_solution_id=[s.info.id for s in solution.sub_trajectory])]
    return msg


def task_solution_from_msg(msg: Solution) -> dict[str, Any]:
    """The JSON TaskSolution the planning core executes (``execute_task_solution``)."""
    if not len(msg.sub_trajectory):
        raise ConversionError(-2, "the solution has no sub_trajectory to execute")
    steps = []
    for k, sub in enumerate(msg.sub_trajectory):
        if len(sub.trajectory.multi_dof_joint_trajectory.points):
            raise ConversionError(-2, f"sub_trajectory {k}: multi-DOF trajectories are not supported")
        step: dict[str, Any] = {
            "info": {"id": int(sub.info.id), "cost": float(sub.info.cost), "comment": sub.info.comment,
                     "stage_id": int(sub.info.stage_id), "planner_id": sub.info.planner_id},
            "execution_info": {"controller_names": list(sub.execution_info.controller_names)},
            "scene_diff": _diff(planning_scene_from_msg(sub.scene_diff)),
        }
        if len(sub.trajectory.joint_trajectory.points):
            step["trajectory"] = {"joint_trajectory": joint_trajectory_from_msg(sub.trajectory.joint_trajectory)}
        steps.append(step)
    return {"task_id": msg.task_id, "sub_trajectory": steps}


def _diff(scene: Mapping[str, Any]) -> dict[str, Any]:
    diff = dict(scene)
    diff["is_diff"] = True
    state = dict(diff.get("robot_state") or {})
    state.update({"joint_names": [], "positions": [], "is_diff": True})
    diff["robot_state"] = state
    return diff
