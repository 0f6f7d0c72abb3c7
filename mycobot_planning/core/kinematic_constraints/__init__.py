"""Path and goal constraints (moveit_core/kinematic_constraints): moveit_msgs/Constraints checked
on states and along paths, and the constraint manifold OMPL projects onto."""
from .kinematic_constraints import ConstraintError, ConstraintManifold, PathConstraints, dense_violation

__all__ = ["ConstraintError", "ConstraintManifold", "PathConstraints", "dense_violation"]
