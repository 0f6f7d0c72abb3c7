"""Names of stored states (waypoints, warehouse robot states) and atomic file writes, shared by
the waypoint store (behavior_tree.behaviors.waypoints) and the warehouse."""
from __future__ import annotations

import os
import tempfile
import unicodedata
from pathlib import Path
from typing import Any

__all__ = ["MAX_NAME_LENGTH", "atomic_write_text", "name_problem"]

#: longest name accepted (characters)
MAX_NAME_LENGTH = 256


def name_problem(name: Any, what: str = "waypoint name") -> str | None:
    """Why ``name`` cannot name a waypoint (or a stored robot state), None when it can: a
    non-empty string without control characters (NUL, newlines, escapes), at most
    MAX_NAME_LENGTH characters, not only blanks."""
    if not isinstance(name, str):
        return f"{what} must be a string, got {type(name).__name__}"
    if not name.strip():
        return f"{what} must not be empty"
    if len(name) > MAX_NAME_LENGTH:
        return f"{what} is {len(name)} characters long (at most {MAX_NAME_LENGTH})"
    bad = [c for c in name if unicodedata.category(c) in ("Cc", "Cf", "Cs") and c != "\u200d"]
    if bad:
        return f"{what} {name!r} contains control characters ({', '.join(repr(c) for c in bad[:3])})"
    return None


def atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` so that a reader (or a crash) sees either the old file or the
    new one, never a part: a temporary file beside it, fsynced, then os.replace."""
    path = Path(path)
    handle, temp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        try:
            mode = path.stat().st_mode & 0o7777  # the old file's permissions, not mkstemp's 0600
        except FileNotFoundError:
            umask = os.umask(0)
            os.umask(umask)
            mode = 0o666 & ~umask
        os.chmod(temp, mode)
        with os.fdopen(handle, "w", encoding="utf-8") as out:
            out.write(text)
            out.flush()
            os.fsync(out.fileno())
        os.replace(temp, path)
    except BaseException:
        try:
            os.unlink(temp)
        except OSError:
            pass
        raise
