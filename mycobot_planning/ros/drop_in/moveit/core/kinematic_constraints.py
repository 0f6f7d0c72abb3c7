"""``moveit.core.kinematic_constraints``: moveit_msgs/Constraints built as MoveIt's
kinematic_constraints::constructGoalConstraints builds them (moveit_py's construct_* functions)."""
from __future__ import annotations

from typing import Any, Sequence

from geometry_msgs.msg import Pose
from moveit_msgs.msg import Constraints, JointConstraint, OrientationConstraint, PositionConstraint
from shape_msgs.msg import SolidPrimitive

from mycobot_planning.core.kinematic_constraints.kinematic_constraints import ConstraintError
from mycobot_planning.task.path_constraints import as_path_constraints

from .robot_model import JointModelGroup
from .robot_state import core_state

__all__ = ["construct_joint_constraint", "construct_link_constraint", "constraints_satisfied",
           "joint_goal_constraints", "pose_goal_constraints"]


def joint_goal_constraints(state: Any, group: str, tolerance: float) -> Constraints:
    """One JointConstraint per variable of ``group`` at the state's value, +-``tolerance``."""
    core = core_state(state)
    jmg = core.model.group(group)
    constraints = Constraints()
    for name, value in zip(jmg.joint_names, core.group_positions(group)):
        constraints.joint_constraints.append(JointConstraint(
            joint_name=name, position=float(value), tolerance_above=float(tolerance),
            tolerance_below=float(tolerance), weight=1.0))
    return constraints


def _on_link(constraint: Any, link_name: str, frame: str) -> Any:
    """``constraint`` (a position or orientation constraint) on ``link_name`` in ``frame``, weight 1."""
    constraint.header.frame_id = frame
    constraint.link_name = link_name
    constraint.weight = 1.0
    return constraint


def _position_constraint(link_name: str, frame: str, position: Sequence[float], tolerance: float
                         ) -> PositionConstraint:
    pc = _on_link(PositionConstraint(), link_name, frame)
    sphere = SolidPrimitive(type=SolidPrimitive.SPHERE, dimensions=[float(tolerance)])
    pc.constraint_region.primitives.append(sphere)
    centre = Pose()
    centre.position.x, centre.position.y, centre.position.z = (float(v) for v in position)
    centre.orientation.w = 1.0
    pc.constraint_region.primitive_poses.append(centre)
    return pc


def _orientation_constraint(link_name: str, frame: str, quaternion: Sequence[float], tolerance: float
                            ) -> OrientationConstraint:
    oc = _on_link(OrientationConstraint(), link_name, frame)
    oc.orientation.x, oc.orientation.y, oc.orientation.z, oc.orientation.w = (float(v) for v in quaternion)
    oc.absolute_x_axis_tolerance = oc.absolute_y_axis_tolerance = oc.absolute_z_axis_tolerance = float(tolerance)
    return oc


def pose_goal_constraints(link_name: str, pose_stamped: Any, position_tolerance: float = 1e-3,
                          orientation_tolerance: float = 1e-2) -> Constraints:
    """A PoseStamped goal for ``link_name``: a sphere of ``position_tolerance`` around its
    position and its orientation within ``orientation_tolerance`` per axis (MoveIt's defaults)."""
    p, q = pose_stamped.pose.position, pose_stamped.pose.orientation
    frame = pose_stamped.header.frame_id
    constraints = Constraints()
    constraints.position_constraints.append(_position_constraint(link_name, frame, (p.x, p.y, p.z),
                                                                 position_tolerance))
    constraints.orientation_constraints.append(_orientation_constraint(link_name, frame, (q.x, q.y, q.z, q.w),
                                                                       orientation_tolerance))
    return constraints


def construct_joint_constraint(robot_state: Any, joint_model_group: Any, tolerance: float = 0.01) -> Constraints:
    """Joint constraints holding the group's joints at the state's values (+-``tolerance``)."""
    group = joint_model_group.name if isinstance(joint_model_group, JointModelGroup) else str(joint_model_group)
    return joint_goal_constraints(robot_state, group, tolerance)


def construct_link_constraint(link_name: str, source_frame: str, cartesian_position: Sequence[float] | None = None,
                              cartesian_position_tolerance: float | None = None,
                              orientation: Sequence[float] | None = None,
                              orientation_tolerance: float | None = None) -> Constraints:
    """A position constraint (a sphere around ``cartesian_position``), an orientation constraint
    (quaternion x, y, z, w), or both, for ``link_name`` in ``source_frame``."""
    if cartesian_position is None and orientation is None:
        raise ValueError("No link cartesian or orientation constraints specified")
    constraints = Constraints()
    if cartesian_position is not None:
        if cartesian_position_tolerance is None or len(cartesian_position) != 3:
            raise ValueError("cartesian_position needs 3 values and a cartesian_position_tolerance")
        constraints.position_constraints.append(_position_constraint(link_name, source_frame, cartesian_position,
                                                                     cartesian_position_tolerance))
    if orientation is not None:
        if orientation_tolerance is None or len(orientation) != 4:
            raise ValueError("orientation needs 4 values (x, y, z, w) and an orientation_tolerance")
        constraints.orientation_constraints.append(_orientation_constraint(link_name, source_frame, orientation,
                                                                           orientation_tolerance))
    return constraints


def constraints_satisfied(scene: Any, state: Any, constraints: Any) -> tuple[bool, str]:
    """(True, "") when ``state`` satisfies the moveit_msgs/Constraints in the core ``scene``, else
    (False, why)."""
    try:
        resolved = as_path_constraints(constraints).resolve(scene)
    except (ConstraintError, ValueError, TypeError, KeyError) as exc:
        return False, f"invalid constraints: {exc}"
    if not resolved:
        return True, ""
    problem = resolved.violation(core_state(state))
    return problem is None, problem or ""
