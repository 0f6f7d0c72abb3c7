"""The YAML files of a robot configuration, in the formats MoveIt's config packages use.

Controllers: one per group that is not made of subgroups, in group order, skipping a group whose
joints an earlier controller already drives (a MoveIt config has one controller per joint). A
one-joint end-effector group gets a GripperCommand controller, every other a
FollowJointTrajectory one: what the mock controllers and the planning_server's execution need.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from ..core.robot_model.robot_model import RobotModel
from ..paths import config_file

GENERATED = "# Written by mycobot_planning's setup assistant for robot '{name}'.\n"


def _dump(header: str, data: Any) -> str:
    return header + yaml.safe_dump(data, sort_keys=False, default_flow_style=False)


def joint_limits_yaml(model: RobotModel) -> str:
    limits = {}
    for name in model.variable_names:
        joint = model.joint(name)
        entry: dict[str, Any] = {"has_velocity_limits": bool(joint.max_velocity < float("inf"))}
        if entry["has_velocity_limits"]:
            entry["max_velocity"] = float(joint.max_velocity)
        entry["has_acceleration_limits"] = False
        entry["max_acceleration"] = 0.0
        limits[name] = entry
    header = GENERATED.format(name=model.name) + (
        "# Velocity limits from the URDF. The URDF has no acceleration limits: until you set\n"
        "# has_acceleration_limits / max_acceleration here, planning assumes 1 rad/s^2 (m/s^2).\n")
    return _dump(header, {"default_velocity_scaling_factor": 1.0, "default_acceleration_scaling_factor": 1.0,
                          "joint_limits": limits})


def kinematics_yaml(model: RobotModel) -> str:
    data = {group: {"kinematics_solver": "mycobot_planning/PinocchioIK",
                    "kinematics_solver_search_resolution": 0.005,
                    "kinematics_solver_timeout": 0.05,
                    "kinematics_solver_attempts": 3,
                    "position_only_ik": False}
            for group in model.group_names if model.group(group).variable_count}
    return _dump(GENERATED.format(name=model.name), data)


def ompl_planning_yaml(model: RobotModel) -> str:
    """The package's pipeline settings and planner configs, with a section per group."""
    template = yaml.safe_load(config_file("ompl_planning.yaml").read_text())
    data = {k: v for k, v in template.items() if k in ("planning_plugins", "request_adapters",
                                                        "response_adapters", "planner_configs")}
    names = list(data.get("planner_configs", {}))
    for group in model.group_names:
        joints = model.group(group).joint_names
        if not joints:
            continue
        data[group] = {"default_planner_config": "RRTConnectkConfigDefault", "planner_configs": names,
                       "projection_evaluator": f"joints({', '.join(joints[:2])})",
                       "longest_valid_segment_fraction": 0.005}
    return _dump(GENERATED.format(name=model.name), data)


def controllers(model: RobotModel) -> list[tuple[str, str, tuple[str, ...]]]:
    """(controller name, 'FollowJointTrajectory' | 'GripperCommand', joints) per driven group."""
    eef_groups = {e.group for e in model.end_effectors.values()}
    taken: set[str] = set()
    out = []
    for name in model.group_names:
        group = model.group(name)
        if group.subgroups or not group.joint_names or taken & set(group.joint_names):
            continue
        kind = "GripperCommand" if name in eef_groups and group.variable_count == 1 else "FollowJointTrajectory"
        out.append((f"{name}_controller", kind, tuple(group.joint_names)))
        taken |= set(group.joint_names)
    return out


def moveit_controllers_yaml(model: RobotModel) -> str:
    listed = controllers(model)
    manager: dict[str, Any] = {"controller_names": [name for name, _, _ in listed]}
    for name, kind, joints in listed:
        manager[name] = {"type": kind, "action_ns": "follow_joint_trajectory" if kind == "FollowJointTrajectory"
                         else "gripper_cmd", "default": True, "joints": list(joints)}
    return _dump(GENERATED.format(name=model.name), {
        "moveit_controller_manager": "moveit_simple_controller_manager/MoveItSimpleControllerManager",
        "moveit_simple_controller_manager": manager})


def ros2_controllers_yaml(model: RobotModel) -> str:
    """ros2_control's controllers file: what the mock controllers (or a real stack) load."""
    listed = controllers(model)
    manager: dict[str, Any] = {"update_rate": 100}
    data: dict[str, Any] = {"controller_manager": {"ros__parameters": manager}}
    for name, kind, joints in listed:
        manager[name] = {"type": "position_controllers/GripperActionController" if kind == "GripperCommand"
                         else "joint_trajectory_controller/JointTrajectoryController"}
        data[name] = {"ros__parameters": {"joints": list(joints), "update_rate": 100,
                                          "goal_tolerance": 0.01, "start_tolerance": 0.05}}
    manager["joint_state_broadcaster"] = {"type": "joint_state_broadcaster/JointStateBroadcaster"}
    return _dump(GENERATED.format(name=model.name), data)


def manifest_yaml(name: str, source: Path, package_dirs: list[str]) -> str:
    header = GENERATED.format(name=name) + (
        "# The files of this robot configuration (RobotModel.from_config, the nodes' robot_config\n"
        "# parameter). package_dirs: where the URDF's package:// meshes resolve.\n")
    return _dump(header, {"robot_name": name, "urdf": f"{name}.urdf", "srdf": f"{name}.srdf",
                          "joint_limits": "joint_limits.yaml", "kinematics": "kinematics.yaml",
                          "ompl_planning": "ompl_planning.yaml", "moveit_controllers": "moveit_controllers.yaml",
                          "ros2_controllers": "ros2_controllers.yaml", "source_urdf": str(source),
                          "package_dirs": package_dirs})
