"""Opening the SQLite databases the warehouse and the trajectory cache keep (warehouse_ros_sqlite
style: one file, or ``:memory:``): the path expanded and its directory made, one connection
usable from every thread (callers hold their own lock), autocommit so each change runs in the
explicit transaction its caller opens."""
from __future__ import annotations

import sqlite3
from pathlib import Path

__all__ = ["MEMORY", "connect_database"]

MEMORY = ":memory:"


def connect_database(database: str | Path, what: str, error: type[Exception]) -> tuple[sqlite3.Connection, str]:
    """(connection, resolved path) of ``database``; ``error`` (naming ``what``) when the file's
    directory cannot be made or the file cannot be opened. Nothing is written: the caller checks
    what the file holds before it changes anything."""
    path = str(database)
    if path != MEMORY:
        resolved = Path(path).expanduser()
        if resolved.is_dir():
            raise error(f"{what} '{resolved}' is a directory, not a file")
        try:
            resolved.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise error(f"cannot create the directory of {what} '{resolved}': {exc}") from None
        path = str(resolved)
    try:
        return sqlite3.connect(path, check_same_thread=False, isolation_level=None, timeout=10.0), path
    except sqlite3.Error as exc:
        raise error(f"cannot open {what} '{path}': {exc}") from None
