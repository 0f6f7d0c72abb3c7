"""MoveIt's MoveGroupContext (move_group_context.hpp): what every move_group capability works
on: the monitored scene and current state (it is the PlanningSceneMonitor), the planning
pipeline with its planning contexts, the trajectory execution manager, the request defaults, and
the last plan. Capabilities (one module each in this package) are typed calls on a context; the
faces (moveit_msgs in ros/move_group/move_group.py, JSON in json_face.py) only translate.

Thread-safe: ROS callbacks (joint states, scene updates, requests, stop) arrive on several
executor threads. The scene is guarded by one lock held only for short updates; planning works on
a copy of the scene, so joint states keep flowing while a planner runs; executions are serialised
by the execution manager (one at a time, stop always answered).
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence, TypeVar

import numpy as np

from interfaces_py.msgs import (
    JointTrajectory,
    MessageError,
    MoveItErrorCode,
    PlanningScene as PlanningSceneMsg,
    RobotState as RobotStateMsg,
)

from ..core.errors import SceneError, StateError
from ..core.kinematic_constraints.kinematic_constraints import ConstraintError, PathConstraints, path_constraints_from_json
from ..core.planning_interface.planning_context import PlanningContext
from ..core.planning_interface.planning_workers import PlanningWorkers
from ..core.planning_interface.planning_interface import (
    JointGoal,
    MotionPlanRequest,
    MotionPlanResponse,
    NamedGoal,
    PoseGoal,
)
from ..core.planning_scene.planning_scene import PlanningScene
from ..core.planning_scene.planning_scene_monitor import PlanningSceneMonitor, RequestError
from ..core.robot_model.robot_model import RobotModel
from ..core.trajectory_execution import (
    ControllerBus,
    ControllerInfo,
    ExecutionSettings,
    TrajectoryExecutionManager,
    load_controllers,
)
from .state_queries import StateQueries

__all__ = ["MoveGroupContext", "NoControllers", "PlanningDefaults", "RequestError", "SOURCE", "check_number",
           "planning_only"]

#: the error codes' source when move_group itself refuses a request
SOURCE = "planning_server"


@dataclass
class PlanningDefaults:
    """What a request does not say (MoveIt's plan_request_params)."""

    pipeline_id: str = "ompl"
    planner_id: str = ""
    planning_time: float = 5.0
    num_planning_attempts: int = 1
    max_velocity_scaling_factor: float = 1.0
    max_acceleration_scaling_factor: float = 1.0
    sample_period: float = 0.1  # s between published trajectory points, as MoveIt's resample_dt (0: planner breakpoints only)


def check_number(value: Any, what: str, code: int = MoveItErrorCode.INVALID_MOTION_PLAN) -> float:
    """A finite number, else RequestError(code)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise RequestError(code, f"{what} must be a finite number, got {value!r}")
    return float(value)


def check_tolerance(value: Any, what: str) -> float:
    """A goal tolerance: a finite number >= 0, else RequestError(INVALID_GOAL_CONSTRAINTS) (both
    faces read tolerances through this: a NaN or negative one is refused, never replaced)."""
    number = check_number(value, what, MoveItErrorCode.INVALID_GOAL_CONSTRAINTS)
    if number < 0:
        raise RequestError(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, f"{what} must not be negative, got {number:g}")
    return number


def check_goal(model: Any, goal: Any) -> None:
    """The typed goal a face built, checked where every face's request enters the capabilities
    (plan.complete_request): finite joint values of joints the robot has, finite non-negative
    tolerances, a finite pose. RequestError(INVALID_GOAL_CONSTRAINTS) otherwise."""
    bad = MoveItErrorCode.INVALID_GOAL_CONSTRAINTS
    if isinstance(goal, JointGoal):
        check_tolerance(goal.tolerance, "goal tolerance")
        if isinstance(goal.values, Mapping):
            known = set(model.variable_names) | set(model.joint_names)
            unknown = [name for name in goal.values if name not in known]
            if unknown:
                raise RequestError(bad, f"goal names joints {unknown} that robot '{model.name}' does not have")
            values = list(goal.values.values())
        else:
            values = list(np.asarray(goal.values, dtype=float).ravel())
        for value in values:
            check_number(value, "goal joint value", bad)
    elif isinstance(goal, NamedGoal):
        check_tolerance(goal.tolerance, "goal tolerance")
    elif isinstance(goal, PoseGoal):
        check_tolerance(goal.position_tolerance, "position tolerance")
        check_tolerance(goal.orientation_tolerance, "orientation tolerance")
        if not np.all(np.isfinite(np.asarray(goal.pose, dtype=float))):
            raise RequestError(bad, "goal pose must be finite")


class NoControllers:
    """A ControllerBus with no controller behind it, for a context that only plans (benches,
    in-process references): nothing is ever sent to a controller."""

    def is_available(self, controller: str) -> bool:
        return False

    def send(self, controller: str, trajectory: JointTrajectory) -> None:
        raise RuntimeError("this move_group context only plans: it executes nothing")

    def stop(self, controller: str) -> None:
        pass

    def controller_state(self, controller: str, goal_id: str | None = None) -> None:
        return None


class MoveGroupContext(PlanningSceneMonitor):
    """The state move_group's capabilities share (see the module docstring)."""

    def __init__(
        self,
        model: RobotModel,
        pipeline: Any,
        controllers: Sequence[ControllerInfo],
        bus: ControllerBus,
        settings: ExecutionSettings | None = None,
        defaults: PlanningDefaults | None = None,
        clock: Callable[[], float] = time.monotonic,
        log: Callable[[str, str], None] | None = None,
        workers: PlanningWorkers | None = None,
    ) -> None:
        """Plans of several clients run at once, each in a PlanningContext of its own on the one
        model and pipeline (see core/planning_interface/planning_context.py); with ``workers``,
        in worker processes that run the same pipeline (planning_workers.py)."""
        super().__init__(model, clock, log)
        self.pipeline = pipeline
        self.workers = workers
        self.planning: set[PlanningContext] = set()  # the plans running now (stop terminates them)
        self.shutting_down = False  # stop.shut_down(): every plan started from then on is refused
        self.defaults = defaults or PlanningDefaults()
        #: (trajectory, group) of the last successful plan, what execute() without a trajectory runs
        self.last_plan: tuple[JointTrajectory, str] | None = None
        self.last_plan_problem = "nothing has been planned yet"
        self.trajectory_listeners: list[Callable[[JointTrajectory], None]] = []
        self.executor = TrajectoryExecutionManager(
            model, controllers, bus, self.joint_positions, settings or ExecutionSettings(), clock=clock, log=self._log,
            scene_source=self.scene_copy,
        )
        # MoveIt's plan_execution: every change of the monitored scene re-checks the path ahead
        self.scene_listeners.append(self.executor.scene_changed)
        self.queries = StateQueries(model)
        #: capabilities/trajectory_cache.py's MoveGroupTrajectoryCache once configured (None: no cache)
        self.trajectory_cache: Any = None

    def log(self, level: str, text: str) -> None:
        self._log(level, text)

    # ------------------------------------------------------------------ settings
    @property
    def settings(self) -> ExecutionSettings:
        return self.executor.settings

    @settings.setter
    def settings(self, value: ExecutionSettings) -> None:
        self.executor.settings = value

    @property
    def joint_state_timeout(self) -> float:
        return self.executor.settings.joint_state_timeout

    def _joint_state_arrived(self) -> None:
        self.executor.notify()

    def limit_problems(self, values: Mapping[str, float]) -> list[str]:
        return self._limit_problems(values)

    # ------------------------------------------------------------------ what capabilities share
    def running_plans(self) -> list[PlanningContext]:
        """The planning contexts of the plans running now (stop terminates them)."""
        with self._lock:
            return list(self.planning)

    def start_scene(self, start_state: Any, group_joints: Sequence[str], scene_diff: Any = None) -> PlanningScene:
        """A copy of the monitored scene whose current state is the request's start state.

        A start state naming every active joint needs no joint states; otherwise its joints (if
        any) are merged onto the current state, which must be fresh (RequestError otherwise).
        ``scene_diff`` (a PlanningScene message, MoveIt's planning_options.planning_scene_diff)
        is applied to the copy first: this request's scene only, the live one keeps nothing.
        """
        msg = None
        if start_state is not None:
            try:
                msg = start_state if isinstance(start_state, RobotStateMsg) else RobotStateMsg.from_dict(start_state)
            except MessageError as exc:
                raise RequestError(MoveItErrorCode.INVALID_ROBOT_STATE, f"invalid start_state: {exc}") from None
        given = msg.joint_positions() if msg is not None else {}
        mimic = set(self.model.mimic_joint_names)
        active = {n: v for n, v in given.items() if n not in mimic}
        unknown = [n for n in active if n not in self.model.variable_names]
        if unknown:
            raise RequestError(MoveItErrorCode.INVALID_ROBOT_STATE,
                               f"start_state names joints {unknown} that robot '{self.model.name}' does not have")
        outside = self._limit_problems(active)
        if outside:
            raise RequestError(MoveItErrorCode.INVALID_ROBOT_STATE,
                               "start_state is outside the joint limits: " + "; ".join(outside))
        complete = all(n in active for n in self.model.variable_names)
        if not complete:
            problem = self.joint_state_problem([j for j in group_joints if j not in active])
            if problem is not None:
                raise RequestError(*problem)
        scene = self.scene_copy() if scene_diff is None else self.scene_with_diff(scene_diff)
        try:
            if active:
                scene.set_current_state(active)
            if msg is not None:
                for attached in msg.attached_collision_objects:
                    scene.apply_attached_collision_object(attached)
        except (StateError, SceneError, ValueError) as exc:
            raise RequestError(MoveItErrorCode.INVALID_ROBOT_STATE, f"invalid start_state: {exc}") from None
        return scene

    def in_world(self, poses: list[np.ndarray], frame: str, scene: PlanningScene) -> list[np.ndarray]:
        """Waypoints given in ``frame`` (the world, the robot's root link or any robot link, posed
        at the start state, as MoveIt reads a waypoint's header.frame_id) in the world frame."""
        if frame in ("world", "/world", self.model.root_link):
            return poses
        if not self.model.has_link(frame):
            raise RequestError(MoveItErrorCode.FRAME_TRANSFORM_FAILURE,
                               f"unknown frame {frame!r}: waypoints may be given in 'world', "
                               f"'{self.model.root_link}' or a link of robot '{self.model.name}'")
        base = scene.current_state.frame_pose(frame)
        return [base @ pose for pose in poses]

    def resolve_path_constraints(self, data: Any, scene: PlanningScene) -> PathConstraints | None:
        """The request's path constraints ({"joints", "orientation", "position"}, see
        core/kinematic_constraints/kinematic_constraints.py), frames resolved at the start state."""
        if data is None:
            return None
        if not isinstance(data, Mapping) or set(data) - {"joints", "orientation", "position"}:
            raise RequestError(MoveItErrorCode.INVALID_MOTION_PLAN,
                               "path_constraints must be an object with 'joints', 'orientation' and 'position' lists")

        def frame_pose(frame: str) -> np.ndarray:
            try:
                return scene.frame_pose(frame)
            except SceneError as exc:
                raise RequestError(MoveItErrorCode.FRAME_TRANSFORM_FAILURE, f"path constraint frame: {exc}") from None

        try:
            constraints = path_constraints_from_json(data, scene.current_state, frame_pose)
        except (ConstraintError, KeyError, TypeError, ValueError) as exc:
            if isinstance(exc, RequestError):
                raise
            raise RequestError(MoveItErrorCode.INVALID_MOTION_PLAN, f"invalid path constraint: {exc}") from None
        return constraints or None

    def shut_down(self) -> None:
        """From now on every plan and every execution that starts is refused, PREEMPTED
        (capabilities/stop.py's shut_down)."""
        with self._lock:
            self.shutting_down = True
        self.executor.shut_down()

    def plan_in_context(self, scene: PlanningScene, request: MotionPlanRequest) -> Any:
        """Plan in a planning context of its own, terminated by stop()."""
        context = PlanningContext(self.workers or self.pipeline, scene, request)
        with self._lock:
            if self.shutting_down:  # a plan that missed the shutdown's stop
                return MotionPlanResponse(MoveItErrorCode(MoveItErrorCode.PREEMPTED,
                                                          "planning refused: move_group is shutting down"),
                                          group_name=request.group, planner_id=request.planner_id)
            self.planning.add(context)
        try:
            return context.solve()
        finally:
            with self._lock:
                self.planning.discard(context)
            context.clear()

    def wait_for_rest(self, joints: Sequence[str], timeout: float = 2.0, tolerance: float = 1e-4,
                      settle: float = 0.03) -> bool:
        """Whether /joint_states shows ``joints`` at rest (two readings ``settle`` s apart within
        ``tolerance``) within ``timeout`` s: what replanning waits for after a stop, so that the
        new plan starts where the arm really is."""
        deadline = time.monotonic() + timeout
        reference: tuple[float, list[float]] | None = None
        while time.monotonic() < deadline:
            positions, age = self.joint_positions()
            if positions is not None and all(j in positions for j in joints):
                values = [positions[j] for j in joints]
                now = time.monotonic()
                if reference is None:
                    reference = (now, values)
                elif now - reference[0] >= settle:
                    if max(abs(a - b) for a, b in zip(values, reference[1])) <= tolerance:
                        return True
                    reference = (now, values)
            time.sleep(0.005)
        return False

    def display(self, trajectory: JointTrajectory) -> None:
        for listener in list(self.trajectory_listeners):
            try:
                listener(trajectory)
            except Exception as exc:
                self._log("error", f"publishing the planned trajectory failed: {exc}")

    def apply_diff_live(self, diff: PlanningSceneMsg) -> None:
        with self._lock:
            self.scene.apply_planning_scene_msg(diff)
        self._changed()

    def run(self, wait: bool, work: Callable[[], Any], what: str) -> str | None:
        """Run ``work`` now (``wait``) or in a background thread; None when it ran or started,
        else why it was refused (another execution runs)."""
        if wait:
            work()
            return None
        if self.executor.executing_after_stop():
            status = self.executor.status()
            return (f"refused: another execution ({status['description']}) is in progress; "
                    "stop it first or wait for it to finish")
        threading.Thread(target=work, name=f"planning_server {what}", daemon=True).start()
        return None

    def get_state(self, controller_states: Mapping[str, Any] | None = None) -> dict[str, Any]:
        positions, age = self.joint_positions()
        with self._lock:
            state = self.scene.current_state
            robot_state = RobotStateMsg(joint_names=list(self.model.variable_names),
                                        positions=[float(v) for v in state.positions]).to_dict()
        return {
            "robot_state": robot_state,
            "joint_state_age": age,
            "joint_state_received": positions is not None,
            "execution": self.executor.status(),
            "planning": len(self.planning),  # plans running now (stop cancels them)
            "has_plan": self.last_plan is not None,
            "controllers": dict(controller_states or {}),
            "trajectory_cache": (self.trajectory_cache.status(self.model) if self.trajectory_cache is not None
                                 else {"enabled": False}),
        }


C = TypeVar("C", bound=MoveGroupContext)


def planning_only(context_type: type[C], model: RobotModel, pipeline: Any, **kwargs: Any) -> C:
    """An in-process ``context_type`` (MoveGroupContext or a face of it) that plans, solves IK and
    keeps a scene but has no controllers: what benches and in-process references build."""
    return context_type(model, pipeline, load_controllers(None), NoControllers(), **kwargs)
