"""The planning pipelines by id, as move_group offers them: one call, any planner.

MoveIt users pick a pipeline (``ompl``, ``pilz_industrial_motion_planner``) and a planner id on
the request; MTC's JointInterpolationPlanner is exposed as a third pipeline so task stages and
the planning server reach every core planner the same way. Each planner is built once and reused.
"""
from __future__ import annotations

import time
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from interfaces_py.msgs import MoveItErrorCode

from ..planners.joint_interpolation.joint_interpolation import plan_joint_interpolation
from ..kinematic_constraints.kinematic_constraints import dense_violation
from ..planners.ompl import OmplPlanner
from ..planners.pilz import KNOWN_PLANNER_IDS as PILZ_PLANNER_IDS
from ..planners.pilz import PILZ_PIPELINE_ID, IndustrialMotionPlanner
from .planning_interface import MotionPlanRequest, MotionPlanResponse, PlanningFailure, failure
from ..planning_scene.planning_scene import PlanningScene

OMPL_PIPELINE_ID = "ompl"
JOINT_INTERPOLATION_PIPELINE_ID = "joint_interpolation"


class PlanningPipeline:
    """Dispatches a MotionPlanRequest to the pipeline named by request.pipeline_id."""

    def __init__(
        self,
        ompl_config: str | Path | Mapping | None = None,
        cartesian_limits: str | Path | Mapping | None = None,
    ) -> None:
        self.ompl = OmplPlanner(ompl_config)
        self.industrial = IndustrialMotionPlanner(cartesian_limits)

    @property
    def pipeline_ids(self) -> list[str]:
        return [OMPL_PIPELINE_ID, PILZ_PIPELINE_ID, JOINT_INTERPOLATION_PIPELINE_ID]

    def planner_id_problem(self, planner_id: str, groups: Sequence[str] = ()) -> str | None:
        """Why ``planner_id`` names no planner (None when some pipeline has it): an OMPL
        configuration of one of ``groups`` (default: every configured group, or any configuration
        for a group the YAML does not list), or one of the industrial planner's."""
        if not planner_id or planner_id in PILZ_PLANNER_IDS:
            return None
        for group in list(groups) or list(self.ompl.config.groups) or ["arm"]:
            try:
                self.ompl._resolve(group, planner_id)
                return None
            except PlanningFailure:
                continue
        return (f"unknown planner id '{planner_id}': neither an OMPL planner configuration "
                f"({', '.join(sorted(self.ompl.config.planner_configs)[:4])}, ...) nor one of the industrial "
                f"planner's {list(PILZ_PLANNER_IDS)}")

    @staticmethod
    def _within_path_constraints(request: MotionPlanRequest, response: MotionPlanResponse) -> MotionPlanResponse:
        """Planners that do not search (industrial, joint interpolation) either follow the path
        constraints or not: their path is checked and refused if it leaves them."""
        constraints = request.path_constraints
        if not constraints or not response.success or response.trajectory is None:
            return response
        start = response.start_state if response.start_state is not None else request.start_state
        trajectory = response.trajectory
        # every sample, and the straight joint-space segments between them
        found = dense_violation(constraints, start, trajectory.joint_names, trajectory.positions)
        if found is None:
            return response
        index, fraction, problem = found
        times = np.asarray(trajectory.times, dtype=float)
        if index == 0 and fraction == 0.0:
            code, what = MoveItErrorCode.START_STATE_VIOLATES_PATH_CONSTRAINTS, "the start state"
        elif index == len(trajectory.positions) - 1:
            code, what = MoveItErrorCode.GOAL_VIOLATES_PATH_CONSTRAINTS, "the goal state"
        else:
            t = times[index] + fraction * (times[index + 1] - times[index]) if fraction else times[index]
            code, what = MoveItErrorCode.PLANNING_FAILED, f"the path at t = {t:.3f} s"
        return failure(code, f"{what} violates the path constraints: {problem}").to_response(
            time.perf_counter() - response.planning_time, request)

    def plan(self, scene: PlanningScene, request: MotionPlanRequest) -> MotionPlanResponse:
        """Plan with the requested pipeline; unknown pipelines get INVALID_MOTION_PLAN."""
        pipeline = request.pipeline_id or OMPL_PIPELINE_ID
        if pipeline == OMPL_PIPELINE_ID:
            return self.ompl.plan(scene, request)
        if pipeline == PILZ_PIPELINE_ID:
            return self._within_path_constraints(request, self.industrial.plan(scene, request))
        if pipeline == JOINT_INTERPOLATION_PIPELINE_ID:
            return self._within_path_constraints(request, plan_joint_interpolation(scene, request))
        return failure(
            MoveItErrorCode.INVALID_MOTION_PLAN,
            f"unknown planning pipeline '{pipeline}'; known: {', '.join(self.pipeline_ids)}",
        ).to_response(time.perf_counter(), request)
