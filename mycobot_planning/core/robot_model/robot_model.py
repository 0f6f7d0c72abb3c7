"""RobotModel: one robot, from any URDF + SRDF, as Pinocchio and Coal see it plus MoveIt's semantics.

Pinocchio owns kinematics (mimic joints included) and Coal owns the collision shapes; this class
adds what MoveIt users expect on top: planning groups, named states, end effectors, the SRDF's
disabled collision pairs, and joint limits overridden by joint_limits.yaml. It is immutable after
construction (attributes cannot be reassigned, its arrays are read-only) and holds no scratch
data: every thread may share one instance, and the Pinocchio data a computation writes belongs to
the computation (see thread_data.py and docs/core.md, "The model shared, the data per computation").
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, TypeVar

import numpy as np
import pinocchio as pin

from ...paths import config_file, example_robot_data_dir, package_share_dirs, read_yaml_file
from ..errors import RobotModelError
from .robot_config import RobotConfig
from .srdf import Srdf, parse_robot_xml, parse_srdf
from .srdf_check import UrdfTree, drop_unknown_names

_T = TypeVar("_T")

_LOG = logging.getLogger(__name__)

_MISSING = object()

#: Acceleration assumed where neither the URDF nor joint_limits.yaml gives one (MoveIt's default).
DEFAULT_MAX_ACCELERATION = 1.0


@dataclass(frozen=True)
class MimicInfo:
    joint: str
    multiplier: float
    offset: float


@dataclass(frozen=True)
class JointInfo:
    """Joint facts from the URDF, limits possibly overridden by joint_limits.yaml."""

    name: str
    type: str  # revolute, continuous, prismatic, fixed, floating, planar
    parent_link: str
    child_link: str
    lower: float
    upper: float
    max_velocity: float
    max_acceleration: float
    max_jerk: float | None
    has_acceleration_limits: bool
    mimic: MimicInfo | None = None

    @property
    def is_active(self) -> bool:
        """A joint with its own variable: moving and not mimicking another."""
        return self.type in ("revolute", "continuous", "prismatic") and self.mimic is None


@dataclass(frozen=True)
class EndEffector:
    name: str
    parent_link: str
    group: str
    parent_group: str


@dataclass(frozen=True)
class JointModelGroup:
    """A planning group: the variables it moves and the links that belong to it."""

    name: str
    joint_names: tuple[str, ...]  # active variables, in model order
    variable_indices: np.ndarray  # indices into RobotModel.variable_names
    all_joint_names: tuple[str, ...]  # including fixed and mimic joints of the group
    link_names: tuple[str, ...]  # child links of the group's joints (MoveIt's link models)
    updated_link_names: tuple[str, ...]  # every link whose pose the group's variables move
    base_link: str
    tip_link: str
    subgroups: tuple[str, ...] = ()
    end_effector: str | None = None

    @property
    def variable_count(self) -> int:
        return len(self.joint_names)


@dataclass
class _UrdfInfo:
    name: str
    links: list[str] = field(default_factory=list)
    joints: dict[str, dict[str, Any]] = field(default_factory=dict)


def _parse_urdf_info(urdf_xml: str) -> _UrdfInfo:
    """The URDF facts Pinocchio does not expose in Python: mimic parameters, link tree, limits."""
    root = parse_robot_xml(urdf_xml, "URDF")
    info = _UrdfInfo(name=root.get("name", ""))
    info.links = [link.get("name", "") for link in root.findall("link")]
    if not info.links or any(not name for name in info.links):
        raise RobotModelError("URDF has no links, or a <link> without a name")
    for joint in root.findall("joint"):
        name = joint.get("name")
        jtype = joint.get("type")
        parent = joint.find("parent")
        child = joint.find("child")
        if not name or not jtype or parent is None or child is None:
            raise RobotModelError(f"URDF joint '{name}' lacks a name, type, parent or child")
        entry: dict[str, Any] = {
            "type": jtype,
            "parent": parent.get("link", ""),
            "child": child.get("link", ""),
            "lower": None,
            "upper": None,
            "velocity": None,
            "mimic": None,
        }
        limit = joint.find("limit")
        if limit is not None:
            for key in ("lower", "upper", "velocity"):
                if limit.get(key) is not None:
                    try:
                        entry[key] = float(limit.get(key))
                    except ValueError:
                        raise RobotModelError(
                            f"URDF joint '{name}': limit {key}='{limit.get(key)}' is not a number"
                        ) from None
        mimic = joint.find("mimic")
        if mimic is not None:
            entry["mimic"] = MimicInfo(
                joint=mimic.get("joint", ""),
                multiplier=float(mimic.get("multiplier", "1.0")),
                offset=float(mimic.get("offset", "0.0")),
            )
        info.joints[name] = entry
    return info


def _load_yaml(source: str | Path | Mapping | None, what: str) -> dict:
    if source is None:
        return {}
    if isinstance(source, Mapping):
        return dict(source)
    data = read_yaml_file(source, RobotModelError, f"{what} '{source}'")
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise RobotModelError(f"{what} '{source}' must hold a mapping at the top level")
    return data


def _lookup(table: Mapping[str, _T], name: str, unknown: Callable[[], str]) -> _T:
    """``table[name]``, or a RobotModelError with the message ``unknown()`` (built only then)."""
    try:
        return table[name]
    except KeyError:
        raise RobotModelError(unknown()) from None


class RobotModel:
    """Kinematic, collision and semantic model of one robot. Build with from_files/from_strings."""

    def __init__(
        self,
        urdf_xml: str,
        srdf_xml: str,
        joint_limits: Mapping | None = None,
        kinematics: Mapping | None = None,
        package_dirs: Iterable[str | Path] = (),
        strict: bool = False,
    ) -> None:
        self.urdf_xml = urdf_xml
        self.srdf_xml = srdf_xml
        urdf = _parse_urdf_info(urdf_xml)
        self.srdf: Srdf = parse_srdf(srdf_xml)
        #: What the forgiving loader skipped, one sentence each (also logged as warnings).
        self.load_warnings: list[str] = []
        self._strict = strict
        if not strict:
            tree = UrdfTree.build(urdf.links, {j: (e["parent"], e["child"]) for j, e in urdf.joints.items()})
            self.srdf, self.load_warnings = drop_unknown_names(self.srdf, tree)
            self._drop_unknown_mimics(urdf)
        self.name = urdf.name or self.srdf.robot_name
        try:
            # mimic=False: Pinocchio 4.1 adds a link's child joints in name order and refuses a
            # mimic joint added before its source (the myCobot's finger names do exactly that), so
            # we keep mimic joints as ordinary joints and fill them from their source in to_q().
            self.pin_model: pin.Model = pin.buildModelFromXML(urdf_xml, mimic=False)
        except (ValueError, RuntimeError) as exc:
            raise RobotModelError(f"Pinocchio cannot build the URDF model: {exc}") from None
        dirs = [str(p) for p in package_dirs]
        try:
            self.pin_collision_model: pin.GeometryModel = pin.buildGeomFromUrdfString(
                self.pin_model, urdf_xml, pin.GeometryType.COLLISION, package_dirs=dirs
            )
        except (ValueError, RuntimeError, OSError) as exc:
            raise RobotModelError(f"cannot load the URDF collision geometry: {exc}") from None
        for geom in self.pin_collision_model.geometryObjects:
            geom.geometry.computeLocalAABB()  # the broad phase needs them; computed now, never later
        self._kinematics_config = dict(kinematics or {})
        self._cache: dict[Any, Any] = {}
        self._build_joints(urdf, dict(joint_limits or {}))
        self._build_links(urdf)
        self._build_groups()
        self._build_named_states()
        self._build_disabled_pairs()
        self._freeze()

    def _freeze(self) -> None:
        """Refuse later changes: arrays read-only, attributes no longer assignable."""
        for value in self.__dict__.values():
            if isinstance(value, np.ndarray):
                value.flags.writeable = False
        for group in self._groups.values():
            group.variable_indices.flags.writeable = False
        object.__setattr__(self, "_frozen", True)

    def __setattr__(self, name: str, value: Any) -> None:
        if getattr(self, "_frozen", False):
            raise AttributeError(f"RobotModel '{self.name}' is immutable: cannot set '{name}' (build another model)")
        object.__setattr__(self, name, value)

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"RobotModel '{self.name}' is immutable: cannot delete '{name}'")

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_strings(
        cls,
        urdf_xml: str,
        srdf_xml: str,
        joint_limits: Mapping | None = None,
        kinematics: Mapping | None = None,
        package_dirs: Iterable[str | Path] = (),
        strict: bool = False,
    ) -> "RobotModel":
        """Build from URDF and SRDF text (e.g. the robot_description parameters).

        By default the SRDF is read as MoveIt reads it: groups, states, end effectors and
        disabled pairs naming links or joints the URDF lacks are skipped with a warning each
        (`load_warnings`); `strict=True` refuses the whole model instead."""
        return cls(urdf_xml, srdf_xml, joint_limits, kinematics, package_dirs, strict)

    @classmethod
    def from_files(
        cls,
        urdf_path: str | Path,
        srdf_path: str | Path,
        joint_limits_path: str | Path | None = None,
        kinematics_path: str | Path | None = None,
        package_dirs: Iterable[str | Path] | None = None,
        strict: bool = False,
    ) -> "RobotModel":
        """Build from files; package:// meshes resolve against the URDF's ancestor folders.
        `strict` as in from_strings."""
        texts = []
        for path, what in ((urdf_path, "URDF"), (srdf_path, "SRDF")):
            try:
                texts.append(Path(path).read_text())
            except OSError as exc:
                raise RobotModelError(f"cannot read {what} file '{path}': {exc}") from None
        if package_dirs is None:
            package_dirs = [str(p) for p in Path(urdf_path).resolve().parents]
        return cls(
            texts[0],
            texts[1],
            _load_yaml(joint_limits_path, "joint limits file"),
            _load_yaml(kinematics_path, "kinematics file"),
            package_dirs,
            strict,
        )

    @classmethod
    def from_config(cls, directory: str | Path, strict: bool = False) -> "RobotModel":
        """Build from a robot configuration directory: the setup assistant's output, or a folder
        with one URDF and one SRDF (see core/robot_model/robot_config.py for the files it reads)."""
        config = RobotConfig.load(directory)
        dirs = [*config.package_dirs, *(str(p) for p in package_share_dirs())]
        return cls.from_files(config.urdf, config.srdf, config.joint_limits, config.kinematics,
                              package_dirs=dirs, strict=strict)

    @classmethod
    def mycobot(cls) -> "RobotModel":
        """The myCobot 280 with the package's own config/ files."""
        return cls.from_files(
            config_file("mycobot_280.urdf"),
            config_file("mycobot_280.srdf"),
            config_file("joint_limits.yaml"),
            config_file("kinematics.yaml"),
        )

    @classmethod
    def panda(cls) -> "RobotModel":
        """The Franka Panda with its hand, named as MoveIt's panda_moveit_config names it (groups
        panda_arm, hand, panda_arm_hand; end effector hand): example-robot-data's URDF and
        meshes with the package's config/panda/ files. MTC's demo scripts run on it."""
        robots = example_robot_data_dir()
        return cls.from_files(
            robots / "panda_description" / "urdf" / "panda.urdf",
            config_file("panda/panda.srdf"),
            config_file("panda/joint_limits.yaml"),
            config_file("panda/kinematics.yaml"),
            package_dirs=[str(robots.parent.parent)],
        )

    def _drop_unknown_mimics(self, urdf: _UrdfInfo) -> None:
        """A mimic tag naming a joint the URDF lacks leaves its joint independent (as Pinocchio,
        which reads the URDF without mimics here, already has it), with a warning."""
        for name, entry in urdf.joints.items():
            mimic = entry["mimic"]
            if mimic is not None and mimic.joint not in urdf.joints:
                entry["mimic"] = None
                message = f"URDF joint '{name}' mimics unknown joint '{mimic.joint}': it moves on its own"
                self.load_warnings.append(message)
                _LOG.warning(message)

    def _build_joints(self, urdf: _UrdfInfo, joint_limits: dict) -> None:
        limits_cfg = joint_limits.get("joint_limits", {}) or {}
        if not isinstance(limits_cfg, dict):
            raise RobotModelError("joint_limits.yaml: 'joint_limits' must be a mapping of joints")
        unknown = sorted(set(limits_cfg) - set(urdf.joints))
        if unknown:
            raise RobotModelError(f"joint_limits.yaml names unknown joints: {unknown}")
        self.default_velocity_scaling_factor = float(joint_limits.get("default_velocity_scaling_factor", 1.0))
        self.default_acceleration_scaling_factor = float(
            joint_limits.get("default_acceleration_scaling_factor", 1.0)
        )
        model = self.pin_model
        self._joints: dict[str, JointInfo] = {}
        for name, entry in urdf.joints.items():
            cfg = limits_cfg.get(name, {}) or {}
            lower = entry["lower"] if entry["lower"] is not None else -math.inf
            upper = entry["upper"] if entry["upper"] is not None else math.inf
            if entry["type"] == "continuous":
                lower, upper = -math.pi, math.pi
            if cfg.get("has_position_limits", False):
                lower = float(cfg.get("min_position", lower))
                upper = float(cfg.get("max_position", upper))
            velocity = entry["velocity"] if entry["velocity"] else math.inf
            if cfg.get("has_velocity_limits", False):
                velocity = float(cfg["max_velocity"])
            has_acc = bool(cfg.get("has_acceleration_limits", False))
            acceleration = float(cfg["max_acceleration"]) if has_acc else DEFAULT_MAX_ACCELERATION
            jerk = float(cfg["max_jerk"]) if cfg.get("has_jerk_limits", False) else None
            mimic = entry["mimic"]
            if mimic is not None and mimic.joint not in urdf.joints:
                raise RobotModelError(f"URDF joint '{name}' mimics unknown joint '{mimic.joint}'")
            if lower > upper:
                raise RobotModelError(f"joint '{name}': lower limit {lower} above upper limit {upper}")
            if not velocity > 0 or not acceleration > 0:
                raise RobotModelError(f"joint '{name}': velocity and acceleration limits must be > 0")
            self._joints[name] = JointInfo(
                name=name,
                type=entry["type"],
                parent_link=entry["parent"],
                child_link=entry["child"],
                lower=lower,
                upper=upper,
                max_velocity=velocity,
                max_acceleration=acceleration,
                max_jerk=jerk,
                has_acceleration_limits=has_acc,
                mimic=mimic,
            )
        # Active variables in Pinocchio's joint order; mimic joints are derived from their source.
        self.variable_names: list[str] = []
        q_index: list[int] = []
        v_index: list[int] = []
        continuous: list[bool] = []
        mimic_joints: list[tuple[str, int, int]] = []
        for jid in range(1, model.njoints):
            jname = model.names[jid]
            jmodel = model.joints[jid]
            info = self._joints.get(jname)
            if info is None:
                raise RobotModelError(f"Pinocchio joint '{jname}' not found in the URDF")
            if jmodel.nv != 1:
                raise RobotModelError(
                    f"joint '{jname}' ({info.type}) has {jmodel.nv} degrees of freedom; "
                    "only single-variable joints are supported"
                )
            if info.mimic is not None:
                if jmodel.nq != 1:
                    raise RobotModelError(f"mimic joint '{jname}' must be revolute or prismatic")
                mimic_joints.append((jname, jmodel.idx_q, jmodel.idx_v))
                continue
            self.variable_names.append(jname)
            q_index.append(jmodel.idx_q)
            v_index.append(jmodel.idx_v)
            continuous.append(jmodel.nq == 2)
        self._variable_index = {name: i for i, name in enumerate(self.variable_names)}
        self.lower_limits = np.array([self._joints[n].lower for n in self.variable_names])
        self.upper_limits = np.array([self._joints[n].upper for n in self.variable_names])
        self.velocity_limits = np.array([self._joints[n].max_velocity for n in self.variable_names])
        self.acceleration_limits = np.array([self._joints[n].max_acceleration for n in self.variable_names])
        jerks = [self._joints[n].max_jerk for n in self.variable_names]
        self.jerk_limits = None if any(j is None for j in jerks) else np.array(jerks, dtype=float)
        # Mimic chains resolved to (source variable, multiplier, offset) once, for vectorised to_q.
        sources, multipliers, offsets = [], [], []
        for jname, _, _ in mimic_joints:
            src, mult, off = self._resolve_mimic(jname)
            sources.append(self._variable_index[src])
            multipliers.append(mult)
            offsets.append(off)
        self._mimic_names = [m[0] for m in mimic_joints]
        self._mimic_q = np.array([m[1] for m in mimic_joints], dtype=int)
        self._mimic_src = np.array(sources, dtype=int)
        self._mimic_mult = np.array(multipliers, dtype=float)
        self._mimic_off = np.array(offsets, dtype=float)
        self._q_index = np.array(q_index, dtype=int)
        self._continuous_mask = np.array(continuous, dtype=bool)
        self._has_continuous = bool(self._continuous_mask.any())
        self._identity_q = (
            not self._has_continuous
            and not mimic_joints
            and model.nq == len(self.variable_names)
            and list(q_index) == list(range(len(self.variable_names)))
        )
        self._q_template = pin.neutral(model)
        # Jacobian columns per variable: its own column plus multiplier x each mimic follower's.
        self._var_to_v = np.zeros((model.nv, len(self.variable_names)))
        self._var_to_v[v_index, np.arange(len(self.variable_names))] = 1.0
        for (_, _, v_idx), src, mult in zip(mimic_joints, sources, multipliers):
            self._var_to_v[v_idx, src] += mult

    def _resolve_mimic(self, joint: str) -> tuple[str, float, float]:
        """Follow a mimic chain down to an active joint: value = multiplier * source + offset."""
        mult, off, seen = 1.0, 0.0, set()
        while self._joints[joint].mimic is not None:
            if joint in seen:
                raise RobotModelError(f"URDF mimic joints form a cycle through '{joint}'")
            seen.add(joint)
            mimic = self._joints[joint].mimic
            # value = mult * value(joint) + off and value(joint) = m * value(src) + o
            off, mult = off + mult * mimic.offset, mult * mimic.multiplier
            joint = mimic.joint
        if self._joints[joint].type not in ("revolute", "prismatic", "continuous"):
            raise RobotModelError(f"mimic source joint '{joint}' is not a moving joint")
        return joint, mult, off

    def _build_links(self, urdf: _UrdfInfo) -> None:
        self.link_names: list[str] = list(urdf.links)
        self._parent_joint: dict[str, str] = {}
        self._child_joints: dict[str, list[str]] = {name: [] for name in urdf.links}
        for jname, info in self._joints.items():
            for link in (info.parent_link, info.child_link):
                if link not in self._child_joints:
                    raise RobotModelError(f"URDF joint '{jname}' refers to unknown link '{link}'")
            self._parent_joint[info.child_link] = jname
            self._child_joints[info.parent_link].append(jname)
        roots = [link for link in urdf.links if link not in self._parent_joint]
        if len(roots) != 1:
            raise RobotModelError(f"URDF must form one tree with a single root link, roots: {roots}")
        self.root_link = roots[0]
        self._link_geometries: dict[str, list[int]] = {name: [] for name in self.link_names}
        for index, geom in enumerate(self.pin_collision_model.geometryObjects):
            link = self.pin_model.frames[geom.parentFrame].name
            self._link_geometries.setdefault(link, []).append(index)

    def _descendant_links(self, link: str) -> list[str]:
        out, stack = [], [link]
        while stack:
            current = stack.pop()
            out.append(current)
            stack.extend(self._joints[j].child_link for j in self._child_joints.get(current, []))
        return out

    def _chain_joints(self, base: str, tip: str, group: str) -> list[str]:
        for link in (base, tip):
            if link not in self._child_joints:
                raise RobotModelError(f"SRDF group '{group}': chain link '{link}' is not in the URDF")
        joints, link = [], tip
        while link != base:
            if link not in self._parent_joint:
                raise RobotModelError(f"SRDF group '{group}': '{tip}' is not below '{base}'")
            joint = self._parent_joint[link]
            joints.append(joint)
            link = self._joints[joint].parent_link
        return list(reversed(joints))

    def _group_joint_names(self, name: str, seen: tuple[str, ...] = ()) -> list[str]:
        if name in seen:
            raise RobotModelError(f"SRDF group '{name}' contains itself through subgroups")
        if name not in self.srdf.groups:
            raise RobotModelError(f"SRDF names unknown group '{name}'")
        group = self.srdf.groups[name]
        joints: list[str] = []
        for joint in group.joints:
            if joint not in self._joints:
                if any(vj.name == joint for vj in self.srdf.virtual_joints):
                    continue  # the virtual joint is fixed here; it moves nothing
                raise RobotModelError(f"SRDF group '{name}' names unknown joint '{joint}'")
            joints.append(joint)
        for link in group.links:
            if link not in self._child_joints:
                raise RobotModelError(f"SRDF group '{name}' names unknown link '{link}'")
            if link in self._parent_joint:
                joints.append(self._parent_joint[link])
        for chain in group.chains:
            joints.extend(self._chain_joints(chain.base_link, chain.tip_link, name))
        for sub in group.subgroups:
            joints.extend(self._group_joint_names(sub, seen + (name,)))
        return list(dict.fromkeys(joints))

    def _build_groups(self) -> None:
        self._end_effectors: dict[str, EndEffector] = {}
        self._groups: dict[str, JointModelGroup] = {}
        group_joints = {name: self._group_joint_names(name) for name in self.srdf.groups}
        for eef in self.srdf.end_effectors.values():
            if eef.group not in self.srdf.groups or eef.parent_link not in self._child_joints:
                if self._strict:
                    raise RobotModelError(
                        f"SRDF end effector '{eef.name}': group '{eef.group}' or parent link '{eef.parent_link}' "
                        "is unknown")
                _LOG.warning(
                    "SRDF end effector '%s' skipped: group '%s' or parent link '%s' unknown",
                    eef.name, eef.group, eef.parent_link,
                )
                continue
            parent_group = eef.parent_group
            if parent_group and parent_group not in self.srdf.groups:
                raise RobotModelError(f"SRDF end effector '{eef.name}' names unknown parent group '{parent_group}'")
            self._end_effectors[eef.name] = EndEffector(eef.name, eef.parent_link, eef.group, parent_group)
        for name, joints in group_joints.items():
            # Mimic followers move with their source, so they belong to the group too.
            followers = [
                j for j, info in self._joints.items() if info.mimic is not None and info.mimic.joint in joints
            ]
            all_joints = list(dict.fromkeys(joints + followers))
            active = [j for j in self.variable_names if j in all_joints]
            links = [self._joints[j].child_link for j in all_joints]
            updated: list[str] = []
            for joint in all_joints:
                if self._joints[joint].type != "fixed":
                    updated.extend(self._descendant_links(self._joints[joint].child_link))
            updated = list(dict.fromkeys(updated))
            eef_name = None
            tip = None
            # MoveIt's rule: an end effector hangs off the group named as its parent group; without
            # one, off the group it names itself (Panda's SRDF) or the group holding its parent link.
            candidates = [e for e in self._end_effectors.values() if e.parent_group == name]
            candidates += [e for e in self._end_effectors.values() if not e.parent_group and e.group == name]
            candidates += [
                e for e in self._end_effectors.values() if not e.parent_group and e.parent_link in links
            ]
            if candidates:
                eef_name, tip = candidates[0].name, candidates[0].parent_link
            srdf_group = self.srdf.groups[name]
            if tip is None and srdf_group.chains:
                tip = srdf_group.chains[-1].tip_link
            if tip is None:
                tip = self._default_tip(active, links)
            base = self._default_base(active, links)
            if srdf_group.chains:
                base = srdf_group.chains[0].base_link
            self._groups[name] = JointModelGroup(
                name=name,
                joint_names=tuple(active),
                variable_indices=np.array([self._variable_index[j] for j in active], dtype=int),
                all_joint_names=tuple(all_joints),
                link_names=tuple(links),
                updated_link_names=tuple(updated),
                base_link=base,
                tip_link=tip,
                subgroups=tuple(srdf_group.subgroups),
                end_effector=eef_name,
            )

    def _default_tip(self, active: list[str], links: list[str]) -> str:
        """Deepest link of the group's serial chain, following fixed joints inside the group."""
        if not active:
            return links[-1] if links else self.root_link
        link = self._joints[active[-1]].child_link
        while True:
            fixed_children = [
                j for j in self._child_joints.get(link, []) if self._joints[j].type == "fixed"
                and self._joints[j].child_link in links
            ]
            if len(fixed_children) != 1:
                return link
            link = self._joints[fixed_children[0]].child_link

    def _default_base(self, active: list[str], links: list[str]) -> str:
        if not active:
            return self.root_link
        return self._joints[active[0]].parent_link

    def _build_named_states(self) -> None:
        self._named_states: dict[str, dict[str, dict[str, float]]] = {}
        # A planar or floating virtual joint's values (a legged robot's base pose in 'standing') are
        # dropped: the model holds the base where the virtual joint's parent frame is.
        virtual = {vj.name for vj in self.srdf.virtual_joints}
        for state in self.srdf.group_states:
            if state.group not in self._groups:
                raise RobotModelError(f"SRDF group_state '{state.name}' names unknown group '{state.group}'")
            values = {}
            for joint, value in state.values.items():
                if joint in virtual:
                    continue
                if joint not in self._joints:
                    raise RobotModelError(
                        f"SRDF group_state '{state.name}' of group '{state.group}' names unknown joint '{joint}'"
                    )
                values[joint] = value
            self._named_states.setdefault(state.group, {})[state.name] = values

    def _build_disabled_pairs(self) -> None:
        pairs: set[frozenset[str]] = set()
        for link1, link2, _reason in self.srdf.disabled_collisions:
            for link in (link1, link2):
                if link not in self._child_joints:
                    raise RobotModelError(f"SRDF disable_collisions names unknown link '{link}'")
            pairs.add(frozenset((link1, link2)))
        self.disabled_collision_pairs: frozenset[frozenset[str]] = frozenset(pairs)

    # ------------------------------------------------------------------ queries
    def joint(self, name: str) -> JointInfo:
        return _lookup(self._joints, name, lambda: f"unknown joint '{name}' in robot '{self.name}'")

    @property
    def joint_names(self) -> list[str]:
        return list(self._joints)

    @property
    def mimic_joint_names(self) -> list[str]:
        return list(self._mimic_names)

    def variable_index(self, name: str) -> int:
        return _lookup(self._variable_index, name,
                       lambda: f"'{name}' is not an active joint of robot '{self.name}'; active: {self.variable_names}")

    def has_link(self, name: str) -> bool:
        return name in self._child_joints

    def frame_id(self, name: str) -> int:
        """Pinocchio frame id of a link (its body frame); 'world' is the model root when not a link.

        Link and joint names are separate namespaces in URDF and MoveIt (the SO-100 has a link
        and a joint both named 'gripper'), so a link is looked up among body frames only."""
        if self.pin_model.existFrame(name, pin.FrameType.BODY):
            return self.pin_model.getFrameId(name, pin.FrameType.BODY)
        if name == "world" or any(vj.parent_frame == name for vj in self.srdf.virtual_joints):
            return 0
        raise RobotModelError(f"unknown link or frame '{name}' in robot '{self.name}'")

    def parent_joint(self, link: str) -> str | None:
        return self._parent_joint.get(link)

    def link_collision_geometry(self, link: str) -> list[tuple[Any, np.ndarray]]:
        """Coal shapes of a link with their poses in the link frame."""
        if link not in self._link_geometries:
            raise RobotModelError(f"unknown link '{link}' in robot '{self.name}'")
        out = []
        model = self.pin_collision_model
        for index in self._link_geometries[link]:
            geom = model.geometryObjects[index]
            frame = self.pin_model.frames[geom.parentFrame]
            # geom.placement is relative to the parent joint; express it in the link's frame.
            out.append((geom.geometry, (frame.placement.inverse() * geom.placement).homogeneous))
        return out

    def link_geometry_indices(self, link: str) -> list[int]:
        return list(self._link_geometries.get(link, []))

    def links_with_collision_geometry(self) -> list[str]:
        return [link for link, idx in self._link_geometries.items() if idx]

    @property
    def group_names(self) -> list[str]:
        return list(self._groups)

    def group(self, name: str) -> JointModelGroup:
        return _lookup(self._groups, name,
                       lambda: f"unknown planning group '{name}'; known groups: {', '.join(self._groups) or 'none'}")

    def has_group(self, name: str) -> bool:
        return name in self._groups

    def named_state_names(self, group: str | None = None) -> list[str]:
        if group is None:
            return sorted({n for states in self._named_states.values() for n in states})
        self.group(group)
        return list(self._named_states.get(group, {}))

    def named_state(self, name: str, group: str | None = None) -> dict[str, float]:
        """Joint values of a named state (SRDF group_state). Without a group, any group's state."""
        if group is not None:
            self.group(group)
            states = self._named_states.get(group, {})
            if name not in states:
                raise RobotModelError(
                    f"unknown named state '{name}' for group '{group}'; known: {', '.join(states) or 'none'}"
                )
            return dict(states[name])
        for states in self._named_states.values():
            if name in states:
                return dict(states[name])
        raise RobotModelError(f"unknown named state '{name}'; known: {', '.join(self.named_state_names())}")

    @property
    def end_effectors(self) -> dict[str, EndEffector]:
        return dict(self._end_effectors)

    def end_effector(self, name: str) -> EndEffector:
        return _lookup(self._end_effectors, name,
                       lambda: f"unknown end effector '{name}'; known: {', '.join(self._end_effectors) or 'none'}")

    def kinematics(self, group: str) -> dict[str, Any]:
        """kinematics.yaml settings of a group, with MoveIt's defaults filled in."""
        self.group(group)
        cfg = {
            "kinematics_solver_search_resolution": 0.005,
            "kinematics_solver_timeout": 0.05,
            "kinematics_solver_attempts": 3,
            "position_only_ik": False,
        }
        cfg.update(self._kinematics_config.get(group, {}) or {})
        return cfg

    def cached(self, key: Any, factory: Callable[[], Any]) -> Any:
        """Memoise derived data (IK seed tables, compiled collision models) on the model.

        The model never changes after construction, so anything derived from it alone can be
        computed once and shared by every solver and scene built on it. The value must not be
        changed by its users (make its arrays read-only). Thread-safe: two threads asking at once
        may both compute it (the factory is deterministic), and both get the first one stored.
        """
        value = self._cache.get(key, _MISSING)
        if value is _MISSING:
            value = self._cache.setdefault(key, factory())  # atomic: the first value stored wins
        return value

    def default_positions(self) -> np.ndarray:
        """All zeros, clipped into the limits (MoveIt's default state)."""
        return np.clip(np.zeros(len(self.variable_names)), self.lower_limits, self.upper_limits)

    # ------------------------------------------------------------------ configuration mapping
    def to_q(self, positions: np.ndarray) -> np.ndarray:
        """Variable vector → Pinocchio configuration (mimic joints filled, continuous as cos/sin)."""
        if self._identity_q:
            return positions
        q = self._q_template.copy()
        if self._has_continuous:
            mask = self._continuous_mask
            idx = self._q_index
            q[idx[~mask]] = positions[~mask]
            q[idx[mask]] = np.cos(positions[mask])
            q[idx[mask] + 1] = np.sin(positions[mask])
        else:
            q[self._q_index] = positions
        if self._mimic_q.size:
            q[self._mimic_q] = self._mimic_mult * positions[self._mimic_src] + self._mimic_off
        return q

    def q_slots(self, variable_indices: np.ndarray) -> np.ndarray | None:
        """Configuration slots of these variables when writing them there is all to_q does for
        them (no continuous joint, no mimic follower), else None.

        Solvers that change only a group's variables in a loop then update a configuration
        vector in place instead of rebuilding it with to_q on every iteration.
        """
        indices = np.asarray(variable_indices, dtype=int)
        # memoised: scenes ask it for the same groups several times per plan (np.isin ~15 us)
        slots = self.cached(("q_slots", indices.tobytes()), lambda: self._q_slots(indices))
        return None if slots is None else slots.copy()

    def _q_slots(self, indices: np.ndarray) -> np.ndarray | None:
        if self._has_continuous and bool(self._continuous_mask[indices].any()):
            return None
        if self._mimic_src.size and bool(np.isin(indices, self._mimic_src).any()):
            return None
        slots = self._q_index[indices].copy()
        slots.setflags(write=False)
        return slots

    def jacobian_columns(self, variable_indices: np.ndarray) -> slice | np.ndarray | None:
        """The velocity columns the Jacobian map merely picks for these variables (each one
        column with factor 1): a slice when they are consecutive, else an index array; None
        when a variable combines columns (it drives mimic followers). Picking columns is
        cheaper than the product with the map in hot loops, and slicing cheaper still."""
        jmap = self.jacobian_map(np.asarray(variable_indices, dtype=int))
        ones = (jmap == 1.0).sum(axis=0) == 1
        zeros = (jmap == 0.0).sum(axis=0) == jmap.shape[0] - 1
        if not bool(np.all(ones & zeros)):
            return None
        columns = np.argmax(jmap, axis=0)
        if columns.size and np.array_equal(columns, np.arange(columns[0], columns[0] + columns.size)):
            return slice(int(columns[0]), int(columns[0]) + columns.size)
        return columns

    def jacobian_map(self, variable_indices: np.ndarray | None = None) -> np.ndarray:
        """Matrix taking Pinocchio velocity space to the given variables (nv x k): J_vars = J @ M.

        Mimic followers contribute multiplier times their column to their source variable.
        """
        if variable_indices is None:
            return self._var_to_v
        return self._var_to_v[:, variable_indices]

    def mimic_values(self, positions: np.ndarray) -> dict[str, float]:
        """Values of the mimic joints implied by the active variables."""
        values = self._mimic_mult * np.asarray(positions)[self._mimic_src] + self._mimic_off
        return {name: float(v) for name, v in zip(self._mimic_names, values)}

    def __repr__(self) -> str:
        return (
            f"RobotModel('{self.name}', {len(self.variable_names)} variables, "
            f"groups={self.group_names}, links={len(self.link_names)})"
        )


def group_configuration(model: RobotModel, x: np.ndarray, slots: np.ndarray | None, q: np.ndarray,
                        full: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """The Pinocchio configuration with the group values ``x`` (at ``idx`` of the positions):
    written into the buffer ``q`` at ``slots`` when the model gives them (RobotModel.q_slots),
    else through the positions buffer ``full`` and RobotModel.to_q. Solvers that move only a
    group's variables in a loop (IK-based Cartesian steps, CHOMP, constraint projection) build
    their configurations with it."""
    if slots is not None:
        q[slots] = x
        return q
    full[idx] = x
    return model.to_q(full)
