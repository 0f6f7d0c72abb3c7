"""The planning pipelines by id, as move_group offers them: one call, any planner.

MoveIt users pick a pipeline (``ompl``, ``pilz_industrial_motion_planner``) and a planner id on
the request; MTC's JointInterpolationPlanner is exposed as a third pipeline so task stages and
the planning server reach every core planner the same way; STOMP (``stomp``) and CHOMP (``chomp``) are a fourth and fifth. Every planner is a PlannerManager
held in the registry of planner_manager.py (built-ins registered here, third-party ones through
the ``mycobot_planning.planners`` entry-point group); each is built once per pipeline and reused.
"""
from __future__ import annotations

import time
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from interfaces_py.msgs import MoveItErrorCode

from ..planners.chomp import CHOMP_PIPELINE_ID, ChompPlanner
from ..planners.joint_interpolation import JOINT_INTERPOLATION_PIPELINE_ID, JointInterpolationPlanner
from ..kinematic_constraints.kinematic_constraints import dense_violation
from ..planners.ompl.planner_manager import OMPL_PIPELINE_ID, OmplPlanner
from ..planners.pilz import PILZ_PIPELINE_ID, IndustrialMotionPlanner
from ..planners.stomp import STOMP_PIPELINE_ID, StompPlanner
from .planner_manager import PlannerManager, PlannerSettings, planner_factories, register_planner
from .planning_interface import MotionPlanRequest, MotionPlanResponse, failure
from ..planning_scene.planning_scene import PlanningScene

__all__ = ["CHOMP_PIPELINE_ID", "JOINT_INTERPOLATION_PIPELINE_ID", "OMPL_PIPELINE_ID", "PILZ_PIPELINE_ID", "PlanningPipeline",
           "STOMP_PIPELINE_ID"]

register_planner(OMPL_PIPELINE_ID, lambda settings: OmplPlanner(settings.ompl_config))
register_planner(PILZ_PIPELINE_ID, lambda settings: IndustrialMotionPlanner(settings.cartesian_limits))
register_planner(JOINT_INTERPOLATION_PIPELINE_ID, lambda settings: JointInterpolationPlanner())
register_planner(STOMP_PIPELINE_ID, lambda settings: StompPlanner())
register_planner(CHOMP_PIPELINE_ID, lambda settings: ChompPlanner())


class PlanningPipeline:
    """Dispatches a MotionPlanRequest to the planner registered under request.pipeline_id."""

    def __init__(
        self,
        ompl_config: str | Path | Mapping | None = None,
        cartesian_limits: str | Path | Mapping | None = None,
    ) -> None:
        self.settings = PlannerSettings(ompl_config, cartesian_limits)
        self.managers: dict[str, PlannerManager] = {
            pipeline_id: factory(self.settings) for pipeline_id, factory in planner_factories().items()}
        for pipeline_id, manager in self.managers.items():
            if manager.pipeline_id != pipeline_id:
                raise ValueError(f"the planner registered as '{pipeline_id}' says its pipeline id is "
                                 f"'{manager.pipeline_id}'")

    @property
    def pipeline_ids(self) -> list[str]:
        return list(self.managers)

    def manager(self, pipeline_id: str) -> PlannerManager | None:
        """The planner of ``pipeline_id`` ("" : OMPL, MoveIt's default pipeline), None when unknown."""
        return self.managers.get(pipeline_id or OMPL_PIPELINE_ID)

    @property
    def ompl(self) -> OmplPlanner:
        """The OMPL planner (its configuration: ``pipeline.ompl.config``)."""
        return self.managers[OMPL_PIPELINE_ID]  # type: ignore[return-value]

    def planner_id_problem(self, planner_id: str, groups: Sequence[str] = ()) -> str | None:
        """Why ``planner_id`` names no planner of any pipeline (None when one has it) for one of
        ``groups`` (default: any group)."""
        problems = []
        for manager in self.managers.values():
            problem = manager.planner_id_problem(planner_id, groups)
            if problem is None:
                return None
            problems.append(problem)
        return f"unknown planner id '{planner_id}': " + "; ".join(problems)

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
        manager = self.manager(request.pipeline_id)
        if manager is None:
            return failure(
                MoveItErrorCode.INVALID_MOTION_PLAN,
                f"unknown planning pipeline '{request.pipeline_id}'; known: {', '.join(self.pipeline_ids)}",
            ).to_response(time.perf_counter(), request)
        # a planner id the chosen pipeline does not offer is refused, never ignored (a pipeline
        # with one planner, joint interpolation, would otherwise plan 'PTP' as a line in joints)
        problem = manager.planner_id_problem(request.planner_id, [request.group])
        if problem is not None:
            return failure(MoveItErrorCode.INVALID_MOTION_PLAN, problem).to_response(time.perf_counter(), request)
        response = manager.plan(scene, request)
        return response if manager.enforces_path_constraints else self._within_path_constraints(request, response)
