"""Shared helpers for the task-constructor tests (scenes, validation of whole solutions)."""
from __future__ import annotations

import numpy as np

from interfaces_py.msgs import CollisionObject
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.trajectory_validator import validate_trajectory
from mycobot_planning.core.transforms import make_pose


def scene_at(model: RobotModel, named: str = "ready", **joints: float) -> PlanningScene:
    scene = PlanningScene(model)
    state = RobotState(model)
    state.set_named(named, "arm")
    if joints:
        state.set_joint_positions(joints)
    scene.set_current_state(state)
    return scene


def table_scene(model: RobotModel, named: str = "home") -> PlanningScene:
    """The seeds' pick-and-place table (0.10 x 0.20 x 0.03, top at z=0, centred (0.22, 0.12))
    with the cylinder 'object' (h 0.35, r 0.0125) standing on it."""
    scene = scene_at(model, named)
    scene.add_object(CollisionObject.box("table", [0.10, 0.20, 0.03], make_pose([0.22, 0.12, -0.015]), frame_id="base_link"))
    scene.add_object(CollisionObject.cylinder("object", 0.35, 0.0125, make_pose([0.22, 0.12, 0.175]), frame_id="base_link"))
    return scene


def assert_solution_valid(solution) -> int:
    """Every sub-trajectory passes the core validator in the scene it starts from (attached
    objects and allowed collisions included) and starts where its start state is. Returns how
    many trajectories were checked."""
    checked = 0
    for sub in solution.sub_trajectories():
        if sub.trajectory is None:
            continue
        scene = sub.start.scene
        report = validate_trajectory(scene, sub.trajectory, sub.group, scene.current_state)
        assert report.valid, f"{sub.creator.path}: {report.problems}"
        end = sub.end.scene.current_state.group_positions(sub.group)
        assert np.allclose(sub.trajectory.positions[-1], end, atol=1e-6), f"{sub.creator.path}: does not end at its end state"
        checked += 1
    return checked


def chain_is_continuous(solution) -> None:
    """Consecutive steps meet: each step starts where the previous one ended (joint values)."""
    subs = solution.sub_trajectories()
    for previous, current in zip(subs, subs[1:]):
        a = previous.end.scene.current_state.positions
        b = current.start.scene.current_state.positions
        assert np.allclose(a, b, atol=1e-6), f"{previous.creator.path} -> {current.creator.path}: {a} != {b}"
