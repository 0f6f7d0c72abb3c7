"""Saved waypoints: named joint states, kept in a YAML file in MoveIt Pro's waypoint format
(a list of ``{name, description, favorite, joint_group_names, joint_state: {name, position}}``)."""
from __future__ import annotations

import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml


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
    """Waypoints by name, loaded from (and saved to) a YAML file; thread-safe."""

    def __init__(self, path: str | Path | None = None) -> None:
        self.path = Path(path) if path else None
        self._lock = threading.Lock()
        self._waypoints: dict[str, Waypoint] = {}
        if self.path is not None:
            self._waypoints = self._load(self.path)

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
            return list(self._waypoints)

    def get(self, name: str) -> Waypoint:
        with self._lock:
            waypoint = self._waypoints.get(name)
            known = ", ".join(self._waypoints) or "none"
        if waypoint is None:
            raise WaypointError(f"no waypoint named '{name}' (waypoints: {known})")
        return waypoint

    def save(self, waypoint: Waypoint) -> None:
        """Add or replace a waypoint, and write the file when the store has one."""
        with self._lock:
            self._waypoints[waypoint.name] = waypoint
            data = [w.to_yaml() for w in self._waypoints.values()]
            if self.path is not None:
                self.path.write_text(yaml.safe_dump(data, sort_keys=False))
