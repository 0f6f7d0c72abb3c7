"""MoveIt's trajectory cache (moveit_ros/trajectory_cache), ROS-free: planned trajectories in
SQLite, fetched again for requests whose start and goal are close enough. See
docs/trajectory_cache.md."""
from .cache_insert_policies import (
    AlwaysInsertNeverPrunePolicy,
    BestSeenExecutionTimePolicy,
    CacheEntry,
    CacheInsertPolicy,
    CacheValue,
    CartesianAlwaysInsertNeverPrunePolicy,
    CartesianBestSeenExecutionTimePolicy,
    cache_insert_policy,
)
from .features import CacheKey, FeatureError, GetCartesianPathRequest, cartesian_path_request_features, \
    motion_plan_request_features
from .stitching import stitch_to_start
from .trajectory_cache import Options, TrajectoryCache, TrajectoryCacheError, check_options

__all__ = [
    "AlwaysInsertNeverPrunePolicy",
    "BestSeenExecutionTimePolicy",
    "CacheEntry",
    "CacheInsertPolicy",
    "CacheKey",
    "CacheValue",
    "CartesianAlwaysInsertNeverPrunePolicy",
    "CartesianBestSeenExecutionTimePolicy",
    "FeatureError",
    "GetCartesianPathRequest",
    "Options",
    "TrajectoryCache",
    "TrajectoryCacheError",
    "cache_insert_policy",
    "cartesian_path_request_features",
    "check_options",
    "motion_plan_request_features",
    "stitch_to_start",
]
