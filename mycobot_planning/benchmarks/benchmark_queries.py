"""The scenes, queries and start states a benchmark runs (MoveIt's BenchmarkExecutor
loadPlanningScene / loadQueries / loadStates / createRequestCombinations).

Two sources, one result: the SQLite warehouse (core.warehouse.PlanningSceneStorage: scenes by
name, each with its queries) or a YAML queries file of the same content::

    scenes:                 # name -> PlanningScene message (interfaces_py JSON form)
      tabletop: {world: {collision_objects: [...]}}
    queries:                # scene name -> query name -> plan request (the JSON face's schema)
      tabletop:
        over_the_box: {goal: {joints: [...]}, start_state: {joint_names: [...], positions: [...]}}
    start_states:           # optional: name -> {joint: value}, picked by start_states_regex
      left: {link1_to_link2: 0.5}

``start_states_regex`` picks start states among the file's ``start_states`` and the SRDF's
named states of the benchmark group; each query is then run once from each of them (named
``<start>_<query>``), as MoveIt combines warehouse start states with queries."""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import yaml

from ..core.robot_model.robot_model import RobotModel
from ..core.warehouse.planning_scene_storage import PlanningSceneStorage
from ..core.warehouse.robot_state_storage import WarehouseError
from .benchmark_options import BenchmarkConfigError, BenchmarkOptions

__all__ = ["BenchmarkRequest", "load_benchmark_requests"]


@dataclass(frozen=True)
class BenchmarkRequest:
    """One experiment: a named query in a named scene, with its start state if one was picked."""

    name: str
    scene_name: str
    scene: dict[str, Any]
    request: dict[str, Any]
    start_state: dict[str, float] | None = None


@dataclass
class _Source:
    scenes: dict[str, dict[str, Any]]
    queries: dict[str, dict[str, dict[str, Any]]]
    start_states: dict[str, dict[str, float]]


def _mapping(value: Any, what: str) -> dict[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, Mapping) or not all(isinstance(k, str) for k in value):
        raise BenchmarkConfigError(f"{what} must be a mapping from names to entries")
    return dict(value)


def _read_file(path: Path) -> _Source:
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise BenchmarkConfigError(f"cannot read queries file '{path}': {exc}") from None
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise BenchmarkConfigError(f"queries file '{path}' is not valid YAML: {str(exc).splitlines()[0]}") from None
    data = _mapping(data, f"queries file '{path}'")
    unknown = sorted(set(data) - {"scenes", "queries", "start_states"})
    if unknown:
        raise BenchmarkConfigError(f"queries file '{path}' has unknown keys {unknown}; known: "
                                   "['queries', 'scenes', 'start_states']")
    scenes = {name: _mapping(scene, f"scene '{name}' in '{path}'")
              for name, scene in _mapping(data.get("scenes"), f"'scenes' in '{path}'").items()}
    queries: dict[str, dict[str, dict[str, Any]]] = {}
    for scene_name, entries in _mapping(data.get("queries"), f"'queries' in '{path}'").items():
        if scene_name not in scenes:
            raise BenchmarkConfigError(f"queries file '{path}' has queries for scene '{scene_name}', which it does "
                                       f"not define; scenes: {sorted(scenes) or 'none'}")
        queries[scene_name] = {q: _mapping(r, f"query '{q}' of scene '{scene_name}' in '{path}'")
                               for q, r in _mapping(entries, f"queries of scene '{scene_name}'").items()}
    starts: dict[str, dict[str, float]] = {}
    for name, joints in _mapping(data.get("start_states"), f"'start_states' in '{path}'").items():
        joints = _mapping(joints, f"start state '{name}' in '{path}'")
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in joints.values()):
            raise BenchmarkConfigError(f"start state '{name}' in '{path}' must map joint names to numbers")
        starts[name] = {k: float(v) for k, v in joints.items()}
    return _Source(scenes, queries, starts)


def _read_warehouse(path: str) -> _Source:
    try:
        storage = PlanningSceneStorage(path, read_only=True)
    except WarehouseError as exc:
        raise BenchmarkConfigError(str(exc)) from None
    try:
        scenes = {name: storage.planning_scene(name) for name in storage.planning_scene_names()}
        queries = {name: {q: storage.planning_query(name, q) for q in storage.planning_query_names(name)}
                   for name in scenes}
    except WarehouseError as exc:
        raise BenchmarkConfigError(str(exc)) from None
    finally:
        storage.close()
    return _Source(scenes, queries, {})


def load_benchmark_requests(options: BenchmarkOptions, model: RobotModel) -> list[BenchmarkRequest]:
    """The experiments of ``options``, in scene then query order; BenchmarkConfigError when a
    scene is unknown, nothing matches, or a start state names joints the robot lacks."""
    source = _read_file(Path(options.warehouse_host)) if options.queries_file else _read_warehouse(
        options.warehouse_host)
    if options.scene_name:
        if options.scene_name not in source.scenes:
            raise BenchmarkConfigError(f"unknown planning scene '{options.scene_name}' in '{options.warehouse_host}'; "
                                       f"scenes: {sorted(source.scenes) or 'none'}")
        scene_names = [options.scene_name]
    else:
        scene_names = sorted(source.scenes)
    pattern = re.compile(options.queries_regex)
    starts = _start_states(options, model, source)
    requests: list[BenchmarkRequest] = []
    for scene_name in scene_names:
        scene = source.scenes[scene_name]
        for query_name, request in sorted(source.queries.get(scene_name, {}).items()):
            if not pattern.search(query_name):
                continue
            if not starts:
                requests.append(BenchmarkRequest(query_name, scene_name, scene, request))
                continue
            for start_name, joints in starts.items():
                if start_name != query_name:  # MoveIt skips a start state named as the goal
                    requests.append(BenchmarkRequest(f"{start_name}_{query_name}", scene_name, scene, request, joints))
    if not requests:
        raise BenchmarkConfigError(f"no query matches queries_regex {options.queries_regex!r} in scene(s) "
                                   f"{scene_names or 'none'} of '{options.warehouse_host}'")
    names = [r.name for r in requests]
    spaced = sorted(n for n in names if re.search(r"[\s/]", n))
    if spaced:
        raise BenchmarkConfigError(f"query names {spaced} contain blanks or '/': they name the experiments and the "
                                   "log files, which OMPL's log format reads up to the first blank")
    duplicated = sorted({n for n in names if names.count(n) > 1})
    if duplicated:
        raise BenchmarkConfigError(f"queries {duplicated} are named alike in several scenes: their logs would "
                                   "overwrite each other; pick one scene with warehouse.scene_name")
    return requests


def _start_states(options: BenchmarkOptions, model: RobotModel, source: _Source) -> dict[str, dict[str, float]]:
    if not options.start_states_regex:
        return {}
    pattern = re.compile(options.start_states_regex)
    candidates = {name: model.named_state(name, options.group)
                  for name in model.named_state_names(options.group)} if model.has_group(options.group) else {}
    candidates.update(source.start_states)
    picked = {name: joints for name, joints in sorted(candidates.items()) if pattern.search(name)}
    if not picked:
        raise BenchmarkConfigError(f"start_states_regex {options.start_states_regex!r} matches no start state; "
                                   f"known: {sorted(candidates) or 'none'}")
    known = set(model.variable_names)
    for name, joints in picked.items():
        unknown = sorted(set(joints) - known)
        if unknown:
            raise BenchmarkConfigError(f"start state '{name}' names joints {unknown} that robot '{model.name}' "
                                       "does not have")
    return picked
