"""When a trajectory goes into the cache and which entries it replaces (MoveIt's
trajectory_cache cache_insert_policies).

* BestSeenExecutionTimePolicy (the default): insert only a trajectory faster than every entry
  stored under exactly the same key, and prune the slower ones (the best
  ``num_additional_trajectories_to_preserve_when_pruning_worse`` entries are always kept, as in
  MoveIt);
* AlwaysInsertNeverPrunePolicy: insert everything, prune nothing.

The Cartesian variants (CartesianBestSeenExecutionTimePolicy, ...) differ only in name. A
policy instance is used for one insert at a time (the cache resets it after each insert).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from ..robot_trajectory.robot_trajectory import TimedTrajectory

__all__ = ["AlwaysInsertNeverPrunePolicy", "BestSeenExecutionTimePolicy", "CacheEntry", "CacheInsertPolicy", "CacheValue",
           "CartesianAlwaysInsertNeverPrunePolicy", "CartesianBestSeenExecutionTimePolicy", "POLICIES",
           "cache_insert_policy"]


@dataclass(frozen=True)
class CacheValue:
    """What is stored: the trajectory and how it was made (MoveIt's Plan / GetCartesianPath
    response: planning_time, fraction)."""

    trajectory: TimedTrajectory
    planning_time_s: float = 0.0
    fraction: float = 1.0
    planner_id: str = ""

    @property
    def execution_time_s(self) -> float:
        return float(self.trajectory.duration)


@dataclass
class CacheEntry:
    """One stored trajectory as a fetch returns it (``trajectory`` None when fetched
    metadata-only): MoveIt's MessageWithMetadata<RobotTrajectory>."""

    id: int
    execution_time_s: float
    planning_time_s: float
    fraction: float
    planner_id: str
    creation_time: float
    features: dict[str, Any] | None = None
    trajectory: TimedTrajectory | None = None


class CacheInsertPolicy:
    """MoveIt's CacheInsertPolicyInterface: check the inputs, find the entries the candidate
    competes with (exactly the same key), decide what to prune and whether to insert."""

    name = "CacheInsertPolicy"
    #: whether the cache must look up the entries of exactly the same key before inserting
    fetches_matching_entries = False

    def check_cache_insert_inputs(self, value: CacheValue) -> str | None:
        """Why ``value`` cannot be cached, or None."""
        trajectory = value.trajectory
        if not isinstance(trajectory, TimedTrajectory):
            return f"{self.name}: skipping insert: the value is not a TimedTrajectory"
        if len(trajectory) == 0 or not trajectory.joint_names:
            return f"{self.name}: skipping insert: empty trajectory"
        if not 0.0 <= value.fraction <= 1.0:
            return f"{self.name}: skipping insert: fraction {value.fraction} outside [0, 1]"
        return None

    def set_matching_entries(self, entries: list[CacheEntry]) -> None:
        """The entries of exactly the same key, fastest first."""

    def should_prune_matching_entry(self, value: CacheValue, entry: CacheEntry) -> tuple[bool, str]:
        return False, f"{self.name} never prunes"

    def should_insert(self, value: CacheValue) -> tuple[bool, str]:
        return True, f"{self.name} always inserts"

    def reset(self) -> None:
        """Forget what the last insert saw."""


class AlwaysInsertNeverPrunePolicy(CacheInsertPolicy):
    name = "AlwaysInsertNeverPrunePolicy"


class BestSeenExecutionTimePolicy(CacheInsertPolicy):
    name = "BestSeenExecutionTimePolicy"
    fetches_matching_entries = True

    def __init__(self) -> None:
        self.best_seen_execution_time = math.inf

    def set_matching_entries(self, entries: list[CacheEntry]) -> None:
        if entries:
            self.best_seen_execution_time = min(e.execution_time_s for e in entries)

    def should_prune_matching_entry(self, value: CacheValue, entry: CacheEntry) -> tuple[bool, str]:
        candidate = value.execution_time_s
        if entry.execution_time_s >= candidate:
            return True, (f"matching trajectory execution_time_s {entry.execution_time_s:.4f} s is worse than the "
                          f"candidate's {candidate:.4f} s")
        return False, (f"matching trajectory execution_time_s {entry.execution_time_s:.4f} s is better than the "
                       f"candidate's {candidate:.4f} s")

    def should_insert(self, value: CacheValue) -> tuple[bool, str]:
        candidate = value.execution_time_s
        if candidate < self.best_seen_execution_time:
            return True, (f"new trajectory execution_time_s {candidate:.4f} s is better than the best seen "
                          f"{self.best_seen_execution_time:.4f} s")
        return False, (f"new trajectory execution_time_s {candidate:.4f} s is not better than the best seen "
                       f"{self.best_seen_execution_time:.4f} s")

    def reset(self) -> None:
        self.best_seen_execution_time = math.inf


class CartesianAlwaysInsertNeverPrunePolicy(AlwaysInsertNeverPrunePolicy):
    name = "CartesianAlwaysInsertNeverPrunePolicy"


class CartesianBestSeenExecutionTimePolicy(BestSeenExecutionTimePolicy):
    name = "CartesianBestSeenExecutionTimePolicy"


#: policy name -> (motion plan policy, Cartesian policy)
POLICIES: dict[str, tuple[type[CacheInsertPolicy], type[CacheInsertPolicy]]] = {
    "BestSeenExecutionTimePolicy": (BestSeenExecutionTimePolicy, CartesianBestSeenExecutionTimePolicy),
    "AlwaysInsertNeverPrunePolicy": (AlwaysInsertNeverPrunePolicy, CartesianAlwaysInsertNeverPrunePolicy),
}


def cache_insert_policy(name: str, cartesian: bool = False) -> CacheInsertPolicy:
    """A new policy by its MoveIt name (the motion plan one; its Cartesian variant with
    ``cartesian``); ValueError naming the known ones."""
    if name not in POLICIES:
        raise ValueError(f"unknown cache insert policy {name!r}; known: {', '.join(POLICIES)}")
    return POLICIES[name][1 if cartesian else 0]()
