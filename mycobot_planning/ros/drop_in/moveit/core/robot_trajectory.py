"""``moveit.core.robot_trajectory``: moveit_py's RobotTrajectory over the core TimedTrajectory
(what every planner returns), with the start state its joints outside the group come from."""
from __future__ import annotations

from typing import Any, Iterator

import numpy as np
from moveit_msgs.msg import RobotTrajectory as RobotTrajectoryMsg

from interfaces_py.moveit_conversions import robot_trajectory_to_msg
from interfaces_py.msgs import JointTrajectory, RobotTrajectory as RobotTrajectoryData
from mycobot_planning.core.planning_interface.planning_interface import time_group_path
from mycobot_planning.core.robot_state.robot_state import RobotState as CoreRobotState
from mycobot_planning.ros.move_group.moveit_translation import joint_trajectory_from_ros
from mycobot_planning.core.robot_trajectory.robot_trajectory import (
    TimedTrajectory,
    joint_trajectory_to_timed,
    limit_waypoint_distance,
    timed_to_joint_trajectory,
)

from .robot_model import RobotModel, core_model, robot_model
from .robot_state import RobotState, core_state

__all__ = ["RobotTrajectory", "path_length"]


class RobotTrajectory:
    """moveit_py's RobotTrajectory: ``RobotTrajectory(robot_model)`` (empty), or a plan's result."""

    def __init__(self, robot_model: Any) -> None:
        self._model = core_model(robot_model)
        self._trajectory: TimedTrajectory | None = None
        self._start: CoreRobotState = CoreRobotState(self._model)
        self.joint_model_group_name = ""

    @classmethod
    def _wrap(cls, trajectory: TimedTrajectory, group: str, start: CoreRobotState) -> "RobotTrajectory":
        wrapper = cls(start.model)
        wrapper._trajectory, wrapper._start, wrapper.joint_model_group_name = trajectory, start.copy(), group
        return wrapper

    @property
    def timed_trajectory(self) -> TimedTrajectory:
        """The core TimedTrajectory (ValueError for an empty trajectory)."""
        if self._trajectory is None:
            raise ValueError("the trajectory is empty")
        return self._trajectory

    @property
    def start_state(self) -> CoreRobotState:
        return self._start

    @property
    def robot_model(self) -> RobotModel:
        return robot_model(self._model)

    @property
    def duration(self) -> float:
        return 0.0 if self._trajectory is None else self._trajectory.duration

    @property
    def average_segment_duration(self) -> float:
        n = len(self)
        return self.duration / (n - 1) if n > 1 else 0.0

    def __len__(self) -> int:
        return 0 if self._trajectory is None else len(self._trajectory)

    def __getitem__(self, index: int) -> RobotState:
        """The robot state at waypoint ``index``."""
        trajectory = self.timed_trajectory
        state = self._start.copy()
        state.set_joint_positions(dict(zip(trajectory.joint_names, trajectory.positions[index])))
        return RobotState._wrap(state)

    def __iter__(self) -> Iterator[RobotState]:
        return (self[k] for k in range(len(self)))

    def get_waypoint_durations(self) -> list[float]:
        """Time from the previous waypoint to each waypoint (0 for the first)."""
        if self._trajectory is None:
            return []
        return [0.0] + np.diff(self._trajectory.times).tolist()

    def get_robot_trajectory_msg(self, joint_filter: list[str] | None = None) -> RobotTrajectoryMsg:
        """A moveit_msgs/RobotTrajectory (``joint_filter``: only those joints)."""
        joint = timed_to_joint_trajectory(self._trajectory)
        if joint_filter:
            keep = [k for k, name in enumerate(joint.joint_names) if name in joint_filter]
            joint = JointTrajectory.from_dict({
                "joint_names": [joint.joint_names[k] for k in keep],
                "points": [{"positions": [p.positions[k] for k in keep],
                            "velocities": [p.velocities[k] for k in keep] if p.velocities else [],
                            "accelerations": [p.accelerations[k] for k in keep] if p.accelerations else [],
                            "time_from_start": p.time_from_start} for p in joint.points]})
        data = RobotTrajectoryData(joint_trajectory=joint, group_name=self.joint_model_group_name)
        return robot_trajectory_to_msg(data.to_dict())

    def set_robot_trajectory_msg(self, robot_state: Any, msg: RobotTrajectoryMsg) -> None:
        """Take the joint trajectory of ``msg``; ``robot_state`` gives the joints it does not name."""
        joint, _ = joint_trajectory_from_ros(msg)
        self._start = core_state(robot_state).copy()
        self._trajectory = joint_trajectory_to_timed(joint)

    def apply_totg_time_parameterization(self, velocity_scaling_factor: float, acceleration_scaling_factor: float,
                                         path_tolerance: float = 0.1, resample_dt: float = 0.1,
                                         min_angle_change: float = 0.001) -> bool:
        """Re-time the waypoints under the joint limits and the scaling factors (the core's time
        parameterisation; path_tolerance, resample_dt and min_angle_change are TOTG's own knobs
        and are not used)."""
        if self._trajectory is None or not self.joint_model_group_name:
            return False
        jmg = self._model.group(self.joint_model_group_name)
        path = self._trajectory.path if self._trajectory.path is not None else self._trajectory.positions
        self._trajectory = limit_waypoint_distance(time_group_path(
            self._model, jmg, np.asarray(path), float(velocity_scaling_factor), float(acceleration_scaling_factor)))
        return True

    def unwind(self) -> None:
        """Nothing to unwind: continuous joints are not wrapped by the core planners."""

    def __repr__(self) -> str:
        return f"RobotTrajectory(group={self.joint_model_group_name!r}, waypoints={len(self)}, duration={self.duration:.3f})"


def path_length(trajectory: TimedTrajectory) -> float:
    """MoveIt's robot_trajectory::pathLength: the summed joint distance between waypoints."""
    return float(np.sum(np.abs(np.diff(trajectory.positions, axis=0)))) if len(trajectory) > 1 else 0.0
