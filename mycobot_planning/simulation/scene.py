"""The simulated world around the robot: a floor and objects with mass and friction, from YAML.

Format (``config/mujoco_scene.yaml`` is the seeds' pick-and-place world; docs/simulation.md,
section "Scene file", explains every key)::

    frame_id: world                 # poses below are in the simulator's world frame
    floor: {z: -0.03, friction: [0.8, 0.005, 0.0001]}     # or null: no floor
    objects:
      - {id: table, shape: box, size: [0.10, 0.20, 0.03], pose: [0.22, 0.12, -0.015, 0, 0, 0], fixed: true}
      - {id: object, shape: cylinder, height: 0.35, radius: 0.0125, pose: [0.22, 0.12, 0.175, 0, 0, 0],
         mass: 0.07, friction: [1.0, 0.005, 0.0001]}
    camera_file: camera_scene.yaml  # its camera: section (or an inline camera: mapping)

Poses are ``[x, y, z, roll, pitch, yaw]`` (fixed axes, as in URDF) or ``[x, y, z, qx, qy, qz, qw]``
of the shape's centre; a cylinder's axis is its local z, as in shape_msgs. An object without
``fixed: true`` is a free body and needs a mass > 0.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from interfaces_py.pose_conversion import PoseError, pose_matrix

from ..paths import read_yaml_file
from ..perception.depth_camera import DepthCameraConfig
from ..perception.errors import PerceptionError
from .errors import SimulationModelError
from .settings import finite_number, friction_triple

SHAPES = ("box", "cylinder", "sphere")
_OBJECT_KEYS = {"id", "shape", "size", "height", "radius", "pose", "mass", "fixed", "friction", "color"}
_SCENE_KEYS = {"frame_id", "floor", "objects", "camera", "camera_file"}
DEFAULT_FRICTION = (0.8, 0.005, 0.0001)
DEFAULT_COLOR = (0.6, 0.6, 0.6, 1.0)


@dataclass(frozen=True)
class SceneObject:
    """One body of the world. ``size``: box (x, y, z) full lengths, cylinder (height, radius),
    sphere (radius,) — the shape_msgs/SolidPrimitive conventions. ``pose``: 4x4 of the centre.
    ``fixed``: welded to the world (a table); otherwise a free body of ``mass`` kg, its inertia
    that of a solid of uniform density."""

    id: str
    shape: str
    size: tuple[float, ...]
    pose: np.ndarray
    mass: float = 0.0
    fixed: bool = False
    friction: tuple[float, float, float] = DEFAULT_FRICTION
    color: tuple[float, float, float, float] = DEFAULT_COLOR

    def __post_init__(self) -> None:
        where = f"object '{self.id}'"
        if not isinstance(self.id, str) or not self.id.strip():
            raise SimulationModelError("every object needs a non-empty 'id'")
        if self.shape not in SHAPES:
            raise SimulationModelError(f"{where}: shape must be one of {list(SHAPES)}, got {self.shape!r}")
        want = {"box": 3, "cylinder": 2, "sphere": 1}[self.shape]
        size = tuple(finite_number(f"{where} size", v, 0.0, low_open=True) for v in self.size)
        if len(size) != want:
            raise SimulationModelError(f"{where}: a {self.shape} needs {want} sizes, got {list(self.size)}")
        object.__setattr__(self, "size", size)
        try:
            object.__setattr__(self, "pose", pose_matrix(self.pose, f"{where} pose"))
        except PoseError as exc:
            raise SimulationModelError(str(exc)) from None
        if not self.fixed:
            mass = self.mass
            if isinstance(mass, bool) or not isinstance(mass, (int, float)) or not math.isfinite(mass) or mass <= 0:
                raise SimulationModelError(
                    f"{where} is a free body with mass {mass!r}: MuJoCo cannot simulate a free body without "
                    "mass; give it a mass > 0 (kg) or make it fixed (fixed: true)")
        object.__setattr__(self, "mass", float(self.mass or 0.0))
        object.__setattr__(self, "friction", friction_triple(f"{where} friction", self.friction))
        color = tuple(float(c) for c in self.color)
        if len(color) not in (3, 4) or any(not 0.0 <= c <= 1.0 for c in color):
            raise SimulationModelError(f"{where}: color must be [r, g, b(, a)] in 0..1, got {list(self.color)}")
        object.__setattr__(self, "color", color + (1.0,) * (4 - len(color)))

    @property
    def half_extents(self) -> np.ndarray:
        """Half sizes along the object's own x, y, z."""
        if self.shape == "box":
            return np.asarray(self.size) / 2.0
        if self.shape == "cylinder":
            return np.array([self.size[1], self.size[1], self.size[0] / 2.0])
        return np.full(3, self.size[0])

    def moved_to(self, pose: Any) -> "SceneObject":
        """The same object at another pose."""
        return replace(self, pose=pose)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], index: int = 0) -> "SceneObject":
        """From one entry of the scene file's ``objects:`` list."""
        if not isinstance(data, Mapping):
            raise SimulationModelError(f"objects[{index}] must be a mapping, got {type(data).__name__}")
        name = data.get("id", f"objects[{index}]")
        unknown = sorted(set(data) - _OBJECT_KEYS)
        if unknown:
            raise SimulationModelError(f"object '{name}': unknown keys {unknown} (known: {sorted(_OBJECT_KEYS)})")
        shape = data.get("shape")
        if shape == "box":
            size = data.get("size")
        elif shape == "cylinder":
            size = [data.get("height"), data.get("radius")]
        elif shape == "sphere":
            size = [data.get("radius")]
        else:
            raise SimulationModelError(f"object '{name}': shape must be one of {list(SHAPES)}, got {shape!r}")
        if not isinstance(size, (list, tuple)) or any(v is None for v in size):
            need = {"box": "size: [x, y, z]", "cylinder": "height and radius", "sphere": "radius"}[shape]
            raise SimulationModelError(f"object '{name}': a {shape} needs {need}")
        if "pose" not in data:
            raise SimulationModelError(f"object '{name}': no pose")
        fixed = data.get("fixed", False)
        if not isinstance(fixed, bool):
            raise SimulationModelError(f"object '{name}': fixed must be true or false, got {fixed!r}")
        return cls(str(name), shape, tuple(size), data["pose"], data.get("mass", 0.0), fixed,
                   data.get("friction", DEFAULT_FRICTION), data.get("color", DEFAULT_COLOR))


@dataclass(frozen=True)
class Floor:
    """A ground plane at height ``z`` (world frame)."""

    z: float = 0.0
    friction: tuple[float, float, float] = DEFAULT_FRICTION

    def __post_init__(self) -> None:
        finite_number("floor.z", self.z)
        object.__setattr__(self, "friction", friction_triple("floor.friction", self.friction))


@dataclass(frozen=True)
class SimScene:
    """The world: an optional floor, objects (unique ids), and the camera looking at it."""

    objects: tuple[SceneObject, ...] = ()
    floor: Floor | None = field(default_factory=Floor)
    frame_id: str = "world"
    camera: DepthCameraConfig | None = None
    source: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "objects", tuple(self.objects))
        seen: set[str] = set()
        for obj in self.objects:
            if obj.id in seen:
                raise SimulationModelError(f"two objects are named '{obj.id}'{self._where()}")
            seen.add(obj.id)

    def _where(self) -> str:
        return f" in {self.source}" if self.source else ""

    def object(self, name: str) -> SceneObject:
        for obj in self.objects:
            if obj.id == name:
                return obj
        raise KeyError(f"no object '{name}' in the scene (objects: {', '.join(o.id for o in self.objects) or 'none'})")

    @property
    def object_ids(self) -> list[str]:
        return [o.id for o in self.objects]

    def with_object(self, obj: SceneObject) -> "SimScene":
        """This scene with ``obj`` added, or replacing the object of the same id."""
        others = [o for o in self.objects if o.id != obj.id]
        return replace(self, objects=tuple(others + [obj]))

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], base_dir: Path | None = None, source: str = "") -> "SimScene":
        """From the scene file's mapping; ``camera_file`` is relative to ``base_dir``."""
        if not isinstance(data, Mapping):
            raise SimulationModelError(f"a scene file must hold a mapping{f' ({source})' if source else ''}")
        unknown = sorted(set(data) - _SCENE_KEYS)
        if unknown:
            raise SimulationModelError(f"unknown scene keys {unknown} (known: {sorted(_SCENE_KEYS)})")
        floor_data = data.get("floor", {})
        floor = None
        if floor_data is not None:
            if not isinstance(floor_data, Mapping) or sorted(set(floor_data) - {"z", "friction"}):
                raise SimulationModelError(f"floor must be a mapping with z and friction, got {floor_data!r}")
            floor = Floor(floor_data.get("z", 0.0), floor_data.get("friction", DEFAULT_FRICTION))
        raw = data.get("objects", []) or []
        if not isinstance(raw, Sequence) or isinstance(raw, (str, bytes)):
            raise SimulationModelError("objects must be a list")
        objects = tuple(SceneObject.from_dict(entry, i) for i, entry in enumerate(raw))
        camera = None
        if data.get("camera") is not None and data.get("camera_file") is not None:
            raise SimulationModelError("give camera or camera_file, not both")
        try:
            if data.get("camera") is not None:
                camera = DepthCameraConfig.from_dict(data["camera"])
            elif data.get("camera_file") is not None:
                path = Path(str(data["camera_file"]))
                if not path.is_absolute() and base_dir is not None:
                    path = base_dir / path
                camera = _camera_from_file(path)
        except PerceptionError as exc:
            raise SimulationModelError(str(exc)) from None
        frame_id = data.get("frame_id", "world")
        if not isinstance(frame_id, str) or not frame_id:
            raise SimulationModelError(f"frame_id must be a frame name, got {frame_id!r}")
        return cls(objects, floor, frame_id, camera, source)


def _camera_from_file(path: Path) -> DepthCameraConfig:
    data = read_yaml_file(path, SimulationModelError, f"camera_file '{path}'") or {}
    if not isinstance(data, Mapping) or "camera" not in data:
        raise SimulationModelError(f"camera_file '{path}' has no camera: section")
    return DepthCameraConfig.from_dict(data["camera"])


def load_scene(path: str | Path) -> SimScene:
    """The scene of a YAML file; every problem is a SimulationModelError naming the file."""
    path = Path(path)
    data = read_yaml_file(path, SimulationModelError, f"scene file '{path}'")
    try:
        return SimScene.from_dict(data or {}, path.parent, str(path))
    except SimulationModelError as exc:
        raise SimulationModelError(f"{path}: {exc}") from None
