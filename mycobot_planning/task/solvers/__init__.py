"""Planners for MoveTo / MoveRelative / Connect (MTC's solvers), wrapping the planning core: one
module per solver as MTC's solvers/ (planner_interface, pipeline_planner, cartesian_path,
joint_interpolation, multi_planner).

* :class:`PipelinePlanner`: the planning pipelines by id and planner id, as move_group offers
  them: OMPL (``{"ompl": "arm[RRTConnectkConfigDefault]"}``) and the industrial PTP / LIN / CIRC
  (``{"pilz_industrial_motion_planner": "PTP"}``). One :class:`PlanningPipeline` is shared by
  every PipelinePlanner of the process unless one is given, so OMPL configurations load once.
* :class:`CartesianPath`: a straight line of the ik frame (step size, jump threshold, minimum
  fraction, velocity/acceleration scaling), MTC's defaults (step 0.01 m, jump threshold 1.5).
* :class:`JointInterpolationPlanner`: a straight line in joint space, checked every
  ``max_step`` (the core's 0.01 rad; MTC's 0.1 rad lets a link sweep through thin objects, see
  core/planners/joint_interpolation/joint_interpolation.py).

Each planner answers two questions: plan to a goal *state* (the joints of a group in the goal
scene) and plan the link ``link`` (with the rigid ``offset`` of the ik frame) to a world pose.
Both return a :class:`PlanResult` with the trajectory of the group, which may be partial when
planning failed (MoveRelative measures how far a partial Cartesian path got).

Planner properties are MTC's: set them as attributes (``cartesian.step_size = 0.005``), through
``properties``, or with MTC's setters (``setStepSize``).

Both questions take MTC's ``path_constraints`` (the stage's property: a moveit_msgs/Constraints,
its dict or JSON form, or a core PathConstraints; see task/path_constraints.py), resolved in the
scene planned from, so a constraint may name an object attached there. PipelinePlanner hands them
to the planning pipeline (OMPL plans on the constraint manifold; the industrial planner's paths
are checked); CartesianPath stops where its line would leave them (its fraction then falls short);
JointInterpolationPlanner checks its straight line densely and fails naming the broken
constraint (MTC's ignores them on joint-space goals; it only keeps them at IK for pose goals,
which it does here too).
"""
from .cartesian_path import CartesianPath
from .joint_interpolation import JointInterpolationPlanner
from .multi_planner import MultiPlanner
from .pipeline_planner import PipelinePlanner
from .planner_interface import PlannerInterface, PlanResult, default_pipeline

__all__ = ["CartesianPath", "JointInterpolationPlanner", "MultiPlanner", "PipelinePlanner", "PlanResult", "PlannerInterface",
           "default_pipeline"]
