"""move_group's state queries: inverse kinematics (compute_ik), forward kinematics (compute_fk)
and state validity (check_state_validity), on a scene whose current state is the request's.

Kept apart from planning so that both faces of the planning_server (moveit_msgs services and the
JSON requests) answer them through the same calls. IK solvers are built once per (group, link):
building one precomputes its table of seed poses, which costs far more than a query.
"""
from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.errors import KinematicsError
from ..core.kinematics.ik_solver import IKSolver
from ..core.planning_scene.planning_scene import PlanningScene
from ..core.robot_model.robot_model import RobotModel
from ..core.robot_state.robot_state import RobotState

#: s: IK timeout when the request gives none (MoveIt's default kinematics_solver_timeout is 0.005
#: per attempt; a service caller expects an answer, not an early give-up)
DEFAULT_IK_TIMEOUT = 0.1
MAX_IK_TIMEOUT = 60.0


@dataclass
class IKAnswer:
    """An IK solution (the whole robot state) or why there is none (MoveIt error code name)."""

    state: RobotState | None
    error: str = ""  # NO_IK_SOLUTION, INVALID_GROUP_NAME, INVALID_LINK_NAME, ...
    message: str = ""


@dataclass
class ValidityAnswer:
    valid: bool
    contacts: list[tuple[str, str, float]] = field(default_factory=list)  # (body_a, body_b, depth)
    bounds: list[str] = field(default_factory=list)  # joints outside their limits
    #: (satisfied, distance) of each constraint asked about (MoveIt's constraint_result), in the
    #: order joints, orientations, positions
    constraint_results: list[tuple[bool, float]] = field(default_factory=list)


class StateQueries:
    """IK, FK and validity on a given scene (thread-safe: one lock per IK solver)."""

    def __init__(self, model: RobotModel) -> None:
        self.model = model
        self._solvers: dict[tuple[str, str], tuple[IKSolver, threading.Lock]] = {}
        self._lock = threading.Lock()

    def _solver(self, group: str, link: str) -> tuple[IKSolver, threading.Lock]:
        key = (group, link)
        with self._lock:
            entry = self._solvers.get(key)
            if entry is None:
                entry = (IKSolver(self.model, group, link or None), threading.Lock())
                self._solvers[key] = entry
            return entry

    def compute_ik(self, scene: PlanningScene, group: str, target: np.ndarray, link: str = "",
                   avoid_collisions: bool = False, timeout: float = DEFAULT_IK_TIMEOUT,
                   constraints: Any = None) -> IKAnswer:
        """A state of the group placing ``link`` (default: the group's tip) at the world pose
        ``target``, seeded from the scene's current state; with ``avoid_collisions`` the state must
        be collision-free in the scene, with ``constraints`` (core PathConstraints, MoveIt's
        ik_request.constraints) satisfy them: both are the solver's validity callback, as
        MoveIt's compute_ik checks its constraints on every candidate solution."""
        if not self.model.has_group(group):
            return IKAnswer(None, "INVALID_GROUP_NAME",
                            f"unknown planning group {group!r}; known: {', '.join(self.model.group_names)}")
        if link and not self.model.has_link(link):
            return IKAnswer(None, "INVALID_LINK_NAME", f"unknown link {link!r} of robot '{self.model.name}'")
        try:
            solver, lock = self._solver(group, link)
        except KinematicsError as exc:
            return IKAnswer(None, "INVALID_GROUP_NAME", str(exc))
        checks = [check for check in (scene.is_state_valid if avoid_collisions else None,
                                      constraints.satisfied if constraints else None) if check is not None]
        validity = None if not checks else checks[0] if len(checks) == 1 else (
            lambda state: all(check(state) for check in checks))
        with lock:
            solutions = solver.solve(target, seed=scene.current_state, timeout=timeout, validity=validity)
        if not solutions:
            what = ("collision-free " if avoid_collisions else "") + ("constraint-satisfying " if constraints else "")
            return IKAnswer(None, "NO_IK_SOLUTION",
                            f"no {what}IK solution for link '{link or self.model.group(group).tip_link}' of group "
                            f"'{group}' within {timeout:g} s")
        return IKAnswer(solutions[0])

    @staticmethod
    def compute_fk(scene: PlanningScene, links: list[str], frame: str = "world") -> dict[str, np.ndarray]:
        """Poses of ``links`` (robot links, attached objects or world objects) in ``frame`` at the
        scene's current state (raises SceneError for an unknown name)."""
        base_inv = np.linalg.inv(scene.frame_pose(frame)) if frame not in ("world", "/world") else None
        poses = {}
        for link in links:
            pose = scene.frame_pose(link)
            poses[link] = pose if base_inv is None else base_inv @ pose
        return poses

    @staticmethod
    def check_validity(scene: PlanningScene) -> ValidityAnswer:
        """Collision-free (robot with itself and the world, attached objects included) and within
        the joint limits, at the scene's current state."""
        state = scene.current_state
        bounds = state.violated_bounds()
        report = scene.check_collision(state)
        contacts = [(c.body_a, c.body_b, float(c.depth)) for c in report.contacts]
        if report.collision and not contacts:
            contacts = [("?", "?", 0.0)]
        return ValidityAnswer(not report.collision and not bounds, contacts, bounds)


def state_to_json(state: RobotState) -> dict[str, Any]:
    """The JSON RobotState of every (non-mimic) variable of a core state."""
    values = state.to_joint_dict(include_mimic=False)
    return {"joint_names": list(values), "positions": [float(v) for v in values.values()]}
