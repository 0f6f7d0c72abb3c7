"""The planning_server's ROS parameters (besides where its robot comes from): the trajectory
cache, the execution manager's settings, the planning defaults and the Trigger services' goal,
each with its description, range and check. The node: planning_server.py.

The full story: docs/nodes.md, section mycobot_planning.ros.move_group.planning_server.
"""
from __future__ import annotations

import math
from typing import Any, Callable

from mycobot_planning.core.planning_interface.planning_pipeline import PlanningPipeline
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.robot_trajectory.robot_trajectory import DEFAULT_MAX_WAYPOINT_DISTANCE
from mycobot_planning.core.trajectory_cache.cache_insert_policies import POLICIES
from mycobot_planning.core.trajectory_processing.trajectory_limits import DEFAULT_LIMIT_TOLERANCE
from mycobot_planning.ros.node_runtime import ParameterSpec

__all__ = ["planning_server_parameter_specs"]


def _numbers(name: str, size: int | None = None) -> Callable[[Any], str | None]:
    def check(value: Any) -> str | None:
        if value is None:  # `[]` in a params file has no type: rcl leaves the parameter unset
            return None
        if not isinstance(value, (list, tuple)):
            return f"{name} must be a list of numbers, got {type(value).__name__} {value!r}"
        if len(value) == 0:
            return None
        if any(isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) for v in value):
            return f"{name} must contain finite numbers only, got {list(value)!r}"
        if size is not None and len(value) != size:
            return f"{name} must be empty or have exactly {size} values, got {len(value)}"
        if size == 7 and math.hypot(*value[3:]) < 1e-9:
            return f"{name}: the quaternion (values 4-7) must not be zero"
        return None

    return check


def planning_server_parameter_specs(model: RobotModel, pipeline: PlanningPipeline,
                                    goal_group: Callable[[], str]) -> list[ParameterSpec]:
    """The planning_server's parameters, checked against ``model`` (groups, named states, links)
    and ``pipeline`` (its planners); ``goal_group()`` is the group goal.joint_values are for."""
    named = sorted({n for g in model.group_names for n in model.named_state_names(g)})

    def group_check(value: Any) -> str | None:
        return None if model.has_group(value) else f"unknown planning group '{value}'; known: {model.group_names}"

    def named_check(value: Any) -> str | None:
        return None if not value or value in named else f"unknown named state '{value}'; known: {named}"

    def link_check(value: Any) -> str | None:
        return None if not value or model.has_link(value) else f"unknown link '{value}' of robot '{model.name}'"

    def pipeline_check(value: Any) -> str | None:
        ids = pipeline.pipeline_ids
        return None if value in ids else f"unknown planning pipeline '{value}'; known: {ids}"

    def planner_check(value: Any) -> str | None:
        return pipeline.planner_id_problem(value, model.group_names)

    joint_numbers = _numbers("goal.joint_values")

    def joint_values_check(value: Any) -> str | None:
        problem = joint_numbers(value)
        if problem is not None or not value:
            return problem
        group = goal_group()
        joints = model.group(group).joint_names if model.has_group(group) else []
        if len(value) != len(joints):
            return (f"goal.joint_values has {len(value)} values but group '{group}' has {len(joints)} joints "
                    f"{list(joints)}")
        return None

    def policy_check(value: Any) -> str | None:
        return None if value in POLICIES else f"unknown cache insert policy '{value}'; known: {list(POLICIES)}"

    ex = "trajectory_execution."
    tc = "trajectory_cache."
    return [
        ParameterSpec(tc + "enabled", False,
                      "answer plan and Cartesian path requests from the trajectory cache when a stored "
                      "trajectory matches (and passes the validator in the current scene), and store what is "
                      "planned"),
        ParameterSpec(tc + "cache_namespace", "", "the cache's namespace (MoveIt's collection); empty: the "
                      "robot's name"),
        ParameterSpec(tc + "start_tolerance", 0.025,
                      "rad or m: a cached start state matches when every joint is within half of this of the "
                      "request's (MoveIt's start_tolerance); the hit is stitched to the actual start",
                      range=(0.0, 10.0)),
        ParameterSpec(tc + "goal_tolerance", 0.001,
                      "rad, m or quaternion component: cached goals, waypoints and path constraints match "
                      "within half of this (MoveIt's goal_tolerance)", range=(0.0, 10.0)),
        ParameterSpec(tc + "exact_match_precision", 1e-6,
                      "slack of exact matches (MoveIt's exact_match_precision)", range=(0.0, 0.1)),
        ParameterSpec(tc + "cache_insert_policy", "BestSeenExecutionTimePolicy",
                      "BestSeenExecutionTimePolicy (insert only faster trajectories, prune slower) or "
                      "AlwaysInsertNeverPrunePolicy", validator=policy_check),
        ParameterSpec(tc + "prune_worse_trajectories", True,
                      "let the insert policy delete slower entries of exactly the same request"),
        ParameterSpec(tc + "num_additional_trajectories_to_preserve_when_pruning_worse", 1,
                      "best entries kept when pruning (MoveIt's option of that name)", range=(0, 1000)),
        ParameterSpec("joint_state_timeout", 1.0,
                      "seconds after which the last /joint_states message is stale: planning and execution "
                      "refuse a stale current state", range=(0.01, 3600.0)),
        ParameterSpec("scene_publish_rate", 2.0, "Hz at which the monitored planning scene (both faces) and the scene markers "
                      "are republished (they are also published on every change)", range=(0.1, 100.0)),
        ParameterSpec("trajectory_sample_period", 0.1,
                      "seconds between the points of planned trajectories, MoveIt's resample_dt (the breakpoints are "
                      "always kept, so controllers interpolating cubically follow them exactly; 0: breakpoints only)",
                      range=(0.0, 1.0)),
        ParameterSpec(ex + "allowed_execution_duration_scaling", 1.2,
                      "execution may take this many times the trajectory's duration (plus the margin)",
                      range=(1.0, 100.0)),
        ParameterSpec(ex + "allowed_goal_duration_margin", 0.5,
                      "seconds added to the scaled duration before execution is cancelled as TIMED_OUT",
                      range=(0.0, 3600.0)),
        ParameterSpec(ex + "limit_tolerance", DEFAULT_LIMIT_TOLERANCE,
                      "relative slack on the joint velocity and acceleration limits: a trajectory exceeding "
                      "them by more is refused before it is sent (0.05: 5 %)", range=(0.0, 1.0)),
        ParameterSpec(ex + "max_waypoint_distance", DEFAULT_MAX_WAYPOINT_DISTANCE,
                      "largest joint motion (rad or m) between consecutive points sent to a controller: "
                      "sparser trajectories get points of the controller's own spline in between, so the "
                      "path it follows is the one described and checked (0: send points as given)",
                      range=(0.0, 10.0)),
        ParameterSpec(ex + "allowed_start_tolerance", 0.01,
                      "largest distance (rad or m) between a trajectory's first point and the current state; "
                      "0 disables the check", range=(0.0, 10.0)),
        ParameterSpec(ex + "execution_duration_monitoring", True,
                      "cancel executions that exceed the allowed duration"),
        ParameterSpec(ex + "goal_tolerance", 0.02,
                      "largest distance (rad or m) between the last point and /joint_states for an execution "
                      "to succeed; 0 trusts the controllers", range=(0.0, 10.0)),
        ParameterSpec("planning_pipeline", "ompl", "default planning pipeline, one of the registered planners: "
                      + ", ".join(pipeline.pipeline_ids), validator=pipeline_check),
        ParameterSpec("planner_id", "", "default planner id (empty: the pipeline's default), e.g. "
                      "'RRTConnectkConfigDefault' or, for the industrial pipeline, PTP, LIN or CIRC",
                      validator=planner_check),
        ParameterSpec("planning_time", 5.0, "default allowed planning time in seconds", range=(0.001, 3600.0)),
        ParameterSpec("planning_attempts", 1, "default number of planning attempts", range=(1, 1000)),
        ParameterSpec("max_velocity_scaling_factor", 1.0, "default velocity scaling factor",
                      range=(0.0001, 1.0)),
        ParameterSpec("max_acceleration_scaling_factor", 1.0, "default acceleration scaling factor",
                      range=(0.0001, 1.0)),
        ParameterSpec("goal.group", "arm" if model.has_group("arm") or not model.group_names else model.group_names[0],
                      "planning group of the Trigger 'plan' service", validator=group_check),
        ParameterSpec("goal.named_target", "", "named state goal (e.g. 'ready') of the Trigger 'plan' service; "
                      "the goal.* target set last is the one planned to", validator=named_check),
        ParameterSpec("goal.joint_values", [], "joint goal (one value per group joint, rad) of the Trigger "
                      "'plan' service", validator=joint_values_check, dynamic_typing=True),
        ParameterSpec("goal.pose", [], "pose goal [x, y, z, qx, qy, qz, qw] in the world frame of the Trigger "
                      "'plan' service", validator=_numbers("goal.pose", 7), dynamic_typing=True),
        ParameterSpec("goal.link", "", "link the pose goal is for (empty: the group's tip link)",
                      validator=link_check),
    ]
