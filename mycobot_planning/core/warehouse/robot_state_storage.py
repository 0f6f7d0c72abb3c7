"""Named robot states in an SQLite database: moveit_ros_warehouse's RobotStateStorage (backed,
as with warehouse_ros_sqlite, by one SQLite file, or ``:memory:``).

A state is kept as an opaque blob beside its name and robot (the ROS face stores the serialized
moveit_msgs/RobotState, as warehouse_ros_sqlite stores the serialized message): this module
never reads it, so it needs no ROS. The semantics follow RobotStateStorage: an empty ``robot``
in a query matches every robot; saving a name that exists for that robot replaces it
(``overwrite=False`` refuses instead); names go through the waypoint store's name check. Every
change runs in one transaction: a crash mid-write leaves the database as it was."""
from __future__ import annotations

import re
import sqlite3
import threading
from pathlib import Path

from .names import name_problem
from .sqlite_database import MEMORY, connect_database

__all__ = ["RobotStateStorage", "WarehouseError"]


class WarehouseError(ValueError):
    """A name, regex or database the warehouse cannot use; the message says which and why."""


class RobotStateStorage:
    """Robot states by (name, robot) in SQLite; thread-safe (one connection, one lock)."""

    def __init__(self, database: str | Path = MEMORY) -> None:
        self._db, self.database = connect_database(database, "warehouse database", WarehouseError)
        self._lock = threading.Lock()
        try:
            self._db.execute("PRAGMA journal_mode=WAL" if self.database != MEMORY else "PRAGMA journal_mode=MEMORY")
            self._db.execute("CREATE TABLE IF NOT EXISTS robot_states (name TEXT NOT NULL, robot TEXT NOT NULL, "
                             "state BLOB NOT NULL, PRIMARY KEY (name, robot))")
        except sqlite3.Error as exc:
            raise WarehouseError(f"cannot open warehouse database '{self.database}': {exc}") from None

    def close(self) -> None:
        with self._lock:
            self._db.close()

    # ---------------------------------------------------------------- queries
    @staticmethod
    def _where(name: str | None, robot: str) -> tuple[str, list[str]]:
        clauses, args = [], []
        if name is not None:
            clauses.append("name = ?")
            args.append(name)
        if robot:
            clauses.append("robot = ?")
            args.append(robot)
        return (" WHERE " + " AND ".join(clauses)) if clauses else "", args

    def names(self, regex: str = "", robot: str = "") -> list[str]:
        """Names of the stored states (of ``robot``, or of every robot when empty), sorted, those
        ``regex`` finds a match in when it is not empty (RobotStateStorage's filterNames)."""
        try:
            pattern = re.compile(regex) if regex else None
        except re.error as exc:
            raise WarehouseError(f"bad regex {regex!r}: {exc}") from None
        where, args = self._where(None, robot)
        with self._lock:
            rows = self._db.execute(f"SELECT DISTINCT name FROM robot_states{where} ORDER BY name", args).fetchall()
        return [n for (n,) in rows if pattern is None or pattern.search(n)]

    def has(self, name: str, robot: str = "") -> bool:
        where, args = self._where(name, robot)
        with self._lock:
            return self._db.execute(f"SELECT 1 FROM robot_states{where} LIMIT 1", args).fetchone() is not None

    def get(self, name: str, robot: str = "") -> bytes:
        """The state stored as ``name`` (for ``robot``; any robot when empty)."""
        where, args = self._where(name, robot)
        with self._lock:
            row = self._db.execute(f"SELECT state FROM robot_states{where} ORDER BY robot LIMIT 1", args).fetchone()
        if row is None:
            raise WarehouseError(f"no robot state named '{name}'" + (f" for robot '{robot}'" if robot else ""))
        return bytes(row[0])

    # ---------------------------------------------------------------- changes
    def save(self, name: str, robot: str, state: bytes, overwrite: bool = True) -> None:
        """Store ``state`` as ``name`` for ``robot`` (replacing one of that name, as MoveIt's
        addRobotState does, unless ``overwrite`` is False)."""
        problem = name_problem(name, "robot state name")
        if problem:
            raise WarehouseError(problem)
        if not isinstance(state, (bytes, bytearray)) or not state:
            raise WarehouseError(f"robot state '{name}': nothing to store")
        verb = "INSERT OR REPLACE" if overwrite else "INSERT"
        try:
            self._transaction(f"{verb} INTO robot_states (name, robot, state) VALUES (?, ?, ?)",
                              [name, robot, bytes(state)])
        except sqlite3.IntegrityError:
            raise WarehouseError(f"a robot state named '{name}' exists already for robot '{robot}'") from None

    def rename(self, old_name: str, new_name: str, robot: str = "") -> None:
        problem = name_problem(new_name, "new robot state name")
        if problem:
            raise WarehouseError(problem)
        if not self.has(old_name, robot):
            raise WarehouseError(f"no robot state named '{old_name}'" + (f" for robot '{robot}'" if robot else ""))
        where, args = self._where(old_name, robot)
        try:
            self._transaction(f"UPDATE robot_states SET name = ?{where}", [new_name, *args])
        except sqlite3.IntegrityError:
            raise WarehouseError(f"a robot state named '{new_name}' exists already") from None

    def delete(self, name: str, robot: str = "") -> int:
        """Remove the states named ``name`` (of ``robot``; of every robot when empty); how many."""
        where, args = self._where(name, robot)
        return self._transaction(f"DELETE FROM robot_states{where}", args)

    def _transaction(self, sql: str, args: list) -> int:
        """Run one change in its own transaction: all of it lands, or nothing does."""
        with self._lock:
            try:
                self._db.execute("BEGIN IMMEDIATE")
                count = self._db.execute(sql, args).rowcount
                self._db.execute("COMMIT")
                return count
            except BaseException:
                self._db.execute("ROLLBACK")
                raise
