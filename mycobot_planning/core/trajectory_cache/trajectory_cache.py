"""MoveIt's trajectory_cache (moveit_ros/trajectory_cache): planned trajectories stored under the
features of their request, fetched again for a request whose start and goal are close enough.

Why: a work cell repeats the same few motions (pick, place, home); planning each one again costs
tens of milliseconds to seconds, fetching it costs well under one. The keys and their matching
are in features.py, the insert policies in cache_insert_policies.py. Nothing here looks at the
planning scene: as in MoveIt, a fetched trajectory must be validated against the current scene
before use (capabilities/trajectory_cache.py does, for the planning server).

Storage follows the warehouse (core/warehouse: robot_state_storage.py, opened the same way by
sqlite_database.py): one SQLite file (stdlib sqlite3), or ``:memory:``, one connection behind one lock (thread-safe), every change in one
transaction. Tables are MoveIt's database names, ``move_group_trajectory_cache`` and
``move_group_cartesian_trajectory_cache``, a row per trajectory with its cache_namespace
(MoveIt's collection), the features (JSON, readable), the key's numbers (a float64 blob compared
in numpy), the trajectory (float64 blob) and execution_time_s, planning_time_s, fraction. A file
that is not an SQLite database, is damaged, or holds other tables is refused with
TrajectoryCacheError, never altered.
"""
from __future__ import annotations

import json
import sqlite3
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from ..robot_trajectory.robot_trajectory import TimedTrajectory
from ..warehouse.sqlite_database import MEMORY, connect_database
from .cache_insert_policies import CacheEntry, CacheInsertPolicy, CacheValue
from .features import CacheKey

__all__ = ["CARTESIAN_TABLE", "MOTION_TABLE", "Options", "TrajectoryCache", "TrajectoryCacheError", "check_options"]

MOTION_TABLE = "move_group_trajectory_cache"
CARTESIAN_TABLE = "move_group_cartesian_trajectory_cache"
META_TABLE = "trajectory_cache_meta"
SCHEMA = "mycobot_planning.trajectory_cache"
SCHEMA_VERSION = "1"
#: what a fetch may be sorted by (MoveIt's default sort feature is execution_time_s)
SORT_FEATURES = ("execution_time_s", "planning_time_s", "fraction", "creation_time", "id")
_COLUMNS = "id, execution_time_s, planning_time_s, fraction, planner_id, creation_time"


class TrajectoryCacheError(ValueError):
    """A database, entry or argument the cache cannot use; the message says which and why."""


@dataclass(frozen=True)
class Options:
    """MoveIt's TrajectoryCache::Options (db_port has no meaning for SQLite)."""

    db_path: str = MEMORY
    exact_match_precision: float = 1e-6
    num_additional_trajectories_to_preserve_when_pruning_worse: int = 1


def check_options(options: Options) -> None:
    """TrajectoryCacheError when ``options`` cannot be used."""
    precision = options.exact_match_precision
    if isinstance(precision, bool) or not isinstance(precision, (int, float)) or not 0 <= precision < 1:
        raise TrajectoryCacheError(f"exact_match_precision must be in [0, 1), got {precision!r}")
    keep = options.num_additional_trajectories_to_preserve_when_pruning_worse
    if isinstance(keep, bool) or not isinstance(keep, int) or keep < 0:
        raise TrajectoryCacheError(
            f"num_additional_trajectories_to_preserve_when_pruning_worse must be an integer >= 0, got {keep!r}")
    if not isinstance(options.db_path, (str, Path)) or not str(options.db_path):
        raise TrajectoryCacheError(f"db_path must be a file path or ':memory:', got {options.db_path!r}")


def _encode(trajectory: TimedTrajectory) -> bytes:
    """n, d, path rows, waypoint times, then times, positions, velocities, accelerations, path,
    waypoint_times, all float64."""
    path = trajectory.path if trajectory.path is not None else np.zeros((0, trajectory.dof))
    stamps = trajectory.waypoint_times if trajectory.waypoint_times is not None else np.zeros(0)
    header = np.array([len(trajectory), trajectory.dof, path.shape[0] if trajectory.path is not None else -1,
                       stamps.shape[0] if trajectory.waypoint_times is not None else -1], dtype=float)
    return np.concatenate([header, trajectory.times, trajectory.positions.ravel(), trajectory.velocities.ravel(),
                           trajectory.accelerations.ravel(), np.asarray(path, dtype=float).ravel(),
                           np.asarray(stamps, dtype=float).ravel()]).tobytes()


def _decode(blob: bytes, joint_names: list[str], interpolation: str) -> TimedTrajectory:
    data = np.frombuffer(blob, dtype=float)
    n, d, rows, stamps = (int(v) for v in data[:4])
    if d != len(joint_names) or n < 1:
        raise ValueError(f"{n} points of {d} joints for joint names {joint_names}")
    sizes = [n, n * d, n * d, n * d, max(rows, 0) * d, max(stamps, 0)]
    if data.shape[0] != 4 + sum(sizes):
        raise ValueError(f"{data.shape[0]} numbers where {4 + sum(sizes)} were expected")
    parts, at = [], 4
    for size in sizes:
        parts.append(data[at:at + size])
        at += size
    times, q, qd, qdd, path, wt = parts
    return TimedTrajectory(joint_names, times.copy(), q.reshape(n, d).copy(), qd.reshape(n, d).copy(),
                           qdd.reshape(n, d).copy(), interpolation=interpolation,  # type: ignore[arg-type]
                           path=path.reshape(rows, d).copy() if rows >= 0 else None,
                           waypoint_times=wt.copy() if stamps >= 0 else None)


class TrajectoryCache:
    """MoveIt's TrajectoryCache: fetch{All,Best}Matching{,Cartesian}Trajectory,
    insert{,Cartesian}Trajectory, count{,Cartesian}Trajectories. Thread-safe."""

    def __init__(self, options: Options | None = None) -> None:
        self.options = options or Options()
        check_options(self.options)
        self._db, self.db_path = connect_database(self.options.db_path, "trajectory cache database",
                                                  TrajectoryCacheError)
        self._lock = threading.Lock()
        try:
            self._open_schema()
        except sqlite3.DatabaseError as exc:
            self._db.close()
            raise TrajectoryCacheError(f"'{self.db_path}' is not a trajectory cache: not a usable SQLite database "
                                       f"({exc})") from None
        except TrajectoryCacheError:
            self._db.close()
            raise

    def _open_schema(self) -> None:
        db = self._db
        if self.db_path != MEMORY:
            problems = [row[0] for row in db.execute("PRAGMA quick_check").fetchall()]
            if problems != ["ok"]:
                raise TrajectoryCacheError(f"'{self.db_path}' is a damaged SQLite database: {'; '.join(problems[:3])}")
        tables = {row[0] for row in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        tables.discard("sqlite_sequence")
        ours = {META_TABLE, MOTION_TABLE, CARTESIAN_TABLE}
        if tables and META_TABLE not in tables:
            raise TrajectoryCacheError(
                f"'{self.db_path}' is an SQLite database of something else (tables: {', '.join(sorted(tables))}), "
                "not a trajectory cache; give the cache a file of its own")
        if tables:
            meta = dict(db.execute(f"SELECT key, value FROM {META_TABLE}").fetchall())
            if meta.get("schema") != SCHEMA or meta.get("version") != SCHEMA_VERSION or tables != ours:
                raise TrajectoryCacheError(
                    f"'{self.db_path}' holds a trajectory cache this version cannot read (schema "
                    f"{meta.get('schema')!r} version {meta.get('version')!r}, tables {sorted(tables)}; expected "
                    f"{SCHEMA!r} version {SCHEMA_VERSION}); give the cache another file")
            db.execute("PRAGMA journal_mode=WAL" if self.db_path != MEMORY else "PRAGMA journal_mode=MEMORY")
            db.execute("PRAGMA synchronous=NORMAL")  # WAL: a crash may lose the last inserts, never corrupts
            return
        db.execute("PRAGMA journal_mode=WAL" if self.db_path != MEMORY else "PRAGMA journal_mode=MEMORY")
        db.execute("PRAGMA synchronous=NORMAL")
        db.execute("BEGIN IMMEDIATE")
        try:
            db.execute(f"CREATE TABLE {META_TABLE} (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
            db.executemany(f"INSERT INTO {META_TABLE} VALUES (?, ?)", [("schema", SCHEMA), ("version", SCHEMA_VERSION)])
            for table in (MOTION_TABLE, CARTESIAN_TABLE):
                db.execute(
                    f"CREATE TABLE {table} (id INTEGER PRIMARY KEY AUTOINCREMENT, cache_namespace TEXT NOT NULL, "
                    "signature TEXT NOT NULL, features TEXT NOT NULL, key_values BLOB NOT NULL, "
                    "joint_names TEXT NOT NULL, interpolation TEXT NOT NULL, trajectory BLOB NOT NULL, "
                    "execution_time_s REAL NOT NULL, planning_time_s REAL NOT NULL, fraction REAL NOT NULL, "
                    "planner_id TEXT NOT NULL, creation_time REAL NOT NULL)")
                db.execute(f"CREATE INDEX {table}_lookup ON {table} (cache_namespace, signature, execution_time_s)")
            db.execute("COMMIT")
        except BaseException:
            db.execute("ROLLBACK")
            raise

    def close(self) -> None:
        with self._lock:
            self._db.close()

    # ------------------------------------------------------------------ counts
    def count_trajectories(self, cache_namespace: str) -> int:
        return self._count(MOTION_TABLE, cache_namespace)

    def count_cartesian_trajectories(self, cache_namespace: str) -> int:
        return self._count(CARTESIAN_TABLE, cache_namespace)

    @contextmanager
    def _locked(self) -> Iterator[sqlite3.Connection]:
        """The connection, under the lock; SQLite's errors (a closed, locked or full database)
        as TrajectoryCacheError."""
        with self._lock:
            try:
                yield self._db
            except sqlite3.Error as exc:
                raise TrajectoryCacheError(f"trajectory cache database '{self.db_path}': {exc}") from None

    def _count(self, table: str, cache_namespace: str) -> int:
        with self._locked():
            return int(self._db.execute(f"SELECT COUNT(*) FROM {table} WHERE cache_namespace = ?",
                                        [cache_namespace]).fetchone()[0])

    # ------------------------------------------------------------------ fetch
    def fetch_all_matching_trajectories(self, cache_namespace: str, key: CacheKey, start_tolerance: float,
                                        goal_tolerance: float, metadata_only: bool = False,
                                        sort_by: str = "execution_time_s", ascending: bool = True) -> list[CacheEntry]:
        """Every entry whose key matches ``key`` within the tolerances, sorted by ``sort_by``."""
        return self._fetch(MOTION_TABLE, cache_namespace, key, start_tolerance, goal_tolerance, None, metadata_only,
                           sort_by, ascending)

    def fetch_best_matching_trajectory(self, cache_namespace: str, key: CacheKey, start_tolerance: float,
                                       goal_tolerance: float, metadata_only: bool = False,
                                       sort_by: str = "execution_time_s", ascending: bool = True) -> CacheEntry | None:
        entries = self._fetch(MOTION_TABLE, cache_namespace, key, start_tolerance, goal_tolerance, None, True,
                              sort_by, ascending)
        return self._first(MOTION_TABLE, entries, metadata_only)

    def fetch_all_matching_cartesian_trajectories(self, cache_namespace: str, key: CacheKey, start_tolerance: float,
                                                  goal_tolerance: float, min_fraction: float = 0.0,
                                                  metadata_only: bool = False, sort_by: str = "execution_time_s",
                                                  ascending: bool = True) -> list[CacheEntry]:
        """As fetch_all_matching_trajectories, for Cartesian paths of at least ``min_fraction``."""
        return self._fetch(CARTESIAN_TABLE, cache_namespace, key, start_tolerance, goal_tolerance, min_fraction,
                           metadata_only, sort_by, ascending)

    def fetch_best_matching_cartesian_trajectory(self, cache_namespace: str, key: CacheKey, start_tolerance: float,
                                                 goal_tolerance: float, min_fraction: float = 0.0,
                                                 metadata_only: bool = False, sort_by: str = "execution_time_s",
                                                 ascending: bool = True) -> CacheEntry | None:
        entries = self._fetch(CARTESIAN_TABLE, cache_namespace, key, start_tolerance, goal_tolerance, min_fraction,
                              True, sort_by, ascending)
        return self._first(CARTESIAN_TABLE, entries, metadata_only)

    def load_trajectory(self, entry: CacheEntry, cartesian: bool = False) -> TimedTrajectory:
        """The trajectory of an entry fetched metadata-only (TrajectoryCacheError when it has
        been pruned since, or its row cannot be read)."""
        if entry.trajectory is None:
            entry.trajectory = self._load(CARTESIAN_TABLE if cartesian else MOTION_TABLE, [entry.id])[entry.id]
        return entry.trajectory

    def _first(self, table: str, entries: list[CacheEntry], metadata_only: bool) -> CacheEntry | None:
        if not entries:
            return None
        best = entries[0]
        if not metadata_only:
            best.trajectory = self._load(table, [best.id])[best.id]
        return best

    def _fetch(self, table: str, cache_namespace: str, key: CacheKey, start_tolerance: float, goal_tolerance: float,
               min_fraction: float | None, metadata_only: bool, sort_by: str, ascending: bool,
               exact: bool = False) -> list[CacheEntry]:
        if sort_by not in SORT_FEATURES:
            raise TrajectoryCacheError(f"cannot sort by {sort_by!r}; known: {', '.join(SORT_FEATURES)}")
        for name, value in (("start_tolerance", start_tolerance), ("goal_tolerance", goal_tolerance)):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value < float("inf"):
                raise TrajectoryCacheError(f"{name} must be a finite number >= 0, got {value!r}")
        sql = (f"SELECT {_COLUMNS}, key_values FROM {table} WHERE cache_namespace = ? AND signature = ?"
               + (" AND fraction >= ?" if min_fraction is not None else "")
               + f" ORDER BY {sort_by} {'ASC' if ascending else 'DESC'}, id ASC")
        args: list[Any] = [cache_namespace, key.signature] + ([float(min_fraction)] if min_fraction is not None else [])
        with self._locked():
            rows = self._db.execute(sql, args).fetchall()
        if not rows:
            return []
        width = len(key.values)
        try:
            cached = np.frombuffer(b"".join(row[-1] for row in rows), dtype=float).reshape(len(rows), width)
        except ValueError:
            raise TrajectoryCacheError(f"{table}: entries {[r[0] for r in rows]} have keys of the wrong size "
                                       "(the database is damaged)") from None
        mask = key.match_mask(cached, start_tolerance, goal_tolerance, self.options.exact_match_precision, exact)
        entries = [CacheEntry(int(r[0]), float(r[1]), float(r[2]), float(r[3]), str(r[4]), float(r[5]))
                   for r, ok in zip(rows, mask) if ok]
        if entries and not metadata_only:
            loaded = self._load(table, [e.id for e in entries])
            for entry in entries:
                entry.trajectory = loaded[entry.id]
        return entries

    def _load(self, table: str, ids: list[int]) -> dict[int, TimedTrajectory]:
        marks = ", ".join("?" * len(ids))
        with self._locked():
            rows = self._db.execute(f"SELECT id, joint_names, interpolation, trajectory, features FROM {table} "
                                    f"WHERE id IN ({marks})", ids).fetchall()
        found: dict[int, TimedTrajectory] = {}
        for entry_id, names, interpolation, blob, _ in rows:
            try:
                found[int(entry_id)] = _decode(bytes(blob), json.loads(names), interpolation)
            except Exception as exc:
                raise TrajectoryCacheError(f"{table} entry {entry_id} cannot be read (the database is damaged): "
                                           f"{exc}") from None
        missing = [i for i in ids if i not in found]
        if missing:
            raise TrajectoryCacheError(f"{table}: entries {missing} are gone (pruned meanwhile)")
        return found

    # ------------------------------------------------------------------ insert
    def insert_trajectory(self, cache_namespace: str, key: CacheKey, value: CacheValue, policy: CacheInsertPolicy,
                          prune_worse_trajectories: bool = True) -> tuple[bool, str]:
        """MoveIt's insertTrajectory: (inserted, why)."""
        return self._insert(MOTION_TABLE, cache_namespace, key, value, policy, prune_worse_trajectories)

    def insert_cartesian_trajectory(self, cache_namespace: str, key: CacheKey, value: CacheValue,
                                    policy: CacheInsertPolicy, prune_worse_trajectories: bool = True) -> tuple[bool, str]:
        """MoveIt's insertCartesianTrajectory: (inserted, why)."""
        return self._insert(CARTESIAN_TABLE, cache_namespace, key, value, policy, prune_worse_trajectories)

    def _insert(self, table: str, cache_namespace: str, key: CacheKey, value: CacheValue, policy: CacheInsertPolicy,
                prune: bool) -> tuple[bool, str]:
        if not isinstance(cache_namespace, str):
            raise TrajectoryCacheError(f"cache_namespace must be a string, got {cache_namespace!r}")
        try:
            problem = policy.check_cache_insert_inputs(value)
            if problem:
                return False, problem
            row = [cache_namespace, key.signature, json.dumps(key.as_dict()), key.values.astype(float).tobytes(),
                   json.dumps(list(value.trajectory.joint_names)), value.trajectory.interpolation,
                   _encode(value.trajectory), value.execution_time_s, float(value.planning_time_s),
                   float(value.fraction), str(value.planner_id), time.time()]
            # one transaction: the entries compared, pruned and the new one inserted together
            with self._locked():
                self._db.execute("BEGIN IMMEDIATE")
                try:
                    result = self._insert_locked(table, cache_namespace, key, value, policy, prune, row)
                    self._db.execute("COMMIT")
                except BaseException:
                    self._db.execute("ROLLBACK")
                    raise
            return result
        finally:
            policy.reset()

    def _insert_locked(self, table: str, cache_namespace: str, key: CacheKey, value: CacheValue,
                       policy: CacheInsertPolicy, prune: bool, row: list[Any]) -> tuple[bool, str]:
        pruned = 0
        if policy.fetches_matching_entries:
            rows = self._db.execute(
                f"SELECT {_COLUMNS}, key_values FROM {table} WHERE cache_namespace = ? AND signature = ? "
                "ORDER BY execution_time_s ASC, id ASC", [cache_namespace, key.signature]).fetchall()
            matching = []
            if rows:
                cached = np.frombuffer(b"".join(r[-1] for r in rows), dtype=float).reshape(len(rows), len(key.values))
                mask = key.match_mask(cached, 0.0, 0.0, self.options.exact_match_precision, exact=True)
                matching = [CacheEntry(int(r[0]), float(r[1]), float(r[2]), float(r[3]), str(r[4]), float(r[5]))
                            for r, ok in zip(rows, mask) if ok]
            policy.set_matching_entries(matching)
            if prune:
                keep = self.options.num_additional_trajectories_to_preserve_when_pruning_worse
                for entry in matching[keep:]:
                    worse, _ = policy.should_prune_matching_entry(value, entry)
                    if worse:
                        self._db.execute(f"DELETE FROM {table} WHERE id = ?", [entry.id])
                        pruned += 1
        insert, reason = policy.should_insert(value)
        if insert:
            self._db.execute(
                f"INSERT INTO {table} (cache_namespace, signature, features, key_values, joint_names, interpolation, "
                "trajectory, execution_time_s, planning_time_s, fraction, planner_id, creation_time) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)", row)
        return insert, reason + (f"; pruned {pruned} worse" if pruned else "")
