"""MoveIt Pro's MTC behaviors on our task constructor (mycobot_planning.task): a task is created
with the robot model move_group serves (InitializeMTCTask), stages are appended by the Setup
behaviors, planned (PlanMTCTask) and the solution executed through move_group's
/execute_task_solution (ExecuteMTCSolution; a halt cancels it and the arm stops).

The task and the solution travel through the blackboard as Python objects (ports of type
``moveit_pro::behaviors::MTCTask`` style names are not given: ANY, as BT.CPP's AnyTypeAllowed).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from moveit_task_constructor_msgs.action import ExecuteTaskSolution

from interfaces_py.mtc_conversions import task_solution_to_msg
from interfaces_py.names import EXECUTE_TASK_SOLUTION_ACTION
from mycobot_planning.behavior_tree import (
    ANY,
    BOOL,
    DOUBLE,
    FAILURE,
    INT,
    POSE_STAMPED,
    STRING,
    SUCCESS,
    NodeStatus,
    SyncActionNode,
    ThreadedAction,
    input_port,
    output_port,
)
from mycobot_planning.behavior_tree.behaviors import JOINT_STATE
from mycobot_planning.core.transforms import make_pose
from mycobot_planning.task.geometry import PoseStamped as TaskPoseStamped
from mycobot_planning.task.geometry import Vector3Stamped
from mycobot_planning.task.solvers import CartesianPath, PipelinePlanner
from mycobot_planning.task.stages import CurrentState, ModifyPlanningScene, MoveRelative, MoveTo
from mycobot_planning.task.task import Task

from .ros_behaviors import RosBehavior, error_name
from .ros_calls import PendingCall
from .ros_context import RosBehaviorContext


@dataclass
class MTCSolution:
    """A planned solution with the task it belongs to (the task turns it into a message)."""

    task: Task
    solution: Any

    def __str__(self) -> str:
        return f"MTC solution of task '{self.task.name}' (cost {getattr(self.solution, 'cost', '?')})"


def _task(node: Any) -> Task:
    task = node.get_input("task")
    if not isinstance(task, Task):
        raise ValueError(f"task must come from InitializeMTCTask, got {type(task).__name__}")
    return task


class _SetupStage(SyncActionNode):
    """Appends one stage to the task on the blackboard."""

    def __init__(self, name: str, config: Any, context: RosBehaviorContext):
        super().__init__(name, config)
        self.context = context

    def stage(self, task: Task) -> Any:  # pragma: no cover - abstract
        raise NotImplementedError

    def tick(self) -> NodeStatus:
        try:
            task = _task(self)
            task.add(self.stage(task))
        except (ValueError, LookupError) as exc:
            self.context.log("error", f"{self.config.path or self.name}: {exc}")
            return FAILURE
        return SUCCESS


_TASK = input_port("task", ANY, description="the task (from InitializeMTCTask)")
_GROUP = input_port("planning_group_name", STRING, "arm", "the planning group that moves")


class InitializeMTCTask(ThreadedAction):
    DESCRIPTION = "Creates a task constructor task for the robot move_group serves (its model loaded from move_group)."

    def __init__(self, name: str, config: Any, context: RosBehaviorContext):
        super().__init__(name, config)
        self.context = context

    @classmethod
    def provided_ports(cls):
        return (input_port("task_id", STRING, "objective", "the task's name"),
                input_port("controller_names", STRING, "", "controllers the task's trajectories run on "
                           "(space separated; empty: move_group's default)"),
                output_port("task", ANY, description="the new, empty task"))

    def tick(self) -> NodeStatus:
        task = Task(self.get_input("task_id"))
        try:
            task.loadRobotModel(self.context.node)
        except Exception as exc:  # the task's own errors (no move_group, bad model) fail the behavior
            self.context.log("error", f"{self.config.path or self.name}: {exc}")
            return FAILURE
        task.setProperty("group", self.context.planning_group)
        task.setProperty("ik_frame", self.context.ik_frame)
        controllers = self.get_input("controller_names").split()
        if controllers:
            task.setProperty("trajectory_execution_info", {"controller_names": controllers})
        self.set_output("task", task)
        return SUCCESS


class SetupMTCCurrentState(_SetupStage):
    DESCRIPTION = "Adds MTC's CurrentState stage: the task starts from move_group's current scene and state."

    @classmethod
    def provided_ports(cls):
        return (_TASK,)

    def stage(self, task: Task) -> Any:
        return CurrentState("current state")


class SetupMTCPlanToPose(_SetupStage):
    DESCRIPTION = "Adds a MoveTo stage: a free-space motion (OMPL) of ik_frame to a stamped pose."

    @classmethod
    def provided_ports(cls):
        return (_TASK, _GROUP,
                input_port("target_pose", POSE_STAMPED, description="where ik_frame goes"),
                input_port("ik_frame", STRING, "", "the link placed at target_pose (empty: the server's ik_frame)"))

    def stage(self, task: Task) -> Any:
        target = self.get_input("target_pose")
        stage = MoveTo(self.name if self.name != "SetupMTCPlanToPose" else "plan to pose", PipelinePlanner())
        stage.setGroup(self.get_input("planning_group_name"))
        stage.setGoal(TaskPoseStamped(target.frame_id or "world",
                                      make_pose(target.pose.position, quat_xyzw=target.pose.orientation)))
        stage.setIKFrame(self.get_input("ik_frame") or self.context.ik_frame)
        return stage


class SetupMTCPlanToRobotState(_SetupStage):
    DESCRIPTION = "Adds a MoveTo stage: a free-space motion (OMPL) of a planning group to a joint state."

    @classmethod
    def provided_ports(cls):
        return (_TASK, _GROUP, input_port("joint_state", JOINT_STATE, description="the goal joint state"))

    def stage(self, task: Task) -> Any:
        stage = MoveTo(self.name if self.name != "SetupMTCPlanToRobotState" else "plan to state", PipelinePlanner())
        stage.setGroup(self.get_input("planning_group_name"))
        stage.setGoal(self.get_input("joint_state").as_dict())
        return stage


class SetupMTCMoveAlongFrameAxis(_SetupStage):
    DESCRIPTION = "Adds a MoveRelative stage: a straight-line motion of hand_frame along an axis of axis_frame."

    @classmethod
    def provided_ports(cls):
        return (_TASK, _GROUP,
                input_port("hand_frame", STRING, description="the link that moves in a straight line"),
                input_port("axis_frame", STRING, "world", "the frame the axis is given in"),
                input_port("axis_x", DOUBLE, 0.0, "x of the direction"),
                input_port("axis_y", DOUBLE, 0.0, "y of the direction"),
                input_port("axis_z", DOUBLE, 1.0, "z of the direction"),
                input_port("min_distance", DOUBLE, 0.0, "shortest acceptable motion (m)"),
                input_port("max_distance", DOUBLE, 0.1, "longest motion (m)"),
                input_port("velocity_scale", DOUBLE, 1.0, "fraction of the velocity limits"),
                input_port("acceleration_scale", DOUBLE, 1.0, "fraction of the acceleration limits"))

    def stage(self, task: Task) -> Any:
        planner = CartesianPath()
        planner.setMaxVelocityScalingFactor(self.get_input("velocity_scale"))
        planner.setMaxAccelerationScalingFactor(self.get_input("acceleration_scale"))
        stage = MoveRelative(self.name if self.name != "SetupMTCMoveAlongFrameAxis" else "move along axis", planner)
        stage.setGroup(self.get_input("planning_group_name"))
        stage.setIKFrame(self.get_input("hand_frame"))
        stage.setMinMaxDistance(self.get_input("min_distance"), self.get_input("max_distance"))
        stage.setDirection(Vector3Stamped(self.get_input("axis_frame"),
                                          [self.get_input("axis_x"), self.get_input("axis_y"), self.get_input("axis_z")]))
        return stage


class SetupMTCSetCollisionRule(_SetupStage):
    DESCRIPTION = "Adds a ModifyPlanningScene stage that allows (or forbids) collisions between two objects or links."

    @classmethod
    def provided_ports(cls):
        return (_TASK,
                input_port("name_a", STRING, description="an object or link"),
                input_port("name_b", STRING, description="another object or link"),
                input_port("allow_collision", BOOL, True, "allow (true) or forbid (false)"))

    def stage(self, task: Task) -> Any:
        allow = self.get_input("allow_collision")
        stage = ModifyPlanningScene(f"{'allow' if allow else 'forbid'} collision "
                                    f"({self.get_input('name_a')},{self.get_input('name_b')})")
        stage.allowCollisions([self.get_input("name_a")], [self.get_input("name_b")], allow)
        return stage


class PlanMTCTask(ThreadedAction):
    DESCRIPTION = "Plans the task; the best solution goes to the blackboard (FAILURE says which stage failed)."

    def __init__(self, name: str, config: Any, context: RosBehaviorContext):
        super().__init__(name, config)
        self.context = context
        self._task: Task | None = None

    @classmethod
    def provided_ports(cls):
        return (_TASK, input_port("max_solutions", INT, 1, "stop after this many solutions"),
                output_port("solution", ANY, description="the best solution"))

    def tick(self) -> NodeStatus:
        try:
            task = self._task = _task(self)
        except ValueError as exc:
            self.context.log("error", f"{self.config.path or self.name}: {exc}")
            return FAILURE
        code = task.plan(max_solutions=self.get_input("max_solutions"))
        if self.is_halt_requested():
            return FAILURE
        if not code or not task.solutions:
            why = task.explainFailure(stream=None).strip() or str(code)
            self.context.log("error", f"{self.config.path or self.name}: planning failed: {why}")
            return FAILURE
        self.set_output("solution", MTCSolution(task, task.solutions[0]))
        return SUCCESS

    def halt(self) -> None:
        if self._task is not None:
            self._task.preempt()  # planning stops at its next check; halt then joins the thread
        super().halt()


class ExecuteMTCSolution(RosBehavior):
    DESCRIPTION = "Executes a planned solution through move_group's /execute_task_solution (cancelable)."

    @classmethod
    def provided_ports(cls):
        return (input_port("solution", ANY, description="the solution (from PlanMTCTask)"),)

    def start(self) -> PendingCall | NodeStatus:
        planned = self.get_input("solution")
        if not isinstance(planned, MTCSolution):
            raise ValueError(f"solution must come from PlanMTCTask, got {type(planned).__name__}")
        msg = task_solution_to_msg(planned.task.to_msg(planned.solution), getattr(planned.solution, "id", 0))
        return self.goal(ExecuteTaskSolution, EXECUTE_TASK_SOLUTION_ACTION, ExecuteTaskSolution.Goal(solution=msg))

    def finish(self, call: PendingCall) -> NodeStatus:
        code = call.result.error_code
        if code.val != 1:
            return self.fail(f"execute_task_solution: {error_name(code.val)}: {code.message}")
        return SUCCESS


MTC_BEHAVIORS = (
    (InitializeMTCTask, "InitializeMTCTask", "MTC"),
    (SetupMTCCurrentState, "SetupMTCCurrentState", "MTC"),
    (SetupMTCPlanToPose, "SetupMTCPlanToPose", "MTC"),
    (SetupMTCPlanToRobotState, "SetupMTCPlanToRobotState", "MTC"),
    (SetupMTCMoveAlongFrameAxis, "SetupMTCMoveAlongFrameAxis", "MTC"),
    (SetupMTCSetCollisionRule, "SetupMTCSetCollisionRule", "MTC"),
    (PlanMTCTask, "PlanMTCTask", "MTC"),
    (ExecuteMTCSolution, "ExecuteMTCSolution", "MTC"),
)
