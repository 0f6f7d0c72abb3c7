"""``moveit.core.planning_interface``: moveit_py's MotionPlanResponse."""
from __future__ import annotations

from interfaces_py.msgs import MoveItErrorCode

from .robot_state import RobotState
from .robot_trajectory import RobotTrajectory

__all__ = ["MotionPlanResponse"]


class MotionPlanResponse:
    """A plan's answer: ``trajectory`` (None when planning failed), ``error_code`` (truthy on
    SUCCESS, with MoveIt's ``val`` and our ``message``), ``planning_time``, ``start_state``,
    ``planner_id``; the response itself is truthy on success."""

    def __init__(self, error_code: MoveItErrorCode, trajectory: RobotTrajectory | None = None,
                 planning_time: float = 0.0, start_state: RobotState | None = None, planner_id: str = "") -> None:
        self.error_code = error_code
        self.trajectory = trajectory
        self.planning_time = float(planning_time)
        self.start_state = start_state
        self.planner_id = planner_id

    def __bool__(self) -> bool:
        return bool(self.error_code) and self.trajectory is not None

    def __repr__(self) -> str:
        return (f"MotionPlanResponse({self.error_code.name}, planner_id={self.planner_id!r}, "
                f"planning_time={self.planning_time:.3f})")
