"""The planners the ompl 2.0.1 wheel offers, under MoveIt's type names, with their settable
parameters (the wheel cannot list them itself: docs/ompl.md), and OMPL's log level."""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from importlib.metadata import version
from typing import Any

import numpy as np
from ompl import geometric as og
from ompl import util as ou

from ...errors import PlanningError


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
    handler would need the GIL there (see docs/ompl.md on PRM).
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
class PlannerSpec:
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
    PlannerSpec("geometric::RRT", "RRT", {"range": _RANGE, "goal_bias": _GOAL_BIAS, "intermediate_states": _INTERMEDIATE}),
    PlannerSpec(
        "geometric::RRTConnect", "RRTConnect", {"range": _RANGE, "intermediate_states": _INTERMEDIATE}, goals_as_starts=True,
        plain_motion_checks=True,
    ),
    PlannerSpec("geometric::RRTstar", "RRTstar", {**_RRTSTAR_COMMON, **_RRTSTAR_ONLY}, optimizing=True),
    PlannerSpec("geometric::InformedRRTstar", "InformedRRTstar", dict(_RRTSTAR_COMMON), optimizing=True),
    PlannerSpec("geometric::SORRTstar", "SORRTstar", dict(_RRTSTAR_COMMON), optimizing=True),
    PlannerSpec("geometric::AORRTC", "AORRTC", {"range": _RANGE}, optimizing=True, one_goal_at_a_time=True),
    PlannerSpec(
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
    PlannerSpec(
        "geometric::PRM",
        "PRM",
        {"max_nearest_neighbors": _p(int, "setMaxNearestNeighbors", *_GE1)},
        goals_as_starts=True,
    ),
    PlannerSpec("geometric::PRMstar", "PRMstar", {}, optimizing=True, goals_as_starts=True),
    PlannerSpec("geometric::FMT", "FMT", dict(_FMT_COMMON)),
    PlannerSpec(
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
    PlannerSpec(
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
    PlannerSpec(
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
    PlannerSpec(
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

PLANNERS: dict[str, PlannerSpec] = {s.type: s for s in _ALL_SPECS if hasattr(og, s.cls_name)}

# Every accepted spelling -> canonical type: "geometric::KPIECE", "KPIECE", "KPIECE1", "geometric::KPIECE1".
_TYPE_ALIASES: dict[str, str] = {}
for _spec in PLANNERS.values():
    _short = _spec.type.split("::", 1)[1]
    for _alias in (_short, _spec.cls_name, f"geometric::{_spec.cls_name}", _spec.type):
        _TYPE_ALIASES[_alias] = _spec.type


def available_planners() -> list[str]:
    """Canonical MoveIt planner types (``geometric::X``) this wheel provides."""
    return sorted(PLANNERS)


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
        return version("ompl")
    except Exception:  # pragma: no cover - metadata missing in odd installs
        return "?"


_TRUE = {"1", "true", "yes", "on"}
_FALSE = {"0", "false", "no", "off"}


def coerce_param(kind: type, value: Any) -> Any:
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


def validate_params(planner_type: str, params: Mapping[str, Any] | None, where: str) -> dict[str, Any]:
    """Coerce and range-check ``params`` for ``planner_type``; every problem names the parameter."""
    spec = PLANNERS[planner_type]
    out: dict[str, Any] = {}
    for name, raw in (params or {}).items():
        if name not in spec.params:
            known = ", ".join(sorted(spec.params)) or "(none)"
            raise OmplConfigError(
                f"{where}: unknown parameter {name!r} for planner {planner_type}; known: {known}"
            )
        p = spec.params[name]
        try:
            value = coerce_param(p.kind, raw)
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


def apply_params(planner: Any, planner_type: str, params: Mapping[str, Any]) -> None:
    spec = PLANNERS[planner_type]
    for name, value in params.items():
        setter = spec.params[name].setter
        if setter is not None:
            getattr(planner, setter)(value)


