"""Containers: SerialContainer, Alternatives, Fallbacks, Merger and the single-child wrapper.

* **SerialContainer** runs its children in sequence; a solution of the container is one
  solution of every child, joined end to end, costs summed. Its interface is its first child's
  start and its last child's end.
* **Alternatives** gives every child every state and passes on all their solutions (e.g. three
  initial states, or left and right arm).
* **Fallbacks** tries its children in order *per state*: the next child only gets the states the
  previous ones found no solution for (e.g. Cartesian, then PTP, then OMPL).
* **Merger** plans its children (one per group) from the same state and merges their
  trajectories into one simultaneous motion.
* **WrapperBase** holds one child and post-processes its solutions (ComputeIK, PredicateFilter).

The container-internal wiring follows MTC: a container copies every state it receives into its
children's pull interfaces and remembers which internal copy belongs to which external state;
children push into the container's pending interfaces, and the container *lifts* complete
solutions onto its own interfaces, creating external copies of their new end states.
"""
from __future__ import annotations

from collections import defaultdict
from typing import TYPE_CHECKING, Iterable, Iterator

from ..core.robot_trajectory.robot_trajectory import DEFAULT_MAX_WAYPOINT_DISTANCE
from .errors import InitStageException, TaskError
from .stage import Connecting, Stage
from .storage import BACKWARD, CONNECT, END_IF_MASK, FORWARD, GENERATE, PROPAGATE_BACKWARDS, PROPAGATE_FORWARDS, READS_END, READS_START, START_IF_MASK, UNKNOWN, WRITES_NEXT_START, WRITES_PREV_END, GENERATOR_KEY, Interface, InterfaceState, Priority, SolutionBase, SolutionSequence, SubTrajectory, WrappedSolution, flow_symbol_end, flow_symbol_start, interface_text, invert, update_state_priorities
from .trajectories import merge_trajectories

if TYPE_CHECKING:  # pragma: no cover
    from ..core.robot_model.robot_model import RobotModel

__all__ = ["Alternatives", "ContainerBase", "Fallbacks", "Merger", "ParallelContainerBase", "SerialContainer", "WrapperBase"]


class ContainerBase(Stage):
    """Common container machinery: children, state copies and solution lifting."""

    def __init__(self, name: str = "", children: Iterable[Stage] = ()) -> None:
        super().__init__(name)
        self._children: list[Stage] = []
        self._pending_backward = Interface()
        self._pending_forward = Interface()
        self._internal_to_external: dict[int, InterfaceState] = {}
        self._external_to_internal: dict[int, list[InterfaceState]] = defaultdict(list)
        self._required = UNKNOWN
        self._properties.declare("pruning", type=bool, description="enable pruning?").configureInitFrom(self.PARENT)
        for child in children:
            self.add(child)

    # ------------------------------------------------------------------ children
    def add(self, *stages: Stage) -> None:
        """Append stages (MTC's add/insert)."""
        for stage in stages:
            self.insert(stage, -1)

    def insert(self, stage: Stage, before: int = -1) -> None:
        """Insert ``stage`` before the child at index ``before`` (-1: append)."""
        if not isinstance(stage, Stage):
            raise TaskError(f"container '{self._name}': expected a Stage, got {type(stage).__name__}")
        if stage._parent is not None:
            raise TaskError(f"stage '{stage.name}' already belongs to container '{stage._parent.name}'")
        if stage is self or (isinstance(stage, ContainerBase) and self._is_descendant_of(stage)):
            raise TaskError(f"container '{self._name}': cannot insert '{stage.name}' into itself")
        stage._parent = self
        if before == -1 or before >= len(self._children):
            self._children.append(stage)
        else:
            self._children.insert(before if before >= 0 else before + 1, stage)

    def _is_descendant_of(self, other: "ContainerBase") -> bool:
        stage: Stage | None = self
        while stage is not None:
            if stage is other:
                return True
            stage = stage._parent
        return False

    def remove(self, which: int | Stage) -> Stage:
        stage = self._children[which] if isinstance(which, int) else which
        self._children.remove(stage)
        stage._parent = None
        return stage

    def clear(self) -> None:
        for child in self._children:
            child._parent = None
        self._children.clear()

    @property
    def children(self) -> list[Stage]:
        return list(self._children)

    def numChildren(self) -> int:
        return len(self._children)

    def __len__(self) -> int:
        return len(self._children)

    def __iter__(self) -> Iterator[Stage]:
        return iter(self._children)

    def __getitem__(self, key: int | str) -> Stage:
        """A child by index, or a descendant by name or 'a/b' path (KeyError naming it)."""
        if isinstance(key, int):
            return self._children[key]
        found = self.findChild(key)
        if found is None:
            names = ", ".join(f"'{c.name}'" for c in self._children)
            raise KeyError(f"container '{self._name}' has no stage '{key}' (children: {names})")
        return found

    def findChild(self, name: str) -> Stage | None:
        """A child by name, a deeper stage by 'container/child' path, or (failing both) the first
        stage of that name anywhere below."""
        head, _, rest = name.partition("/")
        for child in self._children:
            if child.name == head:
                if not rest:
                    return child
                if isinstance(child, ContainerBase):
                    found = child.findChild(rest)
                    if found is not None:
                        return found
        if "/" not in name:
            for stage, _depth in self.traverseRecursively():
                if stage is not self and stage.name == name:
                    return stage
        return None

    def traverseRecursively(self, depth: int = 0) -> Iterator[tuple[Stage, int]]:
        """This container and every stage below it, pre-order, with depth."""
        yield self, depth
        for child in self._children:
            if isinstance(child, ContainerBase):
                yield from child.traverseRecursively(depth + 1)
            else:
                yield child, depth + 1

    # ------------------------------------------------------------------ life cycle
    def reset(self) -> None:
        for child in self._children:
            child.reset()
        self._pending_backward.clear()
        self._pending_forward.clear()
        self._internal_to_external.clear()
        self._external_to_internal.clear()
        self._required = UNKNOWN
        super().reset()
        self._starts = None
        self._ends = None

    def init(self, robot_model: "RobotModel") -> None:
        Stage.init(self, robot_model)
        if not self._children:
            raise InitStageException(self, "no children (an empty container cannot produce solutions)")
        errors = InitStageException()
        for child in self._children:
            errors.collect(child.init, robot_model)
        if errors:
            raise errors

    def _required_interface(self) -> int:
        return self._required

    def _schedule_key(self) -> tuple | None:
        """The most urgent work of the children. (A container's own interfaces keep the states
        it has handed on, so they say nothing about pending work.)"""
        keys = [key for key in (child._schedule_key() for child in self._children) if key is not None]
        if keys:
            return min(keys)
        return GENERATOR_KEY if self._can_compute() else None

    def _validate_connectivity(self) -> None:
        for child in self._children:
            child._validate_connectivity()

    # ------------------------------------------------------------------ wiring
    def _set_child_push_backward(self, child: Stage) -> None:
        child._prev_ends = self._pending_backward if child._required_interface() & WRITES_PREV_END else None

    def _set_child_push_forward(self, child: Stage) -> None:
        child._next_starts = self._pending_forward if child._required_interface() & WRITES_NEXT_START else None

    def _copy_state(self, external: InterfaceState, target: Interface, updated: bool, direction: int = FORWARD) -> None:
        """Give a child its own copy of a state this container received (or refresh the
        priority of the copies)."""
        if updated:
            for internal in self._external_to_internal.get(id(external), ()):
                update_state_priorities(internal, external.priority, BACKWARD if direction == FORWARD else FORWARD)
            return
        internal = InterfaceState(external.scene, external.properties, external.priority, external.lineage_depth)
        self._states.append(internal)
        self._internal_to_external[id(internal)] = external
        self._external_to_internal[id(external)].append(internal)
        target.add(internal)

    def _lift_solution(self, solution: SolutionBase, internal_from: InterfaceState, internal_to: InterfaceState) -> None:
        """Store a solution found inside the container as the container's own, between external
        states (copies of the internal ones, created when new)."""
        self._compute_cost(internal_from, internal_to, solution)
        external_from = self._internal_to_external.get(id(internal_from))
        created_from = external_from is None
        if created_from:
            external_from = self._external_copy(internal_from)
        external_to = self._internal_to_external.get(id(internal_to))
        created_to = external_to is None
        if created_to:
            external_to = self._external_copy(internal_to)
        self._store_solution(solution, external_from, external_to)
        solution.set_start_state(external_from)
        solution.set_end_state(external_to)
        if not solution.is_failure:
            if created_from and self._prev_ends is not None:
                self._prev_ends.add(external_from)
            if created_to and self._next_starts is not None:
                self._next_starts.add(external_to)
        self._new_solution(solution)

    def _external_copy(self, internal: InterfaceState) -> InterfaceState:
        external = InterfaceState(internal.scene, internal.properties, internal.priority, internal.lineage_depth)
        self._states.append(external)
        self._internal_to_external[id(internal)] = external
        self._external_to_internal[id(external)].append(internal)
        return external

    def _on_new_solution(self, solution: SolutionBase) -> None:
        raise NotImplementedError

    def _on_new_failure(self, child: Stage, from_state: InterfaceState | None, to_state: InterfaceState | None) -> None:
        """A child failed on a state (MTC prunes here; pruning is off by default in a Task)."""

    # ------------------------------------------------------------------ introspection
    #: Whether the failure explanation names every child that failed (Alternatives), not only the first.
    _explains_every_failed_child = False

    def _explain_failure(self) -> str:
        """MTC's ContainerBase::explainFailure: the first child without solutions that failed,
        with its first failure's comment; descend into children that neither succeeded nor
        failed. A container's own failures (e.g. a PredicateFilter's rejections) come first."""
        if self._failures:
            return ": " + self._failures[0].comment
        lines = []
        for child in self._children:
            if child._solutions:
                continue
            if child._num_failures:
                lines.append(f"{child.name} (0/{child._num_failures}){child._explain_failure()}")
                if self._explains_every_failed_child:
                    continue
                break
            inner = child._explain_failure()
            if inner:
                lines.append(inner.lstrip(": "))
        return "\n".join(line for line in lines if line)


# ---------------------------------------------------------------------------- serial
class SerialContainer(ContainerBase):
    """Children in sequence; solutions are end-to-end sequences of the children's solutions."""

    def _resolve_interface(self, expected: int) -> None:
        if not self._children:
            raise InitStageException(self, "no children (an empty container cannot produce solutions)")
        if not expected & START_IF_MASK:
            raise InitStageException(self, "unknown start interface")
        errors = InitStageException()
        first, last = self._children[0], self._children[-1]
        try:
            first._resolve_interface(expected & START_IF_MASK)
            self._set_child_push_backward(first)
            self._validate_interface(first, expected, START_IF_MASK)
            target = first._starts
            if target is not None:
                self._starts = Interface(lambda s, updated, target=target: self._copy_state(s, target, updated, FORWARD))
        except InitStageException as exc:
            errors.append(exc)
        for previous, child in zip(self._children, self._children[1:]):
            try:
                child._resolve_interface(invert(previous._required_interface()) & START_IF_MASK)
                self._connect_children(previous, child)
            except InitStageException as exc:
                errors.append(exc)
        try:
            self._set_child_push_forward(last)
            self._validate_interface(last, expected, END_IF_MASK)
            target = last._ends
            if target is not None:
                self._ends = Interface(lambda s, updated, target=target: self._copy_state(s, target, updated, BACKWARD))
        except InitStageException as exc:
            errors.append(exc)
        self._required = (first._interface_flags() & START_IF_MASK) | (last._interface_flags() & END_IF_MASK)
        if errors:
            raise errors

    def _validate_interface(self, child: Stage, required: int, mask: int) -> None:
        required &= mask
        if required == UNKNOWN:
            return
        child_flags = child._interface_flags() & mask
        if child_flags != required:
            side = "start" if mask == START_IF_MASK else "end"
            symbol = flow_symbol_start if mask == START_IF_MASK else flow_symbol_end
            raise InitStageException(self, f"{side} interface ({symbol(child_flags)}) of '{child.name}' does not "
                                            f"match mine ({symbol(required)})")

    def _connect_children(self, first: Stage, second: Stage) -> None:
        f1, f2 = first._required_interface(), second._required_interface()
        if f1 & WRITES_NEXT_START and f2 & READS_START:
            first._next_starts = second._starts
        elif f1 & READS_END and f2 & WRITES_PREV_END:
            second._prev_ends = first._ends
        else:
            raise InitStageException(
                self, f"cannot connect end interface of '{first.name}' ({flow_symbol_end(f1)}) to start interface of "
                      f"'{second.name}' ({flow_symbol_start(f2)})")

    def _validate_connectivity(self) -> None:
        super()._validate_connectivity()
        for index, child in enumerate(self._children):
            flags = child._interface_flags()
            if index > 0 and flags & READS_START and self._children[index - 1]._next_starts is None:
                raise InitStageException(child, "start interface is not fed")
            if index + 1 < len(self._children) and flags & READS_END and self._children[index + 1]._prev_ends is None:
                raise InitStageException(child, "end interface is not fed")

    def _can_compute(self) -> bool:
        return any(child._can_compute() for child in self._children)

    def _schedule_key(self) -> tuple | None:
        keys = [key for key in (child._schedule_key() for child in self._children) if key is not None]
        return min(keys) if keys else None

    def _compute(self) -> None:
        # One child per step, the one with the most urgent work (see the schedule note in
        # stage.py; MTC computes every child once per round). Ties go to the earlier child.
        chosen, best = None, None
        for child in self._children:
            key = child._schedule_key()
            if key is not None and (best is None or key < best):
                chosen, best = child, key
        if chosen is not None:
            chosen._run_compute()

    def _on_new_solution(self, current: SolutionBase) -> None:
        children = self._children
        incoming = _collect(current.start, BACKWARD)
        outgoing = _collect(current.end, FORWARD)
        complete: list[SolutionSequence] = []
        own = Priority(1, current.cost)
        for in_trace, in_prio in incoming:
            for out_trace, out_prio in outgoing:
                prio = in_prio + own + out_prio
                if prio.depth == len(children):
                    sequence = list(reversed(in_trace)) + [current] + out_trace
                    complete.append(SolutionSequence(self, sequence, prio.cost))
                if prio.depth > 1:
                    update_state_priorities(current.start, prio, BACKWARD)  # type: ignore[arg-type]
                    update_state_priorities(current.end, prio, FORWARD)  # type: ignore[arg-type]
        complete.sort(key=lambda s: s.cost)
        for sequence in complete:
            self._lift_solution(sequence, sequence.internal_start, sequence.internal_end)


def _collect(state: InterfaceState | None, direction: int) -> list[tuple[list[SolutionBase], Priority]]:
    """Every partial solution path leaving ``state`` in ``direction`` (MTC's SolutionCollector)."""
    results: list[tuple[list[SolutionBase], Priority]] = []
    trace: list[SolutionBase] = []

    def traverse(current: InterfaceState, prio: Priority) -> None:
        successors = current.outgoing if direction == FORWARD else current.incoming
        if not successors:
            results.append((list(trace), prio))
            return
        for solution in successors:
            if solution.is_failure:
                continue
            trace.append(solution)
            traverse(solution.end if direction == FORWARD else solution.start, prio + Priority(1, solution.cost))
            trace.pop()

    if state is not None:
        traverse(state, Priority(0, 0.0))
    return results


# ---------------------------------------------------------------------------- parallel
class ParallelContainerBase(ContainerBase):
    """Children that work side by side on the same states."""

    def _resolve_interface(self, expected: int) -> None:
        if not self._children:
            raise InitStageException(self, "no children (an empty container cannot produce solutions)")
        errors = InitStageException()
        external = expected
        first = True
        for child in self._children:
            try:
                child._resolve_interface(expected)
                external = self._validate_child(child, external, first)
                self._set_child_push_backward(child)
                self._set_child_push_forward(child)
                first = False
            except InitStageException as exc:
                errors.append(exc)
        if errors:
            raise errors
        self._required = external
        self._initialize_external_interfaces()

    def _validate_child(self, child: Stage, external: int, first: bool) -> int:
        child_flags = child._required_interface()
        valid = True
        for mask in (START_IF_MASK, END_IF_MASK):
            if external & mask == UNKNOWN:
                external |= child_flags & mask
            valid = valid and (external & mask) == (child_flags & mask)
        if not valid:
            other = "the external one" if first else "the other children's"
            raise InitStageException(self, f"interface of '{child.name}' ({interface_text(child_flags)}) does not match "
                                            f"{other} ({interface_text(external)})")
        return external

    def _initialize_external_interfaces(self) -> None:
        if self._required & READS_START:
            self._starts = Interface(lambda s, updated: self._to_all_children(s, updated, FORWARD))
        if self._required & READS_END:
            self._ends = Interface(lambda s, updated: self._to_all_children(s, updated, BACKWARD))

    def _to_all_children(self, external: InterfaceState, updated: bool, direction: int) -> None:
        for child in self._children:
            target = child._starts if direction == FORWARD else child._ends
            if target is not None:
                self._copy_state(external, target, updated, direction)

    def _can_compute(self) -> bool:
        """Whether any child can compute (the children work side by side)."""
        return any(child._can_compute() for child in self._children)

    def _compute(self) -> None:
        """One compute step of every child that can compute."""
        for child in self._children:
            if child._can_compute():
                child._run_compute()

    def _lift_wrapped(self, solution: SolutionBase, cost: float | None = None, comment: str | None = None) -> None:
        self._lift_solution(WrappedSolution(self, solution, cost, comment), solution.start, solution.end)  # type: ignore[arg-type]

    # pushing own results (ComputeIK, Merger)
    def spawn(self, state: InterfaceState, solution: SolutionBase) -> None:
        self._spawn(state, InterfaceState(state.scene, state.properties, state.priority, state.lineage_depth), solution)

    def sendForward(self, from_state: InterfaceState, to_state: InterfaceState, solution: SolutionBase) -> None:
        self._send_forward(from_state, to_state, solution)

    def sendBackward(self, from_state: InterfaceState, to_state: InterfaceState, solution: SolutionBase) -> None:
        self._send_backward(from_state, to_state, solution)


class Alternatives(ParallelContainerBase):
    """All children get every state; every child solution is a solution of the container."""

    _explains_every_failed_child = True

    def _on_new_solution(self, solution: SolutionBase) -> None:
        self._lift_wrapped(solution)


class Fallbacks(ParallelContainerBase):
    """Children tried in order: a child gets a state (or pair of states) only if the children
    before it found no solution for it. As a generator, the first child with solutions wins."""

    def __init__(self, name: str = "", children: Iterable[Stage] = ()) -> None:
        super().__init__(name, children)
        self._mode = UNKNOWN
        self._current = 0
        self._job: InterfaceState | None = None
        self._job_has_solutions = False
        self._direction = FORWARD
        self._active = 0

    def reset(self) -> None:
        super().reset()
        self._mode = UNKNOWN
        self._current = 0
        self._job = None
        self._job_has_solutions = False
        self._active = 0

    def _initialize_external_interfaces(self) -> None:
        required = self._required
        self._mode = required
        if required == GENERATE:
            self._current = 0
        elif required in (PROPAGATE_FORWARDS, PROPAGATE_BACKWARDS):
            # Jobs wait here; each is handed to one child at a time.
            self._direction = FORWARD if required == PROPAGATE_FORWARDS else BACKWARD
            if self._direction == FORWARD:
                self._starts = Interface()
            else:
                self._ends = Interface()
            self._current = 0
            self._job = None
        elif required == CONNECT:
            for child in self._children:
                if not isinstance(child, Connecting):
                    raise InitStageException(self, f"a connecting Fallbacks needs connecting children; "
                                                    f"'{child.name}' is a {type(child).__name__}")
            first = self._children[0]
            # All children share the first child's interfaces; pairs move on to the next child
            # when a child fails on them.
            for child in self._children[1:]:
                child._starts, child._ends = first._starts, first._ends
            self._starts = Interface(lambda s, updated: self._copy_state(s, first._starts, updated, FORWARD))  # type: ignore[arg-type]
            self._ends = Interface(lambda s, updated: self._copy_state(s, first._ends, updated, BACKWARD))  # type: ignore[arg-type]
            self._active = 0
        else:
            raise InitStageException(self, f"unsupported interface {interface_text(required)}")

    def _pull(self) -> Interface:
        return self._starts if self._direction == FORWARD else self._ends  # type: ignore[return-value]

    def _can_compute(self) -> bool:
        mode = self._mode
        children = self._children
        if mode == CONNECT:
            for index, child in enumerate(children):
                if child._can_compute():
                    self._active = index
                    return True
            return False
        while self._current < len(children) and not children[self._current]._can_compute():
            if not self._next_job():
                return False
        return self._current < len(children)

    def _next_job(self) -> bool:
        children = self._children
        if self._mode == GENERATE:
            if self._solutions:
                self._current = len(children)  # exhausted: the first successful child wins
                return False
            self._current += 1
            while self._current < len(children) and not children[self._current]._can_compute():
                self._current += 1
            return self._current < len(children)
        jobs = self._pull()
        if self._job is not None:
            if not self._job_has_solutions:
                self._current += 1  # this child failed on the job: try the next one
            else:
                self._current = len(children)
        self._job_has_solutions = False
        if self._current >= len(children):
            if self._job is not None:
                if self._job in jobs:
                    jobs.remove(self._job)
                self._job = None
            self._current = 0
        if self._job is None:
            front = jobs.front()
            if front is None:
                return False
            self._job = front
        child = children[self._current]
        target = child._starts if self._direction == FORWARD else child._ends
        self._copy_state(self._job, target, False, self._direction)  # type: ignore[arg-type]
        return True

    def _compute(self) -> None:
        index = self._active if self._mode == CONNECT else self._current
        self._children[index]._run_compute()

    def _schedule_key(self) -> tuple | None:
        if not self._can_compute():  # (also hands the next job to a child)
            return None
        key = super()._schedule_key()
        if key is not None and self._mode in (PROPAGATE_FORWARDS, PROPAGATE_BACKWARDS):
            waiting = self._pull().front_key()  # jobs not yet handed to a child
            if waiting is not None and waiting < key:
                key = waiting
        return key

    def _on_new_solution(self, solution: SolutionBase) -> None:
        self._job_has_solutions = True
        self._lift_wrapped(solution)

    def _on_new_failure(self, child: Stage, from_state, to_state) -> None:
        if self._mode != CONNECT:
            return
        index = self._children.index(child)
        if index + 1 < len(self._children) and from_state is not None and to_state is not None:
            self._children[index + 1]._pending.append((from_state, to_state))  # type: ignore[attr-defined]

    def _explain_failure(self) -> str:
        if self._failures:
            return ": " + self._failures[0].comment
        lines = []
        for child in self._children:
            if child._num_failures and not child._solutions:
                lines.append(f"{child.name} (0/{child._num_failures}){child._explain_failure()}")
        return "\n".join(lines)


class Merger(ParallelContainerBase):
    """Plan every child (one group each) from the same state and merge their trajectories into
    one simultaneous motion of the union of the groups."""

    def __init__(self, name: str = "", children: Iterable[Stage] = ()) -> None:
        super().__init__(name, children)
        self._solutions_by_source: dict[int, dict[int, list[SubTrajectory]]] = {}

    def reset(self) -> None:
        super().reset()
        self._solutions_by_source = {}

    def _resolve_interface(self, expected: int) -> None:
        super()._resolve_interface(expected)
        if self._required in (PROPAGATE_FORWARDS, PROPAGATE_BACKWARDS, UNKNOWN):
            return
        if self._required == GENERATE:
            raise InitStageException(self, "generator stages are not supported by Merger")
        if self._required == CONNECT:
            raise InitStageException(self, "cannot merge connecting stages; use Connect with several groups")
        raise InitStageException(self, f"children's interface {interface_text(self._required)} is not supported")

    def _on_new_solution(self, solution: SolutionBase) -> None:
        if not isinstance(solution, SubTrajectory) or solution.trajectory is None:
            self._silent_failure()
            return
        forward = self._required == PROPAGATE_FORWARDS
        internal = solution.start if forward else solution.end
        external = self._internal_to_external.get(id(internal))
        if external is None:
            return
        by_child = self._solutions_by_source.setdefault(id(external), {})
        by_child.setdefault(id(solution.creator), []).append(solution)
        if len(by_child) < len(self._children):
            return
        others = [by_child[id(child)] for child in self._children if child is not solution.creator]
        for combination in _product(others):
            self._merge([solution] + combination, external, forward)

    def _merge(self, parts: list[SubTrajectory], external: InterfaceState, forward: bool) -> None:
        scene = external.scene
        start = scene.current_state
        ordered = sorted(parts, key=lambda s: self._children.index(s.creator))  # type: ignore[arg-type]
        if not forward:
            # Backward children planned towards the external state: merge them from their starts,
            # which share the external state's joints outside their own group.
            start = _combined_start(ordered, scene)
        planners = [getattr(s.creator, "planner", None) for s in ordered]
        distances = [float(p.properties["max_waypoint_distance"]) for p in planners if p is not None]
        trajectory, group, message = merge_trajectories(
            scene, start, [(s.group, s.trajectory) for s in ordered],  # type: ignore[misc]
            max_waypoint_distance=min(distances, default=DEFAULT_MAX_WAYPOINT_DISTANCE))
        solution = SubTrajectory(trajectory, group or None, planner_id=", ".join(s.planner_id for s in ordered if s.planner_id))
        new_scene = scene.diff()
        if trajectory is None:
            solution.markAsFailure(message)
        else:
            jmg = scene.robot_model.group(group)
            positions = start.positions.copy()
            positions[jmg.variable_indices] = trajectory.positions[-1 if forward else 0]
            new_scene.set_current_state(positions)
        if forward:
            self._send_forward(external, InterfaceState(new_scene), solution)
        else:
            self._send_backward(InterfaceState(new_scene), external, solution)


def _product(lists: list[list[SubTrajectory]]) -> Iterator[list[SubTrajectory]]:
    if not lists:
        yield []
        return
    for item in lists[0]:
        for rest in _product(lists[1:]):
            yield [item] + rest


def _combined_start(parts: list[SubTrajectory], scene) -> "object":
    start = scene.current_state.copy()
    positions = start.positions.copy()
    model = scene.robot_model
    for part in parts:
        indices = [model.variable_index(n) for n in part.trajectory.joint_names]  # type: ignore[union-attr]
        positions[indices] = part.trajectory.positions[0]  # type: ignore[union-attr]
    start.set_positions(positions)
    return start


class WrapperBase(ParallelContainerBase):
    """A container with exactly one child whose solutions it post-processes."""

    def __init__(self, name: str = "", child: Stage | None = None) -> None:
        super().__init__(name)
        if child is not None:
            self.insert(child)

    def insert(self, stage: Stage, before: int = -1) -> None:
        if self._children:
            raise TaskError(f"wrapper '{self._name}' holds a single child (it already wraps '{self._children[0].name}')")
        super().insert(stage, before)

    @property
    def wrapped(self) -> Stage | None:
        return self._children[0] if self._children else None

    def _can_compute(self) -> bool:
        return self._children[0]._can_compute()

    def _compute(self) -> None:
        self._children[0]._run_compute()

    def _on_new_solution(self, solution: SolutionBase) -> None:
        self._lift_wrapped(solution)

