"""moveit_task_constructor_msgs equivalents: solutions, sub-trajectories, task descriptions and statistics."""
from __future__ import annotations

from dataclasses import dataclass, field

from .base import MessageError, _Message, _require_len, _require_unique_names
from .scene import PlanningScene
from .trajectory import JointTrajectory, RobotTrajectory


@dataclass
class TrajectoryExecutionInfo(_Message):
    """moveit_task_constructor_msgs/TrajectoryExecutionInfo: the controllers that execute a
    sub-trajectory. Empty means "whichever controllers drive the trajectory's joints"."""

    controller_names: list[str] = field(default_factory=list)

    def _validate(self) -> None:
        _require_unique_names("TrajectoryExecutionInfo.controller_names", self.controller_names)


@dataclass
class SolutionInfo(_Message):
    """moveit_task_constructor_msgs/SolutionInfo: which stage made a (sub-)solution, its cost
    and comment. ``stage_name`` and ``planner_id`` are additions for readable logs."""

    id: int = 0
    cost: float = 0.0
    comment: str = ""
    stage_id: int = 0
    stage_name: str = ""
    planner_id: str = ""

    def _validate(self) -> None:
        if self.id < 0:
            raise MessageError("SolutionInfo.id", f"must be >= 0, got {self.id}")
        if self.stage_id < 0:
            raise MessageError("SolutionInfo.stage_id", f"must be >= 0, got {self.stage_id}")


def _empty_robot_trajectory() -> RobotTrajectory:
    return RobotTrajectory(joint_trajectory=JointTrajectory(joint_names=[], points=[]))


def _empty_scene_diff() -> PlanningScene:
    return PlanningScene(is_diff=True)


@dataclass
class SubTrajectory(_Message):
    """moveit_task_constructor_msgs/SubTrajectory: one step of a task solution.

    Execution semantics (MTC's ExecuteTaskSolution): execute ``trajectory`` (may be empty, e.g.
    for "attach object") with ``execution_info.controller_names``, then apply ``scene_diff``
    (attached/detached objects, allowed collisions, world changes) to the monitored scene.
    The diff never carries joint values (``robot_state.joint_names`` is empty): joints move only
    through trajectories.
    """

    info: SolutionInfo = field(default_factory=SolutionInfo)
    execution_info: TrajectoryExecutionInfo = field(default_factory=TrajectoryExecutionInfo)
    trajectory: RobotTrajectory = field(default_factory=_empty_robot_trajectory)
    scene_diff: PlanningScene = field(default_factory=_empty_scene_diff)

    def _validate(self) -> None:
        if not self.scene_diff.is_diff:
            raise MessageError("SubTrajectory.scene_diff.is_diff", "must be true: a sub-trajectory carries a scene diff")
        if self.scene_diff.robot_state.joint_names:
            raise MessageError("SubTrajectory.scene_diff.robot_state.joint_names",
                               "must be empty: joints move only through the trajectory")

    @property
    def duration(self) -> float:
        return self.trajectory.joint_trajectory.duration

    @property
    def has_trajectory(self) -> bool:
        return bool(self.trajectory.joint_trajectory.points)


@dataclass
class TaskSolution(_Message):
    """moveit_task_constructor_msgs/Solution: a complete task solution, ready to execute.

    ``start_scene`` is the full scene the solution starts from (execution should refuse to start
    if the robot is elsewhere); ``sub_trajectory`` lists the steps in execution order. ``cost``
    and ``comment`` (additions) repeat the top-level solution's values.
    """

    task_id: str = ""
    start_scene: PlanningScene = field(default_factory=PlanningScene)
    sub_trajectory: list[SubTrajectory] = field(default_factory=list)
    cost: float = 0.0
    comment: str = ""

    @property
    def motion_duration(self) -> float:
        """Seconds of motion: the steps' trajectory durations added up."""
        return float(sum(sub.trajectory.joint_trajectory.points[-1].time_from_start
                         for sub in self.sub_trajectory if sub.trajectory.joint_trajectory.points))

    @property
    def moves(self) -> bool:
        """Whether any step carries a trajectory (a solution of only states moves nothing)."""
        return any(sub.trajectory.joint_trajectory.points for sub in self.sub_trajectory)

    def _validate(self) -> None:
        if self.start_scene.is_diff:
            raise MessageError("TaskSolution.start_scene.is_diff", "must be false: the start scene is a full scene")
        ids = [s.info.id for s in self.sub_trajectory]
        if len(set(ids)) != len(ids):
            raise MessageError("TaskSolution.sub_trajectory", "duplicate sub-trajectory info.id")

    @property
    def duration(self) -> float:
        """Total execution time of the trajectories (s)."""
        return sum(s.duration for s in self.sub_trajectory)

    def controller_names(self) -> list[str]:
        """Every controller named by a sub-trajectory, in first-use order."""
        names: list[str] = []
        for sub in self.sub_trajectory:
            for name in sub.execution_info.controller_names:
                if name not in names:
                    names.append(name)
        return names


@dataclass
class StageDescription(_Message):
    """moveit_task_constructor_msgs/StageDescription: one stage of the task tree.

    ``flags`` are MTC's interface flags (READS_START 1, READS_END 2, WRITES_NEXT_START 4,
    WRITES_PREV_END 8); ``parent_id`` is 0 for the root container; ``type`` is the stage class.
    """

    id: int
    parent_id: int = 0
    name: str = ""
    flags: int = 0
    type: str = ""

    def _validate(self) -> None:
        if self.id <= 0:
            raise MessageError("StageDescription.id", f"must be > 0, got {self.id}")
        if self.parent_id < 0 or self.parent_id == self.id:
            raise MessageError("StageDescription.parent_id", f"invalid parent id {self.parent_id} for stage {self.id}")
        if not 0 <= self.flags <= 15:
            raise MessageError("StageDescription.flags", f"must be in [0, 15], got {self.flags}")


@dataclass
class TaskDescription(_Message):
    """moveit_task_constructor_msgs/TaskDescription: the stage tree, parents before children."""

    task_id: str = ""
    stages: list[StageDescription] = field(default_factory=list)

    def _validate(self) -> None:
        seen: set[int] = set()
        for i, stage in enumerate(self.stages):
            if stage.id in seen:
                raise MessageError(f"TaskDescription.stages[{i}].id", f"duplicate stage id {stage.id}")
            if stage.parent_id != 0 and stage.parent_id not in seen:
                raise MessageError(f"TaskDescription.stages[{i}].parent_id",
                                   f"parent {stage.parent_id} must be listed before stage {stage.id}")
            seen.add(stage.id)


@dataclass
class StageStatistics(_Message):
    """moveit_task_constructor_msgs/StageStatistics: solution ids (and costs) and failures of a
    stage, and the time it spent computing (s, children included for containers)."""

    id: int
    solved: list[int] = field(default_factory=list)
    failed: list[int] = field(default_factory=list)
    cost: list[float] = field(default_factory=list)
    num_failed: int = 0
    total_compute_time: float = 0.0

    def _validate(self) -> None:
        _require_len("StageStatistics.cost", self.cost, len(self.solved), "costs (one per solved id)")
        if self.num_failed < len(self.failed):
            raise MessageError("StageStatistics.num_failed",
                               f"{self.num_failed} is less than the {len(self.failed)} failures listed")
        if self.total_compute_time < 0:
            raise MessageError("StageStatistics.total_compute_time", f"must be >= 0, got {self.total_compute_time}")


@dataclass
class TaskStatistics(_Message):
    """moveit_task_constructor_msgs/TaskStatistics: statistics of every stage."""

    task_id: str = ""
    stages: list[StageStatistics] = field(default_factory=list)

    def _validate(self) -> None:
        ids = [s.id for s in self.stages]
        if len(set(ids)) != len(ids):
            raise MessageError("TaskStatistics.stages", "duplicate stage id")
