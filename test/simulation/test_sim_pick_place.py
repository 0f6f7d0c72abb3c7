"""The seeds' pick and place in physics (ROS-free): planned with the core as mtc_node plans it,
executed on the simulator as the planning_server executes it through the controllers. The
gripper really closes on the cylinder (nothing is welded or attached in the simulator), and
the simulator's verdict decides: within 1 cm of the place pose, upright within 5 degrees,
never more than 5 mm of slip in the hand. A grasp that does not close enough fails and leaves
the cylinder on the table."""
from __future__ import annotations

import numpy as np
import pytest

from mycobot_planning.simulation import MujocoSimulator, tilt_deg
from mycobot_planning.demos.pick_place import PickPlaceParameters, expected_place_pose
from mycobot_planning.demos.sim_pick_place import execute_in_simulation, plan_pick_place, solution_steps
from mycobot_planning.simulation.grasp_monitor import PLACE_TOLERANCE, SLIP_TOLERANCE, TILT_TOLERANCE_DEG

PARAMS = PickPlaceParameters(max_solutions=1)


@pytest.fixture(scope="module")
def steps(mycobot):
    """The seeds' task planned once (its first solution), with the twin's floor in the scene."""
    solution = plan_pick_place(mycobot, PARAMS, seed=0, floor_z=-0.03)
    assert solution is not None
    return solution_steps(solution)


def test_the_seeds_pick_and_place_holds_in_physics(sim, steps):
    start = sim.object_pose(PARAMS.object_name)
    result = execute_in_simulation(sim, steps, PARAMS)
    assert result.success, result.message
    outcome = result.outcome
    assert outcome.place_error <= PLACE_TOLERANCE and outcome.tilt_deg <= TILT_TOLERANCE_DEG
    assert 0 < outcome.slip <= SLIP_TOLERANCE
    final = sim.object_pose(PARAMS.object_name)
    assert np.linalg.norm(final[:3, 3] - expected_place_pose(PARAMS)[:3, 3]) <= 0.01
    assert np.linalg.norm(final[:3, 3] - start[:3, 3]) > 0.3  # it really travelled
    close = next(s for s in result.steps if s.name == "close gripper")
    assert close.gripper.contacts == (PARAMS.object_name,)  # the pads closed on the cylinder
    assert sim.contacts_of(PARAMS.object_name) == ["floor"]  # standing on the floor, the gripper gone
    # the arm tracked every motion within the arm controller's goal tolerance
    assert result.max_tracking_error <= 0.01


def test_a_grasp_that_does_not_close_enough_leaves_the_cylinder_on_the_table(sim, steps):
    start = sim.object_pose(PARAMS.object_name)
    result = execute_in_simulation(sim, steps, PARAMS, close_position=-0.2)
    assert not result.success
    assert "lift object" in result.message and "lost from the hand" in result.message
    assert not result.outcome.success
    final = sim.object_pose(PARAMS.object_name)
    assert np.linalg.norm(final[:3, 3] - start[:3, 3]) < 0.005
    assert tilt_deg(final) < 2.0
    assert sim.contacts_of(PARAMS.object_name) == ["table"]


def test_closing_fully_on_the_cylinder_stalls_on_it(sim, steps):
    """The gripper's 'closed' state (-0.5) is past the cylinder: the fingers stop on it and the
    GripperCommand result is stalled, not reached_goal; the grasp holds through the lift."""
    result = execute_in_simulation(sim, steps[:steps.index(next(s for s in steps if s[0] == "lift object")) + 1],
                                   PARAMS, close_position=-0.5)
    close = next(s for s in result.steps if s.name == "close gripper")
    assert close.gripper.stalled and not close.gripper.reached_goal
    assert close.gripper.contacts == (PARAMS.object_name,)
    assert close.gripper.position > -0.45
    assert sim.object_pose(PARAMS.object_name)[2, 3] > 0.175 + 0.1  # lifted with the hand
