"""MTC's JointInterpolationPlanner: a straight line in joint space, checked densely."""
from __future__ import annotations

import numpy as np

from ...core.errors import PlanningError
from ...core.planners.joint_interpolation.joint_interpolation import DEFAULT_MAX_STEP, interpolate_joint_path
from ...core.planning_interface.planning_interface import PlanningFailure, PoseGoal, goal_states
from ..properties import PropertySetter
from ..trajectories import time_path
from .planner_interface import (PlannerInterface, PlanResult, check_path, constraint_failure, constraints_key,
                                plan_seed)


class JointInterpolationPlanner(PlannerInterface):
    """A straight line in joint space from start to goal, every ``max_step`` checked."""

    def __init__(self, max_step: float = DEFAULT_MAX_STEP) -> None:
        super().__init__()
        self._properties.declare("max_step", max_step, "max joint step between checked states (rad)", type=float)
        self._properties.declare("max_effort", None, "max_effort for gripper commands (passed through)", type=float)

    setMaxStep = PropertySetter("max_step", float)

    @property
    def planner_id(self) -> str:
        return "JointInterpolation"

    def init(self, robot_model):
        super().init(robot_model)
        if not self._properties["max_step"] > 0:
            raise ValueError(f"max_step must be > 0, got {self._properties['max_step']}")

    def plan(self, from_scene, to_scene, group, timeout, context=None, path_constraints=None):
        goal = to_scene.current_state.group_positions(group)
        return self._memoized(context, from_scene, ("state", group, goal.tobytes(), constraints_key(path_constraints)),
                              lambda: self._plan_line(from_scene, group, goal, path_constraints))

    def _plan_line(self, from_scene, group, goal, path_constraints=None):
        constraints, failed = constraint_failure(self, path_constraints, from_scene)
        if failed is not None:
            return failed
        model = from_scene.robot_model
        jmg = model.group(group)
        start = from_scene.current_state
        try:
            path, message = interpolate_joint_path(from_scene, group, start, goal, float(self._properties["max_step"]))
        except PlanningError as exc:
            return PlanResult(False, None, str(exc), self.planner_id)
        if path is None:
            return PlanResult(False, None, message, self.planner_id)
        broken = check_path(constraints, start, jmg.joint_names, path, "line")
        if broken is not None:
            return PlanResult(False, None, f"joint interpolation: {broken}", self.planner_id)
        velocity, acceleration = self._scaling()
        # The line is collision-checked above; timing its two ends gives the same straight
        # motion (the timing never leaves the path) at a fraction of the cost.
        trajectory = time_path(model, jmg, path[[0, -1]], velocity, acceleration)
        return PlanResult(True, trajectory, message, self.planner_id)

    def plan_pose(self, from_scene, link, offset, target, group, timeout, context=None, path_constraints=None):
        model = from_scene.robot_model
        jmg = model.group(group)
        timeout = self._timeout(timeout)
        constraints, failed = constraint_failure(self, path_constraints, from_scene)
        if failed is not None:
            return failed
        rng = np.random.default_rng(plan_seed(context))
        goal = PoseGoal(np.asarray(target, dtype=float), link=link, ik_frame_offset=np.asarray(offset, dtype=float))
        try:
            states = goal_states(from_scene, jmg, from_scene.current_state, goal, 8, max(timeout, 1e-3), rng)
        except PlanningFailure as exc:
            return PlanResult(False, None, f"IK failed for pose target: {exc.message}", self.planner_id)
        if constraints:  # as MTC: the IK solution must satisfy the path constraints
            kept = [state for state in states if constraints.satisfied(state)]
            if not kept:
                return PlanResult(False, None, "IK failed for pose target: no solution satisfies the path "
                                               f"constraints ({constraints.violation(states[0])})", self.planner_id)
            states = kept
        to_scene = from_scene.diff()
        to_scene.set_current_state(states[0])
        return self.plan(from_scene, to_scene, group, timeout, context, path_constraints)
