"""Path and goal constraints (moveit_core/kinematic_constraints): moveit_msgs/Constraints checked
on states and along paths, and the constraint manifold OMPL projects onto."""
from .constraint_manifold import ConstraintManifold
from .kinematic_constraints import ConstraintError, PathConstraints, dense_violation

__all__ = ["ConstraintError", "ConstraintManifold", "PathConstraints", "dense_violation"]
