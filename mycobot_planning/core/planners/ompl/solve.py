"""Joint-space planning with OMPL: a box, a validity callback, a start and goals in; a path out.

Knows no robot. The wheel's threading and ownership rules this code works around are in
docs/ompl.md.
"""
from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from .config import DEFAULT_LVSF
from .planners import PLANNERS, OmplConfigError, apply_params, PlannerSpec, validate_params, canonical_planner_type

# --------------------------------------------------------------------------------------------
# Planning
# --------------------------------------------------------------------------------------------

#: |f| at which OMPL's projection onto a constraint manifold stops (OMPL's default)
MANIFOLD_TOLERANCE = 1e-4
#: _solve_once's message for a constrained path still to be reversed (it runs goal -> start)
_REVERSE_LATER = "reverse later"


@dataclass
class OmplResult:
    """Outcome of plan_joint_space.

    ``status`` is the name of OMPL's PlannerStatus (``EXACT_SOLUTION``, ``TIMEOUT``,
    ``INVALID_START``, ``INVALID_GOAL``, ``INFEASIBLE``; ``ABORT`` when cancelled, ``CRASH`` when
    OMPL raised, with the reason in ``message``), with one mapping: OMPL's
    ``APPROXIMATE_SOLUTION`` is reported as ``TIMEOUT`` (``approximate=True``). With our
    termination conditions a planner only stops short of the goal when the time is up, and an
    approximate path does not reach the goal, so MoveIt-style callers must treat it as a
    time-out failure. ``success`` is True only for ``EXACT_SOLUTION``; ``path`` is then
    ``N x d`` (first row = start, last row = one of the goals, ``goal_index`` says which) and
    otherwise ``0 x d``.
    """

    success: bool
    status: str
    path: np.ndarray
    planning_time: float
    simplify_time: float
    planner: str = ""
    goal_index: int | None = None
    approximate: bool = False
    validity_checks: int = 0  # states checked: pre-checks + every state OMPL asked about (planning + simplification)
    message: str = ""
    direct: bool = False  # the path is the straight motion start -> goal (try_direct), nothing shorter exists


class _CallbackContext:
    """State shared by the validity bridge and plan_joint_space. Holds no OMPL object except,
    during solve only, the termination condition (cleared in ``finally``; see docs/ompl.md)."""

    __slots__ = ("error", "ptc", "cancelled")

    def __init__(self) -> None:
        self.error: BaseException | None = None
        self.ptc: Any = None
        self.cancelled = False


#: what a detached _ManifoldBridge points to instead of a planning call's context
_DETACHED = _CallbackContext()


def _guarded_validity(
    fn: Callable[[np.ndarray], bool],
    ctx: _CallbackContext,
    counter: list[int],
    cancel: Any = None,
) -> Callable[[np.ndarray], bool]:
    """The user function as OMPL may call it: counted, never raising, and cancellable.

    An exception from the user function must not unwind through OMPL (PRM would hit
    std::terminate with its helper thread still running), so it is stored, the planner is told
    to stop, every further state is reported invalid, and plan_joint_space re-raises it.
    ``cancel`` (anything with ``is_set()``) is polled here too: a Python termination condition
    is not an option (PRM evaluates it from its own thread), and every planner checks states
    continuously, so this is where a cancel request is seen soonest. The test and the call are
    made under a lock: PRM calls from two threads, and without it one thread could pass the test
    while the other's call is raising, so the user function would be called after its failure.
    """
    lock = threading.Lock()

    def valid(q: np.ndarray) -> bool:
        with lock:
            counter[0] += 1
            if ctx.error is not None or ctx.cancelled:
                return False
            if cancel is not None and cancel.is_set():
                ctx.cancelled = True
                if ctx.ptc is not None:
                    ctx.ptc.terminate()
                return False
            try:
                return bool(fn(q))
            except BaseException as e:  # noqa: BLE001 - re-raised by plan_joint_space
                ctx.error = e
                if ctx.ptc is not None:
                    ctx.ptc.terminate()
                return False

    return valid


def _guarded_batch(
    fn: Callable[[np.ndarray], np.ndarray] | None,
    ctx: _CallbackContext,
    counter: list[int],
) -> Callable[[np.ndarray], np.ndarray] | None:
    """The batch test (``batch_free``) as the edge checks call it: never raising (an exception is
    stored and re-raised by plan_joint_space, as _guarded_validity does) and counted: each state
    it calls free counts as a check (the others go on to the validity function, counted there)."""
    if fn is None:
        return None

    def free(states: np.ndarray) -> np.ndarray:
        if ctx.error is not None or ctx.cancelled:
            return np.zeros(len(states), dtype=bool)
        try:
            out = np.asarray(fn(states), dtype=bool)
        except BaseException as e:  # noqa: BLE001 - re-raised by plan_joint_space
            ctx.error = e
            if ctx.ptc is not None:
                ctx.ptc.terminate()
            return np.zeros(len(states), dtype=bool)
        counter[0] += int(np.count_nonzero(out))
        return out

    return free


def _make_validity_bridge(valid: Callable[[np.ndarray], bool], dim: int,
                          indexed: bool = False) -> Callable[[Any], bool]:
    """The callable OMPL calls per state: state -> fresh numpy array -> guarded user function.
    ``indexed``: the states are a constrained space's, which can only be read one value at a time."""
    array = np.array
    if indexed:
        dims = range(dim)

        def is_valid_indexed(state: Any) -> bool:
            return valid(array([state[i] for i in dims]))

        return is_valid_indexed

    def is_valid(state: Any) -> bool:
        return valid(array(state[0:dim]))

    return is_valid


class _ManifoldBridge(ob.Constraint):
    """OMPL's view of a constraint manifold ``f(x) = 0`` (a Python object with ``codim``,
    ``value(x)`` and ``jacobian(x)``): OMPL's ProjectedStateSpace calls ``function`` and
    ``jacobian`` to project states (Newton steps) and to walk along the manifold. Like the
    validity bridge, it never lets an exception unwind through OMPL: it is stored in the
    context, the planner is told to stop, and plan_joint_space re-raises it. Holds no OMPL
    object (see docs/ompl.md on reference cycles)."""

    def __init__(self, dim: int, manifold: Any, tolerance: float, ctx: "_CallbackContext") -> None:
        super().__init__(dim, int(manifold.codim), float(tolerance))
        self._value = manifold.value
        self._jacobian = manifold.jacobian
        self._ctx = ctx

    def detach(self) -> None:
        """Drop every reference to Python objects: the C++ space keeps this object alive, and a
        stored exception's traceback can lead back to that space (a cycle the GC cannot see)."""
        self._value = self._jacobian = None
        self._ctx = _DETACHED

    def _fail(self, error: BaseException) -> None:
        ctx = self._ctx
        if ctx.error is None:
            ctx.error = error
        if ctx.ptc is not None:
            ctx.ptc.terminate()

    def function(self, x: Any, out: Any) -> None:  # noqa: D401 - OMPL's name
        if self._ctx.error is not None or self._value is None:
            out[:] = 0.0
            return
        try:
            out[:] = self._value(np.array(x, dtype=float))
        except BaseException as e:  # noqa: BLE001 - re-raised by plan_joint_space
            self._fail(e)
            out[:] = 0.0

    def jacobian(self, x: Any, out: Any) -> None:
        if self._ctx.error is not None or self._jacobian is None:
            out[:, :] = 0.0
            return
        try:
            out[:, :] = self._jacobian(np.array(x, dtype=float))
        except BaseException as e:  # noqa: BLE001
            self._fail(e)
            out[:, :] = 0.0


_ORDERS: dict[int, np.ndarray] = {}


def _bisection_order(segments: int) -> np.ndarray:
    """Interior fractions of an edge cut into ``segments``, in DiscreteMotionValidator's order
    (breadth-first halving)."""
    order = _ORDERS.get(segments)
    if order is None:
        mids: list[int] = []
        queue = [(1, segments - 1)] if segments >= 2 else []
        while queue:
            first, last = queue.pop(0)
            mid = (first + last) // 2
            mids.append(mid)
            if first < mid:
                queue.append((first, mid - 1))
            if last > mid:
                queue.append((mid + 1, last))
        order = np.array(mids, dtype=float) / segments
        order.setflags(write=False)
        if len(_ORDERS) < 4096:
            _ORDERS[segments] = order
    return order


_WITH_END: dict[int, np.ndarray] = {}


def _edge_fractions(segments: int) -> np.ndarray:
    """1.0 (the end state), then _bisection_order(segments): an edge's states in checking order."""
    order = _WITH_END.get(segments)
    if order is None:
        order = np.concatenate([[1.0], _bisection_order(segments)])
        order.setflags(write=False)
        if len(_WITH_END) < 4096:
            _WITH_END[segments] = order
    return order


#: _edge_valid's batch stages: the first this many states of an edge, then each stage this many
#: times the previous one (until the rest of the edge)
EDGE_FIRST_STAGE = 8
EDGE_STAGE_GROWTH = 4


def _edge_valid(a: np.ndarray, b: np.ndarray, fractions: np.ndarray, valid: Callable[[np.ndarray], bool],
                batch: Callable[[np.ndarray], np.ndarray] | None, end_known: bool = False) -> int:
    """How far the edge's states ``a + f (b - a)`` (f in ``fractions``, _edge_fractions: the end
    first) are valid, asked in that order, the first invalid one ending it: 0 the end state is
    invalid, 1 an interior state is, 2 all are valid. Each state the batch test calls free is
    valid (it never calls an invalid state free); every other one is asked of ``valid``: the
    answer is ``valid``'s, for fewer calls. ``end_known``: the end is known to be valid."""
    states = a + fractions[:, None] * (b - a)
    states[0] = b  # the end state exactly (a + (b - a) may round)
    if batch is None:
        for k in range(1 if end_known else 0, len(states)):
            if not valid(states[k].copy() if k == 0 else states[k]):  # a copy of the end: it is kept
                return 1 if k else 0
        return 2
    # In stages, the first few states (the end and the first halvings) first: an edge that is
    # invalid is mostly found so within its first five states, and the rest of its states (a
    # plan's edges are ~46 states, three in five edges invalid) need not be tested at all.
    first = 1 if end_known else 0
    count = len(states)
    done, size = 0, EDGE_FIRST_STAGE
    while done < count:
        stop = count if count - done <= 2 * size else done + size
        free = batch(states[done:stop]).tolist()
        if not all(free):
            for k in range(max(done, first), stop):
                if not free[k - done] and not valid(states[k].copy() if k == 0 else states[k]):
                    return 1 if k else 0
        done, size = stop, size * EDGE_STAGE_GROWTH
    return 2


def _direct_motion(a: np.ndarray, b: np.ndarray, valid: Callable[[np.ndarray], bool], resolution: float,
                   batch: Callable[[np.ndarray], np.ndarray] | None = None) -> bool:
    """The straight edge a -> b checked as DiscreteMotionValidator checks an edge (the end, then
    the interior by halving, at most ``resolution`` apart in the Euclidean norm), by ``valid``
    (_guarded_validity's function) after the batch test (_guarded_batch's, or None)."""
    segments = max(1, int(math.ceil(float(np.linalg.norm(b - a)) / resolution)))
    return _edge_valid(a, b, _edge_fractions(segments), valid, batch) == 2


class _EdgeValidator(ob.MotionValidator):
    """OMPL's DiscreteMotionValidator, with each edge's states made by NumPy and checked in one
    Python loop: the end state first, then the interior by repeated halving (the same states in
    the same order, so plans are identical), but without an OMPL-to-Python call, a state copy
    and an array per state. With a batch test (``batch_free`` of plan_joint_space) the edge's
    states first go to it in one call, and only those it cannot call free to the validity
    function (_edge_valid): the same answers for a fraction of the cost. Edge checks are most of a plan's validity checks (the simplifier
    alone makes two thirds of them). Used only for planners that ask plain (from, to)
    questions (``PlannerSpec.plain_motion_checks``).

    Answers are remembered for the plan: an edge asked again (a fifth of the questions on the
    myCobot's benchmark plan: the simplifier's rounds and its final check of the path ask about
    edges already decided) and an end state seen before (tree nodes and path vertices end many
    edges) are not checked again. Same questions, same answers, so the same path: only fewer
    states go to the validity function."""

    def __init__(self, si: Any, valid: Callable[[np.ndarray], bool], dim: int,
                 batch: Callable[[np.ndarray], np.ndarray] | None = None) -> None:
        super().__init__(si)
        self._space = si.getStateSpace()
        self._valid = valid  # _guarded_validity's function: counted, never raising, cancellable
        self._batch = batch  # _guarded_batch's function or None
        self._dim = dim
        self._edges: dict[bytes, bool] = {}
        self._ends: dict[bytes, bool] = {}

    def checkMotion(self, s1: Any, s2: Any, *last_valid: Any) -> bool:  # noqa: N802 - OMPL's name
        if last_valid:  # never asked by the planners this is installed for
            raise RuntimeError("_EdgeValidator cannot report the last valid state")
        dim = self._dim
        a = np.array(s1[0:dim])
        b = np.array(s2[0:dim])
        end = b.tobytes()
        edge = a.tobytes() + end
        known = self._edges.get(edge)
        if known is not None:
            return known
        ok = self._ends.get(end)
        if ok is None and self._batch is None:  # without the batch test: the end alone first
            ok = self._ends[end] = bool(self._valid(b.copy()))  # a copy: the function may write into it
        if ok is False:
            self._edges[edge] = False
            return False
        fractions = _edge_fractions(self._space.validSegmentCount(s1, s2))
        reached = _edge_valid(a, b, fractions, self._valid, self._batch, end_known=ok is True)
        self._ends[end] = reached > 0
        ok = reached == 2
        self._edges[edge] = ok
        return ok


_IDLE: list[Any] = []


def _idle_motion_validator() -> _EdgeValidator:
    """A validator bound to a one-dimensional space of its own, never asked anything: what a
    finished plan's SpaceInformation holds instead of the _EdgeValidator that points back at it."""
    if not _IDLE:
        space = ob.RealVectorStateSpace(1)
        bounds = ob.RealVectorBounds(1)
        bounds.setLow(0.0)
        bounds.setHigh(1.0)
        space.setBounds(bounds)
        _IDLE.append(_EdgeValidator(ob.SpaceInformation(space), lambda q: True, 1))
    return _IDLE[0]


def _as_vector(name: str, value: Any, dim: int | None) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise OmplConfigError(f"{name} must be a vector of numbers, got {value!r}") from None
    if v.ndim != 1 or (dim is not None and v.shape[0] != dim):
        want = f"length {dim}" if dim is not None else "a 1-D vector"
        raise OmplConfigError(f"{name} must be {want}, got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise OmplConfigError(f"{name} contains NaN or infinite values: {v.tolist()}")
    return v


def _status_name(status: Any) -> str:
    return status.getStatus().name


def _fill(si: Any, values: np.ndarray) -> Any:
    s = si.allocState()  # uninitialised memory: every coordinate is written below
    if isinstance(s, ob.ConstrainedStateSpaceStateType):
        s.copy([float(x) for x in values])
    else:
        s[0 : len(values)] = [float(x) for x in values]
    return s


def _path_array(path: Any, dim: int) -> np.ndarray:
    states = path.getStates()
    if states and isinstance(states[0], ob.ConstrainedStateSpaceStateType):
        return np.array([[s[i] for i in range(dim)] for s in states], dtype=float).reshape(-1, dim)
    return np.array([s[0:dim] for s in states], dtype=float).reshape(-1, dim)


def plan_joint_space(
    lower: Sequence[float] | np.ndarray,
    upper: Sequence[float] | np.ndarray,
    is_state_valid: Callable[[np.ndarray], bool],
    start: Sequence[float] | np.ndarray,
    goals: Sequence[Sequence[float] | np.ndarray],
    planner_type: str = "geometric::RRTConnect",
    planner_params: Mapping[str, Any] | None = None,
    timeout: float = 5.0,
    longest_valid_segment_fraction: float = DEFAULT_LVSF,
    simplify: bool = True,
    interpolate_states: int | None = None,
    seed: int | None = None,
    *,
    projection_dims: Sequence[int] | None = None,
    stop_on_first_solution: bool = False,
    simplify_max_time: float | None = None,
    cancel: Any = None,
    manifold: Any = None,
    manifold_delta: float | None = None,
    try_direct: bool = False,
    batch_free: Callable[[np.ndarray], np.ndarray] | None = None,
) -> OmplResult:
    """Plan a collision-free joint-space path from ``start`` to any of ``goals`` with OMPL.

    The space is the box ``[lower, upper]`` (a RealVectorStateSpace; continuous joints must be
    given finite bounds by the caller). ``is_state_valid(q)`` gets a fresh float64 array of
    length d and says whether ``q`` is collision-free/allowed; it need not check bounds. Edges
    are checked by OMPL's DiscreteMotionValidator at spacing
    ``longest_valid_segment_fraction * extent`` where extent is the diagonal of the box
    (``sqrt(sum((upper-lower)**2))``), exactly as MoveIt does.

    Pre-checks happen here, in Python, for every planner alike: start out of bounds or invalid
    -> ``INVALID_START``; goals out of bounds or invalid are dropped, none left ->
    ``INVALID_GOAL``; a start equal to a goal returns the two-point path at once.

    ``timeout`` bounds the solve (not simplification). Optimizing planners use all of it unless
    ``stop_on_first_solution``. ``simplify`` runs OMPL's PathSimplifier (vertex reduction,
    shortcutting, B-spline smoothing, better-goal search among ``goals``): ``simplifyMax`` when
    ``simplify_max_time`` is None (deterministic), else ``simplify(path, simplify_max_time)``
    as MoveIt does. ``interpolate_states``: None keeps the waypoints; 0 interpolates to the
    validity-checking resolution (MoveIt's ``interpolate()``); n > 0 additionally guarantees at
    least n states (MoveIt's ``minimum_waypoint_count``). ``projection_dims`` are the state
    dimensions KPIECE-family planners project onto (default: the first two). ``seed`` (>= 1)
    reseeds OMPL's global RNG first (see docs/ompl.md for what that makes reproducible).
    ``cancel`` (e.g. a ``threading.Event``, set from another thread: an action server's cancel)
    stops planning or simplification within one state check; the result is then ``ABORT``.

    ``manifold`` (an object with ``codim`` > 0, ``value(x)`` -> ``f`` of length codim and
    ``jacobian(x)`` -> codim x d) plans on the constraint manifold ``f(x) = 0`` with OMPL's
    ProjectedStateSpace (MoveIt's ``enforce_constrained_state_space``): samples are projected
    onto it by Newton steps, and edges are walked along it in steps of ``manifold_delta``
    (joint-space distance; default OMPL's 0.05), each state projected and checked, so
    ``longest_valid_segment_fraction`` no longer sets the edge resolution; interpolation
    (``interpolate_states``) follows the manifold the same way. The start and the goals must
    satisfy ``f = 0`` (within OMPL's projection tolerance, 1e-4 on ``|f|``). ``is_state_valid``
    still decides validity. Bidirectional planners given several goals plan from the goals
    (see docs/ompl.md); their path is simplified and interpolated in the direction it was
    planned, then reversed, because a walk along the manifold depends on its direction. Every
    configured planner runs on it; some only slowly (on the Panda demo of
    test/task/test_mtc_path_constraints.py, SORRTstar and BFMT time out).

    ``try_direct`` (not with a manifold): before OMPL is set up, the straight edge from the start
    to each goal (nearest first) is checked exactly as the planner checks an edge; the first
    valid one is the answer (``message`` says so), with no tree, no simplification (a straight
    edge is what the simplifier would end at) and interpolation as asked. Easy problems then
    cost one edge check; when every direct edge is blocked (most checks fail at the first
    halvings) the planner runs as usual.

    ``batch_free`` (not with a manifold): ``f(states (N, d)) -> (N,) bool``, True only for states
    ``is_state_valid`` certainly calls valid (PlanningScene.batch_free_checker): edges (the
    planner's, when it asks plain edge questions, and try_direct's) go to it in one call per
    edge first, and to ``is_state_valid`` only for the states it leaves undecided. Same
    answers, so the same path, for fewer calls.

    Raises OmplConfigError for malformed input (naming it) and re-raises any exception from
    ``is_state_valid`` (or the manifold's functions) after stopping the planner.
    """
    ptype = canonical_planner_type(planner_type)
    spec = PLANNERS[ptype]
    params = validate_params(ptype, planner_params, f"planner {ptype}")

    lo = _as_vector("lower", lower, None)
    dim = lo.shape[0]
    if dim == 0:
        raise OmplConfigError("lower/upper must have at least one dimension")
    hi = _as_vector("upper", upper, dim)
    bad = [i for i in range(dim) if not lo[i] < hi[i]]
    if bad:
        raise OmplConfigError(f"lower must be < upper in every dimension; not so in dimension(s) {bad}")
    q_start = _as_vector("start", start, dim)
    if isinstance(goals, np.ndarray) and goals.ndim == 1:
        raise OmplConfigError("goals must be a list of goal vectors (wrap a single goal in a list)")
    goal_list = [_as_vector(f"goals[{i}]", g, dim) for i, g in enumerate(goals)]
    if not goal_list:
        raise OmplConfigError("goals is empty: give at least one goal configuration")
    if not callable(is_state_valid):
        raise OmplConfigError("is_state_valid must be callable: q (np.ndarray) -> bool")
    if not (isinstance(timeout, (int, float)) and math.isfinite(timeout) and timeout > 0):
        raise OmplConfigError(f"timeout must be a positive number of seconds, got {timeout!r}")
    if not (isinstance(longest_valid_segment_fraction, (int, float)) and 0 < longest_valid_segment_fraction <= 1):
        raise OmplConfigError(
            f"longest_valid_segment_fraction must be in (0, 1], got {longest_valid_segment_fraction!r}"
        )
    if interpolate_states is not None and (
        isinstance(interpolate_states, bool) or not isinstance(interpolate_states, int) or interpolate_states < 0
    ):
        raise OmplConfigError(f"interpolate_states must be None or an int >= 0, got {interpolate_states!r}")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 1 <= seed < 2**32):
        raise OmplConfigError(f"seed must be None or an integer in [1, 2**32), got {seed!r}")
    if simplify_max_time is not None and not (
        isinstance(simplify_max_time, (int, float)) and math.isfinite(simplify_max_time) and simplify_max_time > 0
    ):
        raise OmplConfigError(f"simplify_max_time must be None or > 0 seconds, got {simplify_max_time!r}")
    if projection_dims is None:
        proj = list(range(min(2, dim)))
    else:
        proj = [int(i) for i in projection_dims]
        if not proj or len(set(proj)) != len(proj) or any(not 0 <= i < dim for i in proj):
            raise OmplConfigError(
                f"projection_dims must be distinct state dimensions in [0, {dim}), got {list(projection_dims)!r}"
            )

    if batch_free is not None and not callable(batch_free):
        raise OmplConfigError("batch_free must be None or callable: states (N, d) -> (N,) bool")
    if cancel is not None and not callable(getattr(cancel, "is_set", None)):
        raise OmplConfigError("cancel must be None or an object with is_set() (e.g. threading.Event)")
    constrained = manifold is not None
    if constrained:
        codim = getattr(manifold, "codim", None)
        if isinstance(codim, bool) or not isinstance(codim, (int, np.integer)) or not 0 < codim < dim:
            raise OmplConfigError(f"manifold.codim must be an integer in [1, {dim}), got {codim!r}")
        if not (callable(getattr(manifold, "value", None)) and callable(getattr(manifold, "jacobian", None))):
            raise OmplConfigError("manifold needs value(x) and jacobian(x)")
    if manifold_delta is not None and not (
        isinstance(manifold_delta, (int, float)) and math.isfinite(manifold_delta) and manifold_delta > 0
    ):
        raise OmplConfigError(f"manifold_delta must be None or > 0, got {manifold_delta!r}")

    counter = [0]
    ctx = _CallbackContext()
    guarded = _guarded_validity(is_state_valid, ctx, counter, cancel)
    guarded_batch = _guarded_batch(batch_free, ctx, counter)
    bridge = _make_validity_bridge(guarded, dim, indexed=constrained)

    def result(status: str, path: np.ndarray | None = None, **kw: Any) -> OmplResult:
        return OmplResult(
            success=status == "EXACT_SOLUTION",
            status=status,
            path=np.empty((0, dim)) if path is None else path,
            planning_time=kw.pop("planning_time", 0.0),
            simplify_time=kw.pop("simplify_time", 0.0),
            planner=ptype,
            validity_checks=counter[0],
            **kw,
        )

    # Pre-checks, identical for every planner (OMPL's own are planner-specific and noisy).
    eps = 1e-12 * max(1.0, float(np.max(np.abs(np.concatenate([lo, hi])))))

    def in_bounds(q: np.ndarray) -> bool:
        return bool(np.all(q >= lo - eps) and np.all(q <= hi + eps))

    def precheck(q: np.ndarray) -> bool:
        counter[0] += 1
        return bool(is_state_valid(q.copy()))

    t0 = time.perf_counter()
    if cancel is not None and cancel.is_set():
        return result("ABORT", message="cancelled before planning started")
    if not in_bounds(q_start):
        return result("INVALID_START", message="start state is outside the joint bounds")
    if not precheck(q_start):
        return result("INVALID_START", message="start state is invalid (is_state_valid returned False)")
    valid_goals = [(i, g) for i, g in enumerate(goal_list) if in_bounds(g) and precheck(g)]
    if not valid_goals:
        return result("INVALID_GOAL", message=f"all {len(goal_list)} goal state(s) are out of bounds or invalid")
    q_start = np.clip(q_start, lo, hi)
    valid_goals = [(i, np.clip(g, lo, hi)) for i, g in valid_goals]
    for i, g in valid_goals:
        if np.max(np.abs(g - q_start)) <= 1e-12:
            return result(
                "EXACT_SOLUTION",
                np.array([q_start, g]),
                goal_index=i,
                planning_time=time.perf_counter() - t0,
                message="start already satisfies the goal",
            )

    if try_direct and not constrained:
        extent = float(np.linalg.norm(hi - lo))
        resolution = float(longest_valid_segment_fraction) * extent
        for i, g in sorted(valid_goals, key=lambda ig: float(np.linalg.norm(ig[1] - q_start))):
            ok = _direct_motion(q_start, g, guarded, resolution, guarded_batch)
            if ctx.error is not None:
                raise ctx.error
            if ctx.cancelled:
                return result("ABORT", planning_time=time.perf_counter() - t0, message="cancelled during planning")
            if ok:
                planning_time = time.perf_counter() - t0
                waypoints = np.array([q_start, g])
                if interpolate_states is not None:
                    segments = max(1, int(math.ceil(float(np.linalg.norm(g - q_start)) / resolution)))
                    count = max(segments + 1, interpolate_states)
                    waypoints = q_start + np.linspace(0.0, 1.0, count)[:, None] * (g - q_start)
                    waypoints[-1] = g
                return result("EXACT_SOLUTION", waypoints, goal_index=i, planning_time=planning_time,
                              message="the straight motion to the goal is valid", direct=True)

    if seed is not None:
        previous = ou.getLogLevel()
        ou.setLogLevel(ou.LOG_NONE)  # silence "Random number generation already started" (it reseeds anyway)
        try:
            ou.RNG.setSeed(int(seed))
        finally:
            ou.setLogLevel(previous)

    space = ob.RealVectorStateSpace(dim)
    bounds = ob.RealVectorBounds(dim)
    for i in range(dim):
        bounds.setLow(i, float(lo[i]))
        bounds.setHigh(i, float(hi[i]))
    space.setBounds(bounds)
    space.registerDefaultProjection(ob.RealVectorOrthogonalProjectionEvaluator(space, proj))
    edge_validator = spec.plain_motion_checks and not constrained
    manifold_bridge = None
    if constrained:
        manifold_bridge = _ManifoldBridge(dim, manifold, MANIFOLD_TOLERANCE, ctx)
        projected = ob.ProjectedStateSpace(space, manifold_bridge)
        if manifold_delta is not None:
            projected.setDelta(float(manifold_delta))
        si = ob.ConstrainedSpaceInformation(projected)
    else:
        si = ob.SpaceInformation(space)
    si.setStateValidityChecker(bridge)
    si.setStateValidityCheckingResolution(float(longest_valid_segment_fraction))
    if edge_validator:
        si.setMotionValidator(_EdgeValidator(si, guarded, dim, guarded_batch))
    si.setup()

    planning_time = 0.0
    simplify_time = 0.0
    try:
        def solve_once(goals_to_try: list[tuple[int, np.ndarray]], budget: float) -> tuple[str, Any, bool, str]:
            return _solve_once(si, spec, params, q_start, goals_to_try, budget, stop_on_first_solution, ctx)

        outcome = _solve(spec, q_start, valid_goals, float(timeout), ctx, solve_once)
        planning_time = time.perf_counter() - t0
        if ctx.error is not None:
            raise ctx.error
        status, path, approximate, message = outcome
        reverse_later = message == _REVERSE_LATER
        if reverse_later:
            message = ""
        if ctx.cancelled:
            return result("ABORT", planning_time=planning_time, message="cancelled during planning")
        if path is None:
            return result(status, planning_time=planning_time, approximate=approximate, message=message)

        t1 = time.perf_counter()
        goal_region = ob.GoalStates(si)
        for g in ([q_start] if reverse_later else [g for _, g in valid_goals]):  # where the path ends
            goal_region.addState(_fill(si, g))
        if simplify:
            simplifier = og.PathSimplifier(si, goal_region)
            if simplify_max_time is None:
                simplifier.simplifyMax(path)
            else:
                simplifier.simplify(path, float(simplify_max_time))
        if interpolate_states is not None:
            _interpolate(si, path, interpolate_states)
        if ctx.error is not None:
            raise ctx.error
        if ctx.cancelled:
            return result("ABORT", planning_time=planning_time, message="cancelled during simplification")
        waypoints = _path_array(path, dim)
        if reverse_later:
            waypoints = waypoints[::-1].copy()
        if constrained:
            waypoints = _tidy_manifold_path(waypoints)
        simplify_time = time.perf_counter() - t1
    finally:
        ctx.ptc = None
        si.setStateValidityChecker(ob.AllValidStateValidityChecker(si))
        if manifold_bridge is not None:
            manifold_bridge.detach()
        if edge_validator:
            # The validator keeps its SpaceInformation alive and the SpaceInformation keeps the
            # validator: a C++ cycle Python's collector cannot see. Swap in an idle one.
            si.setMotionValidator(_idle_motion_validator())

    goal_index = next((i for i, g in valid_goals if np.allclose(waypoints[-1], g, rtol=0, atol=1e-9)), None)
    return result(
        "EXACT_SOLUTION",
        waypoints,
        planning_time=planning_time,
        simplify_time=simplify_time,
        goal_index=goal_index,
        message=message,
    )


def _tidy_manifold_path(waypoints: np.ndarray) -> np.ndarray:
    """A path interpolated along a constraint manifold, without its walk's artefacts: repeated
    states (where a walk stops short, interpolation repeats its first state) and back-steps (a
    walk ends within one step of its target, possibly beyond it, so the path turns back there).
    Dropping them shortens a chord by at most a step; the caller checks the path densely anyway.
    The ends are kept."""
    if len(waypoints) < 3:
        return waypoints
    rows = [waypoints[0]]
    for i in range(1, len(waypoints) - 1):  # one pass: a state is left out only for its own step
        before, after = waypoints[i] - rows[-1], waypoints[i + 1] - waypoints[i]
        if np.linalg.norm(before) > 1e-12 and float(np.dot(before, after)) >= 0.0:
            rows.append(waypoints[i])
    if len(rows) > 1 and np.linalg.norm(waypoints[-1] - rows[-1]) <= 1e-12:
        rows.pop()  # the goal repeated: keep the goal itself
    rows.append(waypoints[-1])
    return np.array(rows)


def _interpolate(si: Any, path: Any, minimum: int) -> None:
    """MoveIt's interpolateSolution: states at the checking resolution, at least ``minimum``."""
    space = si.getStateSpace()
    states = path.getStates()
    eventual = 1 + sum(space.validSegmentCount(a, b) for a, b in zip(states, states[1:]))
    if minimum > 0 and eventual < minimum:
        path.interpolate(int(minimum))
    else:
        path.interpolate()


def _solve(
    spec: PlannerSpec,
    q_start: np.ndarray,
    goals: list[tuple[int, np.ndarray]],
    timeout: float,
    ctx: _CallbackContext,
    solve_once: Callable[[list[tuple[int, np.ndarray]], float], tuple[str, Any, bool, str]],
) -> tuple[str, Any, bool, str]:
    """Run the planner (``solve_once(goals, time budget)``: one _solve_once call), all goals at
    once or, for a planner that takes one goal at a time, nearest goal first; returns (status,
    PathGeometric oriented start->goal or None, approximate, message)."""
    if spec.one_goal_at_a_time and len(goals) > 1:
        deadline = time.perf_counter() + timeout
        ordered = sorted(goals, key=lambda ig: float(np.linalg.norm(ig[1] - q_start)))
        statuses = []
        for k, goal in enumerate(ordered):
            budget = (deadline - time.perf_counter()) / (len(ordered) - k)
            if budget <= 0:
                break
            status, path, approximate, message = solve_once([goal], budget)
            if path is not None or ctx.error is not None or ctx.cancelled:
                return status, path, approximate, message
            statuses.append((status, approximate))
        if not statuses:
            return "TIMEOUT", None, False, "time limit reached"
        if any(s == "TIMEOUT" for s, _ in statuses):
            return "TIMEOUT", None, any(a for _, a in statuses), "no goal reached within the time limit"
        return statuses[-1][0], None, False, f"planner returned {statuses[-1][0]} for every goal"
    return solve_once(goals, timeout)


def _solve_once(
    si: Any,
    spec: PlannerSpec,
    params: Mapping[str, Any],
    q_start: np.ndarray,
    goals: list[tuple[int, np.ndarray]],
    timeout: float,
    stop_on_first_solution: bool,
    ctx: _CallbackContext,
) -> tuple[str, Any, bool, str]:
    setup = og.SimpleSetup(si)
    if stop_on_first_solution:
        # Optimizing planners (RRTstar, PRMstar, BITstar...) stop once the objective is
        # satisfied; an infinite threshold makes the first exact solution satisfy it. (They only
        # publish their solution at the end, so the exact-solution PTC below alone cannot stop them.)
        # Otherwise no objective is set, keeping OMPL's per-planner defaults: e.g. PRM stops at its
        # first solution only because its *default* objective has an infinite threshold.
        objective = ob.PathLengthOptimizationObjective(si)
        objective.setCostThreshold(objective.infiniteCost())
        setup.setOptimizationObjective(objective)
    swapped = spec.goals_as_starts and len(goals) > 1
    if swapped:
        for _, g in goals:
            setup.addStartState(_fill(si, g))
        setup.setGoalState(_fill(si, q_start))
    else:
        setup.setStartState(_fill(si, q_start))
        region = ob.GoalStates(si)
        for _, g in goals:
            region.addState(_fill(si, g))
        setup.setGoal(region)

    planner = getattr(og, spec.cls_name)(si)
    apply_params(planner, spec.type, params)  # validated beforehand: setters cannot fail here
    setup.setPlanner(planner)
    setup.setup()  # before anything can raise: AORRTC segfaults if destroyed un-set-up

    ptc = ob.timedPlannerTerminationCondition(timeout)
    if stop_on_first_solution:
        ptc = ob.plannerOrTerminationCondition(ptc, ob.exactSolnPlannerTerminationCondition(setup.getProblemDefinition()))
    ctx.ptc = ptc
    try:
        status = _status_name(setup.solve(ptc))
    except RuntimeError as e:  # C++ exception from OMPL (not from the callback: that is caught)
        return "CRASH", None, False, f"OMPL raised: {e}"
    finally:
        ctx.ptc = None

    if status == "EXACT_SOLUTION":
        path = og.PathGeometric(setup.getSolutionPath())  # own copy, independent of setup
        if swapped:
            if isinstance(si, ob.ConstrainedSpaceInformation):
                # A walk along a constraint manifold depends on its direction: the path is kept as
                # planned (goal -> start) through simplification and interpolation, and reversed
                # as an array at the end (see plan_joint_space).
                return status, path, False, _REVERSE_LATER
            path.reverse()
        return status, path, False, ""
    if status == "APPROXIMATE_SOLUTION":
        return "TIMEOUT", None, True, "time limit reached with only an approximate solution"
    if status == "TIMEOUT":
        return status, None, False, "time limit reached without a solution"
    return status, None, False, f"planner returned {status}"
