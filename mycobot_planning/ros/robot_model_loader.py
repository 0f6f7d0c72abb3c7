"""MoveIt's robot_model_loader for rclpy: the robot model a node's parameters describe, or else
the one the running move_group (our planning_server) carries.

MTC's ``Task.loadRobotModel(node)`` and MoveItPy both build their robot from
``robot_description`` and ``robot_description_semantic`` with the joint limits of
``robot_description_planning.*`` and the IK settings of ``robot_description_kinematics.*``. A
node started with those parameters (a launch file's usual way) uses its own; a script node
without them reads them from ``/move_group``, as RViz and pymoveit2 do.
"""
from __future__ import annotations

from typing import Any

import rclpy
import rclpy.parameter
from rcl_interfaces.srv import GetParameters, ListParameters
from rclpy.node import Node

from interfaces_py import names
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.paths import package_share_dirs
from mycobot_planning.ros.node_waiter import SERVER_TIMEOUT, NodeWaiter

__all__ = ["KINEMATICS_PREFIX", "PLANNING_PREFIX", "load_robot_model", "parameter_tree"]

PLANNING_PREFIX = "robot_description_planning"
KINEMATICS_PREFIX = "robot_description_kinematics"


def parameter_tree(flat: dict[str, Any], prefix: str) -> dict[str, Any]:
    """``{"a.b.c": 1}`` under ``prefix`` "a" -> ``{"b": {"c": 1}}`` (how ROS 2 flattens YAML)."""
    tree: dict[str, Any] = {}
    for key, value in flat.items():
        if not key.startswith(prefix + "."):
            continue
        node = tree
        *parents, leaf = key[len(prefix) + 1:].split(".")
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = value
    return tree


def _own_parameters(node: Node, wanted: list[str]) -> dict[str, Any]:
    out = {}
    for name in wanted:
        if node.has_parameter(name):
            value = node.get_parameter(name).value
            if value not in (None, ""):
                out[name] = value
    return out


def _own_trees(node: Node) -> dict[str, Any]:
    """The node's own robot_description_planning.* / robot_description_kinematics.* parameters."""
    return {name: param.value for name, param in node.get_parameters_by_prefix("").items()
            if name.startswith((PLANNING_PREFIX + ".", KINEMATICS_PREFIX + "."))}


def _move_group_parameters(waiter: NodeWaiter, robot_description: str, timeout: float) -> dict[str, Any]:
    """robot_description(_semantic) and the planning/kinematics trees from move_group."""
    node = waiter.node
    node_name = f"/{names.MOVE_GROUP_NODE}"
    lister = node.create_client(ListParameters, f"{node_name}/list_parameters")
    getter = node.create_client(GetParameters, f"{node_name}/get_parameters")
    try:
        request = ListParameters.Request(prefixes=[PLANNING_PREFIX, KINEMATICS_PREFIX], depth=0)
        listed = list(waiter.call(lister, request, "loading the robot model", timeout).result.names)
        wanted = [robot_description, f"{robot_description}_semantic", *listed]
        answer = waiter.call(getter, GetParameters.Request(names=wanted), "loading the robot model", timeout)
    finally:
        node.destroy_client(lister)
        node.destroy_client(getter)
    return {name: rclpy.parameter.parameter_value_to_python(value) for name, value in zip(wanted, answer.values)}


def load_robot_model(waiter: NodeWaiter, robot_description: str = "robot_description",
                     timeout: float = SERVER_TIMEOUT) -> RobotModel:
    """The URDF and SRDF (with joint limits and IK settings) the node has, else move_group's.

    Raises ValueError when neither has a ``robot_description``, TimeoutError when move_group does
    not answer, RobotModelError for a description the core cannot load."""
    params = _own_parameters(waiter.node, [robot_description, f"{robot_description}_semantic"])
    if robot_description in params:
        params.update(_own_trees(waiter.node))
    else:
        params = _move_group_parameters(waiter, robot_description, timeout)
    urdf = params.get(robot_description)
    if not urdf:
        raise ValueError(f"no '{robot_description}' parameter on this node or on /{names.MOVE_GROUP_NODE}")
    srdf = params.get(f"{robot_description}_semantic") or '<robot name=""/>'
    limits = parameter_tree(params, PLANNING_PREFIX) or None
    kinematics = parameter_tree(params, KINEMATICS_PREFIX) or None
    return RobotModel.from_strings(urdf, srdf, limits, kinematics, package_dirs=package_share_dirs())
