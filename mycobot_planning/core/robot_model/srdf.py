"""SRDF parsing: groups, group states, end effectors, virtual joints and disabled collisions.

Written by hand on ElementTree because no SRDF parser is published on PyPI (srdfdom is C++ and
apt-only). Pinocchio reads the disabled pairs itself but nothing else, and we need the groups.
The result is plain data; RobotModel resolves it against the URDF and reports unknown names.
"""
from __future__ import annotations

import logging
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

from ..errors import RobotModelError

_LOG = logging.getLogger(__name__)


@dataclass(frozen=True)
class SrdfChain:
    base_link: str
    tip_link: str


@dataclass
class SrdfGroup:
    name: str
    joints: list[str] = field(default_factory=list)
    links: list[str] = field(default_factory=list)
    chains: list[SrdfChain] = field(default_factory=list)
    subgroups: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class SrdfGroupState:
    name: str
    group: str
    values: dict[str, float]


@dataclass(frozen=True)
class SrdfEndEffector:
    name: str
    parent_link: str
    group: str
    parent_group: str = ""


@dataclass(frozen=True)
class SrdfVirtualJoint:
    name: str
    type: str
    parent_frame: str
    child_link: str


@dataclass
class Srdf:
    robot_name: str
    groups: dict[str, SrdfGroup] = field(default_factory=dict)
    group_states: list[SrdfGroupState] = field(default_factory=list)
    end_effectors: dict[str, SrdfEndEffector] = field(default_factory=dict)
    virtual_joints: list[SrdfVirtualJoint] = field(default_factory=list)
    disabled_collisions: list[tuple[str, str, str]] = field(default_factory=list)


def _attr(element: ET.Element, name: str, where: str) -> str:
    value = element.get(name)
    if value is None or not value.strip():
        raise RobotModelError(f"SRDF: <{element.tag}> in {where} lacks attribute '{name}'")
    return value.strip()


def parse_robot_xml(xml_text: str, kind: str) -> ET.Element:
    """The <robot> root element of a URDF or SRDF document (``kind`` names it in the
    RobotModelError raised for malformed XML or another root)."""
    try:
        root = ET.fromstring(xml_text)
    except ET.ParseError as exc:
        raise RobotModelError(f"{kind} is not well-formed XML: {exc}") from None
    if root.tag != "robot":
        raise RobotModelError(f"{kind} root element must be <robot>, got <{root.tag}>")
    return root


def parse_srdf(xml_text: str) -> Srdf:
    """Parse SRDF text into plain data, raising RobotModelError for malformed documents."""
    root = parse_robot_xml(xml_text, "SRDF")
    srdf = Srdf(robot_name=root.get("name", ""))

    for element in root.findall("group"):
        name = _attr(element, "name", "<robot>")
        if name in srdf.groups:
            raise RobotModelError(f"SRDF: group '{name}' is defined twice")
        group = SrdfGroup(name=name)
        where = f"group '{name}'"
        for child in element:
            if child.tag == "joint":
                group.joints.append(_attr(child, "name", where))
            elif child.tag == "link":
                group.links.append(_attr(child, "name", where))
            elif child.tag == "chain":
                group.chains.append(
                    SrdfChain(_attr(child, "base_link", where), _attr(child, "tip_link", where))
                )
            elif child.tag == "group":
                group.subgroups.append(_attr(child, "name", where))
        srdf.groups[name] = group

    for element in root.findall("group_state"):
        name = _attr(element, "name", "<robot>")
        if not element.get("group", "").strip():
            # Pinocchio-style SRDFs (example-robot-data's z1, kinova) keep reference postures
            # without a group; MoveIt cannot use them as named states, so they are skipped.
            _LOG.warning("SRDF group_state '%s' has no group attribute; skipped", name)
            continue
        group = _attr(element, "group", f"group_state '{name}'")
        values: dict[str, float] = {}
        for joint in element.findall("joint"):
            joint_name = _attr(joint, "name", f"group_state '{name}'")
            raw = _attr(joint, "value", f"group_state '{name}'")
            try:
                value = float(raw.split()[0])
            except (ValueError, IndexError):
                raise RobotModelError(
                    f"SRDF: group_state '{name}' joint '{joint_name}' value '{raw}' is not a number"
                ) from None
            if not math.isfinite(value):
                raise RobotModelError(f"SRDF: group_state '{name}' joint '{joint_name}' is not finite")
            values[joint_name] = value
        srdf.group_states.append(SrdfGroupState(name, group, values))

    for element in root.findall("end_effector"):
        name = _attr(element, "name", "<robot>")
        where = f"end_effector '{name}'"
        srdf.end_effectors[name] = SrdfEndEffector(
            name=name,
            parent_link=_attr(element, "parent_link", where),
            group=_attr(element, "group", where),
            parent_group=element.get("parent_group", "").strip(),
        )

    for element in root.findall("virtual_joint"):
        name = _attr(element, "name", "<robot>")
        where = f"virtual_joint '{name}'"
        srdf.virtual_joints.append(
            SrdfVirtualJoint(
                name=name,
                type=_attr(element, "type", where),
                parent_frame=_attr(element, "parent_frame", where),
                child_link=_attr(element, "child_link", where),
            )
        )

    for element in root.findall("disable_collisions"):
        srdf.disabled_collisions.append(
            (
                _attr(element, "link1", "disable_collisions"),
                _attr(element, "link2", "disable_collisions"),
                element.get("reason", ""),
            )
        )
    return srdf
