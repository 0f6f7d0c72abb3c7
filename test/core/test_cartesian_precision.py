"""MoveIt's CartesianPrecision on compute_cartesian_path: the ik frame halfway between two states
stays near the line; steps are halved until it does, or the path stops at max_resolution."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from mycobot_planning.core import RobotModel, RobotState
from mycobot_planning.core.planners.cartesian.cartesian_path import STOP_COMPLETE, STOP_PRECISION, compute_cartesian_path
from mycobot_planning.core.planners.cartesian.cartesian_precision import CartesianPrecision

# the cartesian tests' fixtures: the myCobot at 'ready' in an empty scene
from test_cartesian_path import FLANGE, ready, scene  # noqa: E402,F401


def turned_and_moved(pose: np.ndarray) -> np.ndarray:
    """A goal 5.8 cm away and turned 0.3 rad: one step there bulges about 4.6 mm / 0.05 rad."""
    goal = pose.copy()
    goal[:3, 3] += (-0.05, 0.0, -0.03)
    goal[:3, :3] = pose[:3, :3] @ pin.exp3(np.array([0.3, 0.0, 0.0]))
    return goal


def largest_midpoint_deviation(model: RobotModel, start: RobotState, path: np.ndarray) -> tuple[float, float]:
    """Largest (m, rad) distance of the flange, halfway between consecutive path states in joint
    space, from the midpoint of the poses at those states (checked independently of the planner)."""
    idx = model.group("arm").variable_indices
    state = start.copy()

    def pose(values: np.ndarray) -> np.ndarray:
        full = start.positions.copy()
        full[idx] = values
        state.set_positions(full)
        return state.frame_pose(FLANGE)

    worst_t = worst_r = 0.0
    for a, b in zip(path[:-1], path[1:]):
        pa, pb, pm = pose(a), pose(b), pose(0.5 * (a + b))
        expected_r = pa[:3, :3] @ pin.exp3(0.5 * pin.log3(pa[:3, :3].T @ pb[:3, :3]))
        worst_t = max(worst_t, float(np.linalg.norm(pm[:3, 3] - 0.5 * (pa[:3, 3] + pb[:3, 3]))))
        worst_r = max(worst_r, float(np.linalg.norm(pin.log3(expected_r.T @ pm[:3, :3]))))
    return worst_t, worst_r


def test_defaults_are_moveits_and_bad_values_are_refused():
    precision = CartesianPrecision()
    assert (precision.translational, precision.rotational, precision.max_resolution) == (0.001, 0.01, 1e-5)
    assert str(precision) == "CartesianPrecision(translational=0.001, rotational=0.01, max_resolution=1e-05)"
    for bad in ({"translational": 0.0}, {"rotational": -1.0}, {"max_resolution": float("nan")},
                {"translational": True}):
        with pytest.raises(ValueError, match="must be a number > 0"):
            CartesianPrecision(**bad)


def test_coarse_steps_are_refined_until_the_path_keeps_the_precision(scene, ready, mycobot):
    goal = turned_and_moved(ready.frame_pose(FLANGE))
    coarse = compute_cartesian_path(scene, "arm", ready, [goal], eef_step=0.2, max_rotation_step=2.0)
    assert coarse.stop_reason == STOP_COMPLETE and len(coarse.path) == 2  # one step, not checked
    bulge_t, bulge_r = largest_midpoint_deviation(mycobot, ready, coarse.path)
    assert bulge_t > 0.001 or bulge_r > 0.01  # the single step leaves the line

    precise = compute_cartesian_path(scene, "arm", ready, [goal], eef_step=0.2, max_rotation_step=2.0,
                                     precision=CartesianPrecision())
    assert precise.stop_reason == STOP_COMPLETE and precise.fraction == 1.0, precise.message
    assert len(precise.path) > len(coarse.path)
    worst_t, worst_r = largest_midpoint_deviation(mycobot, ready, precise.path)
    assert worst_t <= 0.001 + 2e-6 and worst_r <= 0.01 + 2e-5, (worst_t, worst_r)


def test_the_path_stops_where_steps_would_be_finer_than_max_resolution(scene, ready):
    goal = turned_and_moved(ready.frame_pose(FLANGE))
    result = compute_cartesian_path(scene, "arm", ready, [goal], eef_step=0.2, max_rotation_step=2.0,
                                    precision=CartesianPrecision(translational=1e-9, rotational=1e-9,
                                                                 max_resolution=0.1))
    assert result.success and result.stop_reason == STOP_PRECISION
    assert result.fraction < 1.0
    assert "leaves the line" in result.message


def test_precision_must_be_a_cartesian_precision(scene, ready):
    goal = turned_and_moved(ready.frame_pose(FLANGE))
    result = compute_cartesian_path(scene, "arm", ready, [goal], precision=0.001)
    assert not result.success and "precision must be a CartesianPrecision" in result.message
