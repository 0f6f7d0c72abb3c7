"""Stages, interface states and solutions: the planning engine of the task constructor.

The full story: docs/task.md, section mycobot_planning.task.stage.
"""
from __future__ import annotations

import bisect
import time
from enum import IntEnum
from typing import TYPE_CHECKING, Any, Callable, Iterable

import numpy as np

from interfaces_py.msgs import TrajectoryExecutionInfo

from ..core.errors import PlanningError
from ..core.planning_scene.planning_scene import PlanningScene
from .errors import InitStageException, PropertyError, TaskError
from .cost_terms import CostTerm, LambdaCostTerm
from .properties import PropertyAttributes, PropertyInitializerSource, PropertyMap, PropertySetter
from .storage import (  # re-exported: these names were importable from here
    UNKNOWN,
    READS_START,
    READS_END,
    WRITES_NEXT_START,
    WRITES_PREV_END,
    START_IF_MASK,
    END_IF_MASK,
    PROPAGATE_FORWARDS,
    PROPAGATE_BACKWARDS,
    GENERATE,
    CONNECT,
    FORWARD,
    BACKWARD,
    interface_text,
    Priority,
    schedule_key,
    GENERATOR_KEY,
    InterfaceState,
    Interface,
    SolutionBase,
    SubTrajectory,
    SolutionSequence,
    WrappedSolution,
)

if TYPE_CHECKING:  # pragma: no cover
    from ..core.robot_model.robot_model import RobotModel
    from .containers import ContainerBase
    from .task import TaskContext

__all__ = [
    "CONNECT",
    "GENERATE",
    "PROPAGATE_BACKWARDS",
    "PROPAGATE_FORWARDS",
    "Connecting",
    "Generator",
    "Interface",
    "InterfaceState",
    "MonitoringGenerator",
    "Priority",
    "PropagatingBackward",
    "PropagatingEitherWay",
    "PropagatingForward",
    "SolutionBase",
    "SolutionSequence",
    "Stage",
    "SubTrajectory",
    "WrappedSolution",
]

class Stage(PropertyAttributes):
    """Base of all stages. Properties read and write as attributes (``stage.group = "arm"``)
    or through ``stage.properties["group"]``, as in MTC's Python bindings."""

    PARENT = PropertyInitializerSource.PARENT
    INTERFACE = PropertyInitializerSource.INTERFACE
    MANUAL = PropertyInitializerSource.MANUAL
    PropertyInitializerSource = PropertyInitializerSource

    def __init__(self, name: str = "") -> None:
        if not isinstance(name, str):
            raise TaskError(f"a stage name must be a string, got {type(name).__name__}")
        self._name = name
        self._parent: ContainerBase | None = None
        self._properties = PropertyMap(lambda: self._name)
        p = self._properties
        p.declare("timeout", type=float, description="timeout per run (s)")
        p.declare("marker_ns", name, "marker namespace", type=str)
        p.declare("trajectory_execution_info", TrajectoryExecutionInfo(), "controllers executing this stage's "
                  "trajectories", type=TrajectoryExecutionInfo, coerce=_as_execution_info)
        p.declare("forwarded_properties", frozenset(), "interface properties to forward",
                  type=frozenset, coerce=_as_name_set)
        self._solutions: list[SolutionBase] = []
        self._failures: list[SolutionBase] = []
        self._num_failures = 0
        self._starts: Interface | None = None
        self._ends: Interface | None = None
        self._prev_ends: Interface | None = None
        self._next_starts: Interface | None = None
        self._states: list[InterfaceState] = []

        self._cost_term: CostTerm = CostTerm()
        self._solution_callbacks: list[Callable[[SolutionBase], None]] = []
        self._total_compute_time = 0.0
        self._context: TaskContext | None = None
        self._id = 0

    # ------------------------------------------------------------------ naming and tree
    @property
    def name(self) -> str:
        return self._name

    @name.setter
    def name(self, value: str) -> None:
        self.setName(value)

    def setName(self, name: str) -> None:
        if not isinstance(name, str):
            raise TaskError(f"a stage name must be a string, got {type(name).__name__}")
        self._name = name

    @property
    def parent(self) -> "ContainerBase | None":
        return self._parent

    @property
    def id(self) -> int:
        """Introspection id (assigned by Task.init: the root container is 1, pre-order)."""
        return self._id

    @property
    def path(self) -> str:
        """Slash-separated names from the task's root container, e.g. 'pick object/lift object'."""
        names = []
        stage: Stage | None = self
        while stage is not None and stage._parent is not None:
            names.append(stage._name)
            stage = stage._parent
        return "/".join(reversed(names))

    # ------------------------------------------------------------------ properties
    setMarkerNS = PropertySetter("marker_ns", str)
    setForwardedProperties = PropertySetter("forwarded_properties", Iterable[str])
    setTrajectoryExecutionInfo = PropertySetter("trajectory_execution_info", TrajectoryExecutionInfo | Iterable[str])

    def _attribute_owner(self) -> str:
        return f"{type(self).__name__} '{self.__dict__.get('_name', '?')}'"

    def _undeclared_hint(self, name: str) -> str:
        return f"; use stage.properties.set('{name}', value) to declare a new one"

    # ------------------------------------------------------------------ cost
    def setCostTerm(self, term: "CostTerm | Callable | None") -> None:
        """The cost of this stage's solutions: a CostTerm, or any callable taking the solution
        and returning a cost or ``(cost, comment)``."""

        if term is None:
            self._cost_term = CostTerm()
        elif isinstance(term, CostTerm):
            self._cost_term = term
        elif callable(term):
            self._cost_term = LambdaCostTerm(term)
        else:
            raise TaskError(f"stage '{self._name}': a cost term must be a CostTerm or a callable, got {type(term).__name__}")

    @property
    def cost_term(self) -> "CostTerm":
        return self._cost_term

    # ------------------------------------------------------------------ results
    @property
    def solutions(self) -> list[SolutionBase]:
        """Successful solutions, cheapest first."""
        return list(self._solutions)

    @property
    def failures(self) -> list[SolutionBase]:
        return list(self._failures)

    def numSolutions(self) -> int:
        return len(self._solutions)

    def numFailures(self) -> int:
        return self._num_failures

    def getTotalComputeTime(self) -> float:
        return self._total_compute_time

    @property
    def total_compute_time(self) -> float:
        return self._total_compute_time

    def addSolutionCallback(self, callback: Callable[[SolutionBase], None]) -> Callable[[SolutionBase], None]:
        """Call ``callback(solution)`` for every new solution and failure of this stage."""
        self._solution_callbacks.append(callback)
        return callback

    def removeSolutionCallback(self, callback: Callable[[SolutionBase], None]) -> None:
        self._solution_callbacks.remove(callback)

    # ------------------------------------------------------------------ life cycle
    def reset(self) -> None:
        """Forget solutions, states, interface connections and inherited property values."""
        self._solutions.clear()
        self._failures.clear()
        self._num_failures = 0
        self._states.clear()
        if self._starts is not None:
            self._starts.clear()
        if self._ends is not None:
            self._ends.clear()
        self._prev_ends = None
        self._next_starts = None
        self._properties.reset()
        self._total_compute_time = 0.0

    def init(self, robot_model: "RobotModel") -> None:
        """Initialise from the parent's properties; subclasses validate their configuration and
        raise InitStageException naming the stage and the problem."""
        self._properties.reset()
        self._bad_properties: set[str] = set()
        if self._parent is not None:
            try:
                self._properties.performInitFrom(self.PARENT, self._parent._properties)
            except PropertyError as exc:
                self._bad_properties.add(exc.property_name)
                raise InitStageException(self, f"property '{exc.property_name}': {exc.problem}") from None

    def _describe_undefined(self, name: str) -> str:
        """Why a required property is undefined, following the inheritance chain (MTC's
        composePropertyErrorMsg)."""
        prop = self._properties.property(name)
        parts = [f"property '{name}' is undefined"]
        if prop.initsFrom(self.PARENT):
            stage = self._parent
            while stage is not None:
                if name not in stage._properties:
                    parts.append(f"inherits from parent '{stage.name}', which does not declare it")
                    break
                parent_prop = stage._properties.property(name)
                if not parent_prop.initsFrom(self.PARENT):
                    parts.append(f"inherits from parent '{stage.name}', where it is undefined")
                    break
                stage = stage._parent
        else:
            parts.append("set it on the stage or configure it to inherit from the parent (configureInitFrom)")
        return "; ".join(parts)

    def _require_property(self, name: str, errors: InitStageException) -> Any:
        """The property's value at init time; an error unless defined or read from the interface."""
        prop = self._properties.property(name)
        if prop.value() is None and not prop.initsFrom(self.INTERFACE) and name not in self.__dict__.get("_bad_properties", ()):
            errors.push_back(self, self._describe_undefined(name))
        return prop.value()

    def _check_group(self, name: str, group: Any, robot_model: "RobotModel", errors: InitStageException) -> bool:
        if group is None:
            return False
        if not robot_model.has_group(group):
            errors.push_back(self, f"property '{name}': unknown planning group '{group}'; known: "
                                   f"{', '.join(robot_model.group_names)}")
            return False
        return True

    def _check_eef(self, eef: Any, robot_model: "RobotModel", errors: InitStageException) -> bool:
        """Whether ``eef`` (the property 'eef') names an end effector of the model; an unknown one
        is reported in ``errors``, an undefined one (None) is not."""
        if eef is None:
            return False
        if eef not in robot_model.end_effectors:
            errors.push_back(self, f"property 'eef': unknown end effector '{eef}'; known: "
                                   f"{', '.join(robot_model.end_effectors) or 'none'}")
            return False
        return True

    def timeout_or(self, default: float) -> float:
        value = self._properties.get("timeout")
        return default if value is None else float(value)

    # ------------------------------------------------------------------ interface (engine)
    def _required_interface(self) -> int:
        raise NotImplementedError

    def _interface_flags(self) -> int:
        flags = 0
        if self._starts is not None:
            flags |= READS_START
        if self._ends is not None:
            flags |= READS_END
        if self._prev_ends is not None:
            flags |= WRITES_PREV_END
        if self._next_starts is not None:
            flags |= WRITES_NEXT_START
        return flags

    def _resolve_interface(self, expected: int) -> None:
        """Stages with a fixed interface (generators, connectors) have nothing to resolve; a
        mismatch with the neighbours is reported by the container when it connects them."""

    def _validate_connectivity(self) -> None:
        required = self._required_interface()
        actual = self._interface_flags()
        if required & actual != required:
            raise InitStageException(
                self, f"actual interface {interface_text(actual)} does not match required interface "
                      f"{interface_text(required)}")

    def _can_compute(self) -> bool:
        raise NotImplementedError

    def _compute(self) -> None:
        raise NotImplementedError

    def _schedule_key(self) -> tuple | None:
        """How urgent this stage's pending work is (smallest first; see ``schedule_key``), or
        None when it cannot compute. A container computes its most urgent child. Stages whose
        work derives from no state rank last (GENERATOR_KEY)."""
        return GENERATOR_KEY if self._can_compute() else None

    def _run_compute(self) -> None:
        started = time.perf_counter()
        try:
            self._compute()
        finally:
            self._total_compute_time += time.perf_counter() - started

    # ------------------------------------------------------------------ storing solutions (engine)
    def _store_solution(self, solution: SolutionBase, from_state: InterfaceState | None,
                        to_state: InterfaceState | None) -> bool:
        solution.creator = self
        if self._context is not None:
            solution.id = self._context.next_solution_id()
        if solution.is_failure:
            self._num_failures += 1
            if self._parent is not None:
                self._parent._on_new_failure(self, from_state, to_state)
            self._failures.append(solution)
        else:
            bisect.insort(self._solutions, solution)
        return True

    def _compute_cost(self, from_state: InterfaceState, to_state: InterfaceState, solution: SolutionBase) -> None:
        if solution.is_failure:
            return
        # Cost terms may look at both ends: set them temporarily (MTC's TmpSolutionContext).
        saved = (solution.start, solution.end, solution.creator)
        solution.start, solution.end, solution.creator = from_state, to_state, self
        try:
            cost, comment = solution.compute_cost(self._cost_term)
        finally:
            solution.start, solution.end, solution.creator = saved
        solution.cost = float(cost)
        if comment:
            solution.comment = f"{solution.comment} ({comment})" if solution.comment else comment

    def forwardProperties(self, source: InterfaceState, dest: InterfaceState) -> None:
        for name in self._properties.get("forwarded_properties", frozenset()):
            if name in source.properties:
                dest.properties[name] = source.properties[name]

    def _send_forward(self, from_state: InterfaceState, to_state: InterfaceState, solution: SolutionBase) -> None:
        self._send(from_state, to_state, solution, True)

    def _send_backward(self, from_state: InterfaceState, to_state: InterfaceState, solution: SolutionBase) -> None:
        self._send(from_state, to_state, solution, False)

    def _send(self, from_state: InterfaceState, to_state: InterfaceState, solution: SolutionBase, forward: bool) -> None:
        """Store a propagated solution. The new state (``to_state`` when ``forward``, else
        ``from_state``) takes the forwarded properties and the lineage of the other and, unless
        the solution failed, goes to the next stage's starts (the previous stage's ends)."""
        self._compute_cost(from_state, to_state, solution)
        if not self._store_solution(solution, from_state if forward else None, None if forward else to_state):
            return
        source, new = (from_state, to_state) if forward else (to_state, from_state)
        self.forwardProperties(source, new)
        new.lineage_depth = max(new.lineage_depth, source.lineage_depth)
        self._states.append(new)
        solution.set_start_state(from_state)
        solution.set_end_state(to_state)
        if not solution.is_failure:
            (self._next_starts if forward else self._prev_ends).add(new)  # type: ignore[union-attr]
        self._new_solution(solution)

    def _spawn(self, from_state: InterfaceState, to_state: InterfaceState, solution: SolutionBase) -> None:
        self._compute_cost(from_state, to_state, solution)
        if not self._store_solution(solution, None, None):
            return
        self._states.append(from_state)
        self._states.append(to_state)
        solution.set_start_state(from_state)
        solution.set_end_state(to_state)
        if not solution.is_failure:
            self._prev_ends.add(from_state)  # type: ignore[union-attr]
            self._next_starts.add(to_state)  # type: ignore[union-attr]
        self._new_solution(solution)

    def _connect(self, from_state: InterfaceState, to_state: InterfaceState, solution: SolutionBase) -> None:
        self._compute_cost(from_state, to_state, solution)
        if not self._store_solution(solution, from_state, to_state):
            return
        solution.set_start_state(from_state)
        solution.set_end_state(to_state)
        self._new_solution(solution)

    def _new_solution(self, solution: SolutionBase) -> None:
        for callback in list(self._solution_callbacks):
            callback(solution)
        if self._parent is not None and not solution.is_failure:
            self._parent._on_new_solution(solution)

    def _silent_failure(self) -> None:
        self._num_failures += 1

    # ------------------------------------------------------------------ introspection
    def _explain_failure(self) -> str:
        if self._failures:
            return ": " + self._failures[0].comment
        return ""

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self._name!r})"


def _as_execution_info(value: Any) -> TrajectoryExecutionInfo:
    if isinstance(value, TrajectoryExecutionInfo):
        return value
    if isinstance(value, dict):
        return TrajectoryExecutionInfo.from_dict(value)
    if isinstance(value, (list, tuple)):
        return TrajectoryExecutionInfo(controller_names=list(value))
    names = getattr(value, "controller_names", None)  # a ROS-like message
    if names is not None:
        return TrajectoryExecutionInfo(controller_names=list(names))
    raise TypeError("expected a TrajectoryExecutionInfo or a list of controller names")


def _as_name_set(value: Any) -> frozenset:
    if isinstance(value, str):
        return frozenset([value])
    return frozenset(value)


# ---------------------------------------------------------------------------- computing stages
class ComputeBase(Stage):
    """A stage that computes (as opposed to a container)."""


class Generator(ComputeBase):
    """Creates states on its own and pushes them both ways (``← →``).

    Subclasses implement ``canCompute()`` and ``compute()`` and call ``spawn``.
    """

    def _required_interface(self) -> int:
        return GENERATE

    def _can_compute(self) -> bool:
        return self.canCompute()

    def _compute(self) -> None:
        self.compute()

    def canCompute(self) -> bool:
        raise NotImplementedError

    def compute(self) -> None:
        raise NotImplementedError

    def spawn(self, state: InterfaceState, solution: SolutionBase | float | None = None,
              to_state: InterfaceState | None = None) -> None:
        """Publish a generated state (to both neighbours). ``solution`` may be a cost."""
        if solution is None or isinstance(solution, (int, float)):
            solution = SubTrajectory(cost=0.0 if solution is None else float(solution))
        if to_state is None:
            to_state = InterfaceState(state.scene, state.properties, state.priority, state.lineage_depth)
        self._spawn(state, to_state, solution)


class MonitoringGenerator(Generator):
    """A generator fed by the solutions of another (monitored) stage of the task, e.g. the
    grasp generator watching "current state" or the place generator watching "attach object"."""

    def __init__(self, name: str = "", monitored: "Stage | str | None" = None) -> None:
        super().__init__(name)
        self._monitored: Stage | str | None = None
        self._registered_on: Stage | None = None
        self.setMonitoredStage(monitored)

    def setMonitoredStage(self, monitored: "Stage | str | None") -> None:
        """The stage whose solutions to watch: a Stage, or its name / path within the task."""
        if monitored is not None and not isinstance(monitored, (Stage, str)):
            raise TaskError(f"stage '{self._name}': the monitored stage must be a Stage or a stage name, "
                            f"got {type(monitored).__name__}")
        if self._registered_on is not None and self._registered_on is not monitored:
            self._registered_on.removeSolutionCallback(self._on_monitored_solution)
            self._registered_on = None
        self._monitored = monitored

    @property
    def monitored_stage(self) -> "Stage | None":
        return self._monitored if isinstance(self._monitored, Stage) else None

    def init(self, robot_model: "RobotModel") -> None:
        errors = InitStageException().collect(super().init, robot_model)
        monitored = self._monitored
        if isinstance(monitored, str):
            root = self._context.root if self._context is not None else None
            found = root.findChild(monitored) if root is not None else None
            if found is None:
                errors.push_back(self, f"monitored stage '{monitored}' not found in the task")
            monitored = found
        if monitored is None and not errors:
            errors.push_back(self, "no monitored stage defined (call setMonitoredStage)")
        elif monitored is self:
            errors.push_back(self, "a stage cannot monitor itself")
        elif monitored is not None and self._context is not None and monitored._context is not self._context:
            errors.push_back(self, f"monitored stage '{monitored.name}' is not part of this task")
        if errors:
            raise errors
        assert isinstance(monitored, Stage)
        if self._registered_on is not monitored:
            if self._registered_on is not None:
                self._registered_on.removeSolutionCallback(self._on_monitored_solution)
            monitored.addSolutionCallback(self._on_monitored_solution)
            self._registered_on = monitored

    def _on_monitored_solution(self, solution: SolutionBase) -> None:
        if not solution.is_failure:
            self.onNewSolution(solution)

    def onNewSolution(self, solution: SolutionBase) -> None:
        raise NotImplementedError


class Direction(IntEnum):
    """MTC's PropagatingEitherWay.Direction: AUTO (the container decides), FORWARD, BACKWARD."""

    AUTO = 0
    FORWARD = 1
    BACKWARD = 2


class PropagatingEitherWay(ComputeBase):
    """Reads states on one side, computes, writes the result to the other side.

    The direction is ``AUTO`` by default: the container decides it from the neighbours when the
    task is initialised (forward after a generator, backward before one). Subclasses implement
    ``computeForward(from_state)`` / ``computeBackward(to_state)``, or ``_propagate(state,
    direction)`` returning ``(ok, end_scene, SubTrajectory)``.
    """

    Direction = Direction
    AUTO = Direction.AUTO
    FORWARD = Direction.FORWARD
    BACKWARD = Direction.BACKWARD

    def __init__(self, name: str = "", direction: int = 0) -> None:
        super().__init__(name)
        self._configured_dir = direction
        self._required = UNKNOWN
        self._init_interface(direction)

    def restrictDirection(self, direction: int) -> None:
        if direction == self._configured_dir:
            return
        if self._configured_dir != self.AUTO:
            raise TaskError(f"stage '{self._name}': cannot change the direction once restricted")
        self._configured_dir = direction
        self._init_interface(direction)

    def _init_interface(self, direction: int) -> None:
        if direction == self.FORWARD:
            self._required = PROPAGATE_FORWARDS
            if self._starts is None:
                self._starts = Interface()
            self._ends = None
        elif direction == self.BACKWARD:
            self._required = PROPAGATE_BACKWARDS
            self._starts = None
            if self._ends is None:
                self._ends = Interface()
        else:
            self._required = UNKNOWN

    def _required_interface(self) -> int:
        return self._required

    def _resolve_interface(self, expected: int) -> None:
        if expected == UNKNOWN:
            raise InitStageException(self, "cannot initialize to an unknown interface")
        if (expected & START_IF_MASK) == READS_START or (expected & END_IF_MASK) == WRITES_NEXT_START:
            direction = self.FORWARD
        elif (expected & START_IF_MASK) == WRITES_PREV_END or (expected & END_IF_MASK) == READS_END:
            direction = self.BACKWARD
        else:
            raise InitStageException(self, f"a propagator cannot satisfy the expected interface {interface_text(expected)}")
        if self._configured_dir != self.AUTO and direction != self._configured_dir:
            raise InitStageException(
                self, f"configured interface ({interface_text(self._required)}) does not match the expected one "
                      f"({interface_text(expected)})")
        self._init_interface(direction)

    def reset(self) -> None:
        super().reset()
        if self._configured_dir == self.AUTO:
            self._starts = None
            self._ends = None
            self._required = UNKNOWN

    def _can_compute(self) -> bool:
        return bool(self._starts) or bool(self._ends)

    def _schedule_key(self) -> tuple | None:
        keys = [k for k in (self._starts.front_key() if self._starts else None,
                            self._ends.front_key() if self._ends else None) if k is not None]
        return min(keys) if keys else None

    def _compute(self) -> None:
        if self._starts:
            state = self._starts.pop()
            self._properties.performInitFrom(self.INTERFACE, state.properties)
            self.computeForward(state)
        if self._ends:
            state = self._ends.pop()
            self._properties.performInitFrom(self.INTERFACE, state.properties)
            self.computeBackward(state)

    def computeForward(self, from_state: InterfaceState) -> None:
        self._compute_generic(from_state, FORWARD)

    def computeBackward(self, to_state: InterfaceState) -> None:
        self._compute_generic(to_state, BACKWARD)

    def _compute_generic(self, state: InterfaceState, direction: int) -> None:
        try:
            ok, scene, solution = self._propagate(state, direction)
        except (PlanningError, ValueError) as exc:
            ok, scene, solution = False, None, SubTrajectory.failure(str(exc))
        if not ok and not solution.comment:
            self._silent_failure()
            return
        if not ok:
            solution.markAsFailure()
        if scene is None:
            scene = state.scene
        if direction == FORWARD:
            self._send_forward(state, InterfaceState(scene), solution)
        else:
            self._send_backward(InterfaceState(scene), state, solution)

    def sendForward(self, from_state: InterfaceState, to_state: InterfaceState, solution: SolutionBase) -> None:
        self._send_forward(from_state, to_state, solution)

    def sendBackward(self, from_state: InterfaceState, to_state: InterfaceState, solution: SolutionBase) -> None:
        self._send_backward(from_state, to_state, solution)

    def _propagate(self, state: InterfaceState, direction: int) -> tuple[bool, PlanningScene | None, SubTrajectory]:
        raise NotImplementedError


class PropagatingForward(PropagatingEitherWay):
    def __init__(self, name: str = "") -> None:
        super().__init__(name, PropagatingEitherWay.FORWARD)


class PropagatingBackward(PropagatingEitherWay):
    def __init__(self, name: str = "") -> None:
        super().__init__(name, PropagatingEitherWay.BACKWARD)


class Connecting(ComputeBase):
    """Reads both sides (``→ ←``) and computes a solution for each compatible pair of a start
    and an end state, best pair first."""

    def __init__(self, name: str = "") -> None:
        super().__init__(name)
        self._starts = Interface(lambda s, updated: self._new_state(s, updated, FORWARD))
        self._ends = Interface(lambda s, updated: self._new_state(s, updated, BACKWARD))
        self._pending: list[tuple[InterfaceState, InterfaceState]] = []

    def _required_interface(self) -> int:
        return CONNECT

    def reset(self) -> None:
        self._pending.clear()
        super().reset()

    def _new_state(self, state: InterfaceState, updated: bool, side: int) -> None:
        if updated:
            return  # priorities are read when the next pair is chosen
        others = self._ends if side == FORWARD else self._starts
        for other in list(others._states):  # type: ignore[union-attr]
            pair = (state, other) if side == FORWARD else (other, state)
            if self.compatible(*pair):
                self._pending.append(pair)

    def compatible(self, from_state: InterfaceState, to_state: InterfaceState) -> bool:
        """Whether two states can be connected: same world objects at the same poses, same
        attached objects on the same links (MTC's Connecting::compatible)."""
        return scenes_compatible(from_state.scene, to_state.scene)

    @staticmethod
    def _pair_key(pair: tuple[InterfaceState, InterfaceState]) -> tuple:
        start, end = pair
        return (schedule_key(start.priority + end.priority, max(start.lineage_depth, end.lineage_depth)),
                start._order, end._order)

    def _can_compute(self) -> bool:
        return bool(self._pending)

    def _schedule_key(self) -> tuple | None:
        if not self._pending:
            return None
        return min(self._pair_key(pair) for pair in self._pending)[0]

    def _compute(self) -> None:
        best = min(range(len(self._pending)), key=lambda i: self._pair_key(self._pending[i]))
        from_state, to_state = self._pending.pop(best)
        try:
            self.compute(from_state, to_state)
        except (PlanningError, ValueError) as exc:
            self._connect(from_state, to_state, SubTrajectory.failure(str(exc)))

    def compute(self, from_state: InterfaceState, to_state: InterfaceState) -> None:
        raise NotImplementedError

    def connect(self, from_state: InterfaceState, to_state: InterfaceState, solution: SolutionBase) -> None:
        self._connect(from_state, to_state, solution)


def scenes_compatible(a: PlanningScene, b: PlanningScene, tolerance: float = 1e-4) -> bool:
    """Same world and attached objects (ids, links, poses within ``tolerance``)."""
    if a is b:
        return True
    world_a, world_b = a.world_object_ids(), b.world_object_ids()
    if sorted(world_a) != sorted(world_b):
        return False
    for object_id in world_a:
        if not np.allclose(a.frame_pose(object_id), b.frame_pose(object_id), atol=tolerance):
            return False
    attached_a, attached_b = a.attached_object_ids(), b.attached_object_ids()
    if sorted(attached_a) != sorted(attached_b):
        return False
    for object_id in attached_a:
        msg_a, msg_b = a.get_attached_object(object_id), b.get_attached_object(object_id)
        if msg_a.link_name != msg_b.link_name:
            return False
        if not np.allclose(msg_a.object.pose.to_matrix(), msg_b.object.pose.to_matrix(), atol=tolerance):
            return False
    return True
