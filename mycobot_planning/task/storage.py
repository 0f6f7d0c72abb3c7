"""MTC's storage: what stages exchange and produce, apart from the stages themselves.

Interface states (a planning scene plus properties, waiting in a stage's interface, best first),
the interfaces, and the solutions: SubTrajectory (one stage's result), SolutionSequence (a
container's chain) and WrappedSolution (a container passing a child's solution on). MTC keeps
these in storage.h, beside stage.h; here too, so that cost terms and containers need only this
module, and the task package has no import circle.
"""
from __future__ import annotations

import itertools
import math
from typing import TYPE_CHECKING, Any, Callable, Iterator, NamedTuple

from ..core.planning_scene.planning_scene import PlanningScene
from ..core.robot_trajectory.robot_trajectory import TimedTrajectory
from .errors import TaskError

if TYPE_CHECKING:  # pragma: no cover
    from .cost_terms import CostTerm
    from .stage import Stage

# ---------------------------------------------------------------------------- interface flags
UNKNOWN = 0
READS_START = 0x01
READS_END = 0x02
WRITES_NEXT_START = 0x04
WRITES_PREV_END = 0x08
START_IF_MASK = READS_START | WRITES_PREV_END
END_IF_MASK = READS_END | WRITES_NEXT_START
PROPAGATE_FORWARDS = READS_START | WRITES_NEXT_START
PROPAGATE_BACKWARDS = READS_END | WRITES_PREV_END
GENERATE = WRITES_PREV_END | WRITES_NEXT_START
CONNECT = READS_START | READS_END

FORWARD = 0
BACKWARD = 1


def invert(flags: int) -> int:
    """What a neighbour must do to match ``flags`` (a writer needs a reader and vice versa)."""
    out = 0
    if flags & READS_START:
        out |= WRITES_NEXT_START
    if flags & WRITES_PREV_END:
        out |= READS_END
    if flags & READS_END:
        out |= WRITES_PREV_END
    if flags & WRITES_NEXT_START:
        out |= READS_START
    return out


_START_SYMBOLS = {READS_START: "→", WRITES_PREV_END: "←", UNKNOWN: "?"}
_END_SYMBOLS = {READS_END: "←", WRITES_NEXT_START: "→", UNKNOWN: "?"}


def flow_symbol_start(flags: int) -> str:
    """MTC's arrow for the start side: → reads, ← writes, ? unknown, ↔ both."""
    return _START_SYMBOLS.get(flags & START_IF_MASK, "↔")


def flow_symbol_end(flags: int) -> str:
    """MTC's arrow for the end side: ← reads, → writes, ? unknown, ↔ both."""
    return _END_SYMBOLS.get(flags & END_IF_MASK, "↔")


def interface_text(flags: int) -> str:
    return f"{flow_symbol_start(flags)} {flow_symbol_end(flags)}"


# ---------------------------------------------------------------------------- states
class Priority(NamedTuple):
    """How promising a state is: the depth (number of solutions) and cost of the longest
    partial solution it belongs to. Deeper first, then cheaper; infinite cost last."""

    depth: int = 0
    cost: float = 0.0

    def __add__(self, other: "Priority") -> "Priority":  # type: ignore[override]
        return Priority(self.depth + other.depth, self.cost + other.cost)

    def key(self) -> tuple:
        if math.isinf(self.cost):
            return (1, -self.depth, 0.0)
        return (0, -self.depth, self.cost)


def schedule_key(priority: Priority, lineage_depth: int = 0) -> tuple:
    """How urgent work on a state (or pair of states) is, smallest first: finite cost first,
    then the deeper of the partial solution's depth and the lineage depth, then the partial
    solution's own depth, then its cost. Without lineage it orders as ``Priority.key``."""
    if math.isinf(priority.cost):
        return (1, -priority.depth, -priority.depth, 0.0)
    return (0, -max(priority.depth, lineage_depth), -priority.depth, priority.cost)


#: The schedule key of work that derives from no state (a generator with nothing upstream):
#: after every pending state of finite cost.
GENERATOR_KEY = (0, 0, 0, math.inf)


class InterfaceState:
    """A planning scene (never modified once shared) plus properties for the next stage
    (e.g. GenerateGraspPose's ``target_pose`` for ComputeIK), and the solutions that start or
    end here."""

    __slots__ = ("scene", "properties", "priority", "lineage_depth", "incoming", "outgoing", "owner", "_order",
                 "__weakref__")

    def __init__(self, scene: PlanningScene, properties: dict[str, Any] | None = None,
                 priority: Priority = Priority(), lineage_depth: int = 0) -> None:
        if not isinstance(scene, PlanningScene):
            raise TaskError(f"an interface state needs a PlanningScene, got {type(scene).__name__}")
        self.scene = scene
        self.properties: dict[str, Any] = dict(properties) if properties else {}
        self.priority = priority
        # Depth of the partial solution this state derives from through a monitoring generator
        # (kept along the states computed from it); used only to schedule work (schedule_key).
        self.lineage_depth = lineage_depth
        self.incoming: list[SolutionBase] = []
        self.outgoing: list[SolutionBase] = []
        self.owner: Interface | None = None
        self._order = 0

    @property
    def state(self):
        """The robot state of the scene (a shortcut for ``scene.current_state``)."""
        return self.scene.current_state

    @property
    def schedule_depth(self) -> int:
        """The depth that ranks work on this state: its own partial solution's or its lineage's."""
        return max(self.priority.depth, self.lineage_depth)

    def schedule_key(self) -> tuple:
        return schedule_key(self.priority, self.lineage_depth)

    def __repr__(self) -> str:
        return f"InterfaceState(priority={tuple(self.priority)}, properties={sorted(self.properties)})"


_order_counter = itertools.count()


class Interface:
    """States waiting to be processed, best priority first.

    ``notify(state, updated)`` is called when a state is added (``updated`` False) or its
    priority changes (True); containers use it to forward states to their children.
    """

    __slots__ = ("_states", "_notify")

    def __init__(self, notify: Callable[[InterfaceState, bool], None] | None = None) -> None:
        self._states: list[InterfaceState] = []
        self._notify = notify

    def add(self, state: InterfaceState) -> None:
        state.owner = self
        state._order = next(_order_counter)
        self._states.append(state)
        if self._notify is not None:
            self._notify(state, False)

    def remove(self, state: InterfaceState) -> None:
        self._states.remove(state)
        state.owner = None

    def front(self) -> InterfaceState | None:
        if not self._states:
            return None
        return min(self._states, key=lambda s: (s.schedule_key(), s._order))

    def front_key(self) -> tuple | None:
        """The schedule key of the most urgent state (None when empty)."""
        if not self._states:
            return None
        return min(s.schedule_key() for s in self._states)

    def pop(self) -> InterfaceState:
        state = self.front()
        if state is None:
            raise TaskError("pop from an empty interface")
        self.remove(state)
        return state

    def priority_changed(self, state: InterfaceState) -> None:
        if self._notify is not None:
            self._notify(state, True)

    def clear(self) -> None:
        for state in self._states:
            state.owner = None
        self._states.clear()

    def __len__(self) -> int:
        return len(self._states)

    def __bool__(self) -> bool:
        return bool(self._states)

    def __iter__(self) -> Iterator[InterfaceState]:
        return iter(sorted(self._states, key=lambda s: (s.schedule_key(), s._order)))

    def __contains__(self, state: object) -> bool:
        return any(s is state for s in self._states)


def update_state_priorities(state: InterfaceState, priority: Priority, direction: int) -> None:
    """Give ``priority`` to ``state`` and every state after it along solution paths in
    ``direction`` (MTC's updateStatePrios)."""
    if state.priority == priority:
        return
    state.priority = priority
    if state.owner is not None:
        state.owner.priority_changed(state)
    successors = state.outgoing if direction == FORWARD else state.incoming
    for solution in successors:
        if not solution.is_failure:
            update_state_priorities(solution.end if direction == FORWARD else solution.start, priority, direction)


# ---------------------------------------------------------------------------- solutions
class SolutionBase:
    """A result of a stage between a start and an end state; a failure when its cost is
    infinite (the comment says why)."""

    __slots__ = ("creator", "start", "end", "cost", "comment", "id", "__weakref__")

    def __init__(self, creator: "Stage | None" = None, cost: float = 0.0, comment: str = "") -> None:
        self.creator = creator
        self.start: InterfaceState | None = None
        self.end: InterfaceState | None = None
        self.cost = float(cost)
        self.comment = comment
        self.id = 0

    @property
    def is_failure(self) -> bool:
        return not math.isfinite(self.cost)

    @property
    def isFailure(self) -> bool:
        """A property, as in MTC's bindings: ``if solution.isFailure:``."""
        return self.is_failure

    def markAsFailure(self, comment: str | None = None) -> "SolutionBase":
        self.cost = math.inf
        if comment:
            self.comment = comment
        return self

    def set_start_state(self, state: InterfaceState) -> None:
        self.start = state
        state.outgoing.append(self)

    def set_end_state(self, state: InterfaceState) -> None:
        self.end = state
        state.incoming.append(self)

    def compute_cost(self, term: "CostTerm") -> tuple[float, str]:
        raise NotImplementedError

    def sub_trajectories(self) -> list["SubTrajectory"]:
        """The primitive sub-trajectories of this solution, in execution order."""
        raise NotImplementedError

    @property
    def start_scene(self) -> PlanningScene:
        return self.start.scene  # type: ignore[union-attr]

    @property
    def end_scene(self) -> PlanningScene:
        return self.end.scene  # type: ignore[union-attr]

    def __lt__(self, other: "SolutionBase") -> bool:
        return self.cost < other.cost

    def __repr__(self) -> str:
        who = self.creator.name if self.creator is not None else "?"
        status = "failure" if self.is_failure else f"cost {self.cost:.4g}"
        return f"{type(self).__name__}({who!r}, {status}, {self.comment!r})"


class SubTrajectory(SolutionBase):
    """A primitive solution: a trajectory of one planning group (or none, for a pure state
    change such as attaching an object or an IK solution)."""

    __slots__ = ("trajectory", "group", "planner_id")

    def __init__(self, trajectory: TimedTrajectory | None = None, group: str | None = None, cost: float = 0.0,
                 comment: str = "", planner_id: str = "") -> None:
        super().__init__(None, cost, comment)
        self.trajectory = trajectory
        self.group = group
        self.planner_id = planner_id

    @classmethod
    def failure(cls, comment: str) -> "SubTrajectory":
        return cls().markAsFailure(comment)  # type: ignore[return-value]

    def compute_cost(self, term: "CostTerm") -> tuple[float, str]:
        return term.subtrajectory_cost(self)

    def sub_trajectories(self) -> list["SubTrajectory"]:
        return [self]

    @property
    def duration(self) -> float:
        return 0.0 if self.trajectory is None else self.trajectory.duration


class SolutionSequence(SolutionBase):
    """Solutions of consecutive stages joined end to end (a SerialContainer's solution)."""

    __slots__ = ("children",)

    def __init__(self, creator: "Stage | None", children: list[SolutionBase], cost: float | None = None,
                 comment: str = "") -> None:
        total = sum(c.cost for c in children) if cost is None else cost
        super().__init__(creator, total, comment)
        self.children = list(children)

    @property
    def internal_start(self) -> InterfaceState:
        return self.children[0].start  # type: ignore[return-value]

    @property
    def internal_end(self) -> InterfaceState:
        return self.children[-1].end  # type: ignore[return-value]

    def compute_cost(self, term: "CostTerm") -> tuple[float, str]:
        return term.sequence_cost(self)

    def sub_trajectories(self) -> list[SubTrajectory]:
        out: list[SubTrajectory] = []
        for child in self.children:
            out.extend(child.sub_trajectories())
        return out


class WrappedSolution(SolutionBase):
    """A child's solution passed on by a parallel container or wrapper (possibly re-costed)."""

    __slots__ = ("wrapped",)

    def __init__(self, creator: "Stage | None", wrapped: SolutionBase, cost: float | None = None,
                 comment: str | None = None) -> None:
        super().__init__(creator, wrapped.cost if cost is None else cost,
                         wrapped.comment if comment is None else comment)
        self.wrapped = wrapped

    def compute_cost(self, term: "CostTerm") -> tuple[float, str]:
        return term.wrapped_cost(self)

    def sub_trajectories(self) -> list[SubTrajectory]:
        return self.wrapped.sub_trajectories()


# ---------------------------------------------------------------------------- stage
