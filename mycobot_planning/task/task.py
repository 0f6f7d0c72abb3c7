"""Task: a robot model, a start scene and a tree of stages, planned into sorted solutions.

The full story: docs/task.md, section mycobot_planning.task.task.
"""
from __future__ import annotations

import importlib
import itertools
import logging
import math
import sys
import time
from typing import Any, Callable, Iterable, TextIO

import numpy as np

from interfaces_py.msgs import JointTrajectory, MoveItErrorCode, TaskDescription, TaskSolution, TaskStatistics

from ..core.kinematics.ik_solver import IKSolver, thread_ik_solver
from ..core.planning_interface.planning_pipeline import PlanningPipeline
from ..core.planning_scene.planning_scene import PlanningScene
from ..core.robot_model.robot_model import RobotModel
from .containers import ContainerBase, SerialContainer
from .errors import TaskError
from .introspection import explain_failure, print_state, stage_summary, task_description, task_statistics
from .stage import Stage
from .storage import GENERATE, Interface, SolutionBase
from .properties import PropertyMap
from .solution_export import solution_joint_trajectory, solution_to_msg
from .solvers import default_pipeline

_EYE4 = np.eye(4)
#: np.allclose(offset, eye(4), atol=1e-12)'s tolerance, entry by entry
_IDENTITY_TOLERANCE = 1e-12 + 1e-5 * _EYE4

_LOG = logging.getLogger("mycobot_planning.task")

__all__ = ["Task", "TaskContext"]

#: The module that gives a Task its ROS side when a script hands it a node: loaded by name, as
#: pluginlib loads a plugin, so that this package never imports rclpy (see
#: ros/task/task_ros_interface.py).
ROS_INTERFACE_MODULE = "mycobot_planning.ros.task.task_ros_interface"


def ros_interface(node: Any) -> Any:
    """The ROS side (TaskRosInterface) for ``node``; TaskError when ROS is unavailable."""
    try:
        module = importlib.import_module(ROS_INTERFACE_MODULE)
    except ImportError as exc:
        raise TaskError(f"a ROS node was given, but ROS is not available here: {exc}") from None
    try:
        return module.TaskRosInterface(node)
    except TypeError as exc:
        raise TaskError(str(exc)) from None


#: Default stream of printState / explainFailure: whatever sys.stdout is at the call (so
#: contextlib.redirect_stdout captures them, as it does MTC's).
STDOUT = object()


def _write(text: str, stream: TextIO | None | object) -> str:
    out = sys.stdout if stream is STDOUT else stream
    if out is not None:
        out.write(text)  # type: ignore[union-attr]
    return text


class TaskContext:
    """What stages share while a task plans: the model, the random source, solution ids,
    IK solvers (the planning thread's, thread_ik_solver: built once per group/link/offset and
    kept across tasks) and the planning pipeline."""

    def __init__(self, task: "Task") -> None:
        self.task = task
        self.robot_model: RobotModel = task.robot_model  # type: ignore[assignment]
        self.root: ContainerBase = task.stages
        self._rng = None if task.seed is None else np.random.default_rng(task.seed)
        self._ids = itertools.count(1)
        self.reuse_plans = task.reuse_plans
        self.plan_cache: dict = {}
        self.plan_cache_size = 4096

    def next_seed(self) -> int | None:
        """A seed for the next random query (None when the task has no seed: truly random)."""
        if self._rng is None:
            return None
        return int(self._rng.integers(0, 2**31 - 1))

    def next_solution_id(self) -> int:
        return next(self._ids)

    @property
    def pipeline(self) -> PlanningPipeline:
        if self.task.pipeline is not None:
            return self.task.pipeline

        return default_pipeline()

    def ik_solver(self, group: str, link: str, offset: np.ndarray) -> IKSolver:
        # np.allclose's test (atol 1e-12, rtol 1e-5) without its wrappers (~25 us a call, and
        # every IK stage asks for its solver on every computation)
        identity = bool(np.all(np.abs(np.asarray(offset, dtype=float) - _EYE4) <= _IDENTITY_TOLERANCE))
        return thread_ik_solver(self.robot_model, group, link, None if identity else offset)

    def current_scene(self, timeout: float) -> PlanningScene:
        return self.task._current_scene(timeout)


class Task:
    """A planning task (MTC's Task): owns the robot model, the start scene and the stages."""

    def __init__(self, name: str = "", model: RobotModel | None = None, scene: PlanningScene | None = None, *,
                 seed: int | None = None, pipeline: PlanningPipeline | None = None,
                 container: ContainerBase | None = None) -> None:
        self._root = container if container is not None else SerialContainer(name or "task")
        if container is not None and name:
            self._root.setName(name)
        self._model: RobotModel | None = None
        self._scene: PlanningScene | None = None
        self._scene_provider: Callable[[float], PlanningScene] | None = None
        self.seed = seed
        self.pipeline = pipeline
        #: Reuse results of identical deterministic planner queries within one plan() (see
        #: solvers.PlannerInterface._memoized); False plans every stage afresh, as MTC does.
        self.reuse_plans = True
        self._timeout = math.inf
        self._preempt = False
        self._task_callbacks: list[Callable[["Task"], None]] = []
        self._pending_backward = Interface()
        self._pending_forward = Interface()
        self._context: TaskContext | None = None
        self._planning_time = 0.0
        self._initialized = False
        self._ros: Any = None  # TaskRosInterface once a node is known (loadRobotModel)
        self._introspection_enabled = True
        self._introspection: Any = None
        if model is not None:
            self.setRobotModel(model)
        if scene is not None:
            self.setScene(scene)

    # ------------------------------------------------------------------ configuration
    @property
    def name(self) -> str:
        return self._root.name

    @name.setter
    def name(self, value: str) -> None:
        self._root.setName(value)

    def setName(self, name: str) -> None:
        self._root.setName(name)

    @property
    def stages(self) -> ContainerBase:
        """The root container (MTC's task.stages())."""
        return self._root

    @property
    def robot_model(self) -> RobotModel | None:
        return self._model

    def getRobotModel(self) -> RobotModel | None:
        return self._model

    def loadRobotModel(self, node: Any, robot_description: str = "robot_description") -> None:
        """MTC's loadRobotModel: the robot the node's ``robot_description`` parameters describe,
        else the running planning_server's (move_group's). The node then also gives CurrentState
        the planning_server's current scene (unless a scene was set) and publish() / execute()
        their ROS side."""
        if not isinstance(robot_description, str) or not robot_description:
            raise TaskError(f"robot_description must be a parameter name, got {robot_description!r}")
        ros = ros_interface(node)
        try:
            model = ros.load_robot_model(robot_description)
        except (TimeoutError, ValueError) as exc:
            raise TaskError(f"loading the robot model failed: {exc}") from None
        self._ros = ros
        self.setRobotModel(model)
        if self._scene is None and self._scene_provider is None:
            self._scene_provider = lambda timeout: ros.fetch_scene(model, timeout)
        _LOG.info("task '%s': robot '%s' loaded (groups %s)", self.name, model.name, ", ".join(model.group_names))

    def _node_of_planners(self) -> Any:
        """The node of the first MTC-style ``PipelinePlanner(node, ...)`` the stages plan with."""
        pending: list[Any] = []
        for stage, _depth in self._root.traverseRecursively():
            pending.append(getattr(stage, "_planner", None))
            pending += [planner for _group, planner in getattr(stage, "_planners", ())]
        while pending:
            planner = pending.pop(0)
            if planner is None:
                continue
            if getattr(planner, "node", None) is not None:
                return planner.node
            pending += list(getattr(planner, "_planners", ()))  # MultiPlanner
        return None

    def setRobotModel(self, model: RobotModel) -> None:
        if not isinstance(model, RobotModel):
            raise TaskError(f"expected a RobotModel, got {type(model).__name__}")
        if self._model is not None and self._model is not model:
            self.reset()
        self._model = model

    @property
    def scene(self) -> PlanningScene | None:
        """The start scene CurrentState uses (unless a scene provider is set)."""
        return self._scene

    def setScene(self, scene: PlanningScene | None) -> None:
        if scene is not None:
            if not isinstance(scene, PlanningScene):
                raise TaskError(f"expected a PlanningScene, got {type(scene).__name__}")
            if self._model is None:
                self._model = scene.robot_model
            elif scene.robot_model is not self._model:
                raise TaskError(f"the scene is for robot '{scene.robot_model.name}', the task's robot is '{self._model.name}'")
        self._scene = scene

    def setSceneProvider(self, provider: Callable[[float], PlanningScene] | None) -> None:
        """``provider(timeout) -> PlanningScene`` fetches the current scene (e.g. from the
        planning_server) each time the task plans; it takes precedence over ``scene``."""
        if provider is not None and not callable(provider):
            raise TaskError("the scene provider must be callable: provider(timeout) -> PlanningScene")
        self._scene_provider = provider

    def _current_scene(self, timeout: float) -> PlanningScene:
        if self._scene_provider is not None:
            scene = self._scene_provider(timeout)
            if not isinstance(scene, PlanningScene):
                raise TaskError(f"the scene provider returned {type(scene).__name__}, not a PlanningScene")
            if scene.robot_model is not self._model:
                raise TaskError("the scene provider returned a scene of another robot model")
            return scene
        if self._scene is not None:
            return self._scene.copy()
        return PlanningScene(self._model)  # type: ignore[arg-type]

    @property
    def properties(self) -> PropertyMap:
        """The root container's properties (task-level group, eef, ik_frame, ...)."""
        return self._root.properties

    def setProperty(self, name: str, value: Any) -> None:
        self._root.setProperty(name, value)

    @property
    def timeout(self) -> float:
        return self._timeout

    def setTimeout(self, timeout: float) -> None:
        """Overall planning time limit (s); plan() returns TIMED_OUT (with any solutions found)."""
        if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not timeout > 0:
            raise TaskError(f"task timeout must be > 0, got {timeout!r}")
        self._timeout = float(timeout)

    @timeout.setter
    def timeout(self, value: float) -> None:
        self.setTimeout(value)

    # ------------------------------------------------------------------ stages
    def add(self, *stages: Stage) -> None:
        self._root.add(*stages)

    def insert(self, stage: Stage, before: int = -1) -> None:
        self._root.insert(stage, before)

    def clear(self) -> None:
        self.reset()
        self._root.clear()

    def __getitem__(self, key: int | str) -> Stage:
        return self._root[key]

    def findChild(self, name: str) -> Stage | None:
        return self._root.findChild(name)

    def __iter__(self):
        return iter(self._root)

    def __len__(self) -> int:
        return len(self._root)

    def traverse(self) -> Iterable[tuple[Stage, int]]:
        """Every stage, pre-order, with its depth (root container: 0)."""
        return self._root.traverseRecursively()

    def addTaskCallback(self, callback: Callable[["Task"], None]) -> Callable[["Task"], None]:
        """Call ``callback(task)`` after every planning step."""
        self._task_callbacks.append(callback)
        return callback

    def removeTaskCallback(self, callback: Callable[["Task"], None]) -> None:
        self._task_callbacks.remove(callback)

    # ------------------------------------------------------------------ planning
    def reset(self) -> None:
        """Forget all solutions and inherited values (stages and their settings stay)."""
        self._root.reset()
        self._pending_backward.clear()
        self._pending_forward.clear()
        self._initialized = False

    def init(self) -> None:
        """Reset, initialise every stage and resolve the interfaces; InitStageException lists
        every misconfigured stage with its problem."""
        if self._model is None:
            node = self._node_of_planners()
            if node is None:
                raise TaskError("the task has no robot model: call loadRobotModel(node) or setRobotModel(), or "
                                "pass it to Task(name, model)")
            _LOG.info("task '%s' has no robot model: loading it through its PipelinePlanner's node", self.name)
            self.loadRobotModel(node)
        self.reset()
        context = TaskContext(self)
        self._context = context
        for index, (stage, _depth) in enumerate(self._root.traverseRecursively(), start=1):
            stage._context = context
            stage._id = index
        root = self._root
        root._prev_ends = self._pending_backward
        root._next_starts = self._pending_forward
        root.init(self._model)
        root._resolve_interface(GENERATE)
        root._validate_connectivity()
        self._initialized = True
        if self._ros is not None and self._introspection_enabled:
            self.introspection().publishTaskDescription()

    def plan(self, max_solutions: int = 0) -> MoveItErrorCode:
        """Plan until ``max_solutions`` solutions exist (0: all), the timeout, or preempt()."""
        if isinstance(max_solutions, bool) or not isinstance(max_solutions, int) or max_solutions < 0:
            raise TaskError(f"max_solutions must be an integer >= 0 (0: all), got {max_solutions!r}")
        self.init()
        self._preempt = False
        root = self._root
        started = time.perf_counter()
        code = MoveItErrorCode.PLANNING_FAILED
        while root._can_compute() and (max_solutions == 0 or len(root._solutions) < max_solutions):
            if self._preempt:
                code = MoveItErrorCode.PREEMPTED
                break
            if time.perf_counter() - started >= self._timeout:
                code = MoveItErrorCode.TIMED_OUT
                break
            root._run_compute()
            for callback in list(self._task_callbacks):
                callback(self)
        self._planning_time = time.perf_counter() - started
        if self._ros is not None and self._introspection_enabled:
            self.introspection().publishTaskState()
        if root._solutions:
            count = len(root._solutions)
            return MoveItErrorCode(MoveItErrorCode.SUCCESS, f"{count} solution{'s' if count != 1 else ''} found",
                                   source=self.name)
        explanation = self.explainFailure(stream=None)
        _LOG.info("task '%s' failed:\n%s\n%s", self.name, self.printState(stream=None), explanation)
        if code == MoveItErrorCode.PLANNING_FAILED:
            message = explanation.replace("Failing stage(s):\n", "").strip() or "no solution found"
        elif code == MoveItErrorCode.TIMED_OUT:
            message = f"timeout of {self._timeout:g} s reached without a solution"
        else:
            message = "preempted"
        return MoveItErrorCode(code, message, source=self.name)

    def preempt(self) -> None:
        """Stop plan() after the current step (thread-safe enough: a flag read between steps)."""
        self._preempt = True

    @property
    def planning_time(self) -> float:
        """Wall time of the last plan() loop (s), excluding init()."""
        return self._planning_time

    # ------------------------------------------------------------------ results
    @property
    def solutions(self) -> list[SolutionBase]:
        """Complete solutions, cheapest first."""
        return self._root.solutions

    @property
    def failures(self) -> list[SolutionBase]:
        return self._root.failures

    def numSolutions(self) -> int:
        return self._root.numSolutions()

    def setCostTerm(self, term: Any) -> None:
        """The cost term of the task's solutions (MTC's Task.setCostTerm: the root container's)."""
        self._root.setCostTerm(term)

    # ------------------------------------------------------------------ ROS (MTC's introspection)
    def enableIntrospection(self, enabled: bool = True) -> None:
        """MTC's enableIntrospection: with a node (loadRobotModel), init() publishes the task's
        description and plan() its state on MTC's topics and the task viewer's. On by default."""
        self._introspection_enabled = bool(enabled)

    def introspection(self) -> Any:
        """MTC's Introspection (publishTaskDescription, publishTaskState, publishSolution,
        publishAllSolutions, reset); needs a node (loadRobotModel)."""
        if self._ros is None:
            raise TaskError("introspection needs a ROS node: call loadRobotModel(node) first")
        if self._introspection is None:
            self._introspection = self._ros.introspection(self)
        return self._introspection

    def publish(self, solution: SolutionBase | None = None) -> None:
        """MTC's publish: the description, state and the solution (default: the best) on MTC's
        introspection topics, where RViz's panel and our task viewer show it."""
        chosen = self._pick(solution)
        introspection = self.introspection()
        introspection.publishTaskDescription()
        introspection.publishTaskState()
        introspection.publishSolution(chosen)

    def execute(self, solution: SolutionBase | None = None) -> MoveItErrorCode:
        """MTC's execute: the solution (default: the best) to the planning_server's
        execute_task_solution action; blocks until the motion ended."""
        chosen = self._pick(solution)
        if self._ros is None:
            raise TaskError("execute needs a ROS node: call loadRobotModel(node) first")
        return self._ros.execute(self, chosen)

    def printState(self, stream: TextIO | None | object = STDOUT) -> str:
        """MTC's printState: per stage the interface counts and the solutions, indented by depth
        (see introspection.print_state). Written to ``stream`` (None: only returned)."""

        return _write(print_state(self), stream)

    def explainFailure(self, stream: TextIO | None | object = STDOUT) -> str:
        """MTC's explainFailure: the first failing stage along the task and its first comment."""

        return _write(explain_failure(self), stream)

    def stage_summary(self) -> list[dict[str, Any]]:
        """Per stage (pre-order): name, path, depth, type, interface, solutions, failures,
        compute time, best cost and first failure comment."""

        return stage_summary(self)

    def to_msg(self, solution: SolutionBase | None = None) -> TaskSolution:
        """The solution (default: the best) as an interfaces_py TaskSolution."""

        return solution_to_msg(self, self._pick(solution))

    def joint_trajectory(self, solution: SolutionBase | None = None, sample_period: float | None = None) -> JointTrajectory:
        """The solution (default: the best) as one concatenated JointTrajectory over every joint
        it moves (for ``ros2 topic echo`` and simple controllers)."""

        return solution_joint_trajectory(self._pick(solution), sample_period=sample_period)

    def description(self) -> TaskDescription:

        return task_description(self)

    def statistics(self) -> TaskStatistics:

        return task_statistics(self)

    def _pick(self, solution: SolutionBase | None) -> SolutionBase:
        if solution is None:
            solutions = self._root._solutions
            if not solutions:
                raise TaskError(f"task '{self.name}' has no solution (plan() first)")
            return solutions[0]
        if not isinstance(solution, SolutionBase):
            raise TaskError(f"expected a solution of this task, got {type(solution).__name__}")
        return solution

    def __repr__(self) -> str:
        return f"Task({self.name!r}, stages={len(self._root)}, solutions={len(self._root._solutions)})"
