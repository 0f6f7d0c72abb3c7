"""The solvers take MTC's constructor forms and properties: PipelinePlanner(node, pipeline,
planner_id) with ``pipeline`` / ``planner`` attributes, and CartesianPath's
``max_cartesian_speed`` / ``cartesian_speed_limited_link``."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from mycobot_planning.core.trajectory_processing.cartesian_speed_limit import max_link_speed
from mycobot_planning.task import core, stages
from task_helpers import assert_solution_valid, scene_at

FLANGE = "link6_flange"


def _move_home(model, planner, name="move"):
    """current state -> MoveTo 'home' of the arm with ``planner``."""
    task = core.Task(name, model, scene_at(model, "ready"))
    task.add(stages.CurrentState("current"))
    move = stages.MoveTo("home", planner)
    move.group = "arm"
    move.setGoal("home")
    task.add(move)
    return task


def test_pipeline_planner_takes_mtc_ros2_constructor_and_attributes(mycobot):
    node = SimpleNamespace(get_name=lambda: "mtc_tutorial")  # what rclpy.create_node would give
    planner = core.PipelinePlanner(node, "ompl", "RRTConnectkConfigDefault")
    assert (planner.pipeline, planner.planner) == ("ompl", "RRTConnectkConfigDefault")
    planner.planner = "PRMkConfigDefault"
    planner.num_planning_attempts = 2
    assert planner.properties["pipeline_id_planner_id_map"] == {"ompl": "PRMkConfigDefault"}
    planner.pipeline = "pilz_industrial_motion_planner"
    planner.planner = "PTP"
    assert planner.properties["pipeline_id_planner_id_map"] == {"pilz_industrial_motion_planner": "PTP"}

    task = _move_home(mycobot, planner, "ptp")
    assert task.plan()
    assert_solution_valid(task.solutions[0])
    with pytest.raises(Exception, match="too many arguments"):
        core.PipelinePlanner("ompl", "RRTConnectkConfigDefault", "extra")


def _down(model, solver):
    """current state -> MoveRelative 5 cm down with ``solver``."""
    task = core.Task("down", model, scene_at(model, "ready"))
    task.add(stages.CurrentState("current"))
    move = stages.MoveRelative("down 5 cm", solver)
    move.group = "arm"
    move.setDirection(core.Vector3Stamped("base_link", [0.0, 0.0, -0.05]))
    task.add(move)
    return task


def _relative(model, solver):
    task = _down(model, solver)
    assert task.plan()
    assert_solution_valid(task.solutions[0])
    (sub,) = [s for s in task.solutions[0].sub_trajectories() if s.trajectory is not None]
    return sub


def test_cartesian_path_max_cartesian_speed_slows_the_link_down(mycobot):
    free = _relative(mycobot, core.CartesianPath())
    state = free.start.scene.current_state
    fast = max_link_speed(free.trajectory, state, FLANGE)
    limited = core.CartesianPath()
    limited.max_cartesian_speed = fast / 4
    slow = _relative(mycobot, limited)
    assert max_link_speed(slow.trajectory, state, FLANGE) <= fast / 4 * (1 + 1e-6)
    assert slow.trajectory.duration == pytest.approx(4 * free.trajectory.duration, rel=0.02)
    assert np.allclose(slow.trajectory.positions[-1], free.trajectory.positions[-1])


def test_cartesian_speed_limited_link_must_exist(mycobot):
    solver = core.CartesianPath()
    solver.max_cartesian_speed = 0.05
    solver.cartesian_speed_limited_link = "no_such_link"
    with pytest.raises(Exception, match="no_such_link"):
        _down(mycobot, solver).init()


def test_multi_planner_answers_with_the_first_planner_that_succeeds(mycobot):
    # Cartesian first: a joint goal far from a straight line makes it fail, so the joint
    # interpolation planner behind it answers (MTC's multi_planner demo has this order).
    cartesian = core.CartesianPath()
    cartesian.min_fraction = 1.0
    multi = core.MultiPlanner()
    multi.add(cartesian, core.JointInterpolationPlanner())
    assert len(multi) == 2 and multi[1].planner_id == "JointInterpolation"
    task = _move_home(mycobot, multi, "multi")
    assert task.plan()
    assert_solution_valid(task.solutions[0])
    moved = [sub for sub in task.solutions[0].sub_trajectories() if sub.trajectory is not None]
    assert [sub.planner_id for sub in moved] == ["JointInterpolation"]  # the Cartesian attempt failed
    with pytest.raises(Exception, match="no planners"):
        _move_home(mycobot, core.MultiPlanner(), "empty").init()


def test_task_set_cost_term_and_trajectory_cost_term_mode(mycobot):
    task = _move_home(mycobot, core.JointInterpolationPlanner(), "duration")
    task.setCostTerm(core.TrajectoryDuration())  # MTC: the task's solutions cost their duration
    assert task.plan()
    (moved,) = [s for s in task.solutions[0].sub_trajectories() if s.trajectory is not None]
    assert task.solutions[0].cost == pytest.approx(moved.trajectory.duration)

    Mode = core.TrajectoryCostTerm.Mode
    assert [m.name for m in Mode] == ["AUTO", "START_INTERFACE", "END_INTERFACE", "TRAJECTORY"]
    assert core.Clearance(mode=Mode.END_INTERFACE).mode == core.Clearance.END_INTERFACE == 2
