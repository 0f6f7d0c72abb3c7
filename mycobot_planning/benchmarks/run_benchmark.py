"""MoveIt's RunBenchmark: options and queries in, one OMPL-format log per query, the Planner
Arena database and plots out. ``run_benchmark`` is the whole command without its argument
handling (``moveit_run_benchmark``, __main__.py), for scripts and tests."""
from __future__ import annotations

import datetime
import math
import socket
import statistics
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import mycobot_planning

from .benchmark_executor import (PlannerResults, RunResult, average_waypoint_distances, benchmark_context,
                                 check_benchmark, failure_summary, make_tasks)
from .benchmark_log import BenchmarkLog, PlannerLog, write_benchmark_log
from .benchmark_options import BenchmarkOptions
from .benchmark_queries import BenchmarkRequest, load_benchmark_requests
from .benchmark_statistics import build_database, plot_database
from .distribution import run_local, run_on_ray

__all__ = ["BenchmarkOutcome", "prepare_benchmark", "run_benchmark"]

LIBRARY = "mycobot_planning"


@dataclass
class BenchmarkOutcome:
    """What a benchmark produced: the files, and per query and planner its runs."""

    logs: list[Path]
    database: Path | None
    plots: list[Path]
    results: dict[str, list[PlannerResults]]
    seed: int
    distribution: str
    failures: dict[str, int] = field(default_factory=dict)

    def summary(self) -> dict[str, Any]:
        """Per planner over every query: runs, solved, median time and median final path length."""
        planners: dict[str, dict[str, Any]] = {}
        for per_query in self.results.values():
            for planner in per_query:
                key = f"{planner.planner_id} ({planner.pipeline})"
                entry = planners.setdefault(key, {"runs": 0, "solved": 0, "times": [], "lengths": []})
                for run in planner.runs:
                    entry["runs"] += 1
                    entry["solved"] += int(run.solved)
                    entry["times"].append(float(run.properties["time REAL"]))
                    if run.solved:
                        entry["lengths"].append(float(run.properties["final_path_length REAL"]))
        out = {}
        for key, entry in planners.items():
            out[key] = {"runs": entry["runs"], "solved": entry["solved"],
                        "median_time_s": round(statistics.median(entry["times"]), 4),
                        "median_final_path_length": round(statistics.median(entry["lengths"]), 4)
                        if entry["lengths"] else None}
        return {"queries": len(self.results), "seed": self.seed, "distribution": self.distribution,
                "planners": out, "failures": self.failures,
                "logs": [str(p) for p in self.logs], "database": str(self.database) if self.database else None,
                "plots": [str(p) for p in self.plots]}


def prepare_benchmark(options: BenchmarkOptions) -> list[BenchmarkRequest]:
    """Load and check everything before a run starts (BenchmarkConfigError otherwise), and make
    the output directory (OSError when it cannot be: better before the runs than after)."""
    face = benchmark_context()
    requests = load_benchmark_requests(options, face.model)
    check_benchmark(options, requests, face)
    Path(options.output_directory).mkdir(parents=True, exist_ok=True)
    return requests


def _setup(options: BenchmarkOptions, request: BenchmarkRequest, robot: str) -> str:
    """The experiment setup block, as MoveIt writes it."""
    return (f"Motion plan request:\n  planner_id: \n  group_name: {options.group}\n  num_planning_attempts: 1\n"
            f"  allowed_planning_time: {options.timeout:g}\nPlanning scene:\n  scene_name: {request.scene_name}\n"
            f"  robot_model_name: {robot}\n")


def _log_name(options: BenchmarkOptions, request: BenchmarkRequest, host: str, start: str) -> str:
    """MoveIt's file name: [<name>_]<query>_<host>_<start time>.log."""
    return f"{options.name + '_' if options.name else ''}{request.name}_{host}_{start}.log"


def run_benchmark(options: BenchmarkOptions, requests: Sequence[BenchmarkRequest] | None = None, *, seed: int = 0,
                  jobs: int = 1, ray: str | None = None, database: str | Path | None = None,
                  append: bool = False, plots: bool = True,
                  progress: Callable[[RunResult], None] | None = None) -> BenchmarkOutcome:
    """Run the benchmark of ``options`` (its queries: loaded and checked unless given) and write
    the logs into output_directory, the database (default <output_directory>/<name or
    'benchmark'>.db) and the PNG plots beside it."""
    if requests is None:
        requests = prepare_benchmark(options)
    face = benchmark_context()
    tasks = make_tasks(options, requests, face.model, seed)
    if ray:
        results = run_on_ray(tasks, ray, num_cpus=max(1, jobs), progress=progress)
        distribution = f"ray:{ray}"
    else:
        results = run_local(tasks, jobs, progress=progress)
        distribution = f"local:{max(1, jobs)}"
    planners = [(p.pipeline, planner) for p in options.pipelines for planner in p.planners]
    grouped: dict[str, list[PlannerResults]] = {}
    for qi, request in enumerate(requests):
        grouped[request.name] = []
        for pi, (pipeline, planner) in enumerate(planners):
            runs = sorted((r for r in results if r.query_index == qi and r.planner_index == pi),
                          key=lambda r: r.run_index)
            for run, distance in zip(runs, average_waypoint_distances(runs)):
                run.properties["average_waypoint_distance REAL"] = \
                    "nan" if math.isnan(distance) else ("inf" if math.isinf(distance) else repr(distance))
            grouped[request.name].append(PlannerResults(pipeline, planner, runs))

    host = socket.gethostname() or "UNKNOWN"
    output = Path(options.output_directory)
    logs = []
    parsed = []
    for request in requests:
        per_planner = grouped[request.name]
        runs = [r for p in per_planner for r in p.runs]
        started = min(r.started_at for r in runs)
        start = datetime.datetime.fromtimestamp(started).isoformat(timespec="microseconds")
        blocks = []
        for planner in per_planner:
            properties = sorted({k for r in planner.runs for k in r.properties})
            blocks.append(PlannerLog(f"{planner.planner_id} ({planner.pipeline})", properties,
                                     [[r.properties.get(k, "") for k in properties] for r in planner.runs]))
        log = BenchmarkLog(LIBRARY, mycobot_planning.__version__, request.name, host, start, _setup(options, request, face.model.name), seed,
                           options.timeout, -1, options.runs, sum(float(r.properties["time REAL"]) for r in runs),
                           blocks)
        logs.append(write_benchmark_log(log, output / _log_name(options, request, host, start)))
        parsed.append(log)
    db_path = Path(database) if database else output / f"{options.name or 'benchmark'}.db"
    build_database(db_path, parsed, append=append)
    pictures = plot_database(db_path, db_path.parent, prefix=f"{db_path.stem}_") if plots else []
    return BenchmarkOutcome(logs, db_path, pictures, grouped, seed, distribution, failure_summary(results))
