"""A robot configuration directory: the files a MoveIt config package holds, found by one path.

The setup assistant writes one (with a manifest, setup_assistant.yaml, naming each file); a folder
holding exactly one URDF and one SRDF works too, with joint_limits.yaml, kinematics.yaml,
ompl_planning.yaml, moveit_controllers.yaml and ros2_controllers.yaml picked up by those names
when present. The library (RobotModel.from_config) and every node (parameter `robot_config`)
read it through this one class, so they cannot disagree about which file means what.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ...paths import read_yaml_file
from ..errors import RobotModelError

MANIFEST = "setup_assistant.yaml"
#: manifest key -> file name used when the manifest does not say (or there is none)
OPTIONAL_FILES = {
    "joint_limits": "joint_limits.yaml",
    "kinematics": "kinematics.yaml",
    "ompl_planning": "ompl_planning.yaml",
    "moveit_controllers": "moveit_controllers.yaml",
    "ros2_controllers": "ros2_controllers.yaml",
}


@dataclass(frozen=True)
class RobotConfig:
    directory: Path
    urdf: Path
    srdf: Path
    joint_limits: Path | None = None
    kinematics: Path | None = None
    ompl_planning: Path | None = None
    moveit_controllers: Path | None = None
    ros2_controllers: Path | None = None
    package_dirs: tuple[str, ...] = ()

    @classmethod
    def load(cls, directory: str | Path) -> "RobotConfig":
        """The configuration in `directory`; RobotModelError saying what is missing otherwise."""
        root = Path(directory).expanduser()
        if not root.is_dir():
            raise RobotModelError(f"robot config '{directory}' is not a directory")
        manifest = _read_manifest(root)

        def path(key: str, default: str | None) -> Path | None:
            name = manifest.get(key, default)
            if not name:
                return None
            candidate = root / str(name)
            if key in manifest and not candidate.is_file():
                raise RobotModelError(f"robot config '{root}': {MANIFEST} names {key} '{name}', which does not exist")
            return candidate if candidate.is_file() else None

        urdf = path("urdf", None) or _only(root, "*.urdf", "URDF")
        srdf = path("srdf", None) or _only(root, "*.srdf", "SRDF")
        extra = manifest.get("package_dirs", []) or []
        if not isinstance(extra, list):
            raise RobotModelError(f"robot config '{root}': {MANIFEST} package_dirs must be a list of folders")
        dirs = [str((root / d).resolve()) for d in extra] + [str(p) for p in root.resolve().parents]
        return cls(root, urdf, srdf, package_dirs=tuple(dict.fromkeys(dirs)),
                   **{key: path(key, name) for key, name in OPTIONAL_FILES.items()})


def _read_manifest(root: Path) -> dict[str, Any]:
    file = root / MANIFEST
    if not file.is_file():
        return {}
    data = read_yaml_file(file, RobotModelError, f"'{file}'") or {}
    if not isinstance(data, dict):
        raise RobotModelError(f"'{file}' must hold a mapping")
    return data


def _only(root: Path, pattern: str, what: str) -> Path:
    found = sorted(root.glob(pattern))
    if len(found) != 1:
        listed = ", ".join(p.name for p in found) or "none"
        raise RobotModelError(
            f"robot config '{root}' has no {MANIFEST} and needs exactly one {what} file ({pattern}); found: {listed}")
    return found[0]
