"""The setup assistant's one job: URDF (+ optional SRDF) in, robot configuration directory out.

Order matters and mirrors MoveIt Setup Assistant's: the robot first (xacro expanded, an existing
SRDF read forgivingly so its valid parts are kept), then groups, then the self-collision matrix,
then the files. The result is loaded back through RobotModel.from_config before returning, so a
directory this writes is one the library and the nodes load.
"""
from __future__ import annotations

import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

from ..core.collision_detection.collision_matrix import DEFAULT_SAMPLES, CollisionMatrix, Progress, compute_collision_matrix
from ..core.errors import RobotModelError
from ..core.robot_model.robot_config import MANIFEST
from ..core.robot_model.robot_model import RobotModel
from ..core.robot_model.srdf import SrdfChain, SrdfEndEffector, SrdfGroup, SrdfGroupState
from ..paths import package_share_dirs
from . import config_files
from .default_groups import GroupSpec, default_groups
from .robot_description import read_robot_description
from .srdf_writer import write_srdf


@dataclass
class SetupReport:
    """What was written, for the terminal and for tests."""

    directory: Path
    robot_name: str
    groups: list[str]
    end_effectors: list[str]
    matrix: CollisionMatrix
    files: list[Path] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    model: RobotModel | None = None


def build_config(urdf_path: str | Path, out_dir: str | Path, srdf_path: str | Path | None = None,
                 groups: Sequence[GroupSpec] = (), end_effectors: Sequence[SrdfEndEffector] = (),
                 samples: int = DEFAULT_SAMPLES, seed: int = 0, progress: Progress | None = None,
                 xacro_args: dict[str, str] | None = None) -> SetupReport:
    """Write a robot configuration directory for this URDF; RobotModelError/ValueError on bad input
    (nothing half-written: the directory is filled only after everything was computed)."""
    urdf_path = Path(urdf_path).expanduser().resolve()
    urdf_xml = read_robot_description(urdf_path, xacro_args or {})
    package_dirs = [str(p) for p in urdf_path.parents] + [str(p) for p in package_share_dirs()]
    existing = "<robot name=\"\"/>"
    if srdf_path is not None:
        try:
            existing = Path(srdf_path).expanduser().read_text()
        except OSError as exc:
            raise RobotModelError(f"cannot read SRDF file '{srdf_path}': {exc}") from None
    base = RobotModel.from_strings(urdf_xml, existing, package_dirs=package_dirs)
    srdf = base.srdf
    warnings = list(base.load_warnings)
    name = base.name or urdf_path.stem.split(".")[0]

    wanted_groups, wanted_eefs = list(groups), list(end_effectors)
    if not wanted_groups and not srdf.groups:
        wanted_groups, defaults_eefs = default_groups(base)
        wanted_eefs = defaults_eefs + wanted_eefs
    for spec in wanted_groups:
        if spec.name in srdf.groups:
            warnings.append(f"group '{spec.name}' given on the command line replaces the SRDF's")
        srdf.groups[spec.name] = SrdfGroup(
            spec.name, joints=list(spec.joints),
            chains=[SrdfChain(spec.base_link, spec.tip_link)] if spec.tip_link else [])
    for eef in wanted_eefs:
        srdf.end_effectors[eef.name] = eef

    # Check the groups and end effectors strictly now: a typo on the command line is an error,
    # not something to skip. Then add 'home' (zeros clipped to the limits) where a group lacks it.
    draft_xml = write_srdf(srdf, name, {})
    model = RobotModel.from_strings(urdf_xml, draft_xml, package_dirs=package_dirs, strict=True)
    defaults = model.default_positions()
    for group in model.group_names:
        if "home" not in model.named_state_names(group):
            indices = model.group(group).variable_indices
            values = {j: float(v) for j, v in zip(model.group(group).joint_names, defaults[indices])}
            if values:
                srdf.group_states.append(SrdfGroupState("home", group, values))

    matrix = compute_collision_matrix(model, samples=samples, seed=seed, progress=progress)
    disabled: dict[tuple[str, str], str] = {}
    for link1, link2, reason in srdf.disabled_collisions:  # the given SRDF's pairs stay, reasons too
        disabled[tuple(sorted((link1, link2)))] = reason or "User"
    for pair, reason in matrix.disabled.items():
        disabled.setdefault(pair, reason)
    srdf_xml = write_srdf(srdf, name, disabled)
    final = RobotModel.from_strings(urdf_xml, srdf_xml, package_dirs=package_dirs, strict=True)

    out = Path(out_dir).expanduser()
    out.mkdir(parents=True, exist_ok=True)
    files = {
        f"{name}.urdf": urdf_xml,
        f"{name}.srdf": srdf_xml,
        "joint_limits.yaml": config_files.joint_limits_yaml(final),
        "kinematics.yaml": config_files.kinematics_yaml(final),
        "ompl_planning.yaml": config_files.ompl_planning_yaml(final),
        "moveit_controllers.yaml": config_files.moveit_controllers_yaml(final),
        "ros2_controllers.yaml": config_files.ros2_controllers_yaml(final),
        MANIFEST: config_files.manifest_yaml(name, urdf_path, [str(p) for p in urdf_path.parents]),
    }
    written = []
    for file_name, text in files.items():
        path = out / file_name
        tmp = path.with_name(path.name + ".tmp")
        tmp.write_text(text)
        shutil.move(str(tmp), str(path))
        written.append(path)
    loaded = RobotModel.from_config(out, strict=True)
    return SetupReport(out, name, loaded.group_names, list(loaded.end_effectors), matrix, written, warnings, loaded)
