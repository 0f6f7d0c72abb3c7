"""Connect: plan between a start state and an end state offered by the neighbours (MTC's
stages::Connect), for one or several (group, planner) pairs.

Each group is planned in turn from the state reached so far to the end state's joints of that
group. With several groups the trajectories are merged into one simultaneous motion when a
planning group covers exactly their joints (e.g. arm + gripper = 'arm_with_gripper') and the
merged path is collision-free (merge_mode WAYPOINTS, MTC's default); otherwise they stay a
sequence of sub-trajectories. Joints no planner moves must already agree (within 1e-4) between
the two states, and the states must hold the same objects, or the pair is not attempted.
``path_constraints`` (a moveit_msgs/Constraints, see task/path_constraints.py) go to every
planner, as in MTC (e.g. keep a held object upright).
"""
from __future__ import annotations

from enum import IntEnum
from typing import Any, Sequence

import numpy as np

from ...core.kinematic_constraints.kinematic_constraints import dense_violation
from ..cost_terms import PathLength
from ..errors import InitStageException
from ..path_constraints import check_path_constraints, declare_path_constraints
from ..properties import PropertySetter
from ..solvers import PlannerInterface
from ..stage import Connecting
from ..storage import InterfaceState, SolutionSequence, SubTrajectory
from ..trajectories import find_group, merge_trajectories


class MergeMode(IntEnum):
    """MTC's stages.MergeMode: how Connect joins the trajectories of several groups."""

    SEQUENTIAL = 0  # one after the other
    WAYPOINTS = 1  # merged into one trajectory by their waypoints


class Connect(Connecting):
    MergeMode = MergeMode
    SEQUENTIAL = MergeMode.SEQUENTIAL
    WAYPOINTS = MergeMode.WAYPOINTS

    def __init__(self, name: str = "connect", planners: Sequence[tuple[str, PlannerInterface]] = ()) -> None:
        super().__init__(name)
        self._planners = [(str(group), planner) for group, planner in planners]
        self._merged_group: str | None = None
        self.setTimeout(1.0)
        self.setCostTerm(PathLength())
        p = self._properties
        p.declare("merge_mode", self.WAYPOINTS, "merge mode: SEQUENTIAL (0) or WAYPOINTS (1)", type=int)
        p.declare("max_distance", 1e-2, "maximally accepted distance between the reached and the goal state", type=float)
        declare_path_constraints(p)

    @property
    def planners(self) -> list[tuple[str, PlannerInterface]]:
        return list(self._planners)

    setPathConstraints = PropertySetter("path_constraints", Any)

    def reset(self) -> None:
        super().reset()

    def init(self, robot_model) -> None:
        errors = InitStageException().collect(super().init, robot_model)
        if not self._planners:
            errors.push_back(self, "empty set of groups (give (group, planner) pairs)")
        groups = []
        for group, planner in self._planners:
            if not robot_model.has_group(group):
                errors.push_back(self, f"invalid group: {group}; known: {', '.join(robot_model.group_names)}")
            elif not isinstance(planner, PlannerInterface):
                errors.push_back(self, f"invalid planner for group: {group}")
            else:
                try:
                    planner.init(robot_model)
                except (ValueError, TypeError) as exc:
                    errors.push_back(self, f"planner for group '{group}': {exc}")
                groups.append(group)
        self._merged_group = None
        if not errors and len(groups) >= 2:
            joints = [j for g in groups for j in robot_model.group(g).joint_names]
            if len(set(joints)) == len(joints):
                self._merged_group = find_group(robot_model, set(joints))
        check_path_constraints(self, robot_model, errors)
        if errors:
            raise errors

    def compatible(self, from_state: InterfaceState, to_state: InterfaceState) -> bool:
        if not super().compatible(from_state, to_state):
            return False
        model = from_state.scene.robot_model
        planned = set()
        for group, _ in self._planners:
            if model.has_group(group):
                planned.update(model.group(group).variable_indices.tolist())
        others = np.array([i for i in range(len(model.variable_names)) if i not in planned], dtype=int)
        if others.size == 0:
            return True
        a = from_state.scene.current_state.positions[others]
        b = to_state.scene.current_state.positions[others]
        return bool(np.all(np.abs(a - b) <= 1e-4))

    def compute(self, from_state: InterfaceState, to_state: InterfaceState) -> None:
        timeout = self.timeout_or(1.0)
        mode = self._properties["merge_mode"]
        max_distance = float(self._properties["max_distance"])
        constraints = self._properties["path_constraints"]
        extra = {"path_constraints": constraints} if constraints else {}
        goal = to_state.scene.current_state
        start_scene = from_state.scene
        scenes = [start_scene]
        parts: list[tuple[str, PlannerInterface, object]] = []
        success = True
        comment = "No planners specified"
        for group, planner in self._planners:
            end_scene = start_scene.diff()
            target = end_scene.current_state.copy()
            target.set_group_positions(group, goal.group_positions(group))
            end_scene.set_current_state(target)
            result = planner.plan(start_scene, end_scene, group, timeout, self._context, **extra)
            result.trajectory = planner.dense(result.trajectory)
            parts.append((group, planner, result))
            scenes.append(end_scene)
            if not result.success or result.trajectory is None:
                success = False
                comment = result.message or f"planning for group '{group}' failed"
                break
            reached = result.trajectory.positions[-1]
            if float(np.sum(np.abs(reached - goal.group_positions(group)))) > max_distance:
                success = False
                comment = "Trajectory end-point deviates too much from goal state"
                break
            end_scene.set_current_state(_with_group(start_scene.current_state, group, reached))
            start_scene = end_scene
        solution = None
        if success and mode != self.SEQUENTIAL:
            solution = self._merge(parts, scenes, from_state)
        if solution is None:
            solution = self._sequential(parts, scenes, to_state)
        if not success:
            solution.markAsFailure(comment)
        self._connect(from_state, to_state, solution)

    def _merge(self, parts, scenes, from_state: InterfaceState):
        if len(parts) == 1:
            group, planner, result = parts[0]
            return SubTrajectory(result.trajectory, group, planner_id=result.planner_id or planner.planner_id)
        if self._merged_group is None:
            return None
        trajectory, group, _message = merge_trajectories(
            from_state.scene, from_state.scene.current_state, [(g, r.trajectory) for g, _, r in parts],
            max_waypoint_distance=min(float(p.properties["max_waypoint_distance"]) for _, p, _ in parts))
        if trajectory is None:
            return None
        if not _within_path_constraints(self._properties["path_constraints"], from_state.scene, trajectory):
            return None  # as MTC: the merged path must keep the constraints too, else stay sequential
        planner_ids = ", ".join(r.planner_id or p.planner_id for _, p, r in parts)
        return SubTrajectory(trajectory, group, planner_id=planner_ids)

    def _sequential(self, parts, scenes, to_state: InterfaceState) -> SolutionSequence:
        """One sub-trajectory per group, with its own intermediate states (MTC's makeSequential)."""
        start = InterfaceState(scenes[0])
        self._states.append(start)
        children = []
        for index, (group, planner, result) in enumerate(parts):
            sub = SubTrajectory(result.trajectory, group, planner_id=result.planner_id or planner.planner_id)
            sub.creator = self
            if self._context is not None:
                sub.id = self._context.next_solution_id()
            if result.trajectory is None or not result.success:
                sub.markAsFailure(result.message)
            end_scene = scenes[index + 1] if index + 1 < len(parts) else to_state.scene
            end = InterfaceState(end_scene)
            self._states.append(end)
            sub.set_start_state(start)
            sub.set_end_state(end)
            children.append(sub)
            start = end
        return SolutionSequence(self, children)


def _within_path_constraints(spec: Any, scene, trajectory) -> bool:
    """Whether a (merged) trajectory keeps the stage's path constraints, densely (MTC's merge
    checks isPathValid with them)."""
    if not spec:
        return True
    try:
        constraints = spec.resolve(scene)
    except ValueError:
        return False
    return not constraints or dense_violation(constraints, scene.current_state, trajectory.joint_names,
                                              trajectory.positions) is None


def _with_group(state, group: str, values):
    out = state.copy()
    out.set_group_positions(group, values)
    return out
