"""The 3D scene's displays of the task viewer, RViz's RobotModel and PlanningScene displays in a
viser scene: a robot drawn from its collision shapes, posed by a joint vector, and the planning
scene's objects (world and attached), each under its own root frame that can be shown or hidden.
The page around them: viewer.py.
"""
from __future__ import annotations

import math
from typing import Any, Callable, Mapping, Sequence

import numpy as np


from ..core.robot_model.robot_model import RobotModel
from ..core.robot_state.robot_state import RobotState
from .geometry import object_shapes, robot_link_shapes
from .playback import SceneObjects

__all__ = ["ATTACHED_COLOUR", "ObjectsDisplay", "RobotDisplay"]

#: attached objects are drawn in this colour (world objects take the colour the viewer gives them)
ATTACHED_COLOUR = (140, 70, 215)


def _quat_wxyz(T: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix (Shepperd's method)."""
    R = T[:3, :3]
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        q = (s / 4, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s)
    elif R[0, 0] > R[1, 1] and R[0, 0] > R[2, 2]:
        s = math.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2]) * 2
        q = ((R[2, 1] - R[1, 2]) / s, s / 4, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s)
    elif R[1, 1] > R[2, 2]:
        s = math.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2]) * 2
        q = ((R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, s / 4, (R[1, 2] + R[2, 1]) / s)
    else:
        s = math.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1]) * 2
        q = ((R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, s / 4)
    q = np.asarray(q)
    return q / np.linalg.norm(q)


def _node_name(text: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in text) or "_"


class _RootFrameDisplay:
    """A display whose scene nodes hang under one root frame (``_root``): ``visible`` shows or
    hides them all."""

    _root: Any

    @property
    def visible(self) -> bool:
        return bool(self._root.visible)

    @visible.setter
    def visible(self, value: bool) -> None:
        self._root.visible = bool(value)


class RobotDisplay(_RootFrameDisplay):
    """One robot drawn from its collision shapes: a frame per link, the shapes under it."""

    def __init__(self, server: Any, model: RobotModel, root: str, colour: tuple[int, int, int],
                 visible: bool = True, opacity: float | None = None) -> None:
        self.model = model
        self.root = root
        shapes = robot_link_shapes(model)
        self.links = sorted({s.link for s in shapes}, key=model.link_names.index)
        self.frames: dict[str, Any] = {}
        self._poses: dict[str, np.ndarray] = {}
        self._root = server.scene.add_frame(root, show_axes=False, visible=visible)
        for link in self.links:
            self.frames[link] = server.scene.add_frame(f"{root}/{_node_name(link)}", show_axes=False)
        for s in shapes:
            server.scene.add_mesh_simple(
                f"{root}/{_node_name(s.link)}/shape{s.index}", s.mesh.vertices, s.mesh.faces, color=colour,
                opacity=opacity, flat_shading=s.kind == "box", position=tuple(s.pose[:3, 3]),
                wxyz=tuple(_quat_wxyz(s.pose)))
        self.positions: np.ndarray | None = None
        self._state = RobotState(model)

    def link_poses(self, positions: np.ndarray, extra_links: Sequence[str] = ()) -> dict[str, np.ndarray]:
        self._state.set_positions(positions)
        return self._state.frame_poses(list(dict.fromkeys([*self.links, *extra_links])))

    def set_positions(self, positions: np.ndarray, extra_links: Sequence[str] = ()) -> dict[str, np.ndarray]:
        """Move the robot; only links whose pose changed are sent. Returns every link pose."""
        poses = self.link_poses(positions, extra_links)
        for link in self.links:
            T = poses[link]
            old = self._poses.get(link)
            if old is not None and np.array_equal(old, T):
                continue
            frame = self.frames[link]
            frame.position = T[:3, 3]
            frame.wxyz = _quat_wxyz(T)
            self._poses[link] = T
        self.positions = np.array(positions, dtype=float)
        return poses


class ObjectsDisplay(_RootFrameDisplay):
    """Scene objects under one root: meshes re-created when an object's shapes change, poses
    updated every time (attached objects follow their link)."""

    def __init__(self, server: Any, root: str, colours: Callable[[str], tuple[int, int, int]],
                 package_dirs: Sequence[Any] = ()) -> None:
        self.server = server
        self.root = root
        self._colours = colours
        self._package_dirs = package_dirs
        self._root = server.scene.add_frame(root, show_axes=False)
        self._nodes: dict[str, tuple[str, Any, list[Any]]] = {}  # id -> (signature, frame, meshes)
        self.shown: dict[str, dict[str, Any]] = {}
        self.errors: dict[str, str] = {}

    def update(self, objects: SceneObjects, link_poses: Mapping[str, np.ndarray]) -> None:
        poses = objects.poses(link_poses)
        for object_id in list(self._nodes):
            if object_id not in poses:
                self._remove(object_id)
        shown = {}
        for object_id, pose in poses.items():
            attached = object_id in objects.attached
            colour = ATTACHED_COLOUR if attached else self._colours(object_id)
            signature = objects.shape_signature(object_id) + repr(colour)
            node = self._nodes.get(object_id)
            if node is None or node[0] != signature:
                if node is not None:
                    self._remove(object_id)
                node = self._add(object_id, objects.object(object_id), colour, signature)
                if node is None:
                    continue
            frame = node[1]
            frame.position = pose[:3, 3]
            frame.wxyz = _quat_wxyz(pose)
            shown[object_id] = {"colour": list(colour), "attached_to": objects.attached[object_id][0] if attached else None,
                                "position": [round(float(v), 5) for v in pose[:3, 3]],
                                "shapes": [p.type_name.lower() for p in objects.object(object_id).primitives]
                                + ["mesh"] * len(objects.object(object_id).meshes)}
        self.shown = shown

    def _add(self, object_id: str, obj: Any, colour: tuple[int, int, int], signature: str):
        try:
            shapes = object_shapes(obj, self._package_dirs)
        except Exception as exc:  # a mesh file that cannot be loaded: say so, draw the rest
            self.errors[object_id] = str(exc)
            return None
        name = f"{self.root}/{_node_name(object_id)}"
        frame = self.server.scene.add_frame(name, show_axes=False)
        meshes = [self.server.scene.add_mesh_simple(f"{name}/shape{s.index}", s.mesh.vertices, s.mesh.faces,
                                                    color=colour, flat_shading=s.kind == "box",
                                                    position=tuple(s.pose[:3, 3]), wxyz=tuple(_quat_wxyz(s.pose)))
                  for s in shapes]
        self._nodes[object_id] = (signature, frame, meshes)
        self.errors.pop(object_id, None)
        return self._nodes[object_id]

    def _remove(self, object_id: str) -> None:
        _signature, frame, meshes = self._nodes.pop(object_id)
        for mesh in meshes:
            mesh.remove()
        frame.remove()
