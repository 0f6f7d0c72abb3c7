"""SRDF text from the parsed form (core.robot_model.srdf.Srdf): the inverse of parse_srdf, in MoveIt's layout."""
from __future__ import annotations

import xml.etree.ElementTree as ET

from ..core.robot_model.srdf import Srdf

HEADER = ("<!-- Written by mycobot_planning's setup assistant (python -m mycobot_planning.setup_assistant). "
          "Collision pairs are disabled as MoveIt Setup Assistant disables them: Adjacent, Default, "
          "Always or Never (by sampling), or as the given SRDF had them. -->\n")


def _format_value(value: float) -> str:
    return repr(float(value))


def write_srdf(srdf: Srdf, robot_name: str, disabled: dict[tuple[str, str], str]) -> str:
    root = ET.Element("robot", name=robot_name)
    for group in srdf.groups.values():
        element = ET.SubElement(root, "group", name=group.name)
        for link in group.links:
            ET.SubElement(element, "link", name=link)
        for joint in group.joints:
            ET.SubElement(element, "joint", name=joint)
        for chain in group.chains:
            ET.SubElement(element, "chain", base_link=chain.base_link, tip_link=chain.tip_link)
        for sub in group.subgroups:
            ET.SubElement(element, "group", name=sub)
    for state in srdf.group_states:
        element = ET.SubElement(root, "group_state", name=state.name, group=state.group)
        for joint, value in state.values.items():
            ET.SubElement(element, "joint", name=joint, value=_format_value(value))
    for eef in srdf.end_effectors.values():
        attributes = {"name": eef.name, "parent_link": eef.parent_link, "group": eef.group}
        if eef.parent_group:
            attributes["parent_group"] = eef.parent_group
        ET.SubElement(root, "end_effector", attributes)
    for vj in srdf.virtual_joints:
        ET.SubElement(root, "virtual_joint", name=vj.name, type=vj.type, parent_frame=vj.parent_frame,
                      child_link=vj.child_link)
    for (link1, link2), reason in disabled.items():
        ET.SubElement(root, "disable_collisions", link1=link1, link2=link2, reason=reason)
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + HEADER + ET.tostring(root, encoding="unicode") + "\n"
