"""MoveItCpp's PlanningComponent and plan request parameters, planning with the core pipelines.

Goals are moveit_msgs/Constraints, as MoveIt builds them (a named state or a RobotState become
joint constraints, a PoseStamped a position and an orientation constraint); each goal of the
list is tried in turn until one plans. The multi-pipeline plan runs its requests one after
another in this process (the core's robot model serves one computation at a time; MoveIt runs
them in threads) and answers with the shortest successful path, as getShortestSolution does.
Planned trajectories are made dense (waypoints at most DEFAULT_MAX_WAYPOINT_DISTANCE apart per
joint) with their timing unchanged.
"""
from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any, Callable, Sequence

import rclpy.logging

from interfaces_py.msgs import MoveItErrorCode
from interfaces_py.ros_message_reading import ConversionError
from mycobot_planning.core.errors import PlanningError
from mycobot_planning.core.kinematic_constraints.kinematic_constraints import ConstraintError
from mycobot_planning.core.planning_interface.planning_interface import MotionPlanRequest, PoseGoal
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene as CorePlanningScene
from mycobot_planning.core.robot_state.robot_state import RobotState as CoreRobotState
from mycobot_planning.core.robot_trajectory.robot_trajectory import limit_waypoint_distance
from mycobot_planning.ros.move_group.moveit_translation import goal_from_constraints
from mycobot_planning.task.path_constraints import as_path_constraints

from .core.kinematic_constraints import joint_goal_constraints, pose_goal_constraints
from .core.planning_interface import MotionPlanResponse
from .core.planning_scene import PlanningScene
from .core.robot_state import RobotState, core_state
from .core.robot_trajectory import RobotTrajectory, path_length

if TYPE_CHECKING:  # pragma: no cover - MoveItPy hands itself to the components it makes
    from ._moveit_cpp import MoveItPy

__all__ = ["MultiPipelinePlanRequestParameters", "PlanRequestParameters", "PlanningComponent"]

_LOGGER = rclpy.logging.get_logger("moveit.ros.planning_component")
#: MoveIt's constructGoalConstraints tolerance for a state goal (std::numeric_limits<double>::epsilon()
#: there; the core planners land on a joint goal within 1e-4 anyway)
STATE_GOAL_TOLERANCE = 1e-4


def _parameter(node: Any, name: str, default: Any, kind: type) -> Any:
    if node.has_parameter(name):
        value = node.get_parameter(name).value
        if value is not None:
            try:
                return kind(value)
            except (TypeError, ValueError):
                pass
        _LOGGER.warning(f"Parameter '{name}' not found in config use default value instead, check parameter type "
                        "and namespace in YAML file")
    return default


class PlanRequestParameters:
    """Planner parameters of a request, loaded from ``<ns>.plan_request_params.*`` (or
    ``plan_request_params.*``) of the MoveItPy node, with MoveItCpp's defaults."""

    def __init__(self, moveit_py_instance: MoveItPy | None = None, ns: str = "") -> None:
        self.planner_id = ""
        self.planning_pipeline = ""
        self.planning_time = 1.0
        self.planning_attempts = 5
        self.max_velocity_scaling_factor = 1.0
        self.max_acceleration_scaling_factor = 1.0
        if moveit_py_instance is not None:
            self.load(moveit_py_instance.node, ns)

    def load(self, node: Any, ns: str = "") -> None:
        prefix = f"{ns}.plan_request_params." if ns else "plan_request_params."
        self.planner_id = _parameter(node, prefix + "planner_id", "", str)
        self.planning_pipeline = _parameter(node, prefix + "planning_pipeline", "", str)
        self.planning_time = _parameter(node, prefix + "planning_time", 1.0, float)
        self.planning_attempts = _parameter(node, prefix + "planning_attempts", 5, int)
        self.max_velocity_scaling_factor = _parameter(node, prefix + "max_velocity_scaling_factor", 1.0, float)
        self.max_acceleration_scaling_factor = _parameter(node, prefix + "max_acceleration_scaling_factor", 1.0, float)

    def __repr__(self) -> str:
        return (f"PlanRequestParameters(planning_pipeline={self.planning_pipeline!r}, planner_id={self.planner_id!r}, "
                f"planning_time={self.planning_time}, planning_attempts={self.planning_attempts})")


class MultiPipelinePlanRequestParameters:
    """One PlanRequestParameters per namespace in ``planning_pipeline_names``."""

    def __init__(self, moveit_py_instance: MoveItPy | None = None,
                 planning_pipeline_names: Sequence[str] = ()) -> None:
        self._parameters = [PlanRequestParameters(moveit_py_instance, str(name)) for name in planning_pipeline_names] \
            if moveit_py_instance is not None else []

    @property
    def multi_plan_request_parameters(self) -> list[PlanRequestParameters]:
        return list(self._parameters)


class PlanningComponent:
    """Plans for one joint model group: ``moveit_py.get_planning_component("panda_arm")``."""

    def __init__(self, joint_model_group_name: str, moveit_py_instance: MoveItPy) -> None:
        model = moveit_py_instance._model
        if not model.has_group(joint_model_group_name):
            raise RuntimeError(f"Could not find joint model group '{joint_model_group_name}'.")
        self._moveit = moveit_py_instance
        self._model = model
        self._group = joint_model_group_name
        self._start: CoreRobotState | None = None
        self._goals: list[Any] = []
        self._path_constraints: Any = None

    # ------------------------------------------------------------------ group
    @property
    def planning_group_name(self) -> str:
        return self._group

    @property
    def named_target_states(self) -> list[str]:
        return self._model.named_state_names(self._group)

    def get_named_target_state_values(self, name: str) -> dict[str, float]:
        if name not in self.named_target_states:
            return {}
        return {k: float(v) for k, v in self._model.named_state(name, self._group).items()}

    def _named_state(self, name: str) -> CoreRobotState | None:
        if name not in self.named_target_states:
            _LOGGER.error(f"No predefined joint state found for target name '{name}'")
            return None
        state = CoreRobotState(self._model)
        state.set_named(name, self._group)
        return state

    # ------------------------------------------------------------------ start state
    def set_start_state_to_current_state(self) -> None:
        self._start = None

    def set_start_state(self, configuration_name: str | None = None, robot_state: Any = None) -> bool:
        """The start state: a named state of the group (other joints at their defaults), or a state."""
        if configuration_name is not None and robot_state is not None:
            raise ValueError("Cannot specify both configuration name and robot state")
        if configuration_name is None and robot_state is None:
            raise ValueError("Must specify at least one argument")
        if configuration_name is not None:
            state = self._named_state(configuration_name)
            if state is None:
                return False
            self._start = state
        else:
            self._start = core_state(robot_state).copy()
        return True

    def get_start_state(self) -> RobotState | None:
        """The start state set, else the current state (None without fresh joint states)."""
        if self._start is not None:
            return RobotState._wrap(self._start)
        return self._moveit.current_state()

    # ------------------------------------------------------------------ goal
    def set_goal_state(self, configuration_name: str | None = None, robot_state: Any = None,
                       pose_stamped_msg: Any = None, pose_link: str | None = None,
                       motion_plan_constraints: Sequence[Any] | None = None) -> bool:
        """One goal: a named state, a RobotState, a PoseStamped for ``pose_link``, or a list of
        moveit_msgs/Constraints (alternatives)."""
        given = {"configuration name": configuration_name is not None, "robot state": robot_state is not None,
                 "pose msg": pose_stamped_msg is not None, "motion plan constraints": motion_plan_constraints is not None}
        for a, b in (("configuration name", "robot state"), ("configuration name", "pose msg"),
                     ("configuration name", "motion plan constraints"), ("robot state", "pose msg"),
                     ("robot state", "motion plan constraints"), ("pose msg", "motion plan constraints")):
            if given[a] and given[b]:
                raise ValueError(f"Cannot specify both {a} and {b}")
        if (pose_stamped_msg is None) != (pose_link is None):
            raise ValueError("Must specify both message and corresponding link")
        if not any(given.values()):
            raise ValueError("Must specify at least one argument")
        if configuration_name is not None:
            state = self._named_state(configuration_name)
            if state is None:
                return False
            self._goals = [joint_goal_constraints(state, self._group, STATE_GOAL_TOLERANCE)]
        elif robot_state is not None:
            self._goals = [joint_goal_constraints(robot_state, self._group, STATE_GOAL_TOLERANCE)]
        elif pose_stamped_msg is not None:
            self._goals = [pose_goal_constraints(str(pose_link), pose_stamped_msg)]
        else:
            self._goals = list(motion_plan_constraints or [])
        return True

    def set_path_constraints(self, path_constraints: Any) -> bool:
        """moveit_msgs/Constraints every state of the path must satisfy."""
        self._path_constraints = path_constraints
        return True

    def set_workspace(self, min_x: float, min_y: float, min_z: float, max_x: float, max_y: float, max_z: float) -> None:
        """Accepted and not used: the workspace bounds a mobile base, and the arms here have none
        (MoveIt: "does not limit the workspace of a robot arm")."""

    def unset_workspace(self) -> None:
        """See set_workspace."""

    # ------------------------------------------------------------------ planning
    def plan(self, single_plan_parameters: PlanRequestParameters | None = None,
             multi_plan_parameters: MultiPipelinePlanRequestParameters | None = None,
             planning_scene: PlanningScene | None = None,
             solution_selection_function: Callable[[list[MotionPlanResponse]], MotionPlanResponse] | None = None,
             stopping_criterion_callback: Any = None) -> MotionPlanResponse:
        """Plan from the start state to the goal: with the node's ``plan_request_params``, the
        given parameters, or several pipelines (the shortest successful path, or what
        ``solution_selection_function`` picks from the list of responses)."""
        if single_plan_parameters is not None and multi_plan_parameters is not None:
            raise ValueError("Cannot specify both single and multi plan parameters")
        if single_plan_parameters is None and multi_plan_parameters is None and planning_scene is not None:
            raise ValueError("Cannot specify planning scene without specifying plan parameters")
        if multi_plan_parameters is not None:
            responses = [self._plan_one(p, planning_scene) for p in multi_plan_parameters.multi_plan_request_parameters]
            if not responses:
                return MotionPlanResponse(MoveItErrorCode(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS,
                                                          "MotionPlanResponse vector was empty after parallel planning"))
            select = solution_selection_function or shortest_solution
            return select(responses)
        parameters = single_plan_parameters
        if parameters is None:
            parameters = PlanRequestParameters(self._moveit)
        return self._plan_one(parameters, planning_scene)

    def _failure(self, code: int, message: str, parameters: PlanRequestParameters, started: float
                 ) -> MotionPlanResponse:
        _LOGGER.error(message)
        return MotionPlanResponse(MoveItErrorCode(code, message, "moveit_py"), None, time.perf_counter() - started,
                                  None, parameters.planner_id)

    def _plan_one(self, parameters: PlanRequestParameters, planning_scene: PlanningScene | None) -> MotionPlanResponse:
        started = time.perf_counter()
        if not self._goals:
            return self._failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "No goal constraints set for planning request",
                                 parameters, started)
        pipeline = self._moveit._pipelines.get(parameters.planning_pipeline)
        if pipeline is None:
            hint = "" if parameters.planning_pipeline else "; set plan_request_params.planning_pipeline, e.g. to ompl"
            return self._failure(MoveItErrorCode.FAILURE, "No planning pipeline available for name "
                                 f"'{parameters.planning_pipeline}' (loaded: {sorted(self._moveit._pipelines)}){hint}",
                                 parameters, started)
        scene = self._scene(planning_scene)
        if isinstance(scene, MotionPlanResponse):
            return scene
        try:
            path_constraints = (as_path_constraints(self._path_constraints).resolve(scene)
                                if self._path_constraints is not None else None)
        except (ConstraintError, ValueError, TypeError, KeyError) as exc:
            return self._failure(MoveItErrorCode.INVALID_MOTION_PLAN, f"invalid path constraints: {exc}", parameters,
                                 started)
        response = None
        for constraints in self._goals:
            try:
                goal = self._goal(constraints, scene)
            except ValueError as exc:
                return self._failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, str(exc), parameters, started)
            request = MotionPlanRequest(
                self._group, goal, start_state=scene.current_state.copy(), pipeline_id=parameters.planning_pipeline,
                planner_id=parameters.planner_id, allowed_planning_time=float(parameters.planning_time),
                num_planning_attempts=max(1, int(parameters.planning_attempts)),
                max_velocity_scaling_factor=float(parameters.max_velocity_scaling_factor),
                max_acceleration_scaling_factor=float(parameters.max_acceleration_scaling_factor),
                path_constraints=path_constraints)
            response = pipeline.plan(scene, request)
            if response.success:
                break
        assert response is not None
        start = RobotState._wrap(scene.current_state.copy())
        if not response.success or response.trajectory is None:
            _LOGGER.error(f"Planning with '{parameters.planning_pipeline}' failed: {response.error_code.name}: "
                          f"{response.error_code.message}")
            return MotionPlanResponse(response.error_code, None, response.planning_time, start,
                                      parameters.planner_id)
        trajectory = RobotTrajectory._wrap(limit_waypoint_distance(response.trajectory), self._group,
                                           scene.current_state)
        return MotionPlanResponse(response.error_code, trajectory, time.perf_counter() - started, start,
                                  response.planner_id or parameters.planner_id)

    def _scene(self, planning_scene: PlanningScene | None) -> CorePlanningScene | MotionPlanResponse:
        """The scene to plan in (a copy), its current state the start state."""
        if planning_scene is not None:
            scene = planning_scene._scene.copy()
        else:
            scene = self._moveit.get_planning_scene_monitor().core.scene_copy()
        if self._start is not None:
            scene.set_current_state(self._start)
            return scene
        problem = self._moveit.get_planning_scene_monitor().core.joint_state_problem(
            self._model.group(self._group).joint_names)
        if problem is not None:
            code, message = problem
            _LOGGER.error(f"Did not receive robot state: {message}")
            return MotionPlanResponse(MoveItErrorCode(code, message, "moveit_py"))
        return scene

    def _goal(self, constraints: Any, scene: CorePlanningScene) -> Any:
        """A moveit_msgs/Constraints as the core's goal (a pose goal posed in the world frame)."""
        try:
            goal, frame = goal_from_constraints(constraints)
        except ConversionError as exc:
            raise ValueError(str(exc)) from None
        except (AttributeError, TypeError) as exc:
            raise ValueError(f"goal constraints must be moveit_msgs/Constraints: {exc}") from None
        if isinstance(goal, PoseGoal) and frame not in ("world", "/world"):
            try:
                goal.pose = scene.frame_pose(frame) @ goal.pose
            except PlanningError as exc:
                raise ValueError(f"pose goal: {exc}") from None
        return goal


def shortest_solution(responses: list[MotionPlanResponse]) -> MotionPlanResponse:
    """MoveIt's getShortestSolution: the successful response with the shortest path (the first
    response when none succeeded)."""
    successful = [r for r in responses if r]
    if not successful:
        return responses[0]
    return min(successful, key=lambda r: path_length(r.trajectory.timed_trajectory))
