"""Distances for gradient-based planners (moveit_core/collision_distance_field and distance_field):
collision spheres of the robot's bodies (body_decomposition) and the signed distance to the
world's objects with its gradient (distance_field)."""
from .body_decomposition import BodySpheres, group_spheres, spheres_of_bodies
from .distance_field import WorldDistanceField

__all__ = ["BodySpheres", "WorldDistanceField", "group_spheres", "spheres_of_bodies"]
