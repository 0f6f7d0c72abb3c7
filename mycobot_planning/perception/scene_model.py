"""Ground-truth scenes for the simulated depth camera: a support surface, cylinders and boxes.

A scene is what the camera simulator renders and what the tests compare detections against.
Poses are 4x4 matrices of each shape's centre in the world (``target_frame``) frame, with the
same conventions as ``interfaces_py.msgs.CollisionObject``: a box of ``size`` (x, y, z) centred
on its pose, a cylinder along its local z axis. YAML uses the seeds' pose vectors
``[x, y, z, roll, pitch, yaw]``.

Example YAML (``config/camera_scene.yaml`` has a complete one)::

    scene:
      support_surface: {id: table, size: [0.9, 0.9, 0.03], pose: [0.55, 0.45, -0.015, 0, 0, 0]}
      cylinders:
        - {id: cylinder, height: 0.35, radius: 0.0125, pose: [0.22, 0.12, 0.175, 0, 0, 0]}
      boxes:
        - {id: box, size: [0.04, 0.06, 0.08], pose: [0.40, 0.30, 0.04, 0, 0, 0.5]}
      ground_plane_z: -0.75     # optional floor under the table
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from interfaces_py.msgs import CollisionObject
from interfaces_py.pose_conversion import PoseError, pose_matrix

from ..paths import read_yaml_file
from .errors import PerceptionError

DEFAULT_COLORS = {
    "support": (150, 111, 51),
    "cylinder": (200, 30, 30),
    "box": (30, 90, 200),
    "ground": (90, 90, 90),
}


def pose_from_vector(values: Sequence[float], what: str = "pose") -> np.ndarray:
    """4x4 pose from the seeds' ``[x, y, z, roll, pitch, yaw]`` (or any form pose_matrix takes),
    a bad one refused as a PerceptionError."""
    try:
        return pose_matrix(values, what)
    except PoseError as exc:
        raise PerceptionError(str(exc)) from None


def yaw_pose(x: float, y: float, z: float, yaw: float = 0.0) -> np.ndarray:
    """Pose at (x, y, z) turned by ``yaw`` about the world z axis."""
    c, s = np.cos(yaw), np.sin(yaw)
    T = np.eye(4)
    T[:2, :2] = [[c, -s], [s, c]]
    T[:3, 3] = (x, y, z)
    return T


def _color(value: Any, default: tuple[int, int, int], what: str) -> tuple[int, int, int]:
    if value is None:
        return default
    arr = np.asarray(value, dtype=float).reshape(-1)
    if arr.size != 3 or np.any(arr < 0) or np.any(arr > 255):
        raise PerceptionError(f"{what}: colour must be [r, g, b] in 0..255, got {value!r}")
    return tuple(int(round(v)) for v in arr)  # type: ignore[return-value]


@dataclass
class SceneBox:
    """A box of ``size`` (x, y, z) centred at ``pose``."""

    id: str
    size: np.ndarray
    pose: np.ndarray
    color: tuple[int, int, int] = DEFAULT_COLORS["box"]

    def __post_init__(self) -> None:
        self.size = np.asarray(self.size, dtype=float).reshape(-1)
        self.pose = np.asarray(self.pose, dtype=float)
        if self.size.size != 3 or np.any(~np.isfinite(self.size)) or np.any(self.size <= 0):
            raise PerceptionError(f"box '{self.id}': size must be three positive numbers, got {self.size.tolist()}")
        if self.pose.shape != (4, 4) or not np.all(np.isfinite(self.pose)):
            raise PerceptionError(f"box '{self.id}': pose must be a finite 4x4 matrix")

    def collision_object(self, frame_id: str) -> CollisionObject:
        return CollisionObject.box(self.id, self.size.tolist(), self.pose, frame_id=frame_id)


@dataclass
class SceneCylinder:
    """A cylinder of ``height`` and ``radius`` along its pose's z axis, centred at ``pose``."""

    id: str
    height: float
    radius: float
    pose: np.ndarray
    color: tuple[int, int, int] = DEFAULT_COLORS["cylinder"]

    def __post_init__(self) -> None:
        self.height, self.radius = float(self.height), float(self.radius)
        self.pose = np.asarray(self.pose, dtype=float)
        if not (np.isfinite(self.height) and self.height > 0 and np.isfinite(self.radius) and self.radius > 0):
            raise PerceptionError(f"cylinder '{self.id}': height and radius must be positive, "
                                  f"got {self.height}, {self.radius}")
        if self.pose.shape != (4, 4) or not np.all(np.isfinite(self.pose)):
            raise PerceptionError(f"cylinder '{self.id}': pose must be a finite 4x4 matrix")

    def collision_object(self, frame_id: str) -> CollisionObject:
        return CollisionObject.cylinder(self.id, self.height, self.radius, self.pose, frame_id=frame_id)


@dataclass
class GroundTruthScene:
    """What the simulated camera looks at. ``support_surface`` is a box whose top face the
    objects stand on; ``ground_plane_z`` adds an infinite floor (``None``: no floor)."""

    support_surface: SceneBox | None = None
    cylinders: list[SceneCylinder] = field(default_factory=list)
    boxes: list[SceneBox] = field(default_factory=list)
    ground_plane_z: float | None = None
    ground_color: tuple[int, int, int] = DEFAULT_COLORS["ground"]
    frame_id: str = "base_link"

    def __post_init__(self) -> None:
        ids = [o.id for o in self.shapes()]
        dupes = sorted({i for i in ids if ids.count(i) > 1})
        if dupes:
            raise PerceptionError(f"scene: duplicate object ids {dupes}")

    def shapes(self) -> list[SceneBox | SceneCylinder]:
        """Every solid shape, support surface first (the renderer's shape index order)."""
        out: list[SceneBox | SceneCylinder] = []
        if self.support_surface is not None:
            out.append(self.support_surface)
        return out + list(self.cylinders) + list(self.boxes)

    @property
    def support_top_z(self) -> float:
        """Height of the support surface's top face (0.0 without a support surface)."""
        if self.support_surface is None:
            return 0.0
        s = self.support_surface
        return float(s.pose[2, 3] + 0.5 * abs(s.pose[2, :3]) @ s.size)

    def collision_objects(self) -> list[CollisionObject]:
        """The ground truth as collision objects (support surface first)."""
        return [shape.collision_object(self.frame_id) for shape in self.shapes()]

    # Construction helpers ------------------------------------------------------------------------
    @classmethod
    def tabletop(cls, table_size: Sequence[float] = (0.9, 0.9, 0.03),
                 table_center_xy: Sequence[float] = (0.55, 0.45), table_top_z: float = 0.0,
                 cylinders: Sequence[tuple[float, float, float, float]] = (),
                 boxes: Sequence[tuple[float, float, float, Sequence[float]]] = (),
                 ground_plane_z: float | None = None, frame_id: str = "base_link") -> GroundTruthScene:
        """A table with its top at ``table_top_z`` and objects standing on it.

        ``cylinders``: (x, y, height, radius) each; ``boxes``: (x, y, yaw, (sx, sy, sz)) each.
        Ids are cylinder_gt_0.., box_gt_0.. (distinct from the detector's cylinder_0, box_0)."""
        size = np.asarray(table_size, dtype=float)
        table = SceneBox("table", size, yaw_pose(table_center_xy[0], table_center_xy[1],
                                                 table_top_z - size[2] / 2), DEFAULT_COLORS["support"])
        cyl = [SceneCylinder(f"cylinder_gt_{i}", h, r, yaw_pose(x, y, table_top_z + h / 2))
               for i, (x, y, h, r) in enumerate(cylinders)]
        bx = [SceneBox(f"box_gt_{i}", s, yaw_pose(x, y, table_top_z + s[2] / 2, yaw))
              for i, (x, y, yaw, s) in enumerate(boxes)]
        return cls(table, cyl, bx, ground_plane_z, frame_id=frame_id)

    @classmethod
    def from_flat_parameters(cls, table_size: Sequence[float], table_pose: Sequence[float],
                             cylinders: Sequence[float] = (), boxes: Sequence[float] = (),
                             ground_plane_z: float | None = None, frame_id: str = "base_link") -> GroundTruthScene:
        """Scene from flat number lists, the shape ROS double-array parameters can hold.

        ``table_size`` [x, y, z] and ``table_pose`` [x, y, z, roll, pitch, yaw] as the seeds'
        table_dimensions / table_pose (the pose is the table's centre; an empty size means no
        table); ``cylinders`` = [x, y, height, radius] * n and ``boxes`` = [x, y, yaw, sx, sy, sz]
        * n, each standing on the table top (or on z = 0 without a table)."""
        cyl = np.asarray(cylinders, dtype=float).reshape(-1)
        bx = np.asarray(boxes, dtype=float).reshape(-1)
        if cyl.size % 4:
            raise PerceptionError(f"cylinders: expected groups of 4 numbers [x, y, height, radius], got {cyl.size}")
        if bx.size % 6:
            raise PerceptionError(f"boxes: expected groups of 6 numbers [x, y, yaw, sx, sy, sz], got {bx.size}")
        support = None
        top = 0.0
        if len(table_size):
            support = SceneBox("table", table_size, pose_from_vector(table_pose, "table_pose"), DEFAULT_COLORS["support"])
            top = cls(support).support_top_z
        cyls = [SceneCylinder(f"cylinder_gt_{i}", h, r, yaw_pose(x, y, top + h / 2))
                for i, (x, y, h, r) in enumerate(cyl.reshape(-1, 4))]
        boxes_ = [SceneBox(f"box_gt_{i}", (sx, sy, sz), yaw_pose(x, y, top + sz / 2, yaw))
                  for i, (x, y, yaw, sx, sy, sz) in enumerate(bx.reshape(-1, 6))]
        return cls(support, cyls, boxes_, ground_plane_z, frame_id=frame_id)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> GroundTruthScene:
        """Scene from the mapping under ``scene:`` in a camera-scene YAML (see module docstring)."""
        if not isinstance(data, Mapping):
            raise PerceptionError(f"scene: expected a mapping, got {type(data).__name__}")
        unknown = sorted(set(data) - {"support_surface", "cylinders", "boxes", "ground_plane_z",
                                      "ground_color", "frame_id"})
        if unknown:
            raise PerceptionError(f"scene: unknown keys {unknown}")
        support = None
        if data.get("support_surface") is not None:
            s = data["support_surface"]
            support = SceneBox(str(s.get("id", "table")), s.get("size", ()),
                               pose_from_vector(s.get("pose", ()), "support_surface.pose"),
                               _color(s.get("color"), DEFAULT_COLORS["support"], "support_surface"))
        cylinders = []
        for i, c in enumerate(data.get("cylinders") or []):
            cid = str(c.get("id", f"cylinder_gt_{i}"))
            cylinders.append(SceneCylinder(cid, c.get("height", float("nan")), c.get("radius", float("nan")),
                                           pose_from_vector(c.get("pose", ()), f"cylinder '{cid}' pose"),
                                           _color(c.get("color"), DEFAULT_COLORS["cylinder"], cid)))
        boxes = []
        for i, b in enumerate(data.get("boxes") or []):
            bid = str(b.get("id", f"box_gt_{i}"))
            boxes.append(SceneBox(bid, b.get("size", ()), pose_from_vector(b.get("pose", ()), f"box '{bid}' pose"),
                                  _color(b.get("color"), DEFAULT_COLORS["box"], bid)))
        ground = data.get("ground_plane_z")
        return cls(support, cylinders, boxes, None if ground is None else float(ground),
                   _color(data.get("ground_color"), DEFAULT_COLORS["ground"], "ground"),
                   str(data.get("frame_id", "base_link")))

    @classmethod
    def from_yaml(cls, path: str | Path) -> GroundTruthScene:
        """The ``scene:`` section of a camera-scene YAML file."""
        data = _load_yaml(path)
        if "scene" not in data:
            raise PerceptionError(f"{path}: no 'scene' section")
        return cls.from_dict(data["scene"])


def _load_yaml(path: str | Path) -> Mapping[str, Any]:
    data = read_yaml_file(path, PerceptionError)
    if not isinstance(data, Mapping):
        raise PerceptionError(f"{path}: expected a mapping at the top level")
    return data
