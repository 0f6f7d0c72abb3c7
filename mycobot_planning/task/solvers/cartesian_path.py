"""MTC's CartesianPath solver: a straight line of the ik frame (core compute_cartesian_path)."""
from __future__ import annotations

from typing import Any

import numpy as np

from ...core.planners.cartesian.cartesian_path import compute_cartesian_path
from ...core.planners.cartesian.cartesian_precision import CartesianPrecision
from ...core.trajectory_processing.cartesian_speed_limit import limit_cartesian_link_speed
from ...core.transforms import inverse
from ..geometry import PoseStamped, as_pose_stamped, robot_tip_for_frame
from ..properties import PropertySetter
from .planner_interface import PlannerInterface, PlanResult, constraint_failure, constraints_key


class CartesianPath(PlannerInterface):
    """A straight line of the ik frame, MTC's CartesianPath solver."""

    def __init__(self, step_size: float = 0.01, jump_threshold: float = 1.5, min_fraction: float = 1.0) -> None:
        super().__init__()
        p = self._properties
        p.declare("ik_frame", None, "frame to move linearly (for joint-space targets)", type=PoseStamped,
                  coerce=as_pose_stamped)
        p.declare("step_size", step_size, "step size between consecutive waypoints (m)", type=float)
        p.declare("jump_threshold", jump_threshold, "acceptable fraction of mean joint motion per step", type=float)
        p.declare("min_fraction", min_fraction, "fraction of motion required for success", type=float)
        p.declare("precision", CartesianPrecision(), "precision of the linear path (MoveIt's CartesianPrecision)",
                  type=CartesianPrecision)
        p.declare("max_cartesian_speed", 0.0, "max Cartesian speed of cartesian_speed_limited_link (m/s; 0: "
                  "no limit): the trajectory is slowed down uniformly", type=float)
        p.declare("cartesian_speed_limited_link", "", "link whose speed max_cartesian_speed limits (empty: the "
                  "link the ik_frame is on)", type=str)

    setStepSize = PropertySetter("step_size", float)
    setJumpThreshold = PropertySetter("jump_threshold", float)
    setMinFraction = PropertySetter("min_fraction", float)
    setPrecision = PropertySetter("precision", CartesianPrecision)

    def setIKFrame(self, pose_or_link: Any, link: str | None = None) -> None:
        self._properties.set("ik_frame", pose_or_link if link is None else PoseStamped(link, pose_or_link))

    @property
    def planner_id(self) -> str:
        return "CartesianPath"

    def init(self, robot_model):
        super().init(robot_model)
        p = self._properties
        if not p["step_size"] > 0:
            raise ValueError(f"step_size must be > 0, got {p['step_size']}")
        if p["jump_threshold"] < 0:
            raise ValueError(f"jump_threshold must be >= 0, got {p['jump_threshold']}")
        if not 0.0 <= p["min_fraction"] <= 1.0:
            raise ValueError(f"min_fraction must be in [0, 1], got {p['min_fraction']}")
        if not p["max_cartesian_speed"] >= 0.0:
            raise ValueError(f"max_cartesian_speed must be >= 0 m/s (0: no limit), got {p['max_cartesian_speed']}")
        limited = p["cartesian_speed_limited_link"]
        if limited and not robot_model.has_link(limited):
            raise ValueError(f"cartesian_speed_limited_link '{limited}' is not a link of robot '{robot_model.name}'")

    def plan(self, from_scene, to_scene, group, timeout, context=None, path_constraints=None):
        link, ik_pose = robot_tip_for_frame(self._properties["ik_frame"], from_scene, group)
        offset = inverse(from_scene.current_state.frame_pose(link)) @ ik_pose
        target = to_scene.current_state.frame_pose(link) @ offset
        return self.plan_pose(from_scene, link, offset, target, group, timeout, context, path_constraints)

    def plan_pose(self, from_scene, link, offset, target, group, timeout, context=None, path_constraints=None):
        parts = ("pose", group, link, np.asarray(offset, dtype=float).tobytes(), np.asarray(target, dtype=float).tobytes(),
                 constraints_key(path_constraints))
        return self._memoized(context, from_scene, parts,
                              lambda: self._plan_pose(from_scene, link, offset, target, group, path_constraints))

    def _plan_pose(self, from_scene, link, offset, target, group, path_constraints=None):
        constraints, failed = constraint_failure(self, path_constraints, from_scene)
        if failed is not None:
            return failed
        velocity, acceleration = self._scaling()
        p = self._properties
        result = compute_cartesian_path(
            from_scene, group, from_scene.current_state, [np.asarray(target, dtype=float)], link=link,
            ik_frame_offset=np.asarray(offset, dtype=float), eef_step=float(p["step_size"]),
            jump_threshold=float(p["jump_threshold"]), avoid_collisions=True, velocity_scaling=velocity,
            acceleration_scaling=acceleration, path_constraints=constraints, precision=p["precision"],
        )
        if not result.success:
            return PlanResult(False, None, result.message, self.planner_id)
        fraction = result.fraction
        if fraction < float(p["min_fraction"]) - 1e-12:
            return PlanResult(False, result.trajectory, f"min_fraction not met. Achieved: {fraction:.6f} "
                                                        f"({result.message})", self.planner_id)
        trajectory = result.trajectory
        if p["max_cartesian_speed"] > 0.0 and trajectory is not None:
            limited = p["cartesian_speed_limited_link"] or link
            trajectory = limit_cartesian_link_speed(trajectory, from_scene.current_state, limited,
                                                    float(p["max_cartesian_speed"]))
        return PlanResult(True, trajectory, f"achieved fraction: {fraction:.6f}", self.planner_id)
