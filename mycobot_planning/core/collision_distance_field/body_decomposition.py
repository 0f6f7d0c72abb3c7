"""Collision spheres of robot bodies (MoveIt's collision_distance_field BodyDecomposition).

A gradient-based planner (CHOMP) needs, for every state of a path, points on the robot whose
distance to the world it can read from a distance field and push along a Jacobian. MoveIt
covers each link shape with spheres along its bounding cylinder's axis; here each shape's
points (mesh vertices, or points on a primitive's surface) are covered by the slab spheres of
collision_detection.sphere_cover (the cover the batch collision check uses too). The spheres are fixed in the frame of the shape's Pinocchio joint, so their
world positions and Jacobians come from forward kinematics of that joint.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Sequence

import coal
import numpy as np

from ..collision_detection.sphere_cover import shape_spheres
from ..robot_model.robot_model import RobotModel

__all__ = ["BodySpheres", "geometry_points", "group_spheres", "moving_joints", "shape_spheres",
           "spheres_of_bodies"]


@dataclass(frozen=True)
class BodySpheres:
    """Spheres fixed to Pinocchio joints: ``centres`` (S, 3) in the joint frame, ``radii`` (S,),
    the joint per sphere, and the body (link or attached object) each sphere covers."""

    centres: np.ndarray
    radii: np.ndarray
    joints: np.ndarray
    bodies: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.radii)

    @staticmethod
    def empty() -> "BodySpheres":
        return BodySpheres(np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=int), ())

    def __add__(self, other: "BodySpheres") -> "BodySpheres":
        return BodySpheres(np.vstack([self.centres, other.centres]), np.concatenate([self.radii, other.radii]),
                           np.concatenate([self.joints, other.joints]).astype(int), self.bodies + other.bodies)


def geometry_points(geometry: coal.CollisionGeometry, samples: int = 8) -> np.ndarray | None:
    """Points on the surface of a Coal shape in its own frame (mesh vertices; corners, edges and
    rings of primitives); None for a shape this does not know."""
    if isinstance(geometry, coal.BVHModelBase):
        points = np.asarray(geometry.vertices(), dtype=float)
        return points if len(points) else None
    if isinstance(geometry, coal.ConvexBase):
        return np.asarray(geometry.points(), dtype=float)
    if isinstance(geometry, coal.Sphere):
        r = geometry.radius
        return np.array([[r, 0, 0], [-r, 0, 0], [0, r, 0], [0, -r, 0], [0, 0, r], [0, 0, -r]], dtype=float)
    if isinstance(geometry, coal.Box):
        h = np.asarray(geometry.halfSide, dtype=float)
        axes = [np.linspace(-x, x, samples) for x in h]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        on_surface = np.any(np.isclose(np.abs(grid), h), axis=1)
        return grid[on_surface]
    if isinstance(geometry, (coal.Cylinder, coal.Cone, coal.Capsule)):
        r, h = float(geometry.radius), float(geometry.halfLength)
        angles = np.linspace(0.0, 2.0 * math.pi, 4 * samples, endpoint=False)
        ring = np.column_stack([r * np.cos(angles), r * np.sin(angles)])
        heights = np.linspace(-h, h, samples)
        radius_at = (lambda z: r * (h - z) / (2.0 * h)) if isinstance(geometry, coal.Cone) else (lambda z: r)
        rows = [np.column_stack([ring * (radius_at(z) / r if r > 0 else 0.0), np.full(len(ring), z)])
                for z in heights]
        points = np.vstack(rows)
        if isinstance(geometry, coal.Capsule):
            points = np.vstack([points, [[0, 0, h + r], [0, 0, -h - r]]])
        return points
    return None


def _spheres_of(geometry: coal.CollisionGeometry, placement: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Spheres of one shape in the frame ``placement`` (4x4: that frame -> shape frame) is given in."""
    if isinstance(geometry, coal.Sphere):  # exactly itself
        return placement[:3, 3][None].copy(), np.array([float(geometry.radius)])
    points = geometry_points(geometry)
    if points is None:
        return np.zeros((0, 3)), np.zeros(0)
    points = points @ placement[:3, :3].T + placement[:3, 3]
    return shape_spheres(points)


def spheres_of_bodies(items: Iterable[tuple[str, int, coal.CollisionGeometry, np.ndarray]]) -> BodySpheres:
    """Spheres of (body name, Pinocchio joint, shape, placement in the joint frame) items."""
    centres, radii, joints, bodies = [], [], [], []
    for body, joint, geometry, placement in items:
        c, r = _spheres_of(geometry, np.asarray(placement, dtype=float))
        centres.append(c)
        radii.append(r)
        joints.extend([int(joint)] * len(r))
        bodies.extend([body] * len(r))
    if not joints:
        return BodySpheres.empty()
    return BodySpheres(np.vstack(centres), np.concatenate(radii), np.asarray(joints, dtype=int), tuple(bodies))


def moving_joints(model: RobotModel, variable_indices: Sequence[int]) -> frozenset[int]:
    """Pinocchio joints whose placement changes with these variables (their own joints, mimic
    followers, and every joint below them)."""
    jmap = model.jacobian_map(np.asarray(variable_indices, dtype=int))
    moving_v = set(np.flatnonzero(np.any(jmap != 0.0, axis=1)).tolist())
    pin_model = model.pin_model
    driven = {j for j in range(1, pin_model.njoints)
              if moving_v.intersection(range(pin_model.idx_vs[j], pin_model.idx_vs[j] + pin_model.nvs[j]))}
    return frozenset(j for j in range(1, pin_model.njoints) if driven.intersection(pin_model.supports[j]))


def group_spheres(model: RobotModel, group: str) -> BodySpheres:
    """The collision spheres of the links a group moves (cached on the model)."""
    def build() -> BodySpheres:
        moving = moving_joints(model, model.group(group).variable_indices)
        pin_model = model.pin_model
        items = []
        for geom in model.pin_collision_model.geometryObjects:
            joint = int(geom.parentJoint)
            if joint in moving:
                items.append((pin_model.frames[geom.parentFrame].name, joint, geom.geometry, geom.placement.homogeneous))
        spheres = spheres_of_bodies(items)
        for array in (spheres.centres, spheres.radii, spheres.joints):
            array.setflags(write=False)
        return spheres

    return model.cached(("collision_distance_field.group_spheres", group), build)
