"""OMPL adapter: MoveIt's ``ompl_planning.yaml`` and joint-space planning on the ``ompl`` PyPI wheel.

This module is MoveIt's ``ompl_interface`` without ROS and without a robot: it knows joint-space
boxes, a validity callback, a start and a set of goal configurations. The robot (which joints a
group has, their limits, the collision checker) is supplied by the caller, so the same code plans
for the myCobot, another arm, or the synthetic 2-D/6-D box worlds of the tests.

What the ``ompl`` 2.0.1 wheel is, and what that forces on us
-----------------------------------------------------------
The wheel ships new nanobind bindings (not the old Py++ ones). Facts this module relies on,
each verified against the wheel:

* States come from ``si.allocState()`` and are indexed ``s[i]``; ``s[0:d]`` returns a list.
  Open slices (``s[:]``) raise, indices are **not** bounds-checked, and a fresh state holds
  garbage. Python owns allocated states: calling ``si.freeState(s)`` double-frees (segfault).
* ``Planner.params()`` cannot be called (its ``ParamSet`` return type is not bound: TypeError).
  Planner parameters are therefore set through the typed setters (``setRange``...), using the
  table ``_PLANNERS`` below that maps MoveIt/OMPL parameter names to setters. ``printSettings()``
  still lists the declared parameters; the tests use it to keep the table honest.
* Planners available as classes in ``ompl.geometric``: RRT, RRTConnect, RRTstar,
  InformedRRTstar, SORRTstar, AORRTC, BITstar, PRM, PRMstar, FMT, BFMT, KPIECE1, BKPIECE1,
  LBKPIECE1. Not bound (so not offered): SBL, EST, BiEST, ProjEST, STRIDE, PDST, TRRT, BiTRRT,
  LBTRRT, LazyRRT, LazyPRM, LazyPRMstar, SPARS, SPARStwo, RRTsharp, ABITstar, AITstar...
* ``solve`` does **not** release the GIL; the validity callback re-enters Python. Other Python
  threads still run, at the interpreter's switch interval (about 5 ms), whenever the callback
  runs. Any planner thread other than the caller's that calls Python must get the GIL from the
  solving thread, which deadlocks if the solving thread waits on that thread in C++. PRM does
  exactly that: its solution-checking thread adds goal milestones (``checkMotion`` -> Python)
  while the main thread holds the graph mutex or joins it. With one goal the extra thread never
  calls Python; with several goals it hangs forever. We therefore give PRM/PRMstar the goals as
  *start* states (all added in the main thread) and the start as the single goal, then reverse
  the path (joint-space paths are reversible). Termination conditions are C++ ones only, for
  the same reason (PRM's thread evaluates them).
* Bidirectional planners (RRTConnect, BKPIECE, LBKPIECE) add start states all at once but
  sample a further goal only when the goal tree has grown enough
  (``sampledGoals < goalTree.size() / 2``). A valid goal sealed off in a pocket never grows its
  tree, so the other goals are never tried: RRTConnect times out on a 6-D problem that it
  solves in 10 ms once the sealed goal is removed. They get the same start/goal swap, which
  puts every goal in the tree from the first iteration.
* BFMT segfaults when it has several goals and the first one is unreachable (FMT does the same
  with several starts; we only ever give FMT one start). AORRTC starves like RRTConnect with
  several goals and, given several starts, "simplifies" to a zero-length path and reports
  INVALID_GOAL. Both are given one goal at a time, nearest first, splitting the remaining time.
* AORRTC segfaults if it is destroyed before ``setup()``; we set planners up as soon as they are
  attached, after all validation that could raise.
* Informed planners raise RuntimeError (degenerate prolate hyperspheroid) when start == goal, so
  the trivial problem is answered without OMPL.
* ``RNG.setSeed`` reseeds even after sampling has started (OMPL logs an error saying it won't;
  with these bindings it does), so a seed makes single-threaded planners that stop at their first
  solution reproducible. Optimizing planners (RRTstar, BITstar...) are reproducible only with
  ``stop_on_first_solution=True`` (otherwise their iteration count depends on the clock); PRM and
  PRMstar check for solutions in a helper thread, so nothing guarantees theirs.
* Optimizing planners publish their solution only when they return, so an exact-solution
  termination condition alone does not stop them; ``stop_on_first_solution`` also sets a
  path-length objective whose threshold is infinite. Without it no objective is set, which keeps
  OMPL's per-planner defaults (PRM stops at its first solution *because* its default objective
  has an infinite threshold; setting a plain path-length objective makes it run to the timeout).

Exit-time "nanobind: leaked N instances!" warnings
--------------------------------------------------
They are real leaks, not noise: a reference cycle that passes through C++. ``si`` (Python)
owns the C++ SpaceInformation, which holds a ``std::function`` owning the Python validity
callable; if that callable (or its closure, or its ``__globals__`` when ``si`` is a module
global) references ``si``, the cycle is invisible to Python's GC and survives to interpreter
shutdown, where nanobind reports it. This module never lets a callable handed to C++ reach an
OMPL object: all OMPL objects are locals of one call, the callback closes over the user
function and a small context only, the one reference the context needs during ``solve`` (the
termination condition, to stop on a callback exception) is dropped in ``finally``, and the
validity checker is swapped for a C++ ``AllValidStateValidityChecker`` before returning. Code
elsewhere must follow the same rule: never keep OMPL objects in module globals together with a
Python callback that can see them.

Cost of the callback bridge
---------------------------
Measured from C++ (``si.checkMotion`` over 1e5 states): a bare C++ -> Python call costs about
0.1-0.25 us; the whole bridge (counter, cancel/error checks, ``np.array(s[0:d])``, the call,
``bool``) about 1.2-1.5 us per state for d = 2..7 on an idle machine, i.e. ~1 us on top of the
user's function. That
is small next to a collision query, so the callback receives a fresh, caller-owned
``np.ndarray`` (safe to keep or mutate) rather than a view into OMPL's memory (the bindings
offer none: states have no buffer protocol).
"""
from __future__ import annotations

import math
import re
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from .errors import PlanningError

__all__ = [
    "GroupConfig",
    "OmplConfig",
    "OmplConfigError",
    "OmplResult",
    "PlannerConfig",
    "ResolvedPlanner",
    "UNAVAILABLE_MOVEIT_PLANNERS",
    "available_planners",
    "canonical_planner_type",
    "load_ompl_config",
    "parse_projection_evaluator",
    "plan_joint_space",
    "resolve_planner_id",
    "set_ompl_log_level",
]


class OmplConfigError(PlanningError, ValueError):
    """Malformed ompl_planning.yaml content, unknown planner type/id/parameter, or bad planning input."""


# --------------------------------------------------------------------------------------------
# Logging
# --------------------------------------------------------------------------------------------

_LOG_LEVELS = {
    "DEBUG": ou.LOG_DEBUG,
    "INFO": ou.LOG_INFO,
    "WARN": ou.LOG_WARN,
    "WARNING": ou.LOG_WARN,
    "ERROR": ou.LOG_ERROR,
    "NONE": ou.LOG_NONE,
}


def set_ompl_log_level(level: str) -> None:
    """Set OMPL's own log level (it prints straight to stderr, outside Python's logging).

    OMPL logs at INFO by default: several lines per solve. We set WARN at import. A Python
    OutputHandler is deliberately not used: OMPL logs from planner threads too, and a Python
    handler would need the GIL there (see the module docstring on PRM).
    """
    try:
        ou.setLogLevel(_LOG_LEVELS[level.upper()])
    except (KeyError, AttributeError):
        raise OmplConfigError(
            f"unknown OMPL log level {level!r}; known: {', '.join(sorted(_LOG_LEVELS))}"
        ) from None


set_ompl_log_level("WARN")


# --------------------------------------------------------------------------------------------
# Planner registry: MoveIt type names -> wheel classes and settable parameters
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Param:
    """One planner parameter: how to coerce it, check it, and apply it.

    ``setter=None`` marks parameters OMPL declares but the wheel cannot set: they are accepted
    only with the value OMPL uses anyway (``fixed``), or with any value when ``ignored`` (OMPL
    documents them as having no effect), so a stock MoveIt YAML still loads.
    """

    kind: type
    setter: str | None
    check: Callable[[Any], bool] | None = None
    rule: str = ""
    fixed: Any = None
    ignored: bool = False


def _p(kind: type, setter: str | None, check=None, rule: str = "", **kw: Any) -> _Param:
    return _Param(kind, setter, check, rule, **kw)


_GE0 = (lambda v: v >= 0, ">= 0")
_GT0 = (lambda v: v > 0, "> 0")
_GE1 = (lambda v: v >= 1, ">= 1")
_IN01 = (lambda v: 0 <= v <= 1, "in [0, 1]")
_IN01_OPEN_LOW = (lambda v: 0 < v <= 1, "in (0, 1]")

_RANGE = _p(float, "setRange", *_GE0)
_GOAL_BIAS = _p(float, "setGoalBias", *_IN01)
_INTERMEDIATE = _p(bool, "setIntermediateStates")
_BORDER = _p(float, "setBorderFraction", *_IN01_OPEN_LOW)
_FAILED_SCORE = _p(float, "setFailedExpansionCellScoreFactor", *_IN01_OPEN_LOW)
_MIN_VALID = _p(float, "setMinValidPathFraction", *_IN01)

_RRTSTAR_COMMON = {
    "range": _RANGE,
    "goal_bias": _GOAL_BIAS,
    "rewire_factor": _p(float, "setRewireFactor", *_GT0),
    "use_k_nearest": _p(bool, "setKNearest"),
    "delay_collision_checking": _p(bool, "setDelayCC"),
    "prune_threshold": _p(float, "setPruneThreshold", *_IN01),
    "ordered_sampling": _p(bool, "setOrderedSampling"),
    "ordering_batch_size": _p(int, "setBatchSize", *_GE1),
    "number_sampling_attempts": _p(int, "setNumSamplingAttempts", *_GE1),
}
_RRTSTAR_ONLY = {
    "tree_pruning": _p(bool, "setTreePruning"),
    "pruned_measure": _p(bool, "setPrunedMeasure"),
    "informed_sampling": _p(bool, "setInformedSampling"),
    "sample_rejection": _p(bool, "setSampleRejection"),
    "new_state_rejection": _p(bool, "setNewStateRejection"),
    "use_admissible_heuristic": _p(bool, "setAdmissibleCostToCome"),
    "focus_search": _p(bool, "setFocusSearch"),
}
_FMT_COMMON = {
    "num_samples": _p(int, "setNumSamples", *_GE1),
    "radius_multiplier": _p(float, "setRadiusMultiplier", *_GT0),
    # MoveIt's YAML says nearest_k; OMPL's FMT declares use_k_nearest (BFMT: nearest_k).
    "nearest_k": _p(bool, "setNearestK"),
    "use_k_nearest": _p(bool, "setNearestK"),
    "cache_cc": _p(bool, "setCacheCC"),
    "heuristics": _p(bool, "setHeuristics"),
    "extended_fmt": _p(bool, "setExtendedFMT"),
    "free_space_volume": _p(float, "setFreeSpaceVolume", *_GT0),
}


@dataclass(frozen=True)
class _PlannerSpec:
    type: str  # canonical MoveIt name, e.g. "geometric::KPIECE"
    cls_name: str  # class in ompl.geometric, e.g. "KPIECE1"
    params: Mapping[str, _Param]
    uses_projection: bool = False
    optimizing: bool = False  # keeps improving until the time limit unless told to stop
    goals_as_starts: bool = False  # multi-goal given as starts: PRM deadlock, bidirectional starvation
    one_goal_at_a_time: bool = False  # multi-goal solved goal by goal: BFMT crash, AORRTC bugs
    # Only checks motions as (from, to) -> bool (never asks for the last valid state), so the
    # edge checks can run in one Python loop per edge (_EdgeValidator) instead of one callback
    # per state. The path simplifier only asks that question too.
    plain_motion_checks: bool = False


_ALL_SPECS = [
    _PlannerSpec("geometric::RRT", "RRT", {"range": _RANGE, "goal_bias": _GOAL_BIAS, "intermediate_states": _INTERMEDIATE}),
    _PlannerSpec(
        "geometric::RRTConnect", "RRTConnect", {"range": _RANGE, "intermediate_states": _INTERMEDIATE}, goals_as_starts=True,
        plain_motion_checks=True,
    ),
    _PlannerSpec("geometric::RRTstar", "RRTstar", {**_RRTSTAR_COMMON, **_RRTSTAR_ONLY}, optimizing=True),
    _PlannerSpec("geometric::InformedRRTstar", "InformedRRTstar", dict(_RRTSTAR_COMMON), optimizing=True),
    _PlannerSpec("geometric::SORRTstar", "SORRTstar", dict(_RRTSTAR_COMMON), optimizing=True),
    _PlannerSpec("geometric::AORRTC", "AORRTC", {"range": _RANGE}, optimizing=True, one_goal_at_a_time=True),
    _PlannerSpec(
        "geometric::BITstar",
        "BITstar",
        {
            "rewire_factor": _p(float, "setRewireFactor", *_GT0),
            "samples_per_batch": _p(int, "setSamplesPerBatch", *_GE1),
            "use_k_nearest": _p(bool, "setUseKNearest"),
            "use_graph_pruning": _p(bool, "setPruning"),
            "prune_threshold_as_fractional_cost_change": _p(float, "setPruneThresholdFraction", *_IN01),
            "use_just_in_time_sampling": _p(bool, "setJustInTimeSampling"),
            "drop_unconnected_samples_on_prune": _p(bool, "setDropSamplesOnPrune"),
            "stop_on_each_solution_improvement": _p(bool, "setStopOnSolnImprovement"),
            "find_approximate_solutions": _p(bool, "setConsiderApproximateSolutions"),
            # OMPL: "This option no longer has any effect" (setting them only logs a warning).
            "delay_rewiring_to_first_solution": _p(bool, None, ignored=True),
            "use_strict_queue_ordering": _p(bool, None, ignored=True),
        },
        optimizing=True,
    ),
    _PlannerSpec(
        "geometric::PRM",
        "PRM",
        {"max_nearest_neighbors": _p(int, "setMaxNearestNeighbors", *_GE1)},
        goals_as_starts=True,
    ),
    _PlannerSpec("geometric::PRMstar", "PRMstar", {}, optimizing=True, goals_as_starts=True),
    _PlannerSpec("geometric::FMT", "FMT", dict(_FMT_COMMON)),
    _PlannerSpec(
        "geometric::BFMT",
        "BFMT",
        {
            **_FMT_COMMON,
            # Declared by OMPL, no setter in the wheel: accept OMPL's (and MoveIt's) default only.
            "balanced": _p(bool, None, fixed=False),
            "optimality": _p(bool, None, fixed=True),
        },
        one_goal_at_a_time=True,
    ),
    _PlannerSpec(
        "geometric::KPIECE",
        "KPIECE1",
        {
            "range": _RANGE,
            "goal_bias": _GOAL_BIAS,
            "border_fraction": _BORDER,
            "failed_expansion_score_factor": _FAILED_SCORE,
            "min_valid_path_fraction": _MIN_VALID,
        },
        uses_projection=True,
    ),
    _PlannerSpec(
        "geometric::BKPIECE",
        "BKPIECE1",
        {
            "range": _RANGE,
            "border_fraction": _BORDER,
            "failed_expansion_score_factor": _FAILED_SCORE,
            "min_valid_path_fraction": _MIN_VALID,
        },
        uses_projection=True,
        goals_as_starts=True,
    ),
    _PlannerSpec(
        "geometric::LBKPIECE",
        "LBKPIECE1",
        {"range": _RANGE, "border_fraction": _BORDER, "min_valid_path_fraction": _MIN_VALID},
        uses_projection=True,
        goals_as_starts=True,
    ),
]

#: Planner types MoveIt knows that this wheel does not bind (for error messages).
UNAVAILABLE_MOVEIT_PLANNERS: tuple[str, ...] = tuple(
    f"geometric::{n}"
    for n in (
        "SBL", "EST", "BiEST", "ProjEST", "STRIDE", "PDST", "TRRT", "BiTRRT", "LBTRRT", "LazyRRT",
        "LazyPRM", "LazyPRMstar", "SPARS", "SPARStwo", "RRTsharp", "RRTXstatic", "ABITstar",
        "AITstar", "EITstar", "AnytimePathShortening", "CForest",
    )
    if not hasattr(og, n)
)

_PLANNERS: dict[str, _PlannerSpec] = {s.type: s for s in _ALL_SPECS if hasattr(og, s.cls_name)}

# Every accepted spelling -> canonical type: "geometric::KPIECE", "KPIECE", "KPIECE1", "geometric::KPIECE1".
_TYPE_ALIASES: dict[str, str] = {}
for _spec in _PLANNERS.values():
    _short = _spec.type.split("::", 1)[1]
    for _alias in (_short, _spec.cls_name, f"geometric::{_spec.cls_name}", _spec.type):
        _TYPE_ALIASES[_alias] = _spec.type


def available_planners() -> list[str]:
    """Canonical MoveIt planner types (``geometric::X``) this wheel provides."""
    return sorted(_PLANNERS)


def canonical_planner_type(name: str) -> str:
    """``"RRTConnect"``, ``"geometric::KPIECE1"``... -> the canonical ``geometric::X`` name.

    Raises OmplConfigError for unknown names, saying when MoveIt knows the planner but the wheel
    does not provide it.
    """
    if not isinstance(name, str):
        raise OmplConfigError(f"planner type must be a string, got {name!r}")
    key = name.strip()
    if key in _TYPE_ALIASES:
        return _TYPE_ALIASES[key]
    full = key if key.startswith("geometric::") else f"geometric::{key}"
    if full in UNAVAILABLE_MOVEIT_PLANNERS:
        raise OmplConfigError(
            f"planner type {name!r} is not provided by the ompl {_ompl_version()} wheel; "
            f"available: {', '.join(available_planners())}"
        )
    raise OmplConfigError(f"unknown planner type {name!r}; available: {', '.join(available_planners())}")


def _ompl_version() -> str:
    try:
        from importlib.metadata import version

        return version("ompl")
    except Exception:  # pragma: no cover - metadata missing in odd installs
        return "?"


_TRUE = {"1", "true", "yes", "on"}
_FALSE = {"0", "false", "no", "off"}


def _coerce(kind: type, value: Any) -> Any:
    """MoveIt passes every parameter to OMPL as a string; YAML gives numbers. Accept both."""
    if kind is bool:
        if isinstance(value, (bool, np.bool_)):
            return bool(value)
        if isinstance(value, (int, np.integer)) and value in (0, 1):
            return bool(value)
        if isinstance(value, float) and value in (0.0, 1.0):
            return bool(value)
        if isinstance(value, str) and value.strip().lower() in _TRUE | _FALSE:
            return value.strip().lower() in _TRUE
        raise ValueError("expected a boolean (true/false/0/1)")
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"expected a {kind.__name__}, got a boolean")
    if isinstance(value, str):
        value = value.strip()
        try:
            value = float(value)
        except ValueError:
            raise ValueError(f"expected a {kind.__name__}") from None
    if not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"expected a {kind.__name__}")
    value = float(value)
    if not math.isfinite(value) and kind is int:
        raise ValueError("expected a finite integer")
    if kind is int:
        if value != int(value):
            raise ValueError("expected an integer")
        return int(value)
    if math.isnan(value):
        raise ValueError("NaN is not allowed")
    return value


def _validate_params(planner_type: str, params: Mapping[str, Any] | None, where: str) -> dict[str, Any]:
    """Coerce and range-check ``params`` for ``planner_type``; every problem names the parameter."""
    spec = _PLANNERS[planner_type]
    out: dict[str, Any] = {}
    for name, raw in (params or {}).items():
        if name not in spec.params:
            known = ", ".join(sorted(spec.params)) or "(none)"
            raise OmplConfigError(
                f"{where}: unknown parameter {name!r} for planner {planner_type}; known: {known}"
            )
        p = spec.params[name]
        try:
            value = _coerce(p.kind, raw)
        except ValueError as e:
            raise OmplConfigError(f"{where}: parameter {name!r} = {raw!r}: {e}") from None
        if p.check is not None and not p.check(value):
            raise OmplConfigError(f"{where}: parameter {name!r} = {raw!r} must be {p.rule}")
        if p.setter is None and not p.ignored and value != p.fixed:
            raise OmplConfigError(
                f"{where}: parameter {name!r} of {planner_type} cannot be changed with the ompl "
                f"wheel's bindings (no setter); only {p.fixed!r} (OMPL's default) is accepted"
            )
        out[name] = value
    return out


def _apply_params(planner: Any, planner_type: str, params: Mapping[str, Any]) -> None:
    spec = _PLANNERS[planner_type]
    for name, value in params.items():
        setter = spec.params[name].setter
        if setter is not None:
            getattr(planner, setter)(value)


# --------------------------------------------------------------------------------------------
# ompl_planning.yaml
# --------------------------------------------------------------------------------------------

# Keys MoveIt's planning context consumes itself (not OMPL planner parameters). They may appear
# in a planner config or a group section; group values apply to all of the group's configs and a
# planner config's own value wins (MoveIt's merge order).
_CONTEXT_KEYS = frozenset(
    {
        "longest_valid_segment_fraction",
        "projection_evaluator",
        "enforce_joint_model_state_space",
        "enforce_constrained_state_space",
        "optimization_objective",
        "termination_condition",
        "max_goal_samples",
        "max_state_sampling_attempts",
        "max_goal_sampling_attempts",
        "max_planning_threads",
        "max_solution_segment_length",
        "minimum_waypoint_count",
        "simplify_solutions",
        "interpolate",
        "hybridize",
        "multi_query_planning_enabled",
        "store_planner_data",
        "plugin",
    }
)
_GROUP_KEYS = frozenset({"planner_configs", "default_planner_config"}) | _CONTEXT_KEYS
_DEFAULT_LVSF = 0.005  # MoveIt setup assistant's value for every group


@dataclass(frozen=True)
class PlannerConfig:
    """One entry of ``planner_configs`` (e.g. ``RRTConnectkConfigDefault``)."""

    name: str
    type: str  # canonical, e.g. "geometric::RRTConnect"
    params: Mapping[str, Any]  # OMPL planner parameters, coerced
    context: Mapping[str, Any] = field(default_factory=dict)  # MoveIt context keys set in this config


@dataclass(frozen=True)
class GroupConfig:
    """A planning group's section of ompl_planning.yaml."""

    name: str
    planner_configs: tuple[str, ...]
    default_planner_config: str | None
    longest_valid_segment_fraction: float
    projection_evaluator: str | None
    context: Mapping[str, Any] = field(default_factory=dict)  # all MoveIt context keys of the section


@dataclass(frozen=True)
class OmplConfig:
    """Parsed ompl_planning.yaml: planner configs, group sections, and pipeline-level keys."""

    planner_configs: Mapping[str, PlannerConfig]
    groups: Mapping[str, GroupConfig]
    pipeline: Mapping[str, Any] = field(default_factory=dict)  # planning_plugins, request_adapters...
    skipped_configs: tuple[str, ...] = ()  # configs dropped by skip_unavailable=True

    def group(self, name: str) -> GroupConfig:
        try:
            return self.groups[name]
        except KeyError:
            raise OmplConfigError(
                f"no OMPL configuration for planning group {name!r}; known: {', '.join(sorted(self.groups)) or '(none)'}"
            ) from None


@dataclass(frozen=True)
class ResolvedPlanner:
    """What a planner id resolves to for one group: everything plan_joint_space needs."""

    group: str
    config_name: str  # "RRTConnectkConfigDefault", or the bare type for an ad-hoc default config
    type: str  # canonical "geometric::RRTConnect"
    params: Mapping[str, Any]
    longest_valid_segment_fraction: float
    projection_evaluator: str | None
    context: Mapping[str, Any]  # merged MoveIt context keys (group, then config)

    @property
    def planner_id(self) -> str:
        """MoveIt's full id, ``group[config]``."""
        return f"{self.group}[{self.config_name}]"


_PROJECTION_RE = re.compile(r"^\s*(joints|link)\s*\(\s*([^()]*?)\s*\)\s*$")


def parse_projection_evaluator(spec: str) -> tuple[str, tuple[str, ...]]:
    """MoveIt's ``projection_evaluator`` -> ``("joints", names)`` or ``("link", (name,))``.

    Mapping joint names to state dimensions is the caller's job (it knows the group's order);
    ``plan_joint_space`` takes the resulting ``projection_dims``.
    """
    m = _PROJECTION_RE.match(spec) if isinstance(spec, str) else None
    names = tuple(n.strip() for n in m.group(2).split(",")) if m else ()
    if not m or not names or any(not n for n in names):
        raise OmplConfigError(
            f"malformed projection_evaluator {spec!r}; expected 'joints(j1, j2, ...)' or 'link(name)'"
        )
    if m.group(1) == "link" and len(names) != 1:
        raise OmplConfigError(f"projection_evaluator {spec!r}: link() takes exactly one link name")
    return m.group(1), names


def _check_context(where: str, ctx: Mapping[str, Any]) -> dict[str, Any]:
    out = dict(ctx)
    if "longest_valid_segment_fraction" in out:
        v = out["longest_valid_segment_fraction"]
        try:
            f = _coerce(float, v)
        except ValueError:
            f = float("nan")
        if not (0.0 < f <= 1.0):
            raise OmplConfigError(f"{where}: longest_valid_segment_fraction = {v!r} must be in (0, 1]")
        out["longest_valid_segment_fraction"] = f
    if "projection_evaluator" in out:
        parse_projection_evaluator(out["projection_evaluator"])
    return out


def load_ompl_config(source: str | Path | Mapping[str, Any], *, skip_unavailable: bool = False) -> OmplConfig:
    """Parse MoveIt's ompl_planning.yaml (a path, or the already-loaded mapping).

    Top-level layout (MoveIt's)::

        planner_configs:
          RRTConnectkConfigDefault: {type: geometric::RRTConnect, range: 0.0}
        arm:                                   # any mapping other than planner_configs is a group
          default_planner_config: RRTConnectkConfigDefault
          planner_configs: [RRTConnectkConfigDefault, ...]
          projection_evaluator: joints(j1, j2)
          longest_valid_segment_fraction: 0.005
        planning_plugins: [...]               # non-mapping top-level keys: kept in ``pipeline``

    Raises OmplConfigError naming the config/group/parameter at fault: unknown planner type (or
    one the wheel lacks), unknown parameter, out-of-range value, group listing an undefined
    config. With ``skip_unavailable=True`` configs whose planner type MoveIt knows but the wheel
    lacks are dropped (names in ``skipped_configs``) instead, so a stock MoveIt file loads.
    """
    if isinstance(source, Mapping):
        data: Any = source
    else:
        path = Path(source)
        if not path.is_file():
            raise OmplConfigError(f"OMPL config file not found: {path}")
        try:
            data = yaml.safe_load(path.read_text())
        except yaml.YAMLError as e:
            raise OmplConfigError(f"{path}: invalid YAML: {e}") from None
    if not isinstance(data, Mapping):
        raise OmplConfigError("ompl_planning.yaml must be a mapping at the top level")

    raw_configs = data.get("planner_configs", {}) or {}
    if not isinstance(raw_configs, Mapping):
        raise OmplConfigError("planner_configs must be a mapping of config name -> settings")
    configs: dict[str, PlannerConfig] = {}
    skipped: list[str] = []
    for name, body in raw_configs.items():
        where = f"planner_configs.{name}"
        if not isinstance(body, Mapping):
            raise OmplConfigError(f"{where}: must be a mapping with at least 'type'")
        if "type" not in body:
            raise OmplConfigError(f"{where}: missing 'type' (e.g. geometric::RRTConnect)")
        raw_type = body["type"]
        full = raw_type if str(raw_type).startswith("geometric::") else f"geometric::{raw_type}"
        if skip_unavailable and full in UNAVAILABLE_MOVEIT_PLANNERS:
            skipped.append(str(name))
            continue
        try:
            ptype = canonical_planner_type(raw_type)
        except OmplConfigError as e:
            raise OmplConfigError(f"{where}: {e}") from None
        context = _check_context(where, {k: v for k, v in body.items() if k in _CONTEXT_KEYS})
        params = _validate_params(
            ptype, {k: v for k, v in body.items() if k != "type" and k not in _CONTEXT_KEYS}, where
        )
        configs[str(name)] = PlannerConfig(str(name), ptype, params, context)

    groups: dict[str, GroupConfig] = {}
    pipeline: dict[str, Any] = {}
    for key, body in data.items():
        if key == "planner_configs":
            continue
        if not isinstance(body, Mapping):
            pipeline[str(key)] = body
            continue
        where = f"group {key!r}"
        unknown = sorted(set(body) - _GROUP_KEYS)
        if unknown:
            raise OmplConfigError(
                f"{where}: unknown key(s) {', '.join(map(repr, unknown))}; known: {', '.join(sorted(_GROUP_KEYS))}"
            )
        listed = body.get("planner_configs", []) or []
        if isinstance(listed, str) or not isinstance(listed, Sequence):
            raise OmplConfigError(f"{where}: planner_configs must be a list of config names")
        listed = [str(n) for n in listed if not (skip_unavailable and str(n) in skipped)]
        for n in listed:
            if n not in configs:
                raise OmplConfigError(
                    f"{where}: planner config {n!r} is not defined in planner_configs; "
                    f"defined: {', '.join(sorted(configs)) or '(none)'}"
                )
        default = body.get("default_planner_config")
        if default is not None:
            default = str(default)
            if skip_unavailable and default in skipped:
                default = None
            elif default not in configs:
                raise OmplConfigError(
                    f"{where}: default_planner_config {default!r} is not defined in planner_configs"
                )
        context = _check_context(where, {k: v for k, v in body.items() if k in _CONTEXT_KEYS})
        groups[str(key)] = GroupConfig(
            name=str(key),
            planner_configs=tuple(listed),
            default_planner_config=default,
            longest_valid_segment_fraction=context.get("longest_valid_segment_fraction", _DEFAULT_LVSF),
            projection_evaluator=context.get("projection_evaluator"),
            context=context,
        )
    return OmplConfig(configs, groups, pipeline, tuple(skipped))


_ID_RE = re.compile(r"^\s*([^\[\]]+?)\s*\[\s*([^\[\]]+?)\s*\]\s*$")


def resolve_planner_id(config: OmplConfig, group: str, planner_id: str | None) -> ResolvedPlanner:
    """MoveIt's planner-id lookup for one group.

    Accepted ids: ``""``/None (the group's default_planner_config, else its first listed config,
    else RRTConnect with OMPL defaults, as MoveIt does), a config name
    (``RRTConnectkConfigDefault``), MoveIt's full id (``arm[RRTConnectkConfigDefault]``; the
    group part must match), or a planner type (``RRTConnect``, ``geometric::RRTConnect``): the
    group's config of that type, preferring ``<Type>kConfigDefault``, else any config of that
    type, else the type with OMPL's default parameters. Anything else raises OmplConfigError
    listing the ids that would work.
    """
    g = config.group(group)
    pid = (planner_id or "").strip()

    m = _ID_RE.match(pid)
    if m:
        if m.group(1) != group:
            raise OmplConfigError(
                f"planner id {planner_id!r} is for group {m.group(1)!r}, but the request is for group {group!r}"
            )
        pid = m.group(2)

    if not pid:
        name = g.default_planner_config or (g.planner_configs[0] if g.planner_configs else None)
        if name is None:
            return _resolved(g, None, "geometric::RRTConnect")
        return _resolved(g, config.planner_configs[name], None)

    if pid in config.planner_configs:
        return _resolved(g, config.planner_configs[pid], None)

    try:
        ptype = canonical_planner_type(pid)
    except OmplConfigError:
        ptype = None
    if ptype is not None:
        short = ptype.split("::", 1)[1]
        pool = [config.planner_configs[n] for n in g.planner_configs] + [
            c for n, c in config.planner_configs.items() if n not in g.planner_configs
        ]
        matches = [c for c in pool if c.type == ptype]
        if matches:
            preferred = [c for c in matches if c.name == f"{short}kConfigDefault"]
            return _resolved(g, (preferred or matches)[0], None)
        return _resolved(g, None, ptype)

    known = list(g.planner_configs) + sorted(n for n in config.planner_configs if n not in g.planner_configs)
    raise OmplConfigError(
        f"unknown planner id {planner_id!r} for group {group!r}; known config ids: "
        f"{', '.join(known) or '(none)'}; planner types: {', '.join(available_planners())}"
    )


def _resolved(g: GroupConfig, pc: PlannerConfig | None, ptype: str | None) -> ResolvedPlanner:
    context = dict(g.context)
    if pc is not None:
        context.update(pc.context)
    return ResolvedPlanner(
        group=g.name,
        config_name=pc.name if pc is not None else ptype.split("::", 1)[1],
        type=pc.type if pc is not None else ptype,
        params=dict(pc.params) if pc is not None else {},
        longest_valid_segment_fraction=float(
            context.get("longest_valid_segment_fraction", g.longest_valid_segment_fraction)
        ),
        projection_evaluator=context.get("projection_evaluator"),
        context=context,
    )


# --------------------------------------------------------------------------------------------
# Planning
# --------------------------------------------------------------------------------------------


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


class _CallbackContext:
    """State shared by the validity bridge and plan_joint_space. Holds no OMPL object except,
    during solve only, the termination condition (cleared in ``finally``; see module docstring)."""

    __slots__ = ("error", "ptc", "cancelled")

    def __init__(self) -> None:
        self.error: BaseException | None = None
        self.ptc: Any = None
        self.cancelled = False


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
    continuously, so this is where a cancel request is seen soonest.
    """

    def valid(q: np.ndarray) -> bool:
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


def _make_validity_bridge(valid: Callable[[np.ndarray], bool], dim: int) -> Callable[[Any], bool]:
    """The callable OMPL calls per state: state -> fresh numpy array -> guarded user function."""
    array = np.array

    def is_valid(state: Any) -> bool:
        return valid(array(state[0:dim]))

    return is_valid


class _EdgeValidator(ob.MotionValidator):
    """OMPL's DiscreteMotionValidator, with each edge's states made by NumPy and checked in one
    Python loop: the end state first, then the interior by repeated halving (the same states in
    the same order, so plans are identical), but without an OMPL-to-Python call, a state copy
    and an array per state. Edge checks are most of a plan's validity checks (the simplifier
    alone makes two thirds of them). Used only for planners that ask plain (from, to)
    questions (``_PlannerSpec.plain_motion_checks``)."""

    def __init__(self, si: Any, valid: Callable[[np.ndarray], bool], dim: int) -> None:
        super().__init__(si)
        self._space = si.getStateSpace()
        self._valid = valid  # _guarded_validity's function: counted, never raising, cancellable
        self._dim = dim
        self._orders: dict[int, np.ndarray] = {}

    def _order(self, segments: int) -> np.ndarray:
        """Interior fractions in DiscreteMotionValidator's order (breadth-first halving)."""
        order = self._orders.get(segments)
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
            self._orders[segments] = order
        return order

    def checkMotion(self, s1: Any, s2: Any, *last_valid: Any) -> bool:  # noqa: N802 - OMPL's name
        if last_valid:  # never asked by the planners this is installed for
            raise RuntimeError("_EdgeValidator cannot report the last valid state")
        dim = self._dim
        b = np.array(s2[0:dim])
        if not self._valid(b.copy()):  # a copy: the user function may write into its argument
            return False
        fractions = self._order(self._space.validSegmentCount(s1, s2))
        if fractions.size:
            a = np.array(s1[0:dim])
            for q in a + fractions[:, None] * (b - a):
                if not self._valid(q):
                    return False
        return True


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
    s[0 : len(values)] = [float(x) for x in values]
    return s


def _path_array(path: Any, dim: int) -> np.ndarray:
    return np.array([s[0:dim] for s in path.getStates()], dtype=float).reshape(-1, dim)


def plan_joint_space(
    lower: Sequence[float] | np.ndarray,
    upper: Sequence[float] | np.ndarray,
    is_state_valid: Callable[[np.ndarray], bool],
    start: Sequence[float] | np.ndarray,
    goals: Sequence[Sequence[float] | np.ndarray],
    planner_type: str = "geometric::RRTConnect",
    planner_params: Mapping[str, Any] | None = None,
    timeout: float = 5.0,
    longest_valid_segment_fraction: float = _DEFAULT_LVSF,
    simplify: bool = True,
    interpolate_states: int | None = None,
    seed: int | None = None,
    *,
    projection_dims: Sequence[int] | None = None,
    stop_on_first_solution: bool = False,
    simplify_max_time: float | None = None,
    cancel: Any = None,
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
    reseeds OMPL's global RNG first (see module docstring for what that makes reproducible).
    ``cancel`` (e.g. a ``threading.Event``, set from another thread: an action server's cancel)
    stops planning or simplification within one state check; the result is then ``ABORT``.

    Raises OmplConfigError for malformed input (naming it) and re-raises any exception from
    ``is_state_valid`` after stopping the planner.
    """
    ptype = canonical_planner_type(planner_type)
    spec = _PLANNERS[ptype]
    params = _validate_params(ptype, planner_params, f"planner {ptype}")

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

    if cancel is not None and not callable(getattr(cancel, "is_set", None)):
        raise OmplConfigError("cancel must be None or an object with is_set() (e.g. threading.Event)")

    counter = [0]
    ctx = _CallbackContext()
    guarded = _guarded_validity(is_state_valid, ctx, counter, cancel)
    bridge = _make_validity_bridge(guarded, dim)

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
    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(bridge)
    si.setStateValidityCheckingResolution(float(longest_valid_segment_fraction))
    if spec.plain_motion_checks:
        si.setMotionValidator(_EdgeValidator(si, guarded, dim))
    si.setup()

    planning_time = 0.0
    simplify_time = 0.0
    try:
        outcome = _solve(si, spec, params, q_start, valid_goals, float(timeout), stop_on_first_solution, ctx)
        planning_time = time.perf_counter() - t0
        if ctx.error is not None:
            raise ctx.error
        status, path, approximate, message = outcome
        if ctx.cancelled:
            return result("ABORT", planning_time=planning_time, message="cancelled during planning")
        if path is None:
            return result(status, planning_time=planning_time, approximate=approximate, message=message)

        t1 = time.perf_counter()
        goal_region = ob.GoalStates(si)
        for _, g in valid_goals:
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
        simplify_time = time.perf_counter() - t1
    finally:
        ctx.ptc = None
        si.setStateValidityChecker(ob.AllValidStateValidityChecker(si))
        if spec.plain_motion_checks:
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
    si: Any,
    spec: _PlannerSpec,
    params: Mapping[str, Any],
    q_start: np.ndarray,
    goals: list[tuple[int, np.ndarray]],
    timeout: float,
    stop_on_first_solution: bool,
    ctx: _CallbackContext,
) -> tuple[str, Any, bool, str]:
    """Run the planner; returns (status, PathGeometric oriented start->goal or None, approximate, message)."""
    if spec.one_goal_at_a_time and len(goals) > 1:
        deadline = time.perf_counter() + timeout
        ordered = sorted(goals, key=lambda ig: float(np.linalg.norm(ig[1] - q_start)))
        statuses = []
        for k, goal in enumerate(ordered):
            budget = (deadline - time.perf_counter()) / (len(ordered) - k)
            if budget <= 0:
                break
            status, path, approximate, message = _solve_once(
                si, spec, params, q_start, [goal], budget, stop_on_first_solution, ctx
            )
            if path is not None or ctx.error is not None or ctx.cancelled:
                return status, path, approximate, message
            statuses.append((status, approximate))
        if not statuses:
            return "TIMEOUT", None, False, "time limit reached"
        if any(s == "TIMEOUT" for s, _ in statuses):
            return "TIMEOUT", None, any(a for _, a in statuses), "no goal reached within the time limit"
        return statuses[-1][0], None, False, f"planner returned {statuses[-1][0]} for every goal"
    return _solve_once(si, spec, params, q_start, goals, timeout, stop_on_first_solution, ctx)


def _solve_once(
    si: Any,
    spec: _PlannerSpec,
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
    _apply_params(planner, spec.type, params)  # validated beforehand: setters cannot fail here
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
            path.reverse()
        return status, path, False, ""
    if status == "APPROXIMATE_SOLUTION":
        return "TIMEOUT", None, True, "time limit reached with only an approximate solution"
    if status == "TIMEOUT":
        return status, None, False, "time limit reached without a solution"
    return status, None, False, f"planner returned {status}"
