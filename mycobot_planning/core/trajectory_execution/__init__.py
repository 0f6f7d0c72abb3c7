"""Trajectory execution (MoveIt's trajectory_execution_manager and simple controller manager,
MTC's execute_task_solution), ROS-free. docs/trajectory_execution.md tells the whole story."""
from .controller_manager import (
    ACTION_NAMESPACES,
    FOLLOW_JOINT_TRAJECTORY,
    GRIPPER_COMMAND,
    ControllerBus,
    ControllerInfo,
    ControllerState,
    check_controllers,
    load_controllers,
    select_controllers,
    split_trajectory,
)
from .manager import TrajectoryExecutionManager
from .monitor import ExecutionMonitor, ExecutionResult
from .settings import ExecutionError, ExecutionSettings, allowed_duration
from .task_solution import SolutionResult, SolutionStep, as_scene_diff, parse_task_solution
from .trajectory_preparation import check_start_state, parse_trajectory, prepare_trajectory, trajectory_duration

__all__ = [
    "ACTION_NAMESPACES",
    "FOLLOW_JOINT_TRAJECTORY",
    "GRIPPER_COMMAND",
    "ControllerBus",
    "ControllerInfo",
    "ControllerState",
    "ExecutionError",
    "ExecutionMonitor",
    "ExecutionResult",
    "ExecutionSettings",
    "SolutionResult",
    "SolutionStep",
    "TrajectoryExecutionManager",
    "allowed_duration",
    "as_scene_diff",
    "check_controllers",
    "check_start_state",
    "load_controllers",
    "parse_task_solution",
    "parse_trajectory",
    "prepare_trajectory",
    "select_controllers",
    "split_trajectory",
    "trajectory_duration",
]
