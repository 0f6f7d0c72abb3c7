"""The keys of the trajectory cache (MoveIt's trajectory_cache features): what of a motion plan
request, or of a Cartesian path request, a cached trajectory is stored under and matched on.

A key is a list of named features, named as MoveIt's features name their metadata
("StartStateJointStateFeatures.start_state.joint_state.position.<joint>", ...). Strings (group,
frame, link and joint names, the planner) must be equal; numbers are matched by kind:

* START: within the start tolerance (value in [cached - tol/2, cached + tol/2], MoveIt's
  queryAppendCenterWithTolerance), GOAL: the same with the goal tolerance (goal poses and joint
  values, path constraints, Cartesian waypoints), EXACT: within exact_match_precision;
* AT_MOST: the cached value is at most the requested one (scaling factors, max_step, goal
  tolerances: a trajectory made under stricter settings serves a looser request);
* THRESHOLD: a jump threshold; 0 (disabled) in the request accepts any, a set one needs a set
  cached one at most as large.

Requests are keyed as the plan capability has completed them: the start state whole (every
non-mimic variable), goals and waypoints in the world frame, named goals as their joint values
(so "ready" and its joint values share entries), quaternions with w >= 0. As in MoveIt,
collisions, attached objects and velocities are NOT keys: a hit must be validated against the
current scene before use (the plan capability does so).
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from ..kinematic_constraints.kinematic_constraints import PathConstraints
from ..planning_interface.planning_interface import JointGoal, MotionPlanRequest, NamedGoal, PoseGoal, joint_goal_vector
from ..robot_model.robot_model import JointModelGroup, RobotModel
from ..robot_state.robot_state import RobotState
from ..transforms import matrix_to_quat

__all__ = ["AT_MOST", "CacheKey", "EXACT", "FeatureError", "GOAL", "GetCartesianPathRequest", "START", "THRESHOLD",
           "cartesian_path_request_features", "motion_plan_request_features"]

START, GOAL, EXACT, AT_MOST, THRESHOLD = "start", "goal", "exact", "at_most", "threshold"
_KINDS = (START, GOAL, EXACT, AT_MOST, THRESHOLD)
#: the planning frame every key is stated in (goals and waypoints are restated in it)
WORLD = "world"


class FeatureError(ValueError):
    """A request the cache cannot key (a goal it cannot resolve): it is planned, never cached."""


@dataclass(frozen=True)
class GetCartesianPathRequest:
    """MoveIt's GetCartesianPath request as the cache keys it: waypoints (4x4) in the world frame,
    the link that follows them, the start state whole."""

    group: str
    start_state: RobotState
    waypoints: Sequence[np.ndarray]
    link: str = ""  # "": the group's tip
    ik_frame_offset: np.ndarray | None = None
    max_step: float = 0.01
    jump_threshold: float = 0.0
    revolute_jump_threshold: float = 0.0
    prismatic_jump_threshold: float = 0.0
    max_velocity_scaling_factor: float = 1.0
    max_acceleration_scaling_factor: float = 1.0
    path_constraints: PathConstraints | None = None


@dataclass(frozen=True)
class CacheKey:
    """A request's features: ``strings`` must be equal, ``values[i]`` is matched as ``kinds[i]``.
    ``signature`` digests everything but the values: only entries with the same signature can
    match (the SQL lookup narrows on it, then the values are compared)."""

    strings: tuple[tuple[str, str], ...]
    names: tuple[str, ...]
    kinds: tuple[str, ...]
    values: np.ndarray

    @property
    def signature(self) -> str:
        text = repr((self.strings, self.names, self.kinds))
        return hashlib.sha1(text.encode()).hexdigest()

    def as_dict(self) -> dict[str, Any]:
        """The features by name (what is stored beside the trajectory, readable in the database)."""
        out: dict[str, Any] = dict(self.strings)
        out.update({name: float(v) for name, v in zip(self.names, self.values)})
        return out

    def match_mask(self, cached: np.ndarray, start_tolerance: float, goal_tolerance: float,
                   exact_match_precision: float, exact: bool = False) -> np.ndarray:
        """Which rows of ``cached`` (N x len(values), entries of the same signature) this request
        matches. ``exact``: every number within exact_match_precision (what an insert prunes)."""
        cached = np.asarray(cached, dtype=float).reshape(-1, len(self.values))
        if not len(self.values):
            return np.ones(cached.shape[0], dtype=bool)
        kinds = np.asarray(self.kinds)
        half = np.full(len(self.values), exact_match_precision / 2.0)
        if not exact:
            half[kinds == START] += start_tolerance / 2.0
            half[kinds == GOAL] += goal_tolerance / 2.0
        query = self.values[None, :]
        ok = np.abs(cached - query) <= half
        if not exact:
            at_most = kinds == AT_MOST
            ok[:, at_most] = cached[:, at_most] <= query[:, at_most] + half[at_most]
            threshold = kinds == THRESHOLD
            free = query[0] <= 0.0
            ok[:, threshold & free] = True
            limited = threshold & ~free
            ok[:, limited] = (cached[:, limited] > 0.0) & (cached[:, limited] <= query[:, limited] + half[limited])
        return np.all(ok, axis=1)


class _Builder:
    def __init__(self) -> None:
        self.strings: list[tuple[str, str]] = []
        self.names: list[str] = []
        self.kinds: list[str] = []
        self.values: list[float] = []

    def string(self, name: str, value: str) -> None:
        self.strings.append((name, str(value)))

    def number(self, name: str, value: float, kind: str) -> None:
        value = float(value)
        if not np.isfinite(value):
            raise FeatureError(f"feature {name} is not finite ({value})")
        self.names.append(name)
        self.kinds.append(kind)
        self.values.append(value)

    def pose(self, name: str, pose: np.ndarray, kind: str) -> None:
        pose = np.asarray(pose, dtype=float)
        for axis, v in zip("xyz", pose[:3, 3]):
            self.number(f"{name}.position.{axis}", v, kind)
        for axis, v in zip("xyzw", matrix_to_quat(pose[:3, :3])):
            self.number(f"{name}.orientation.{axis}", v, kind)

    def start_state(self, prefix: str, model: RobotModel, state: RobotState) -> None:
        if not isinstance(state, RobotState) or state.model is not model:
            raise FeatureError("the request's start state is not a RobotState of the robot")
        mimic = set(model.mimic_joint_names)
        positions = state.positions
        for index, name in enumerate(model.variable_names):
            if name not in mimic:
                self.number(f"{prefix}.start_state.joint_state.position.{name}", positions[index], START)

    def scaling(self, prefix: str, velocity: float | None, acceleration: float | None) -> None:
        for name, value in (("max_velocity_scaling_factor", velocity), ("max_acceleration_scaling_factor", acceleration)):
            # MoveIt: 0 (or anything outside (0, 1]) means 1.0
            value = 1.0 if value is None or not 0.0 < float(value) <= 1.0 else float(value)
            self.number(f"{prefix}.{name}", value, AT_MOST)

    def constraints(self, prefix: str, constraints: PathConstraints | None) -> None:
        if not constraints:
            self.string(f"{prefix}", "none")
            return
        for joint in sorted(constraints.joints, key=lambda j: j.joint):
            name = f"{prefix}.joint_constraints.{joint.joint}"
            self.string(f"{name}.joint_name", joint.joint)
            self.number(f"{name}.position", joint.position, GOAL)
            self.number(f"{name}.tolerance_above", joint.tolerance_above, AT_MOST)
            self.number(f"{name}.tolerance_below", joint.tolerance_below, AT_MOST)
        for k, orientation in enumerate(constraints.orientations):
            name = f"{prefix}.orientation_constraints_{k}"
            self.string(f"{name}.link_name", orientation.link)
            self.string(f"{name}.parameterization", str(orientation.parameterization))
            rotation = np.eye(4)
            rotation[:3, :3] = orientation.orientation
            self.pose(f"{name}.orientation", rotation, GOAL)
            for axis, v in zip("xyz", np.asarray(orientation.tolerances, dtype=float)):
                self.number(f"{name}.absolute_{axis}_axis_tolerance", v, AT_MOST)
            self.pose(f"{name}.offset", np.eye(4) if orientation.offset is None else orientation.offset, EXACT)
        for k, position in enumerate(constraints.positions):
            name = f"{prefix}.position_constraints_{k}"
            self.string(f"{name}.link_name", position.link)
            for axis, v in zip("xyz", np.asarray(position.offset, dtype=float)):
                self.number(f"{name}.target_point_offset.{axis}", v, EXACT)
            for r, region in enumerate(position.regions):
                self.string(f"{name}.constraint_region_{r}.type", region.kind)
                for d, v in enumerate(region.dimensions):
                    self.number(f"{name}.constraint_region_{r}.dimensions_{d}", v, GOAL)
                self.pose(f"{name}.constraint_region_{r}.pose", np.linalg.inv(region.pose_inverse), GOAL)

    def build(self) -> CacheKey:
        return CacheKey(tuple(self.strings), tuple(self.names), tuple(self.kinds), np.array(self.values, dtype=float))


def _workspace(model: RobotModel, group: str, features: str, frame_field: str) -> tuple[JointModelGroup, _Builder]:
    """The request's group and a key that starts with its workspace ``features``: the group's
    name and the frame (``frame_field``) the request is in. FeatureError for an unknown group."""
    if not model.has_group(group):
        raise FeatureError(f"unknown planning group {group!r}")
    key = _Builder()
    key.string(f"{features}.group_name", group)
    key.string(f"{features}.{frame_field}", WORLD)
    return model.group(group), key


def motion_plan_request_features(model: RobotModel, request: MotionPlanRequest) -> CacheKey:
    """The key of a completed motion plan request (plan.complete_request's output): MoveIt's
    WorkspaceFeatures, StartStateJointStateFeatures, MaxSpeedAndAccelerationFeatures,
    GoalConstraintsFeatures and PathConstraintsFeatures, plus the pipeline and planner (a PTP or
    LIN request must not be answered with another planner's motion). FeatureError when the goal
    cannot be resolved."""
    jmg, key = _workspace(model, request.group, "WorkspaceFeatures", "workspace_parameters.header.frame_id")
    key.string("PlannerFeatures.pipeline_id", request.pipeline_id)
    key.string("PlannerFeatures.planner_id", request.planner_id)
    key.start_state("StartStateJointStateFeatures", model, request.start_state)
    key.scaling("MaxSpeedAndAccelerationFeatures", request.max_velocity_scaling_factor,
                request.max_acceleration_scaling_factor)
    goal, prefix = request.goal, "GoalConstraintsFeatures.goal_constraints_0"
    if isinstance(goal, (JointGoal, NamedGoal)):
        try:
            vector = joint_goal_vector(model, jmg, goal)
        except Exception as exc:  # PlanningFailure: the planner reports it with its code
            raise FeatureError(f"joint goal: {exc}") from None
        for name, value in sorted(zip(jmg.joint_names, vector)):
            joint = f"{prefix}.joint_constraints.{name}"
            key.string(f"{joint}.joint_name", name)
            key.number(f"{joint}.position", value, GOAL)
            key.number(f"{joint}.tolerance", goal.tolerance, AT_MOST)
    elif isinstance(goal, PoseGoal):
        link = goal.link or jmg.tip_link
        key.string(f"{prefix}.position_constraints_0.link_name", link)
        key.string(f"{prefix}.position_constraints_0.header.frame_id", WORLD)
        key.pose(f"{prefix}.pose", goal.pose, GOAL)
        key.pose(f"{prefix}.ik_frame_offset", np.eye(4) if goal.ik_frame_offset is None else goal.ik_frame_offset, EXACT)
        key.number(f"{prefix}.position_constraints_0.tolerance", goal.position_tolerance, AT_MOST)
        key.number(f"{prefix}.orientation_constraints_0.tolerance", goal.orientation_tolerance, AT_MOST)
    else:
        raise FeatureError(f"unrecognised goal type {type(goal).__name__}")
    for name in ("circ_center", "circ_interim"):
        point = getattr(request, name)
        key.string(f"{prefix}.{name}", "none" if point is None else "set")
        if point is not None:
            for axis, v in zip("xyz", point):
                key.number(f"{prefix}.{name}.{axis}", v, GOAL)
    key.constraints("PathConstraintsFeatures.path_constraints", request.path_constraints)
    return key.build()


def cartesian_path_request_features(model: RobotModel, request: GetCartesianPathRequest) -> CacheKey:
    """The key of a Cartesian path request: MoveIt's CartesianWorkspaceFeatures,
    CartesianStartStateJointStateFeatures, CartesianMaxSpeedAndAccelerationFeatures,
    CartesianMaxStepAndJumpThresholdFeatures, CartesianWaypointsFeatures and
    CartesianPathConstraintsFeatures (the fraction is matched by the fetch, ``min_fraction``)."""
    jmg, key = _workspace(model, request.group, "CartesianWorkspaceFeatures", "header.frame_id")
    key.start_state("CartesianStartStateJointStateFeatures", model, request.start_state)
    key.scaling("CartesianMaxSpeedAndAccelerationFeatures", request.max_velocity_scaling_factor,
                request.max_acceleration_scaling_factor)
    step = "CartesianMaxStepAndJumpThresholdFeatures"
    key.number(f"{step}.max_step", request.max_step, AT_MOST)
    for name in ("jump_threshold", "revolute_jump_threshold", "prismatic_jump_threshold"):
        key.number(f"{step}.{name}", getattr(request, name), THRESHOLD)
    prefix = "CartesianWaypointsFeatures"
    key.string(f"{prefix}.link_name", request.link or jmg.tip_link)
    key.pose(f"{prefix}.ik_frame_offset",
             np.eye(4) if request.ik_frame_offset is None else request.ik_frame_offset, EXACT)
    for k, waypoint in enumerate(request.waypoints):
        key.pose(f"{prefix}.waypoints_{k}", waypoint, GOAL)
    key.constraints("CartesianPathConstraintsFeatures.path_constraints", request.path_constraints)
    return key.build()
