"""Every name MTC's Python bindings export (moveit_task_constructor, ros2 branch, commit 8e76def85452:
core/python/bindings/src/{core,solvers,stages}.cpp) is importable from ours, with MTC's values,
and the ones added last work: LinkRotation, CartesianPath.precision, PropagatingForward/Backward
and PropagatingEitherWay.Direction, MergeMode, PoseDimension with sample_dimension/set_max_solutions.
Not offered: core.Solutions (our solutions are plain lists, cheapest first) and core.Introspection
(the object task.introspection() returns lives in the ROS layer)."""
from __future__ import annotations

import numpy as np
import pytest

from mycobot_planning.task import core, stages
from task_helpers import assert_solution_valid, scene_at

MTC_CORE = """Alternatives Clearance ContainerBase CostTerm DistanceToReference Fallbacks Generator InitStageError
InterfaceState LinkMotion LinkRotation Merger MonitoringGenerator MoveItErrorCode ParallelContainerBase PathLength
PropagatingBackward PropagatingEitherWay PropagatingForward SerialContainer Solution Stage SubTrajectory Task
TrajectoryCostTerm TrajectoryDuration WrapperBase CartesianPath CartesianPrecision JointInterpolationPlanner MultiPlanner
PipelinePlanner PlannerInterface""".split()
MTC_STAGES = """ComputeIK Connect CurrentState FixCollisionObjects FixedState GenerateGraspPose GeneratePlacePose GeneratePose
GenerateRandomPose LimitSolutions MergeMode ModifyPlanningScene MoveRelative MoveTo PassThrough Pick Place PoseDimension
SimpleGrasp SimpleGraspBase SimpleUnGrasp""".split()


def test_every_name_of_mtcs_bindings_is_there():
    assert [n for n in MTC_CORE if not hasattr(core, n)] == []
    assert [n for n in MTC_STAGES if not hasattr(stages, n)] == []
    assert issubclass(core.InitStageError, Exception) and core.Solution is core.SolutionBase


def test_enums_have_mtcs_members_and_values():
    direction = core.PropagatingEitherWay.Direction
    assert [(m.name, int(m)) for m in direction] == [("AUTO", 0), ("FORWARD", 1), ("BACKWARD", 2)]
    assert [(m.name, int(m)) for m in stages.MergeMode] == [("SEQUENTIAL", 0), ("WAYPOINTS", 1)]
    assert [m.name for m in stages.PoseDimension] == ["X", "Y", "Z", "ROLL", "PITCH", "YAW"]
    assert core.Stage.PropertyInitializerSource.PARENT and core.Stage.PropertyInitializerSource.INTERFACE
    assert bool(core.MoveItErrorCode(core.MoveItErrorCode.SUCCESS)) and core.MoveItErrorCode(-1).val == -1


def test_propagating_forward_and_backward_are_restricted():
    forward, backward = core.PropagatingForward("f"), core.PropagatingBackward("b")
    assert forward._configured_dir == core.PropagatingEitherWay.Direction.FORWARD
    assert backward._configured_dir == core.PropagatingEitherWay.Direction.BACKWARD
    either = core.PropagatingEitherWay("e")
    either.restrictDirection(core.PropagatingEitherWay.Direction.BACKWARD)
    with pytest.raises(core.TaskError, match="cannot change the direction"):
        either.restrictDirection(core.PropagatingEitherWay.Direction.FORWARD)


def test_connect_takes_a_merge_mode():
    connect = stages.Connect("connect")
    assert connect.merge_mode == stages.MergeMode.WAYPOINTS  # MTC's default
    connect.merge_mode = stages.MergeMode.SEQUENTIAL
    assert connect.properties["merge_mode"] == 0


def test_generate_random_pose_python_forms():
    generator = stages.GenerateRandomPose("random")
    generator.sample_dimension(stages.PoseDimension.YAW, 0.4)
    generator.set_max_solutions(7)
    assert generator.properties["max_solutions"] == 7
    assert generator._samplers == [(int(stages.PoseDimension.YAW), 0.4, "uniform")]


def test_link_rotation_sums_the_turn_of_the_link(mycobot):
    task = core.Task("turn", mycobot, scene_at(mycobot, "ready"))
    task.add(stages.CurrentState("current"))
    move = stages.MoveRelative("turn 0.3 rad", core.CartesianPath())
    move.group = "arm"
    move.setDirection(core.TwistStamped("link6_flange", [0.0, 0.0, 0.0], [0.0, 0.0, 0.3]))
    move.setCostTerm(core.LinkRotation("link6_flange"))
    task.add(move)
    assert task.plan(), task.explainFailure(stream=None)
    assert_solution_valid(task.solutions[0])
    assert task.solutions[0].cost == pytest.approx(0.3, rel=0.02)
    sub = [s for s in task.solutions[0].sub_trajectories() if s.trajectory is not None][0]
    assert core.LinkRotation("link6_flange")(sub) == pytest.approx(0.3, rel=0.02)
    assert core.LinkRotation("no_such_link")(sub) == float("inf")
    with pytest.raises(core.TaskError, match="needs a link name"):
        core.LinkRotation("")


def _down_bulge(model, solver) -> float | None:
    """Largest distance (m) of the flange from the straight line along the planned trajectory of
    a MoveRelative 5.8 cm down and back (None when the task finds no solution)."""
    task = core.Task("down", model, scene_at(model, "ready"))
    task.add(stages.CurrentState("current"))
    move = stages.MoveRelative("down", solver)
    move.group = "arm"
    move.setDirection(core.Vector3Stamped("base_link", [-0.05, 0.0, -0.03]))
    task.add(move)
    if not task.plan():
        return None
    assert_solution_valid(task.solutions[0])
    sub = [s for s in task.solutions[0].sub_trajectories() if s.trajectory is not None][0]
    state = sub.start.scene.current_state.copy()
    idx = [model.variable_index(n) for n in sub.trajectory.joint_names]
    points = []
    for row in sub.trajectory.sample(np.linspace(0.0, sub.trajectory.duration, 400))[0]:
        positions = state.positions.copy()
        positions[idx] = row
        state.set_positions(positions)
        points.append(state.frame_pose("link6_flange")[:3, 3])
    a, b = points[0], points[-1]
    ab = (b - a) / np.linalg.norm(b - a)
    return max(float(np.linalg.norm((p - a) - ((p - a) @ ab) * ab)) for p in points)


def test_cartesian_path_precision_is_a_property_the_planner_honours(mycobot):
    solver = core.CartesianPath()
    assert str(solver.precision) == "CartesianPrecision(translational=0.001, rotational=0.01, max_resolution=1e-05)"
    assert core.CartesianPath().precision is not solver.precision  # each solver has its own
    solver.step_size = 0.1  # one step for the whole 5.8 cm motion (no jump test, which forces 10)
    solver.jump_threshold = 0.0
    solver.setPrecision(core.CartesianPrecision(translational=0.1, rotational=1.0))
    loose = _down_bulge(mycobot, solver)
    solver.precision = core.CartesianPrecision(translational=0.0002)
    tight = _down_bulge(mycobot, solver)
    assert loose is not None and loose > 0.002, loose  # the joint-space step bulges off the line
    assert tight is not None and tight <= 0.0002 + 1e-5, tight
    solver.setPrecision(core.CartesianPrecision(1e-9, 1e-9, 0.1))  # unreachable: the path stops short
    assert _down_bulge(mycobot, solver) is None
