"""move_group's kinematics capability (MoveIt: MoveGroupKinematicsService, /compute_ik and
/compute_fk) as typed calls; the IK solvers are cached per (group, link) in state_queries."""
from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from interfaces_py.msgs import MoveItErrorCode, RobotState as RobotStateMsg

from ..core.errors import SceneError
from ..core.planning_scene.planning_scene_monitor import BAD_REQUEST
from ..core.robot_state.robot_state import RobotState
from .move_group_context import MoveGroupContext, RequestError
from .state_queries import DEFAULT_IK_TIMEOUT, MAX_IK_TIMEOUT

__all__ = ["compute_fk", "compute_ik"]


def compute_ik(ctx: MoveGroupContext, group: str, pose: np.ndarray, frame: str = "world", link: str = "",
               seed: RobotStateMsg | None = None, avoid_collisions: bool = False,
               timeout: float = 0.0, constraints: Any = None) -> tuple[MoveItErrorCode, RobotState | None]:
    """The whole robot state placing ``link`` (default: the group's tip) at ``pose`` (4x4 in
    ``frame``), seeded from ``seed`` merged onto the current state; ``timeout`` 0:
    DEFAULT_IK_TIMEOUT; ``constraints`` (path constraints' JSON form, MoveIt's
    ik_request.constraints): the solution satisfies them. Never raises for bad input."""
    model = ctx.model
    try:
        if not model.has_group(group):
            raise RequestError(MoveItErrorCode.INVALID_GROUP_NAME,
                               f"unknown planning group {group!r}; known: {', '.join(model.group_names)}")
        if link and not model.has_link(link):
            raise RequestError(MoveItErrorCode.INVALID_LINK_NAME, f"unknown link {link!r} of robot '{model.name}'")
        timeout = timeout or DEFAULT_IK_TIMEOUT
        if not 0 < timeout <= MAX_IK_TIMEOUT:
            raise RequestError(BAD_REQUEST, f"timeout must be in (0, {MAX_IK_TIMEOUT:g}] s, got {timeout:g}")
        scene = ctx.start_scene(seed, model.group(group).joint_names)
        target = ctx.in_world([pose], frame or "world", scene)[0]
        resolved = ctx.resolve_path_constraints(constraints, scene)
    except RequestError as exc:
        return MoveItErrorCode(exc.moveit_code, exc.message, "compute_ik"), None
    answer = ctx.queries.compute_ik(scene, group, target, link, avoid_collisions, timeout, resolved)
    if answer.state is None:
        return MoveItErrorCode(getattr(MoveItErrorCode, answer.error), answer.message, "compute_ik"), None
    return MoveItErrorCode(MoveItErrorCode.SUCCESS, "", "compute_ik"), answer.state


def compute_fk(ctx: MoveGroupContext, links: Sequence[str], frame: str = "world",
               state: RobotStateMsg | None = None) -> tuple[MoveItErrorCode, dict[str, np.ndarray]]:
    """Poses (4x4 in ``frame``: the world, a link or a scene object) of ``links`` at ``state``
    merged onto the current state. Never raises for bad input."""
    model = ctx.model
    try:
        if not links:
            raise RequestError(MoveItErrorCode.INVALID_LINK_NAME, "links must be a non-empty list of link names")
        unknown = [x for x in links if not model.has_link(x)]
        if unknown:
            raise RequestError(MoveItErrorCode.INVALID_LINK_NAME, f"unknown links {unknown} of robot '{model.name}'")
        frame = frame or "world"
        scene = ctx.start_scene(state, model.variable_names)
        if frame not in ("world", "/world") and not model.has_link(frame) and not scene.has_object(frame):
            raise RequestError(MoveItErrorCode.FRAME_TRANSFORM_FAILURE,
                               f"unknown frame {frame!r}: not 'world', a link of robot '{model.name}' or an object of "
                               "the scene")
        try:
            poses = ctx.queries.compute_fk(scene, list(links), frame)
        except SceneError as exc:
            raise RequestError(MoveItErrorCode.FRAME_TRANSFORM_FAILURE, str(exc)) from None
    except RequestError as exc:
        return MoveItErrorCode(exc.moveit_code, exc.message, "compute_fk"), {}
    return MoveItErrorCode(MoveItErrorCode.SUCCESS, "", "compute_fk"), poses
