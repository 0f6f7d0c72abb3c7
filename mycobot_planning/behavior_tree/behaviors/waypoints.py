"""Saved waypoints: named joint states, kept in a YAML file in MoveIt Pro's waypoint format
(a list of ``{name, description, favorite, joint_group_names, joint_state: {name, position}}``).

The one waypoint store of the package: the objectives' behaviors (MoveToWaypoint,
RetrieveWaypoint, SaveWaypoint) and the planning_server's waypoint methods both use it. Names
are checked (non-empty, no control characters or NUL), positions must be finite and, when the
store knows the joint limits, inside them; every change is written atomically (a temporary file
in the same directory, flushed and fsynced, then ``os.replace``): a crash mid-write leaves the
old file whole."""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import yaml

from ...core.warehouse.names import atomic_write_text, name_problem


class WaypointError(ValueError):
    """A waypoint file or name that cannot be used; the message says which and why."""


@dataclass
class Waypoint:
    name: str
    joint_names: list[str]
    positions: list[float]
    description: str = ""
    favorite: bool = False
    joint_group_names: list[str] = field(default_factory=list)

    def to_yaml(self) -> dict[str, Any]:
        return {"name": self.name, "description": self.description, "favorite": self.favorite,
                "joint_group_names": list(self.joint_group_names),
                "joint_state": {"name": list(self.joint_names), "position": [float(p) for p in self.positions]}}


class WaypointStore:
    """Waypoints by name, loaded from (and saved to) a YAML file; thread-safe.

    ``limits``: joint name → (lower, upper) bounds saved positions must lie in (joints it does
    not name are only checked to be finite)."""

    def __init__(self, path: str | Path | None = None,
                 limits: Mapping[str, tuple[float, float]] | None = None) -> None:
        self.path = Path(path) if path else None
        self.limits = dict(limits or {})
        self._lock = threading.Lock()
        self._waypoints: dict[str, Waypoint] = {}
        self._signature: tuple[int, int, int] | None = None
        if self.path is not None:
            self._signature = self._stat()
            self._waypoints = self._load(self.path)

    def _stat(self) -> tuple[int, int, int] | None:
        try:
            st = self.path.stat()
        except OSError:
            return None
        return st.st_ino, st.st_mtime_ns, st.st_size

    def _current(self) -> dict[str, Waypoint]:
        """The waypoints, re-read when the file changed since this store last read or wrote it
        (another process saved one: the objective_server and the planning_server share the
        file). Called with the lock held."""
        if self.path is not None:
            signature = self._stat()
            if signature is not None and signature != self._signature:
                self._waypoints = self._load(self.path)
                self._signature = signature
        return self._waypoints

    @staticmethod
    def _load(path: Path) -> dict[str, Waypoint]:
        try:
            data = yaml.safe_load(path.read_text()) or []
        except (OSError, yaml.YAMLError) as exc:
            raise WaypointError(f"cannot read waypoints file '{path}': {exc}") from None
        if not isinstance(data, list):
            raise WaypointError(f"waypoints file '{path}' must hold a list of waypoints")
        found: dict[str, Waypoint] = {}
        for index, item in enumerate(data):
            where = f"{path}: waypoint #{index + 1}"
            if not isinstance(item, dict) or not isinstance(item.get("name"), str) or not item["name"]:
                raise WaypointError(f"{where}: needs a name")
            state = item.get("joint_state") or {}
            names, positions = state.get("name") or [], state.get("position") or []
            if not names or len(names) != len(positions):
                raise WaypointError(f"{where} ('{item['name']}'): joint_state needs names and as many positions")
            try:
                positions = [float(p) for p in positions]
            except (TypeError, ValueError):
                raise WaypointError(f"{where} ('{item['name']}'): positions must be numbers") from None
            if item["name"] in found:
                raise WaypointError(f"{where}: waypoint '{item['name']}' is defined twice")
            found[item["name"]] = Waypoint(item["name"], [str(n) for n in names], positions,
                                           str(item.get("description", "")), bool(item.get("favorite", False)),
                                           [str(g) for g in item.get("joint_group_names") or []])
        return found

    def names(self) -> list[str]:
        with self._lock:
            return list(self._current())

    def list(self) -> list[Waypoint]:
        """Every waypoint, in file order."""
        with self._lock:
            return list(self._current().values())

    def get(self, name: str) -> Waypoint:
        with self._lock:
            current = self._current()
            waypoint = current.get(name)
            known = ", ".join(current) or "none"
        if waypoint is None:
            raise WaypointError(f"no waypoint named '{name}' (waypoints: {known})")
        return waypoint

    def check(self, waypoint: Waypoint) -> None:
        """Raise WaypointError when ``waypoint`` cannot be saved (its name, its joint state)."""
        problem = name_problem(waypoint.name)
        if problem:
            raise WaypointError(problem)
        names, positions = list(waypoint.joint_names), list(waypoint.positions)
        if not names or len(names) != len(positions):
            raise WaypointError(f"waypoint '{waypoint.name}': {len(names)} joint names but {len(positions)} positions")
        if len(set(names)) != len(names):
            raise WaypointError(f"waypoint '{waypoint.name}': a joint is named twice in {names}")
        for joint, value in zip(names, positions):
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise WaypointError(f"waypoint '{waypoint.name}': joint '{joint}' position {value!r} is not a number") \
                    from None
            if not math.isfinite(value):
                raise WaypointError(f"waypoint '{waypoint.name}': joint '{joint}' position {value} is not finite")
            bounds = self.limits.get(joint)
            if bounds is not None and not bounds[0] <= value <= bounds[1]:
                raise WaypointError(f"waypoint '{waypoint.name}': joint '{joint}' position {value:.6g} is outside "
                                    f"its limits [{bounds[0]:.6g}, {bounds[1]:.6g}]")

    def save(self, waypoint: Waypoint, overwrite: bool = False) -> None:
        """Add a waypoint (replace the one of that name only when ``overwrite``), and write the
        file when the store has one."""
        self.check(waypoint)
        waypoint.positions = [float(p) for p in waypoint.positions]
        with self._lock:
            current = self._current()
            if waypoint.name in current and not overwrite:
                raise WaypointError(f"a waypoint named '{waypoint.name}' exists already (save with overwrite to "
                                    "replace it)")
            updated = dict(current)
            updated[waypoint.name] = waypoint
            self._commit(updated)

    def rename(self, old_name: str, new_name: str) -> None:
        """Give waypoint ``old_name`` the name ``new_name`` (it keeps its place in the file)."""
        problem = name_problem(new_name, "new waypoint name")
        if problem:
            raise WaypointError(problem)
        with self._lock:
            current = self._current()
            if old_name not in current:
                raise WaypointError(f"no waypoint named '{old_name}' (waypoints: {', '.join(current) or 'none'})")
            if new_name != old_name and new_name in current:
                raise WaypointError(f"a waypoint named '{new_name}' exists already")
            updated = {(new_name if name == old_name else name): w for name, w in current.items()}
            updated[new_name] = Waypoint(new_name, *(getattr(updated[new_name], f) for f in (
                "joint_names", "positions", "description", "favorite", "joint_group_names")))
            self._commit(updated)

    def erase(self, name: str) -> None:
        """Remove waypoint ``name``."""
        with self._lock:
            current = self._current()
            if name not in current:
                raise WaypointError(f"no waypoint named '{name}' (waypoints: {', '.join(current) or 'none'})")
            self._commit({n: w for n, w in current.items() if n != name})

    def _commit(self, updated: dict[str, Waypoint]) -> None:
        """Write ``updated`` (atomically) and only then make it the store's content: a failed
        write changes neither the file nor the store. Called with the lock held."""
        if self.path is not None:
            atomic_write_text(self.path, yaml.safe_dump([w.to_yaml() for w in updated.values()], sort_keys=False))
            self._signature = self._stat()
        self._waypoints = updated
