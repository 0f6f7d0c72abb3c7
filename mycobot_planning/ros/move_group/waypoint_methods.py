"""Saved waypoints on the planning_server's JSON face (MoveIt Pro's waypoint operations): the
methods ``list_waypoints``, ``save_waypoint``, ``rename_waypoint``, ``erase_waypoint`` and
``move_to_waypoint`` of /planning_server/rpc.

Thin: the waypoints live in the one WaypointStore (behavior_tree.behaviors.waypoints, the file
the objectives' MoveToWaypoint reads), checked against the robot model's joint limits; a move
is the server's own plan_and_execute with the waypoint as a joint goal (planned collision-free
against the monitored scene, executed and watched like any other motion)."""
from __future__ import annotations

from typing import Any, Callable, Mapping

from interfaces_py.json_rpc import BAD_REQUEST, RpcError
from mycobot_planning.behavior_tree.behaviors.waypoints import Waypoint, WaypointError, WaypointStore
from mycobot_planning.capabilities.json_face import MoveGroupJsonFace

__all__ = ["WaypointMethods"]


def _check_keys(params: Any, allowed: set[str], method: str) -> Mapping[str, Any]:
    if params is None:
        params = {}
    if not isinstance(params, Mapping):
        raise RpcError(BAD_REQUEST, f"{method}: parameters must be an object")
    unknown = sorted(set(params) - allowed)
    if unknown:
        raise RpcError(BAD_REQUEST, f"{method}: unknown parameters {unknown}; known: {sorted(allowed)}")
    return params


def _string(params: Mapping[str, Any], key: str, method: str, default: str | None = None) -> str:
    value = params.get(key, default)
    if not isinstance(value, str):
        raise RpcError(BAD_REQUEST, f"{method}: '{key}' must be a string")
    return value


class WaypointMethods:
    """The waypoint methods, answered from ``store`` and ``core`` (the planning_server's)."""

    def __init__(self, core: MoveGroupJsonFace, store: WaypointStore, default_group: Callable[[], str]) -> None:
        self.core = core
        self.store = store
        self._default_group = default_group

    def methods(self) -> dict[str, Callable[[Mapping[str, Any]], Any]]:
        return {"list_waypoints": self.list_waypoints, "save_waypoint": self.save_waypoint,
                "rename_waypoint": self.rename_waypoint, "erase_waypoint": self.erase_waypoint,
                "move_to_waypoint": self.move_to_waypoint}

    def list_waypoints(self, params: Mapping[str, Any]) -> dict[str, Any]:
        _check_keys(params, set(), "list_waypoints")
        return {"waypoints": [w.to_yaml() for w in self.store.list()]}

    def save_waypoint(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """The current joint state of ``group`` saved as waypoint ``name``."""
        m = "save_waypoint"
        params = _check_keys(params, {"name", "group", "description", "favorite", "overwrite"}, m)
        name = _string(params, "name", m)
        group = _string(params, "group", m, self._default_group())
        description = _string(params, "description", m, "")
        favorite, overwrite = params.get("favorite", False), params.get("overwrite", False)
        if not isinstance(favorite, bool) or not isinstance(overwrite, bool):
            raise RpcError(BAD_REQUEST, f"{m}: 'favorite' and 'overwrite' must be true or false")
        model = self.core.model
        if not model.has_group(group):
            raise RpcError(BAD_REQUEST, f"{m}: unknown planning group '{group}'; known: {model.group_names}")
        positions, _ = self.core.joint_positions()
        joints = list(model.group(group).joint_names)
        missing = [j for j in joints if j not in (positions or {})]
        if missing:
            raise RpcError(BAD_REQUEST, f"{m}: no current position of {missing} (no /joint_states yet?)")
        waypoint = Waypoint(name, joints, [float(positions[j]) for j in joints], description, favorite, [group])
        self._call(lambda: self.store.save(waypoint, overwrite=overwrite), m)
        return {"waypoint": waypoint.to_yaml()}

    def rename_waypoint(self, params: Mapping[str, Any]) -> dict[str, Any]:
        m = "rename_waypoint"
        params = _check_keys(params, {"old_name", "new_name"}, m)
        old, new = _string(params, "old_name", m), _string(params, "new_name", m)
        self._call(lambda: self.store.rename(old, new), m)
        return {}

    def erase_waypoint(self, params: Mapping[str, Any]) -> dict[str, Any]:
        m = "erase_waypoint"
        name = _string(_check_keys(params, {"name"}, m), "name", m)
        self._call(lambda: self.store.erase(name), m)
        return {}

    def move_to_waypoint(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """Plan and execute to waypoint ``name`` (the server's plan_and_execute; its answer)."""
        m = "move_to_waypoint"
        params = _check_keys(params, {"name", "group", "wait"}, m)
        waypoint = self._call(lambda: self.store.get(_string(params, "name", m)), m)
        group = _string(params, "group", m, (waypoint.joint_group_names or [self._default_group()])[0])
        request: dict[str, Any] = {"group": group,
                                   "goal": {"joints": dict(zip(waypoint.joint_names, waypoint.positions))}}
        if "wait" in params:
            request["wait"] = params["wait"]
        return self.core.plan_and_execute(request)

    @staticmethod
    def _call(fn: Callable[[], Any], method: str) -> Any:
        try:
            return fn()
        except WaypointError as exc:
            raise RpcError(BAD_REQUEST, f"{method}: {exc}") from None
