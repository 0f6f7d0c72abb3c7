"""Blocking Python client of the perception_server: the seed's get-planning-scene service.

The full story: docs/interfaces.md, section interfaces_py.perception_client.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

from rclpy.node import Node

from interfaces_py.clients import RpcError, RpcTimeout, _Client, _RosHandle
from interfaces_py.msgs import CollisionObject, PlanningSceneWorld

__all__ = ["DEFAULT_PERCEPTION_SERVER", "PerceptionClient", "PerceptionResult", "RpcError", "RpcTimeout"]

DEFAULT_PERCEPTION_SERVER = "/perception_server"


@dataclass
class PerceptionResult:
    """The get-planning-scene answer, typed. Truthy when ``success``.

    ``objects`` are the detected cylinders and boxes and ``support_surface`` the surface they
    stand on (CollisionObject ADD messages in ``frame_id``, the server's target_frame);
    ``summaries`` the per-object summary (id, shape, dimensions, position, yaw, points);
    ``response`` the raw JSON answer (timings_ms, cloud, applied ids, ...)."""

    success: bool
    message: str
    target_object_id: str = ""
    support_surface_id: str = ""
    objects: list[CollisionObject] = field(default_factory=list)
    support_surface: CollisionObject | None = None
    summaries: list[dict[str, Any]] = field(default_factory=list)
    frame_id: str = ""
    response: dict[str, Any] = field(default_factory=dict)

    def __bool__(self) -> bool:
        return bool(self.success)

    @property
    def target(self) -> CollisionObject | None:
        """The target object's CollisionObject (None if there is no target)."""
        return self.object(self.target_object_id) if self.target_object_id else None

    def object(self, object_id: str) -> CollisionObject:
        """A detected object (or the support surface) by id; KeyError naming the known ids."""
        for obj in [*self.objects, *([self.support_surface] if self.support_surface else [])]:
            if obj.id == object_id:
                return obj
        known = [o.id for o in self.objects] + ([self.support_surface.id] if self.support_surface else [])
        raise KeyError(f"no detected object '{object_id}'; detected: {known}")

    def summary(self, object_id: str) -> dict[str, Any]:
        for item in self.summaries:
            if item.get("id") == object_id:
                return item
        raise KeyError(f"no detected object '{object_id}'; detected: {[s.get('id') for s in self.summaries]}")

    @classmethod
    def from_response(cls, response: Mapping[str, Any]) -> PerceptionResult:
        """Parse the server's JSON answer (DetectionResult.to_response() plus the node's extras)."""
        if not isinstance(response, Mapping):
            raise RpcError(-1001, f"perception_server answered {type(response).__name__}, not an object")
        world = PlanningSceneWorld.from_dict(response.get("scene_world") or {})
        surface_id = str(response.get("support_surface_id") or "")
        surface = next((o for o in world.collision_objects if surface_id and o.id == surface_id), None)
        objects = [o for o in world.collision_objects if o is not surface]
        frame = str(response.get("frame_id") or (objects[0].frame_id if objects else
                                                 surface.frame_id if surface else ""))
        return cls(bool(response.get("success")), str(response.get("message", "")),
                   str(response.get("target_object_id") or ""), surface_id, objects, surface,
                   list(response.get("objects") or []), frame, dict(response))


class PerceptionClient(_Client):
    """Calls the perception_server (see docs/interfaces.md (interfaces_py.perception_client))."""

    _prefix = "perception_client"

    def __init__(self, node: Node | None = None, server: str = DEFAULT_PERCEPTION_SERVER, timeout: float = 30.0,
                 _handle: _RosHandle | None = None) -> None:
        if not isinstance(server, str) or not server.strip():
            raise ValueError(f"server must name the perception_server node, got {server!r}")
        super().__init__(node, server, timeout, _handle)

    def wait_for_server(self, timeout: float | None = None) -> bool:
        """True once the perception_server answers requests (False after ``timeout``)."""
        return super().wait_for_server(timeout)

    def get_planning_scene(self, target_shape: str | None = None, target_dimensions: Sequence[float] | None = None,
                           timeout: float | None = None, apply: bool | None = None) -> PerceptionResult:
        """Detect the support surface and the objects in the latest cloud and pick the target.

        ``target_shape`` "cylinder" (``target_dimensions`` [height, radius]) or "box" ([x, y, z]);
        None uses the server's target_shape / target_dimensions parameters. ``apply`` True/False
        overrides the server's apply_to_planning_server for this request. Blocks up to
        ``timeout`` seconds (default: the client's)."""
        params: dict[str, Any] = {}
        if target_shape is not None:
            params["target_shape"] = target_shape
        if target_dimensions is not None:
            try:
                params["target_dimensions"] = [float(v) for v in target_dimensions]
            except (TypeError, ValueError):
                raise ValueError(f"target_dimensions must be numbers, got {target_dimensions!r}") from None
        if apply is not None:
            params["apply"] = bool(apply)
        return PerceptionResult.from_response(self.call("get_planning_scene", params, timeout))
