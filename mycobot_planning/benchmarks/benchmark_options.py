"""MoveIt's BenchmarkOptions (moveit_ros_benchmarks): the ``benchmark_config`` parameters of
``moveit_run_benchmark``, read from a YAML file and checked before anything runs.

The layout is MoveIt's: ``benchmark_config.warehouse.{host, port, scene_name}``,
``benchmark_config.parameters.{name, runs, group, timeout, output_directory, queries_regex,
start_states_regex, ...}`` and ``benchmark_config.planning_pipelines.{pipelines: [ID, ...],
ID: {name: <pipeline>, planners: [<planner id>, ...]}}``; a ROS parameters file (``<node>:
ros__parameters: benchmark_config: ...``) is read too. ``warehouse.host`` names the SQLite
warehouse (as warehouse_ros_sqlite reads it) or, ending in .yaml/.yml, a queries file. What
MoveIt reads but this runner cannot honour (goal/path/trajectory constraints from the
warehouse, predefined poses, goal offsets, parallel pipelines) is refused when set, never
silently ignored. Unknown keys are refused too: a typo must not change the experiment."""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import yaml

__all__ = ["BenchmarkConfigError", "BenchmarkOptions", "PipelineConfig", "load_benchmark_options"]


class BenchmarkConfigError(ValueError):
    """The benchmark configuration (or its scenes and queries) cannot be run; the message says why."""


@dataclass(frozen=True)
class PipelineConfig:
    """One entry of planning_pipelines.pipelines: its id, the pipeline and its planner ids."""

    id: str
    pipeline: str
    planners: tuple[str, ...]


@dataclass
class BenchmarkOptions:
    """benchmark_config, read and checked (see the module docstring)."""

    name: str = ""
    runs: int = 10
    group: str = ""
    timeout: float = 10.0
    output_directory: str = ""
    queries_regex: str = ".*"
    start_states_regex: str = ""
    warehouse_host: str = "127.0.0.1"
    warehouse_port: int = 33829
    scene_name: str = ""
    pipelines: list[PipelineConfig] = field(default_factory=list)
    source: str = ""  # the file the options were read from

    @property
    def planner_count(self) -> int:
        return sum(len(p.planners) for p in self.pipelines)

    @property
    def queries_file(self) -> bool:
        """Whether warehouse.host names a YAML queries file rather than an SQLite warehouse."""
        return Path(self.warehouse_host).suffix.lower() in (".yaml", ".yml")


_WAREHOUSE_KEYS = {"host", "port", "scene_name", "warehouse_plugin"}
_PARAMETER_KEYS = {"name", "runs", "group", "timeout", "output_directory", "queries_regex", "start_states_regex",
                   "goal_constraints_regex", "path_constraints_regex", "trajectory_constraints_regex",
                   "predefined_poses", "predefined_poses_group", "workspace", "goal_offset"}
#: MoveIt parameters this runner does not implement: refused unless empty / zero.
_UNSUPPORTED = ("goal_constraints_regex", "path_constraints_regex", "trajectory_constraints_regex",
                "predefined_poses", "predefined_poses_group")


def _string(section: Mapping[str, Any], key: str, default: str, where: str) -> str:
    value = section.get(key, default)
    if value is None:
        return default
    if not isinstance(value, str):
        raise BenchmarkConfigError(f"{where}.{key} must be a string, got {value!r}")
    return value


def _regex(value: str, where: str) -> str:
    try:
        re.compile(value)
    except re.error as exc:
        raise BenchmarkConfigError(f"{where} is not a valid regular expression ({value!r}): {exc}") from None
    return value


def _section(parent: Mapping[str, Any], key: str, where: str, required: bool = False) -> Mapping[str, Any]:
    value = parent.get(key)
    if value is None:
        if required:
            raise BenchmarkConfigError(f"{where}.{key} is missing")
        return {}
    if not isinstance(value, Mapping):
        raise BenchmarkConfigError(f"{where}.{key} must be a mapping, got {type(value).__name__}")
    return value


def _unknown(section: Mapping[str, Any], known: set[str], where: str) -> None:
    unknown = sorted(str(k) for k in set(section) - known)
    if unknown:
        raise BenchmarkConfigError(f"{where} has unknown keys {unknown}; known: {sorted(known)}")


def _benchmark_config(data: Any) -> Mapping[str, Any]:
    """benchmark_config at the top level or under <node>.ros__parameters (a ROS parameters file)."""
    if isinstance(data, Mapping):
        if "benchmark_config" in data:
            return _section(data, "benchmark_config", "the file", required=True)
        for value in data.values():
            if isinstance(value, Mapping) and isinstance(value.get("ros__parameters"), Mapping) \
                    and "benchmark_config" in value["ros__parameters"]:
                return _section(value["ros__parameters"], "benchmark_config", "ros__parameters", required=True)
    raise BenchmarkConfigError("no benchmark_config found (expected a top-level 'benchmark_config:' mapping, "
                               "as in MoveIt's benchmark configuration files)")


def load_benchmark_options(source: str | Path | Mapping[str, Any]) -> BenchmarkOptions:
    """Read and check the options; BenchmarkConfigError says what is wrong. Relative paths
    (warehouse.host, output_directory) are taken relative to the configuration file."""
    base = Path.cwd()
    if isinstance(source, Mapping):
        data: Any = source
        where = "<mapping>"
    else:
        path = Path(source).expanduser()
        where = str(path)
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise BenchmarkConfigError(f"cannot read benchmark configuration '{path}': {exc}") from None
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise BenchmarkConfigError(f"benchmark configuration '{path}' is not valid YAML: "
                                       f"{str(exc).splitlines()[0]}") from None
        base = path.resolve().parent
    config = _benchmark_config(data)
    _unknown(config, {"warehouse", "parameters", "planning_pipelines", "warehouse_plugin"}, "benchmark_config")
    warehouse = _section(config, "warehouse", "benchmark_config")
    _unknown(warehouse, _WAREHOUSE_KEYS, "benchmark_config.warehouse")
    params = _section(config, "parameters", "benchmark_config", required=True)
    _unknown(params, _PARAMETER_KEYS, "benchmark_config.parameters")
    where_p = "benchmark_config.parameters"
    for key in _UNSUPPORTED:
        if params.get(key):
            raise BenchmarkConfigError(f"{where_p}.{key} is not supported by this runner (its scenes and queries "
                                       "come with their goals and start states); remove it")
    offset = params.get("goal_offset") or {}
    if not isinstance(offset, Mapping) or any(
            not isinstance(v, (int, float)) or v != 0 for v in offset.values()):
        raise BenchmarkConfigError(f"{where_p}.goal_offset is not supported by this runner (only zero offsets)")

    options = BenchmarkOptions(source=where)
    options.name = _string(params, "name", "", where_p)
    if options.name and not re.fullmatch(r"[\w.\-]+", options.name):
        raise BenchmarkConfigError(f"{where_p}.name {options.name!r} must be letters, digits, '_', '-' or '.' "
                                   "(it names the log files)")
    runs = params.get("runs", 10)
    if isinstance(runs, bool) or not isinstance(runs, int) or runs < 1:
        raise BenchmarkConfigError(f"{where_p}.runs must be an integer >= 1, got {runs!r}")
    options.runs = runs
    group = params.get("group")
    if not isinstance(group, str) or not group:
        raise BenchmarkConfigError(f"{where_p}.group (the planning group) is required")
    options.group = group
    timeout = params.get("timeout", 10.0)
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not math.isfinite(timeout) \
            or timeout <= 0:
        raise BenchmarkConfigError(f"{where_p}.timeout must be a number of seconds > 0, got {timeout!r}")
    options.timeout = float(timeout)
    output = _string(params, "output_directory", "", where_p)
    options.output_directory = str((base / Path(output).expanduser()) if output else base)
    options.queries_regex = _regex(_string(params, "queries_regex", ".*", where_p), f"{where_p}.queries_regex")
    options.start_states_regex = _regex(_string(params, "start_states_regex", "", where_p),
                                        f"{where_p}.start_states_regex")

    host = _string(warehouse, "host", "", "benchmark_config.warehouse")
    if not host:
        raise BenchmarkConfigError("benchmark_config.warehouse.host must name the SQLite warehouse file "
                                   "(or a .yaml queries file) holding the scenes and queries")
    options.warehouse_host = str(base / Path(host).expanduser())
    port = warehouse.get("port", 33829)
    if isinstance(port, bool) or not isinstance(port, int):
        raise BenchmarkConfigError(f"benchmark_config.warehouse.port must be an integer, got {port!r}")
    options.warehouse_port = port  # read as MoveIt reads it; an SQLite warehouse has no port
    options.scene_name = _string(warehouse, "scene_name", "", "benchmark_config.warehouse")

    options.pipelines = _pipelines(_section(config, "planning_pipelines", "benchmark_config", required=True))
    return options


def _pipelines(section: Mapping[str, Any]) -> list[PipelineConfig]:
    where = "benchmark_config.planning_pipelines"
    if section.get("parallel_pipelines"):
        raise BenchmarkConfigError(f"{where}.parallel_pipelines is not supported by this runner")
    ids = section.get("pipelines")
    if not isinstance(ids, list) or not ids or not all(isinstance(i, str) and i for i in ids):
        raise BenchmarkConfigError(f"{where}.pipelines must be a non-empty list of pipeline ids")
    if len(set(ids)) != len(ids):
        raise BenchmarkConfigError(f"{where}.pipelines lists an id twice: {ids}")
    # sections of pipelines the list leaves out are ignored, as MoveIt ignores them (users toggle
    # pipelines by editing the list)
    found: list[PipelineConfig] = []
    seen: set[tuple[str, str]] = set()
    for pid in ids:
        entry = _section(section, pid, where, required=True)
        _unknown(entry, {"name", "planners"}, f"{where}.{pid}")
        name = entry.get("name")
        if not isinstance(name, str) or not name:
            raise BenchmarkConfigError(f"{where}.{pid}.name (the planning pipeline, e.g. 'ompl') is required")
        planners = entry.get("planners")
        if not isinstance(planners, list) or not planners or not all(isinstance(p, str) and p for p in planners):
            raise BenchmarkConfigError(f"{where}.{pid}.planners must be a non-empty list of planner ids")
        for planner in planners:
            if (name, planner) in seen:
                raise BenchmarkConfigError(f"{where}: planner '{planner}' of pipeline '{name}' is listed twice")
            seen.add((name, planner))
        found.append(PipelineConfig(pid, name, tuple(planners)))
    return found
