"""MoveIt's ompl_planning.yaml: planner configurations per group and the planner_id lookup."""
from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from .planners import (
    UNAVAILABLE_MOVEIT_PLANNERS,
    OmplConfigError,
    coerce_param,
    validate_params,
    available_planners,
    canonical_planner_type,
)

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
#: MoveIt's planning context keys a planner configuration may hold (public: set_planner_params)
CONTEXT_KEYS = _CONTEXT_KEYS
#: the context keys whose values are checked here, so set_planner_params may change them
SETTABLE_CONTEXT_KEYS = frozenset({"longest_valid_segment_fraction", "projection_evaluator"})
_GROUP_KEYS = frozenset({"planner_configs", "default_planner_config"}) | _CONTEXT_KEYS
DEFAULT_LVSF = 0.005  # MoveIt setup assistant's value for every group


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


def check_context(where: str, ctx: Mapping[str, Any]) -> dict[str, Any]:
    """Context keys of a planner configuration, the checked ones (SETTABLE_CONTEXT_KEYS) checked."""
    out = dict(ctx)
    if "longest_valid_segment_fraction" in out:
        v = out["longest_valid_segment_fraction"]
        try:
            f = coerce_param(float, v)
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
        context = check_context(where, {k: v for k, v in body.items() if k in _CONTEXT_KEYS})
        params = validate_params(
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
        context = check_context(where, {k: v for k, v in body.items() if k in _CONTEXT_KEYS})
        groups[str(key)] = GroupConfig(
            name=str(key),
            planner_configs=tuple(listed),
            default_planner_config=default,
            longest_valid_segment_fraction=context.get("longest_valid_segment_fraction", DEFAULT_LVSF),
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


