"""move_group's Cartesian path capability (MoveIt: MoveGroupCartesianPathService,
/compute_cartesian_path): waypoints in a frame, followed by the group's link in straight lines.
With the trajectory cache enabled, a complete path stored for the same request (and valid in the
current scene) answers instead; complete paths computed are offered to the cache."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from interfaces_py.msgs import JointTrajectory, MoveItErrorCode, RobotState as RobotStateMsg

from ..core.planners.cartesian.cartesian_path import compute_cartesian_path as follow_waypoints
from ..core.planners.cartesian.cartesian_path import STOP_COMPLETE
from ..core.robot_trajectory.robot_trajectory import timed_to_joint_trajectory
from ..core.trajectory_cache import GetCartesianPathRequest
from . import trajectory_cache
from .move_group_context import MoveGroupContext, RequestError, check_number

#: m: the smallest eef_step (max_step) taken; below it MoveIt answers FAILURE
MIN_EEF_STEP = 2.220446049250313e-16

__all__ = ["CartesianPathRequest", "CartesianPathResult", "MAX_WAYPOINTS", "compute_cartesian_path"]

#: waypoints of one Cartesian request at most (each is one IK target).
MAX_WAYPOINTS = 10_000


@dataclass
class CartesianPathRequest:
    """MoveIt's GetCartesianPath request; 0 scaling factors mean the server's defaults."""

    group: str
    waypoints: Sequence[np.ndarray]  # 4x4 poses in ``frame``
    frame: str = "world"
    link: str = ""  # "": the group's tip
    ik_frame_offset: np.ndarray | None = None
    eef_step: float = 0.01
    jump_threshold: float = 0.0
    revolute_jump_threshold: float = 0.0
    prismatic_jump_threshold: float = 0.0
    avoid_collisions: bool = True
    max_velocity_scaling_factor: float = 0.0
    max_acceleration_scaling_factor: float = 0.0
    start_state: RobotStateMsg | None = None
    path_constraints: Any = None  # the core's constraint description (kinematic_constraints)


@dataclass
class CartesianPathResult:
    error_code: MoveItErrorCode
    trajectory: JointTrajectory | None = None
    fraction: float = 0.0
    stop_reason: str = ""
    planning_time: float = 0.0
    start_state: Any = field(default=None, repr=False)  # core RobotState the path starts from
    #: "hit", "miss" (the cache is enabled and was consulted) or ""
    trajectory_cache: str = ""


def compute_cartesian_path(ctx: MoveGroupContext, request: CartesianPathRequest, display: bool = True
                           ) -> CartesianPathResult:
    """Follow the waypoints as far as possible; never raises for bad input."""
    bad = MoveItErrorCode.INVALID_MOTION_PLAN
    model = ctx.model
    try:
        if not model.has_group(request.group):
            raise RequestError(MoveItErrorCode.INVALID_GROUP_NAME, f"unknown planning group {request.group!r}; "
                                                                  f"known: {', '.join(model.group_names)}")
        if not request.waypoints:
            raise RequestError(bad, "waypoints must be a non-empty list of poses")
        if len(request.waypoints) > MAX_WAYPOINTS:
            raise RequestError(bad, f"{len(request.waypoints)} waypoints: a Cartesian request may have at most "
                                    f"{MAX_WAYPOINTS}")
        kwargs: dict[str, Any] = {key: check_number(getattr(request, key), key) for key in (
            "eef_step", "jump_threshold", "revolute_jump_threshold", "prismatic_jump_threshold")}
        if not kwargs["eef_step"] > MIN_EEF_STEP:  # MoveIt: FAILURE for max_step < epsilon, never a default
            raise RequestError(MoveItErrorCode.FAILURE, f"max_step (eef_step) must be > 0, got {kwargs['eef_step']:g}")
        for key in ("max_velocity_scaling_factor", "max_acceleration_scaling_factor"):
            value = getattr(request, key)
            kwargs[key.replace("max_", "").replace("_factor", "")] = (
                getattr(ctx.defaults, key) if not value else check_number(value, key))
        if request.link and not model.has_link(request.link):
            raise RequestError(bad, f"unknown link {request.link!r} of robot '{model.name}'")
        scene = ctx.start_scene(request.start_state, model.group(request.group).joint_names)
        poses = ctx.in_world(list(request.waypoints), request.frame or "world", scene)
        kwargs["path_constraints"] = ctx.resolve_path_constraints(request.path_constraints, scene)
    except RequestError as exc:
        return CartesianPathResult(MoveItErrorCode(exc.moveit_code, exc.message, "planning_server"),
                                   stop_reason="invalid_request")
    cache_key, refused = None, 0
    if request.avoid_collisions and trajectory_cache.enabled(ctx):  # paths through obstacles are never cached
        cache_key = GetCartesianPathRequest(
            request.group, scene.current_state.copy(), poses, request.link, request.ik_frame_offset,
            kwargs["eef_step"], kwargs["jump_threshold"], kwargs["revolute_jump_threshold"],
            kwargs["prismatic_jump_threshold"], kwargs["velocity_scaling"], kwargs["acceleration_scaling"],
            kwargs["path_constraints"])
        lookup = trajectory_cache.fetch_cartesian_path(ctx, scene, cache_key)
        hit, refused = lookup.hit, lookup.refused
        if hit is not None:
            out = CartesianPathResult(
                MoveItErrorCode(MoveItErrorCode.SUCCESS, f"trajectory cache hit: entry {hit.entry.id}, validated in "
                                "the current scene", "trajectory_cache"),
                timed_to_joint_trajectory(hit.trajectory, ctx.defaults.sample_period or None), 1.0, STOP_COMPLETE,
                hit.lookup_time + hit.validate_time, scene.current_state, "hit")
            if display:
                ctx.display(out.trajectory)
            ctx.log("info", f"cartesian path for '{request.group}' answered from the trajectory cache "
                            f"(entry {hit.entry.id})")
            return out
    result = follow_waypoints(scene, request.group, scene.current_state.copy(), poses, link=request.link or None,
                              ik_frame_offset=request.ik_frame_offset, avoid_collisions=request.avoid_collisions,
                              **kwargs)
    out = CartesianPathResult(MoveItErrorCode(result.error_code.val, result.error_code.message, "cartesian_path"),
                              None, float(result.fraction), result.stop_reason, result.planning_time,
                              scene.current_state, "miss" if cache_key is not None else "")
    if cache_key is not None and result.success and result.trajectory is not None:
        trajectory_cache.insert_cartesian_path(ctx, cache_key, result.trajectory, float(result.fraction),
                                               result.planning_time, refused)
    if result.success and result.trajectory is not None:
        out.trajectory = timed_to_joint_trajectory(result.trajectory, ctx.defaults.sample_period or None)
        if display and result.fraction > 0:
            ctx.display(out.trajectory)
    ctx.log("info" if result.success else "warning", f"cartesian path for '{request.group}': fraction "
            f"{result.fraction:.3f} ({result.stop_reason}) {result.message}")
    return out
