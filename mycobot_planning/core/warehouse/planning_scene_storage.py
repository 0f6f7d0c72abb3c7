"""Planning scenes and the queries planned in them, in an SQLite database: moveit_ros_warehouse's
PlanningSceneStorage (scenes by name, motion plan requests by scene and query name), what
MoveIt's benchmark runner reads its scenes and queries from.

ROS-free: a scene is kept as the JSON of an interfaces_py PlanningScene message, a query as the
JSON of a plan request in the JSON face's schema ({"group", "goal", "start_state", ...}), so a
plain script can fill the warehouse and the benchmarks can read it without ROS. The tables live
beside RobotStateStorage's in the same file (warehouse_host). ``read_only=True`` opens an
existing database without changing it, and refuses a file that is not an SQLite database or
has no planning-scene tables (a foreign database), saying which."""
from __future__ import annotations

import json
import re
import sqlite3
import threading
from pathlib import Path
from typing import Any, Mapping

from .names import name_problem
from .robot_state_storage import WarehouseError

__all__ = ["PlanningSceneStorage"]

MEMORY = ":memory:"
_TABLES = {
    "planning_scenes": "CREATE TABLE IF NOT EXISTS planning_scenes (name TEXT PRIMARY KEY, scene TEXT NOT NULL)",
    "motion_plan_requests": "CREATE TABLE IF NOT EXISTS motion_plan_requests (scene_name TEXT NOT NULL, "
                            "query_name TEXT NOT NULL, request TEXT NOT NULL, PRIMARY KEY (scene_name, query_name))",
}


class PlanningSceneStorage:
    """Scenes by name and queries by (scene, query name); thread-safe (one connection, one lock)."""

    def __init__(self, database: str | Path = MEMORY, read_only: bool = False) -> None:
        self.database = str(database)
        self.read_only = read_only
        self._lock = threading.Lock()
        if self.database != MEMORY:
            path = Path(self.database).expanduser()
            self.database = str(path)
            if read_only and not path.is_file():
                raise WarehouseError(f"warehouse database '{path}' does not exist")
            if not read_only:
                try:
                    path.parent.mkdir(parents=True, exist_ok=True)
                except OSError as exc:
                    raise WarehouseError(f"cannot create the directory of warehouse database '{path}': {exc}") from None
        try:
            if read_only and self.database != MEMORY:
                self._db = sqlite3.connect(f"{Path(self.database).resolve().as_uri()}?mode=ro", uri=True,
                                           check_same_thread=False, isolation_level=None, timeout=10.0)
            else:
                self._db = sqlite3.connect(self.database, check_same_thread=False, isolation_level=None, timeout=10.0)
            tables = {name for (name,) in self._db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
            if read_only:
                missing = sorted(set(_TABLES) - tables)
                if missing:
                    raise WarehouseError(f"'{self.database}' is not a planning-scene warehouse: it has no "
                                         f"{' or '.join(missing)} table (tables: {', '.join(sorted(tables)) or 'none'})")
            else:
                for sql in _TABLES.values():
                    self._db.execute(sql)
        except sqlite3.Error as exc:
            raise WarehouseError(f"cannot open warehouse database '{self.database}': {exc}") from None

    def close(self) -> None:
        with self._lock:
            self._db.close()

    # ---------------------------------------------------------------- reading
    def _rows(self, sql: str, args: list[Any]) -> list[tuple]:
        with self._lock:
            try:
                return self._db.execute(sql, args).fetchall()
            except sqlite3.Error as exc:
                raise WarehouseError(f"cannot read warehouse database '{self.database}': {exc}") from None

    @staticmethod
    def _pattern(regex: str) -> re.Pattern | None:
        try:
            return re.compile(regex) if regex else None
        except re.error as exc:
            raise WarehouseError(f"bad regex {regex!r}: {exc}") from None

    def planning_scene_names(self, regex: str = "") -> list[str]:
        """Names of the stored scenes, sorted; those ``regex`` finds a match in when not empty."""
        pattern = self._pattern(regex)
        return [n for (n,) in self._rows("SELECT name FROM planning_scenes ORDER BY name", [])
                if pattern is None or pattern.search(n)]

    def has_planning_scene(self, name: str) -> bool:
        return bool(self._rows("SELECT 1 FROM planning_scenes WHERE name = ?", [name]))

    def planning_scene(self, name: str) -> dict[str, Any]:
        """The scene stored as ``name`` (a PlanningScene message as a dict)."""
        rows = self._rows("SELECT scene FROM planning_scenes WHERE name = ?", [name])
        if not rows:
            raise WarehouseError(f"no planning scene named '{name}'")
        return self._decoded(rows[0][0], f"planning scene '{name}'")

    def planning_query_names(self, scene_name: str, regex: str = "") -> list[str]:
        """Names of the queries stored for ``scene_name``, sorted, filtered by ``regex``."""
        pattern = self._pattern(regex)
        rows = self._rows("SELECT query_name FROM motion_plan_requests WHERE scene_name = ? ORDER BY query_name",
                          [scene_name])
        return [n for (n,) in rows if pattern is None or pattern.search(n)]

    def planning_query(self, scene_name: str, query_name: str) -> dict[str, Any]:
        """The plan request stored as ``query_name`` for ``scene_name``."""
        rows = self._rows("SELECT request FROM motion_plan_requests WHERE scene_name = ? AND query_name = ?",
                          [scene_name, query_name])
        if not rows:
            raise WarehouseError(f"no query named '{query_name}' for planning scene '{scene_name}'")
        return self._decoded(rows[0][0], f"query '{query_name}' of scene '{scene_name}'")

    def _decoded(self, text: Any, what: str) -> dict[str, Any]:
        try:
            value = json.loads(text)
        except (TypeError, ValueError) as exc:
            raise WarehouseError(f"{what} in '{self.database}' is not JSON: {exc}") from None
        if not isinstance(value, dict):
            raise WarehouseError(f"{what} in '{self.database}' is not a JSON object")
        return value

    # ---------------------------------------------------------------- changes
    def add_planning_scene(self, name: str, scene: Mapping[str, Any]) -> None:
        """Store ``scene`` (a PlanningScene message as a dict) as ``name``, replacing one of that name."""
        self._store("INSERT OR REPLACE INTO planning_scenes (name, scene) VALUES (?, ?)", [name], scene,
                    "planning scene name")

    def add_planning_query(self, scene_name: str, query_name: str, request: Mapping[str, Any]) -> None:
        """Store the plan request ``request`` as ``query_name`` of the stored scene ``scene_name``."""
        if not self.has_planning_scene(scene_name):
            raise WarehouseError(f"no planning scene named '{scene_name}' to add query '{query_name}' to")
        self._store("INSERT OR REPLACE INTO motion_plan_requests (scene_name, query_name, request) VALUES (?, ?, ?)",
                    [scene_name, query_name], request, "query name")

    def remove_planning_scene(self, name: str) -> int:
        """Remove the scene ``name`` and its queries; how many rows went."""
        return self._change(["DELETE FROM motion_plan_requests WHERE scene_name = ?",
                             "DELETE FROM planning_scenes WHERE name = ?"], [name])

    def _store(self, sql: str, names: list[str], value: Mapping[str, Any], what: str) -> None:
        for name in names:
            problem = name_problem(name, what)
            if problem:
                raise WarehouseError(problem)
        if not isinstance(value, Mapping):
            raise WarehouseError(f"{what} '{names[-1]}': the value must be a JSON object")
        try:
            text = json.dumps(dict(value), allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise WarehouseError(f"{what} '{names[-1]}': cannot be stored as JSON: {exc}") from None
        self._change([sql], [*names, text])

    def _change(self, statements: list[str], args: list[Any]) -> int:
        """Run the statements in one transaction: all of them land, or none does."""
        if self.read_only:
            raise WarehouseError(f"warehouse database '{self.database}' was opened read-only")
        with self._lock:
            try:
                self._db.execute("BEGIN IMMEDIATE")
                count = sum(self._db.execute(sql, args[: sql.count("?")]).rowcount for sql in statements)
                self._db.execute("COMMIT")
                return count
            except BaseException:
                self._db.execute("ROLLBACK")
                raise
