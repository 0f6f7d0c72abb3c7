"""MTC's PipelinePlanner: the planning pipelines by id and planner id, as move_group offers them."""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

from ...core.trajectory_processing.trajectory_validator import validate_trajectory
from ...core.planning_interface.planning_interface import JointGoal, MotionPlanRequest, PoseGoal
from ...core.planning_interface.planning_pipeline import PlanningPipeline
from ...core.planning_scene.planning_scene import PlanningScene
from ..errors import TaskError
from .planner_interface import PlannerInterface, PlanResult, constraint_failure, default_pipeline, plan_seed

if TYPE_CHECKING:  # pragma: no cover
    from ...core.robot_model.robot_model import RobotModel


class PipelinePlanner(PlannerInterface):
    """Plans with the planning pipelines (OMPL, industrial), as MTC's PipelinePlanner.

    ``PipelinePlanner("ompl")``, ``PipelinePlanner("ompl", "RRTConnectkConfigDefault")`` or
    MTC's map form ``PipelinePlanner({"pilz_industrial_motion_planner": "PTP"})``. With several
    pipelines in the map they are tried in order and the first success is used.
    """

    def __init__(self, pipeline_id_planner_id_map: Any = "ompl", planner_id: str = "", *args: str,
                 pipeline: PlanningPipeline | None = None) -> None:
        super().__init__()
        node = None if isinstance(pipeline_id_planner_id_map, (str, Mapping)) else pipeline_id_planner_id_map
        if not isinstance(pipeline_id_planner_id_map, (str, Mapping)):
            # MTC's ros2 form PipelinePlanner(node, "ompl", "RRTConnectkConfigDefault"): planning
            # runs here, on the task's robot; the node only lets a task load that robot.
            if len(args) > 1:
                raise TaskError("PipelinePlanner(node, pipeline, planner_id) takes at most three arguments")
            pipeline_id_planner_id_map, planner_id = planner_id or "ompl", (args[0] if args else "")
        elif args:
            raise TaskError("PipelinePlanner: too many arguments; expected (pipeline, planner_id), "
                            "(node, pipeline, planner_id) or ({pipeline: planner_id})")
        if isinstance(pipeline_id_planner_id_map, str):
            mapping = {pipeline_id_planner_id_map: planner_id}
        elif isinstance(pipeline_id_planner_id_map, Mapping):
            if planner_id:
                raise TaskError("give the planner id inside the pipeline map, not as a second argument")
            mapping = {str(k): str(v) for k, v in pipeline_id_planner_id_map.items()}
        else:
            raise TaskError(f"PipelinePlanner: expected a pipeline id or a {{pipeline: planner_id}} map, "
                            f"got {type(pipeline_id_planner_id_map).__name__}")
        if not mapping:
            raise TaskError("PipelinePlanner: the pipeline map is empty")
        p = self._properties
        p.declare("pipeline_id_planner_id_map", mapping, "pipelines and their planner ids, tried in order", type=dict)
        p.declare("num_planning_attempts", 1, "number of planning attempts", type=int)
        p.declare("goal_joint_tolerance", 1e-4, "tolerance for reaching joint goals", type=float)
        p.declare("goal_position_tolerance", 1e-4, "tolerance for reaching position goals", type=float)
        p.declare("goal_orientation_tolerance", 1e-3, "tolerance for reaching orientation goals", type=float)
        p.declare("validate_solution", True, "check every planned trajectory with the trajectory validator and "
                  "re-plan (new seed) when it fails (skipped when the pipeline already validated it, as "
                  "the OMPL pipeline does)", type=bool)
        p.declare("max_validation_retries", 2, "re-plans after a trajectory failed validation", type=int)
        object.__setattr__(self, "_pipeline", pipeline)
        object.__setattr__(self, "_last_planner", "")
        #: the ROS node of MTC's PipelinePlanner(node, ...) form: a Task without a robot model
        #: loads its model through it (see Task.init)
        object.__setattr__(self, "node", node)

    def setPlannerId(self, pipeline_id: str, planner_id: str) -> bool:
        mapping = dict(self._properties["pipeline_id_planner_id_map"])
        if pipeline_id not in mapping:
            return False
        mapping[pipeline_id] = planner_id
        self._properties.set("pipeline_id_planner_id_map", mapping)
        return True

    @property
    def pipeline(self) -> str:
        """The (first) planning pipeline's id, MTC's ``pipeline`` property."""
        return next(iter(self._properties["pipeline_id_planner_id_map"]))

    @pipeline.setter
    def pipeline(self, pipeline_id: str) -> None:
        self._properties.set("pipeline_id_planner_id_map", {str(pipeline_id): self.planner})

    @property
    def planner(self) -> str:
        """The (first) pipeline's planner id, MTC's ``planner`` property ("" means its default)."""
        return next(iter(self._properties["pipeline_id_planner_id_map"].values()))

    @planner.setter
    def planner(self, planner_id: str) -> None:
        mapping = dict(self._properties["pipeline_id_planner_id_map"])
        mapping[next(iter(mapping))] = str(planner_id)
        self._properties.set("pipeline_id_planner_id_map", mapping)

    @property
    def planner_id(self) -> str:
        if self._last_planner:
            return self._last_planner
        return ", ".join(f"{k}:{v}" if v else k for k, v in self._properties["pipeline_id_planner_id_map"].items())

    def init(self, robot_model: "RobotModel") -> None:
        super().init(robot_model)
        pipeline = self._pipeline or default_pipeline()
        for pipeline_id in self._properties["pipeline_id_planner_id_map"]:
            if pipeline_id not in pipeline.pipeline_ids:
                raise ValueError(f"unknown planning pipeline '{pipeline_id}'; known: {', '.join(pipeline.pipeline_ids)}")
        attempts = self._properties["num_planning_attempts"]
        if attempts < 1:
            raise ValueError(f"num_planning_attempts must be >= 1, got {attempts}")

    def _plan(self, scene: PlanningScene, group: str, goal, timeout: float, context,
              path_constraints: Any = None) -> PlanResult:
        constraints, failed = constraint_failure(self, path_constraints, scene)
        if failed is not None:
            return failed
        pipeline = self._pipeline
        if pipeline is None:
            pipeline = context.pipeline if context is not None else default_pipeline()
        velocity, acceleration = self._scaling()
        timeout = self._timeout(timeout)
        messages = []
        for pipeline_id, planner_id in self._properties["pipeline_id_planner_id_map"].items():
            request = MotionPlanRequest(
                group,
                goal,
                start_state=scene.current_state,
                pipeline_id=pipeline_id,
                planner_id=planner_id,
                allowed_planning_time=timeout,
                num_planning_attempts=int(self._properties["num_planning_attempts"]),
                max_velocity_scaling_factor=velocity,
                max_acceleration_scaling_factor=acceleration,
                seed=plan_seed(context),
                path_constraints=constraints,
            )
            retries = int(self._properties["max_validation_retries"]) if self._properties["validate_solution"] else 0
            for attempt in range(retries + 1):
                if attempt:
                    request.seed = plan_seed(context) if request.seed is not None else None
                response = pipeline.plan(scene, request)
                if not response.success:
                    messages.append(f"{pipeline_id}{'/' + planner_id if planner_id else ''}: {response.error_code}")
                    break
                if self._properties["validate_solution"] and not response.validated:
                    # Joint limits unscaled: the industrial LIN/CIRC scale Cartesian limits, not joint ones.
                    report = validate_trajectory(scene, response.trajectory, group, scene.current_state)
                    if not report.valid:
                        messages.append(f"{pipeline_id}{'/' + planner_id if planner_id else ''}: computed path is not "
                                        f"valid: {'; '.join(report.problems[:2])}")
                        continue
                object.__setattr__(self, "_last_planner", response.planner_id or planner_id)
                return PlanResult(True, response.trajectory, response.message, response.planner_id or planner_id)
        return PlanResult(False, None, "; ".join(messages), planner_id)

    def plan(self, from_scene, to_scene, group, timeout, context=None, path_constraints=None):
        values = to_scene.current_state.group_positions(group)
        goal = JointGoal(values, tolerance=float(self._properties["goal_joint_tolerance"]))
        return self._plan(from_scene, group, goal, timeout, context, path_constraints)

    def plan_pose(self, from_scene, link, offset, target, group, timeout, context=None, path_constraints=None):
        goal = PoseGoal(np.asarray(target, dtype=float), link=link, ik_frame_offset=np.asarray(offset, dtype=float),
                        position_tolerance=float(self._properties["goal_position_tolerance"]),
                        orientation_tolerance=float(self._properties["goal_orientation_tolerance"]))
        return self._plan(from_scene, group, goal, timeout, context, path_constraints)


