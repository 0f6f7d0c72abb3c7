"""Dense trajectories: waypoints at most max_distance apart per joint, the motion itself unchanged.

limit_waypoint_distance inserts exact samples of a TimedTrajectory's interpolation;
densify_joint_trajectory does the same for a JointTrajectory message with the spline a
JointTrajectoryController follows (linear, cubic or quintic, by the fields its points carry).
"""
from __future__ import annotations

import numpy as np
import pytest

from interfaces_py.msgs import JointTrajectory, JointTrajectoryPoint
from mycobot_planning.core.robot_trajectory.robot_trajectory import (
    DEFAULT_MAX_WAYPOINT_DISTANCE,
    TimedTrajectory,
    densify_joint_trajectory,
    joint_trajectory_to_timed,
    limit_waypoint_distance,
    timed_to_joint_trajectory,
)
from mycobot_planning.core.trajectory_processing.time_parameterization import time_parameterize

NAMES = ["a", "b", "c"]


def max_gap(positions: np.ndarray) -> float:
    return float(np.max(np.abs(np.diff(positions, axis=0)))) if len(positions) > 1 else 0.0


def timed_line(start, goal, method: str = "auto") -> TimedTrajectory:
    path = np.array([start, goal], dtype=float)
    return time_parameterize(path, np.array([2.0, 1.5, 3.0]), np.array([5.0, 4.0, 6.0]), joint_names=NAMES,
                             method=method)


def test_default_is_mtc_joint_interpolation_max_step() -> None:
    assert DEFAULT_MAX_WAYPOINT_DISTANCE == 0.1


@pytest.mark.parametrize("max_distance", [0.1, 0.03])
def test_a_timed_straight_line_becomes_dense_and_moves_exactly_as_before(max_distance: float) -> None:
    sparse = timed_line([0.0, 0.5, -0.2], [1.2, -0.3, 0.6])
    assert max_gap(sparse.positions) > 0.3  # Ruckig's breakpoints only
    dense = limit_waypoint_distance(sparse, max_distance)
    assert max_gap(dense.positions) <= max_distance + 1e-12
    assert dense.interpolation == sparse.interpolation and dense.duration == pytest.approx(sparse.duration)
    assert set(sparse.times) <= set(dense.times)  # every breakpoint kept
    probe = np.linspace(0.0, sparse.duration, 997)
    for a, b in zip(sparse.sample(probe), dense.sample(probe)):
        np.testing.assert_allclose(a, b, atol=1e-9)
    # and stays a straight line in joint space: every point on the segment start -> goal
    direction = (dense.positions[-1] - dense.positions[0]) / np.linalg.norm(dense.positions[-1] - dense.positions[0])
    offsets = dense.positions - dense.positions[0]
    np.testing.assert_allclose(offsets - np.outer(offsets @ direction, direction), 0.0, atol=1e-9)


def test_dense_enough_trajectories_come_back_unchanged() -> None:
    sparse = timed_line([0.0, 0.0, 0.0], [0.05, 0.02, -0.04])
    assert limit_waypoint_distance(sparse, 0.1) is sparse
    single = TimedTrajectory(NAMES, [0.0], [[0.0, 1.0, 2.0]], [[0.0] * 3], [[0.0] * 3])
    assert limit_waypoint_distance(single, 0.1) is single


def test_quintic_trajectories_keep_their_quintic_pieces() -> None:
    times = [0.0, 1.0, 2.5]
    positions = [[0.0, 0.0, 0.0], [0.8, -0.4, 0.3], [1.0, 0.2, -0.9]]
    velocities = [[0.0] * 3, [0.5, 0.1, -0.6], [0.0] * 3]
    accelerations = [[0.0] * 3, [0.2, -0.3, 0.1], [0.0] * 3]
    traj = TimedTrajectory(NAMES, times, positions, velocities, accelerations, interpolation="quintic")
    dense = limit_waypoint_distance(traj, 0.05)
    assert max_gap(dense.positions) <= 0.05 + 1e-12 and dense.interpolation == "quintic"
    probe = np.linspace(0.0, 2.5, 501)
    for a, b in zip(traj.sample(probe), dense.sample(probe)):
        np.testing.assert_allclose(a, b, atol=1e-9)


def test_bad_max_distance_is_refused() -> None:
    traj = timed_line([0.0, 0.0, 0.0], [1.0, 1.0, 1.0])
    for bad in (0.0, -0.1, float("nan"), "x"):
        with pytest.raises(ValueError, match="max_distance"):
            limit_waypoint_distance(traj, bad)  # type: ignore[arg-type]


def message(points: list[JointTrajectoryPoint]) -> JointTrajectory:
    return JointTrajectory(joint_names=NAMES, points=points, frame_id="world")


def test_cubic_message_densified_on_the_controllers_spline() -> None:
    sparse = timed_line([0.0, 0.5, -0.2], [1.2, -0.3, 0.6])
    msg = timed_to_joint_trajectory(sparse)
    assert not msg.points[0].accelerations  # sent as a cubic Hermite spline
    dense = densify_joint_trajectory(msg, 0.1)
    assert not dense.points[0].accelerations and dense.frame_id == msg.frame_id
    assert max_gap(np.array([p.positions for p in dense.points])) <= 0.1 + 1e-12
    probe = np.linspace(0.0, sparse.duration, 301)
    for a, b in zip(joint_trajectory_to_timed(msg).sample(probe), joint_trajectory_to_timed(dense).sample(probe)):
        np.testing.assert_allclose(a, b, atol=1e-9)


def test_a_late_first_point_keeps_its_time() -> None:
    msg = message([JointTrajectoryPoint([0.0] * 3, [0.0] * 3, time_from_start=0.5),
                   JointTrajectoryPoint([0.6, 0.0, 0.0], [0.0] * 3, time_from_start=2.0)])
    dense = densify_joint_trajectory(msg, 0.1)
    assert dense.points[0].time_from_start == 0.5 and dense.points[-1].time_from_start == 2.0
    assert len(dense.points) >= 7


def test_positions_only_message_gets_points_on_its_lines() -> None:
    msg = message([JointTrajectoryPoint([0.0, 0.0, 0.0], time_from_start=0.0),
                   JointTrajectoryPoint([0.35, -0.1, 0.0], time_from_start=1.0),
                   JointTrajectoryPoint([0.35, -0.1, 0.05], time_from_start=1.5)])
    dense = densify_joint_trajectory(msg, 0.1)
    positions = np.array([p.positions for p in dense.points])
    times = np.array([p.time_from_start for p in dense.points])
    assert max_gap(positions) <= 0.1 + 1e-12 and all(not p.velocities for p in dense.points)
    assert [0.0, 1.0, 1.5] == [t for t in times if t in (0.0, 1.0, 1.5)]
    # linear in time between the given points, as the controller interpolates them
    inner = (times > 0) & (times < 1.0)
    np.testing.assert_allclose(positions[inner], np.outer(times[inner], [0.35, -0.1, 0.0]), atol=1e-12)


def test_mixed_fields_are_left_to_the_controller_to_refuse() -> None:
    msg = message([JointTrajectoryPoint([0.0] * 3, [0.0] * 3, time_from_start=0.0),
                   JointTrajectoryPoint([0.9, 0.0, 0.0], time_from_start=1.0)])
    assert densify_joint_trajectory(msg, 0.1) is msg
