"""Planning groups when the user names none: the arm as the longest chain, its fingers as a gripper.

MoveIt Setup Assistant asks the user; a command line should work without questions for the
common case, an arm with or without a gripper on a fixed or moving base. The arm is one chain
from the root along the branch with the most moving joints. Where that branch splits into several
moving branches after the chain already has ARM_JOINTS moving joints (a hand: fingers), or into
several short ones (at most FINGER_DEPTH moving joints each: a two-finger gripper), the chain ends
there and the branches become a 'gripper' group and end effector, as a MoveIt config has them.
Before that, a split is a base carrying legs and an arm, or a torso carrying two arms: the
deepest branch is followed.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

from ..core.robot_model.robot_model import RobotModel
from ..core.robot_model.srdf import SrdfEndEffector

MOVING = ("revolute", "continuous", "prismatic")
FINGER_DEPTH = 2  # a branch this short (in moving joints) below a split is a finger
ARM_JOINTS = 4  # a chain this long that splits has reached its hand


@dataclass(frozen=True)
class GroupSpec:
    """A planning group: a chain (base_link, tip_link) or a list of joints."""

    name: str
    base_link: str = ""
    tip_link: str = ""
    joints: tuple[str, ...] = ()

    @classmethod
    def parse(cls, text: str) -> "GroupSpec":
        """NAME:BASE_LINK:TIP_LINK (a chain) or NAME:JOINT1,JOINT2,... (a joint list)."""
        parts = text.split(":")
        if len(parts) == 3 and all(parts):
            return cls(parts[0], base_link=parts[1], tip_link=parts[2])
        if len(parts) == 2 and all(parts):
            return cls(parts[0], joints=tuple(j for j in parts[1].split(",") if j))
        raise ValueError(f"--group '{text}': expected NAME:BASE_LINK:TIP_LINK or NAME:JOINT1,JOINT2,...")


def parse_end_effector(text: str) -> SrdfEndEffector:
    """NAME:PARENT_LINK:GROUP (GROUP: the end effector's own group, e.g. the gripper)."""
    parts = text.split(":")
    if len(parts) != 3 or not all(parts):
        raise ValueError(f"--end-effector '{text}': expected NAME:PARENT_LINK:GROUP")
    return SrdfEndEffector(*parts)


def default_groups(model: RobotModel, arm_name: str = "arm") -> tuple[list[GroupSpec], list[SrdfEndEffector]]:
    """The arm chain (and a gripper group + end effector where the chain ends at fingers)."""

    def child_joints(link: str) -> list[str]:
        return [j for j in model.joint_names if model.joint(j).parent_link == link]

    @lru_cache(maxsize=None)
    def depth(link: str) -> int:
        """Most moving joints on any path down from this link."""
        return max((int(model.joint(j).type in MOVING) + depth(model.joint(j).child_link)
                    for j in child_joints(link)), default=0)

    @lru_cache(maxsize=None)
    def length(link: str) -> int:
        """Most links on any path down from this link (to pick among fixed branches)."""
        return max((1 + length(model.joint(j).child_link) for j in child_joints(link)), default=0)

    def branch_depth(joint: str) -> int:
        return int(model.joint(joint).type in MOVING) + depth(model.joint(joint).child_link)

    link, arm_joints, fingers = model.root_link, 0, []
    while True:
        branches = child_joints(link)
        moving = [j for j in branches if branch_depth(j) > 0]
        if not moving:
            break
        if len(moving) >= 2 and (arm_joints >= ARM_JOINTS or (
                arm_joints >= 2 and all(branch_depth(j) <= FINGER_DEPTH for j in moving))):
            fingers = moving
            break
        joint = max(moving, key=branch_depth)
        arm_joints += int(model.joint(joint).type in MOVING)
        link = model.joint(joint).child_link
    # Past the last moving joint (or at the fingers' split) follow the longest fixed branch: a
    # tool0 / tcp frame is where users put their goals.
    while True:
        fixed = [j for j in child_joints(link) if model.joint(j).type == "fixed" and depth(model.joint(j).child_link) == 0]
        if not fixed:
            break
        link = model.joint(max(fixed, key=lambda j: length(model.joint(j).child_link))).child_link
    if arm_joints == 0:
        raise ValueError(f"robot '{model.name}' has no moving joints: there is no arm to plan for")
    groups = [GroupSpec(arm_name, base_link=model.root_link, tip_link=link)]
    eefs = []
    if fingers:
        finger_joints = []
        for joint in fingers:
            stack = [joint]
            while stack:
                current = stack.pop()
                if model.joint(current).type in MOVING:
                    finger_joints.append(current)
                stack.extend(child_joints(model.joint(current).child_link))
        groups.append(GroupSpec("gripper", joints=tuple(finger_joints)))
        eefs.append(SrdfEndEffector("gripper", link, "gripper", arm_name))
    return groups, eefs
