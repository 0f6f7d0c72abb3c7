"""Objects from perception for task nodes: ask the perception_server, put the answer in the scene.

The full story: docs/nodes.md, section mycobot_planning.ros.perception.perception_object_source.
"""
from __future__ import annotations

import math

from dataclasses import dataclass, field, replace
from typing import Any, Iterable, Sequence

import numpy as np
from rclpy.exceptions import ParameterNotDeclaredException
from rclpy.node import Node

from interfaces_py.clients import PlanningSceneInterface, RpcError
from interfaces_py.msgs import CollisionObject, Pose
from interfaces_py.perception_client import DEFAULT_PERCEPTION_SERVER, PerceptionClient, PerceptionResult
from mycobot_planning.core.errors import PlanningError
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.core.transforms import matrix_to_rpy
from mycobot_planning.ros.node_runtime import ParameterSpec
from mycobot_planning.ros.perception.perception_setup import detection_lines

__all__ = [
    "PerceivedObjects",
    "PerceptionObjectSource",
    "apply_detected_objects",
    "fixed_frame_transform",
    "perception_parameter_specs",
    "to_frame",
]


def _server_name(value: Any) -> str | None:
    if not isinstance(value, str) or not value.strip() or any(c.isspace() for c in value):
        return f"perception_server must be a node name without spaces, e.g. /perception_server, got {value!r}"
    return None


def perception_parameter_specs(server: str = DEFAULT_PERCEPTION_SERVER) -> list[ParameterSpec]:
    """The parameters a task node declares to take its object from perception."""
    return [
        ParameterSpec("use_perception", False, "take the object and the support surface from the perception_server "
                      "(the detected cylinder most similar to object_dimensions) instead of object_pose and the "
                      "table parameters"),
        ParameterSpec("perception_server", server, "name of the perception_server node", read_only=True,
                      validator=_server_name),
        ParameterSpec("perception_timeout", 30.0, "seconds to wait for the perception_server's answer",
                      range=(0.1, 600.0)),
        ParameterSpec("perception_padding", 0.0, "metres added to the perceived target cylinder's radius before it "
                      "enters the planning scene and the task: the planner keeps no distance from obstacles "
                      "(MoveIt's padding defaults to 0), and a path grazing a real object knocks it (the twin's "
                      "perception demo uses 0.005, as demo.sh --sim mujoco pads the seed's cylinder)",
                      range=(0.0, 0.05)),
    ]


# ---------------------------------------------------------------------------- frames
def fixed_frame_transform(model: RobotModel, source: str, target: str) -> np.ndarray:
    """T_target_source between two frames of the robot model that no joint moves apart (e.g.
    base_link and world). ValueError if a frame is unknown or moves with the robot: without tf
    there is no "now" to evaluate a moving frame at."""
    scene = PlanningScene(model)
    states = [RobotState(model), RobotState(model, model.lower_limits), RobotState(model, model.upper_limits)]
    try:
        poses = [[scene.frame_pose(f, s) for f in (source, target)] for s in states]
    except PlanningError as exc:
        raise ValueError(str(exc)) from None
    relative = [np.linalg.inv(t) @ s for s, t in poses]
    if any(not np.allclose(relative[0], r, atol=1e-9) for r in relative[1:]):
        raise ValueError(f"frames '{source}' and '{target}' move relative to each other with the robot's joints; "
                         "perception results can only be re-expressed between fixed frames")
    return relative[0]


def to_frame(obj: CollisionObject, frame_id: str, T_frame_obj: np.ndarray) -> CollisionObject:
    """``obj`` re-expressed in ``frame_id`` (``T_frame_obj`` maps the object's frame into it)."""
    if obj.frame_id == frame_id:
        return obj
    pose = Pose.from_matrix(np.asarray(T_frame_obj) @ obj.pose.to_matrix())
    return CollisionObject(id=obj.id, frame_id=frame_id, pose=pose, primitives=list(obj.primitives),
                           primitive_poses=list(obj.primitive_poses), meshes=list(obj.meshes),
                           mesh_poses=list(obj.mesh_poses), operation=obj.operation)


# ---------------------------------------------------------------------------- scene updates
def apply_detected_objects(scene: PlanningSceneInterface, objects: Sequence[CollisionObject],
                           previous_ids: Iterable[str] = (), remove_ids: Iterable[str] = ()
                           ) -> tuple[list[str], list[str], list[str]]:
    """Put detected objects into the planning_server's scene in one all-or-nothing update.

    ADDs ``objects`` (replacing same-id objects) and REMOVEs the ``previous_ids`` (objects an
    earlier detection added) that were not detected again, plus ``remove_ids``, where they are
    world objects. An object the robot holds (attached) is neither replaced nor removed: the
    camera's view of it is not news to the robot. Returns (added, removed, skipped) ids;
    RpcError from the planning_server."""
    ids = [o.id for o in objects]
    stale = sorted((set(previous_ids) - set(ids)) | set(remove_ids))
    attached = set(scene.get_attached_objects(ids + stale)) if ids or stale else set()
    world = set(scene.get_objects(stale)) if stale else set()
    removed = [i for i in stale if i in world and i not in attached]
    added = [o.id for o in objects if o.id not in attached]
    skipped = [i for i in ids if i in attached]
    ops = [CollisionObject(id=i, operation=CollisionObject.REMOVE) for i in removed]
    ops += [o for o in objects if o.id not in attached]
    if ops:
        scene.apply_collision_objects(ops)
    return added, removed, skipped


# ---------------------------------------------------------------------------- the source
@dataclass
class PerceivedObjects:
    """A successful detection in the caller's world frame: the target, the support surface, the
    other detected objects (obstacles), and the raw result (message, summaries, timings)."""

    target: CollisionObject
    support_surface: CollisionObject
    others: list[CollisionObject] = field(default_factory=list)
    result: PerceptionResult | None = None

    @property
    def objects(self) -> list[CollisionObject]:
        """Everything to put into the scene: support surface first, then target, then the others."""
        return [self.support_surface, self.target, *self.others]

    def target_dimensions(self) -> list[float]:
        return [float(v) for v in self.target.primitives[0].dimensions]


class PerceptionObjectSource:
    """Takes a task node's object from the perception_server (see docs/nodes.md (mycobot_planning.ros.perception.perception_object_source))."""

    def __init__(self, node: Node, *, server: str | None = None, timeout: float | None = None) -> None:
        self.node = node
        self._server = server or str(self._param("perception_server", DEFAULT_PERCEPTION_SERVER))
        self._timeout = timeout
        self.client = PerceptionClient(node=node, server=self._server, timeout=self.timeout)
        self._applied: list[str] = []
        self._key: tuple | None = None
        self._params_out: Any = None

    # ------------------------------------------------------------------ parameters
    def _param(self, name: str, default: Any) -> Any:
        params = getattr(self.node, "params", None)
        try:
            if params is not None:
                return params.get(name)
            if self.node.has_parameter(name):
                return self.node.get_parameter(name).value
        except (KeyError, ParameterNotDeclaredException):  # not declared by this node: the default applies
            pass
        return default

    @property
    def enabled(self) -> bool:
        """The node's ``use_perception`` parameter."""
        return bool(self._param("use_perception", False))

    @property
    def timeout(self) -> float:
        return float(self._timeout if self._timeout is not None else self._param("perception_timeout", 30.0))

    @property
    def padding(self) -> float:
        """The node's ``perception_padding`` parameter (m added to the target's radius)."""
        return float(self._param("perception_padding", 0.0))

    def _log(self, text: str, level: str = "info") -> None:
        # rclpy refuses a call site whose severity changes: one call per severity.
        if level == "warning":
            self.node.get_logger().warning(text)
        else:
            self.node.get_logger().info(text)

    # ------------------------------------------------------------------ detection
    def fetch(self, target_shape: str, target_dimensions: Sequence[float], world_frame: str = "world",
              timeout: float | None = None) -> PerceivedObjects:
        """Ask the perception_server for ``target_shape`` of ``target_dimensions`` and return the
        detection in ``world_frame``. ValueError saying why when there is no usable answer
        (no server, no cloud, no support surface, no such object, an unknown frame)."""
        wait = self.timeout if timeout is None else float(timeout)
        try:
            result = self.client.get_planning_scene(target_shape, list(target_dimensions), timeout=wait)
        except RpcError as exc:
            raise ValueError(f"perception_server {self._server}: {exc.message}") from None
        if not result.success:
            raise ValueError(f"perception found no {target_shape} to pick: {result.message}")
        if result.support_surface is None or result.target is None:
            raise ValueError(f"perception answered without a target or support surface: {result.message}")
        frame = result.target.frame_id
        T = np.eye(4)
        if frame != world_frame:
            model = getattr(self.node, "model", None)
            if model is None:
                raise ValueError(f"perception reports objects in '{frame}', the task plans in '{world_frame}', and "
                                 "this node has no robot model to relate the two")
            T = fixed_frame_transform(model, frame, world_frame)
        target = to_frame(result.target, world_frame, T)
        surface = to_frame(result.support_surface, world_frame, T)
        others = [to_frame(o, world_frame, T) for o in result.objects if o.id != result.target_object_id]
        return PerceivedObjects(target, surface, others, result)

    def _scene_still_set_up(self, params: Any) -> bool:
        """The last set-up is still in the scene: its target is there (in the world or held) and
        the seed's objects are not back (the node's own set-up ran while perception was off)."""
        out = self._params_out
        try:
            known = set(self.node.scene_interface.get_known_object_names())
        except RpcError:
            return False
        seed_ids = {params.object_name, params.table_name} - {out.object_name, out.table_name}
        return out.object_name in known and out.table_name in known and not (seed_ids & known)

    def setup_planning_scene(self, params: Any, force: bool = False) -> Any:
        """Detect, update the planning_server's scene, and return ``params`` (PickPlaceParameters)
        pointing at the detected cylinder and support surface (see docs/nodes.md (mycobot_planning.ros.perception.perception_object_source)).
        ValueError when perception or the scene update fails (the task is not built)."""
        padding = self.padding
        key = (tuple(params.object_dimensions), params.world_frame, params.object_name, params.table_name,
               self._server, padding)
        if key == self._key and self._params_out is not None and not force and self._scene_still_set_up(params):
            return self._params_out
        height, radius = (float(v) for v in params.object_dimensions)
        self._log(f"Taking the object from perception: asking {self._server} for a cylinder of height "
                  f"{height:.4f} m and radius {radius:.4f} m")
        perceived = self.fetch("cylinder", [height, radius], params.world_frame)
        seen_radius = perceived.target_dimensions()[1]
        if padding > 0.0:
            t = perceived.target
            perceived = replace(perceived, target=CollisionObject.cylinder(
                t.id, perceived.target_dimensions()[0], seen_radius + padding, t.pose.to_matrix(), t.frame_id))
        result = perceived.result
        for line in _summary_lines(result):
            self._log(line)
        target, surface = perceived.target, perceived.support_surface
        detected = {o.id for o in perceived.objects}
        seed_ids = [i for i in (params.object_name, params.table_name) if i not in detected]
        scene = self.node.scene_interface
        try:
            added, removed, skipped = apply_detected_objects(scene, perceived.objects, self._applied, seed_ids)
        except RpcError as exc:
            self._key = None
            raise ValueError(f"putting the perceived objects into the planning scene failed: {exc.message}") from None
        self._applied = list(dict.fromkeys([*self._applied, *added]))
        self._applied = [i for i in self._applied if i not in removed]
        if removed:
            self._log(f"Removed from the planning scene: {', '.join(removed)}")
        if skipped:
            self._log(f"Not replaced (attached to the robot): {', '.join(skipped)}", "warning")
        self._log(f"Added to the planning scene from perception: {', '.join(added)} (frame '{params.world_frame}')")
        h, r = perceived.target_dimensions()
        base = target.pose.to_matrix()
        base_point = base[:3, 3] - 0.5 * h * base[:3, 2]
        roll, pitch, yaw = _rpy(base)
        out = params.with_changes(
            object_name=target.id, object_dimensions=[h, r], object_reference_frame=params.world_frame,
            object_pose=[*(float(v) for v in base_point), roll, pitch, yaw],
            table_name=surface.id, table_reference_frame=params.world_frame)
        if getattr(params, "surface_link", ""):
            out = out.with_changes(surface_link=surface.id)
        self._key, self._params_out = key, out
        padded = f" (perceived {seen_radius:.4f} m + perception_padding {padding:g} m)" if padding > 0.0 else ""
        self._log(f"Perception target '{target.id}': height {h:.4f} m, radius {r:.4f} m{padded}, base at "
                  f"({base_point[0]:.4f}, {base_point[1]:.4f}, {base_point[2]:.4f}), roll/pitch/yaw "
                  f"({math.degrees(roll):.2f}, {math.degrees(pitch):.2f}, {math.degrees(yaw):.2f}) deg on '{surface.id}'")
        return out


def _rpy(T: np.ndarray) -> tuple[float, float, float]:
    r, p, y = (float(v) for v in matrix_to_rpy(T[:3, :3]))
    return r, p, y


def _summary_lines(result: PerceptionResult | None) -> list[str]:
    if result is None:
        return []
    lines = detection_lines(result.response)
    return [f"Perception: {lines[0]}", *lines[1:]]

