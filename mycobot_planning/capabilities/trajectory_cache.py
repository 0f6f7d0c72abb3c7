"""move_group's trajectory cache: the plan and Cartesian path capabilities answer a request from
core/trajectory_cache (MoveIt's moveit_ros/trajectory_cache) when a stored trajectory fits it,
and store what they plan.

MoveIt's cache ignores collisions and leaves the check to its user; here a hit is only returned
after the same validator the planning pipelines run on their own output (validate_trajectory on
the scene's exact checker, at the validator's resolution, under the request's scaling, plus the
request's path constraints) has passed it in the request's scene, i.e. the CURRENT monitored
scene (with the request's start state and scene diff): a trajectory planned before an obstacle
appeared is refused, counted, and the request is planned afresh. A hit starts where the robot is
(stitch_to_start). A cache that fails (a damaged row) is logged and planning goes on.

Settings come from the planning_server's ``trajectory_cache.*`` parameters; counts appear in its
status (get_state's "trajectory_cache").
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Any, Callable

from ..core.kinematic_constraints.kinematic_constraints import dense_violation
from ..core.planning_interface.planning_interface import MotionPlanRequest, MotionPlanResponse
from ..core.planning_scene.planning_scene import PlanningScene
from ..core.robot_model.robot_model import RobotModel
from ..core.robot_trajectory.robot_trajectory import TimedTrajectory
from ..core.trajectory_cache import (
    CacheEntry,
    CacheKey,
    CacheValue,
    FeatureError,
    GetCartesianPathRequest,
    Options,
    TrajectoryCache,
    TrajectoryCacheError,
    cache_insert_policy,
    cartesian_path_request_features,
    check_options,
    motion_plan_request_features,
    stitch_to_start,
)
from ..core.trajectory_cache.cache_insert_policies import POLICIES
from ..core.trajectory_processing.trajectory_validator import validate_trajectory

__all__ = ["CacheHit", "CacheLookup", "MAX_CANDIDATES", "MoveGroupTrajectoryCache", "TrajectoryCacheSettings", "configure", "enabled",
           "fetch_cartesian_path", "fetch_plan", "insert_cartesian_path", "insert_plan"]

#: matching entries (fastest first) validated per request before it is planned instead: bounds
#: the cost of a lookup in a world that has changed under many entries
MAX_CANDIDATES = 3


@dataclass(frozen=True)
class TrajectoryCacheSettings:
    """The planning_server's trajectory_cache.* parameters (MoveIt's TrajectoryCache::Options and
    the arguments of its fetch and insert calls)."""

    enabled: bool = False
    db_path: str = ":memory:"
    cache_namespace: str = ""  # "": the robot's name
    start_tolerance: float = 0.025
    goal_tolerance: float = 0.001
    exact_match_precision: float = 1e-6
    cache_insert_policy: str = "BestSeenExecutionTimePolicy"
    prune_worse_trajectories: bool = True
    num_additional_trajectories_to_preserve_when_pruning_worse: int = 1

    def problem(self) -> str | None:
        """Why these settings cannot be used, or None."""
        if self.cache_insert_policy not in POLICIES:
            return f"unknown cache_insert_policy {self.cache_insert_policy!r}; known: {', '.join(POLICIES)}"
        for name in ("start_tolerance", "goal_tolerance"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value < float("inf"):
                return f"{name} must be a finite number >= 0, got {value!r}"
        return None


@dataclass
class CacheHit:
    """A validated hit: the stitched trajectory, its entry, and where the time went (s)."""

    trajectory: TimedTrajectory
    entry: CacheEntry
    lookup_time: float
    validate_time: float
    refused: int = 0  # matching entries the validator refused before this one


@dataclass
class CacheLookup:
    """What a lookup found: a validated ``hit``, or None and how many matching entries the
    validator ``refused`` in the current scene (0: nothing matched, or the cache is disabled)."""

    hit: CacheHit | None = None
    refused: int = 0


@dataclass
class _Counts:
    hits: int = 0
    misses: int = 0
    refused: int = 0
    inserted: int = 0
    not_inserted: int = 0


@dataclass
class MoveGroupTrajectoryCache:
    """What a MoveGroupContext holds (``ctx.trajectory_cache``): the open cache, the settings and
    the counts of the status."""

    cache: TrajectoryCache
    settings: TrajectoryCacheSettings
    plans: _Counts = field(default_factory=_Counts)
    cartesian: _Counts = field(default_factory=_Counts)
    last_problem: str = ""
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def namespace(self, model: RobotModel) -> str:
        return self.settings.cache_namespace or model.name

    def count(self, counts: _Counts, **changes: int) -> None:
        with self._lock:
            for name, delta in changes.items():
                setattr(counts, name, getattr(counts, name) + delta)

    def problem(self, text: str) -> None:
        with self._lock:
            self.last_problem = text

    def status(self, model: RobotModel) -> dict[str, Any]:
        namespace = self.namespace(model)
        try:
            entries = self.cache.count_trajectories(namespace)
            cartesian_entries = self.cache.count_cartesian_trajectories(namespace)
        except Exception as exc:  # a closed or damaged database: say so in the status
            entries = cartesian_entries = -1
            self.problem(f"counting entries failed: {exc}")
        with self._lock:
            return {
                "enabled": self.settings.enabled,
                "db_path": self.cache.db_path,
                "cache_namespace": namespace,
                "cache_insert_policy": self.settings.cache_insert_policy,
                "start_tolerance": self.settings.start_tolerance,
                "goal_tolerance": self.settings.goal_tolerance,
                "entries": entries,
                "cartesian_entries": cartesian_entries,
                **{key: value for key, value in vars(self.plans).items()},
                **{f"cartesian_{key}": value for key, value in vars(self.cartesian).items()},
                "last_problem": self.last_problem,
            }


def configure(ctx: Any, settings: TrajectoryCacheSettings) -> MoveGroupTrajectoryCache:
    """Set ``ctx``'s cache to ``settings``: the open database is kept while db_path stays the
    same (its entries too), another is opened (and the old one closed) when it changes.
    TrajectoryCacheError (nothing changed) for unusable settings or a database that is not a
    trajectory cache."""
    problem = settings.problem()
    if problem:
        raise TrajectoryCacheError(problem)
    options = Options(settings.db_path, settings.exact_match_precision,
                      settings.num_additional_trajectories_to_preserve_when_pruning_worse)
    current: MoveGroupTrajectoryCache | None = getattr(ctx, "trajectory_cache", None)
    if current is not None and current.cache.options.db_path == settings.db_path:
        check_options(options)
        current.cache.options = options
        current.settings = settings
        return current
    wrapper = MoveGroupTrajectoryCache(TrajectoryCache(options), settings)
    ctx.trajectory_cache = wrapper
    if current is not None:
        current.cache.close()
    return wrapper


def enabled(ctx: Any) -> bool:
    """Whether ``ctx`` consults a trajectory cache."""
    return _active(ctx) is not None


def _active(ctx: Any) -> MoveGroupTrajectoryCache | None:
    cache = getattr(ctx, "trajectory_cache", None)
    return cache if cache is not None and cache.settings.enabled else None


def _validated(ctx: Any, tc: MoveGroupTrajectoryCache, scene: PlanningScene, group: str, start: Any,
               entries: list[CacheEntry], constraints: Any, velocity_scaling: float, acceleration_scaling: float,
               counts: _Counts, lookup: float, cartesian: bool) -> CacheLookup:
    """The first of ``entries`` that, stitched to ``start``, passes the pipelines' validator in
    ``scene`` (and the path constraints), and how many were refused before it."""
    model = ctx.model
    refused = 0
    validating = 0.0  # s: stitching and validation (``lookup``: key, query and loading)
    for entry in entries[:MAX_CANDIDATES]:
        loading = time.perf_counter()
        try:
            cached = tc.cache.load_trajectory(entry, cartesian=cartesian)
        except TrajectoryCacheError as exc:
            tc.problem(str(exc))
            ctx.log("warning", f"trajectory cache: {exc}")
            continue
        checking = time.perf_counter()
        lookup += checking - loading
        try:
            trajectory = stitch_to_start(model, group, cached, start, velocity_scaling, acceleration_scaling)
        except Exception as exc:  # a cached start too far to time a bridge, a group changed: plan instead
            reason = f"cannot start it at the current state: {exc}"
        else:
            try:
                # the pipelines' check (first_collision: the same verdict, a blocked path refused sooner)
                report = validate_trajectory(scene, trajectory, group, start, velocity_scaling=velocity_scaling,
                                             acceleration_scaling=acceleration_scaling, first_collision=True,
                                             all_pairs=False)
                reason = "" if report.valid else "; ".join(report.problems[:2])
            except ValueError as exc:  # scaling outside (0, 1]: the planner answers that request
                reason = f"cannot validate it: {exc}"
            if not reason and constraints:
                found = dense_violation(constraints, start, trajectory.joint_names, trajectory.positions)
                reason = "" if found is None else f"path constraints: {found[2]}"
        validating += time.perf_counter() - checking
        if not reason:
            tc.count(counts, hits=1, refused=refused)
            return CacheLookup(CacheHit(trajectory, entry, lookup, validating, refused), refused)
        refused += 1
        ctx.log("info", f"trajectory cache entry {entry.id} refused in the current scene: {reason}")
    tc.count(counts, misses=1, refused=refused)
    return CacheLookup(None, refused)


def _key(ctx: Any, tc: MoveGroupTrajectoryCache, features: Callable[[], CacheKey]) -> CacheKey | None:
    try:
        return features()
    except FeatureError as exc:
        ctx.log("info", f"trajectory cache: request not cached: {exc}")
        return None


def fetch_plan(ctx: Any, scene: PlanningScene, request: MotionPlanRequest) -> CacheLookup:
    """A validated hit for a completed request (plan.complete_request), or none (cache disabled,
    no match, every match refused in ``scene``)."""
    return _fetch(ctx, scene, request, lambda: motion_plan_request_features(ctx.model, request),
                  lambda tc, key, s: tc.cache.fetch_all_matching_trajectories(
                      tc.namespace(ctx.model), key, s.start_tolerance, s.goal_tolerance, metadata_only=True),
                  float(request.max_velocity_scaling_factor or 1.0),
                  float(request.max_acceleration_scaling_factor or 1.0), cartesian=False)


def insert_plan(ctx: Any, request: MotionPlanRequest, response: MotionPlanResponse, refused: int = 0) -> bool:
    """Offer a successful plan to the cache (its insert policy decides; see _insert for
    ``refused``); whether it went in."""
    tc = _active(ctx)
    if tc is None or not response.success or response.trajectory is None:
        return False
    key = _key(ctx, tc, lambda: motion_plan_request_features(ctx.model, request))
    if key is None:
        return False
    value = CacheValue(response.trajectory, float(response.planning_time), 1.0, response.planner_id or "")
    return _insert(ctx, tc, key, value, tc.plans, False, refused)


def fetch_cartesian_path(ctx: Any, scene: PlanningScene, request: GetCartesianPathRequest) -> CacheLookup:
    """A validated complete Cartesian path for ``request``, or none."""
    return _fetch(ctx, scene, request, lambda: cartesian_path_request_features(ctx.model, request),
                  lambda tc, key, s: tc.cache.fetch_all_matching_cartesian_trajectories(
                      tc.namespace(ctx.model), key, s.start_tolerance, s.goal_tolerance, min_fraction=1.0,
                      metadata_only=True),
                  request.max_velocity_scaling_factor, request.max_acceleration_scaling_factor, cartesian=True)


def _fetch(ctx: Any, scene: PlanningScene, request: Any, features: Callable[[], CacheKey],
           matching: Callable[[MoveGroupTrajectoryCache, CacheKey, Any], list[CacheEntry]],
           velocity_scaling: float, acceleration_scaling: float, cartesian: bool) -> CacheLookup:
    """The lookup both fetches share: the request's key, the ``matching`` entries (metadata only),
    the first of them valid in ``scene``; a cache failure is a miss, logged."""
    tc = _active(ctx)
    if tc is None:
        return CacheLookup()
    counts = tc.cartesian if cartesian else tc.plans
    started = time.perf_counter()
    key = _key(ctx, tc, features)
    if key is None:
        tc.count(counts, misses=1)
        return CacheLookup()
    try:
        entries = matching(tc, key, tc.settings)
    except TrajectoryCacheError as exc:
        tc.problem(str(exc))
        ctx.log("warning", f"trajectory cache: {exc}")
        tc.count(counts, misses=1)
        return CacheLookup()
    return _validated(ctx, tc, scene, request.group, request.start_state, entries, request.path_constraints,
                      velocity_scaling, acceleration_scaling, counts, time.perf_counter() - started,
                      cartesian=cartesian)


def insert_cartesian_path(ctx: Any, request: GetCartesianPathRequest, trajectory: TimedTrajectory,
                          fraction: float, planning_time: float, refused: int = 0) -> bool:
    """Offer a complete Cartesian path to the cache (a partial one is never stored: it reflects
    whatever stopped it); whether it went in."""
    tc = _active(ctx)
    if tc is None or trajectory is None or fraction < 1.0:
        return False
    key = _key(ctx, tc, lambda: cartesian_path_request_features(ctx.model, request))
    if key is None:
        return False
    return _insert(ctx, tc, key, CacheValue(trajectory, float(planning_time), float(fraction), "cartesian_path"),
                   tc.cartesian, True, refused)


def _insert(ctx: Any, tc: MoveGroupTrajectoryCache, key: CacheKey, value: CacheValue, counts: _Counts,
            cartesian: bool, refused: int) -> bool:
    """Insert under the configured policy; after ``refused`` > 0 (the request's matching entries
    are blocked in the current world) the new trajectory goes in beside them whatever the policy
    says (AlwaysInsertNeverPrune): a detour is slower than the blocked path, so best-seen would
    never keep it, and the blocked entries stay for when the world changes back."""
    s = tc.settings
    policy = cache_insert_policy("AlwaysInsertNeverPrunePolicy" if refused else s.cache_insert_policy, cartesian)
    insert = tc.cache.insert_cartesian_trajectory if cartesian else tc.cache.insert_trajectory
    try:
        inserted, reason = insert(tc.namespace(ctx.model), key, value, policy, s.prune_worse_trajectories)
    except (TrajectoryCacheError, ValueError, OSError) as exc:
        tc.problem(f"insert failed: {exc}")
        ctx.log("warning", f"trajectory cache: insert failed: {exc}")
        return False
    except Exception as exc:  # sqlite3 errors (a full disk, a locked file): never fail the plan for it
        tc.problem(f"insert failed: {type(exc).__name__}: {exc}")
        ctx.log("warning", f"trajectory cache: insert failed: {type(exc).__name__}: {exc}")
        return False
    tc.count(counts, **({"inserted": 1} if inserted else {"not_inserted": 1}))
    ctx.log("info", f"trajectory cache: {'inserted' if inserted else 'not inserted'}: {reason}")
    return inserted
