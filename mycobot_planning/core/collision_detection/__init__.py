"""Collision checking (moveit_core/collision_detection): the Coal geometry of robot and world
(collision; its reports in collision_common, the world's objects and shapes in world), the
allowed collision matrix (acm) and the setup assistant's sampling of which link pairs never,
always or by default touch (collision_matrix)."""
from .acm import AllowedCollisionMatrix
from .collision_common import CollisionReport, Contact, DistanceReport
from .collision_matrix import CollisionMatrix, compute_collision_matrix

__all__ = ["AllowedCollisionMatrix", "CollisionMatrix", "CollisionReport", "Contact", "DistanceReport",
           "compute_collision_matrix"]
