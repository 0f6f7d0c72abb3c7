"""The forgiving half of SRDF loading: drop what names links or joints the URDF lacks, keep the rest.

MoveIt's SRDF parser (srdfdom) logs a bad entry and loads everything else, and MoveIt users'
SRDFs rely on it: example-robot-data ships SRDFs written for a fuller URDF (Z1's and Baxter's
groups name links their URDF lacks, Solo's name joints under other names). Refusing the whole file
for one stale group would make "any arm given as URDF + SRDF" false for those robots, so by default
RobotModel passes the parsed SRDF through `drop_unknown_names` first; `strict=True` skips this and
keeps the all-or-nothing checks.

Whole entries are dropped, never parts of one: a group with one unknown joint is not the group its
author meant, so it is skipped (and so is every group, state and end effector that needs it),
each with one warning naming what is missing.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace
from typing import Mapping

from .srdf import Srdf, SrdfGroup

_LOG = logging.getLogger(__name__)


@dataclass(frozen=True)
class UrdfTree:
    """The URDF facts the check needs: link names and each joint's parent and child link."""

    links: frozenset[str]
    joints: Mapping[str, tuple[str, str]]  # joint -> (parent link, child link)
    parent_joint: Mapping[str, str] = field(default_factory=dict)  # child link -> joint

    @classmethod
    def build(cls, links: list[str], joints: Mapping[str, tuple[str, str]]) -> "UrdfTree":
        return cls(frozenset(links), dict(joints), {child: j for j, (_, child) in joints.items()})

    def is_below(self, tip: str, base: str) -> bool:
        link, seen = tip, set()
        while link != base:
            joint = self.parent_joint.get(link)
            if joint is None or link in seen:
                return False
            seen.add(link)
            link = self.joints[joint][0]
        return True


def _group_problem(group: SrdfGroup, tree: UrdfTree, virtual_joints: set[str]) -> str | None:
    missing_joints = [j for j in group.joints if j not in tree.joints and j not in virtual_joints]
    missing_links = [link for link in group.links if link not in tree.links]
    for chain in group.chains:
        missing_links += [link for link in (chain.base_link, chain.tip_link) if link not in tree.links]
    parts = []
    if missing_joints:
        parts.append(f"joint{'s' if len(missing_joints) > 1 else ''} {', '.join(map(repr, missing_joints))}")
    if missing_links:
        unique = list(dict.fromkeys(missing_links))
        parts.append(f"link{'s' if len(unique) > 1 else ''} {', '.join(map(repr, unique))}")
    if parts:
        return "names " + " and ".join(parts) + " the URDF lacks"
    for chain in group.chains:
        if not tree.is_below(chain.tip_link, chain.base_link):
            return f"its chain's tip '{chain.tip_link}' is not below its base '{chain.base_link}' in the URDF"
    return None


def drop_unknown_names(srdf: Srdf, tree: UrdfTree) -> tuple[Srdf, list[str]]:
    """The SRDF without the entries that name links, joints or groups the URDF (or the SRDF) lacks,
    and one warning per dropped entry (also logged)."""
    warnings: list[str] = []

    def warn(message: str) -> None:
        warnings.append(message)
        _LOG.warning(message)

    virtual_joints = []
    for vj in srdf.virtual_joints:
        if vj.child_link not in tree.links:
            warn(f"SRDF virtual_joint '{vj.name}' skipped: child link '{vj.child_link}' is not in the URDF")
        else:
            virtual_joints.append(vj)
    virtual_names = {vj.name for vj in virtual_joints}

    groups: dict[str, SrdfGroup] = {}
    for name, group in srdf.groups.items():
        problem = _group_problem(group, tree, virtual_names)
        if problem:
            warn(f"SRDF group '{name}' skipped: {problem}")
        else:
            groups[name] = group
    # Subgroups: a group whose subgroup is missing (or was skipped) goes too; repeat until stable.
    changed = True
    while changed:
        changed = False
        for name, group in list(groups.items()):
            missing = [sub for sub in group.subgroups if sub not in groups]
            if missing:
                del groups[name]
                changed = True
                warn(f"SRDF group '{name}' skipped: its subgroup{'s' if len(missing) > 1 else ''} "
                     f"{', '.join(map(repr, missing))} {'are' if len(missing) > 1 else 'is'} unknown or skipped")
    for name in list(groups):
        if name in groups and _in_cycle(name, groups):
            del groups[name]
            warn(f"SRDF group '{name}' skipped: it contains itself through its subgroups")

    states = []
    for state in srdf.group_states:
        if state.group not in groups:
            warn(f"SRDF group_state '{state.name}' skipped: group '{state.group}' is unknown or skipped")
            continue
        missing = [j for j in state.values if j not in tree.joints and j not in virtual_names]
        if missing:
            warn(f"SRDF group_state '{state.name}' of group '{state.group}' skipped: names "
                 f"joint{'s' if len(missing) > 1 else ''} {', '.join(map(repr, missing))} the URDF lacks")
            continue
        states.append(state)

    end_effectors = {}
    for name, eef in srdf.end_effectors.items():
        problems = []
        if eef.group not in groups:
            problems.append(f"group '{eef.group}' is unknown or skipped")
        if eef.parent_link not in tree.links:
            problems.append(f"parent link '{eef.parent_link}' is not in the URDF")
        if eef.parent_group and eef.parent_group not in groups:
            problems.append(f"parent group '{eef.parent_group}' is unknown or skipped")
        if problems:
            warn(f"SRDF end effector '{name}' skipped: " + "; ".join(problems))
        else:
            end_effectors[name] = eef

    disabled = []
    for link1, link2, reason in srdf.disabled_collisions:
        missing = [link for link in (link1, link2) if link not in tree.links]
        if missing:
            warn(f"SRDF disable_collisions '{link1}'/'{link2}' skipped: "
                 f"{' and '.join(map(repr, missing))} {'are' if len(missing) > 1 else 'is'} not in the URDF")
        else:
            disabled.append((link1, link2, reason))

    return replace(srdf, groups=groups, group_states=states, end_effectors=end_effectors,
                   virtual_joints=virtual_joints, disabled_collisions=disabled), warnings


def _in_cycle(start: str, groups: Mapping[str, SrdfGroup]) -> bool:
    stack, seen = list(groups[start].subgroups), set()
    while stack:
        name = stack.pop()
        if name == start:
            return True
        if name in seen or name not in groups:
            continue
        seen.add(name)
        stack.extend(groups[name].subgroups)
    return False
