"""moveit_run_benchmark itself, measured (issue 33): the package's example benchmark
(config/benchmark.yaml: the myCobot's pillar scene, 2 queries x 5 planners x 5 runs) run in this
process, in two local processes and, when Ray is importable, on a local Ray with two workers.

* ``moveit_run_benchmark``: one record per repeat and place (``in_process``, ``local_2``,
  ``ray_2``): wall time, and per planner runs, solved, median time and median final path length;
  ``identical`` says whether every run's solved flag and final path length equal the in-process
  run's with the same seed (repeat r uses seed ``--seed + r``). Summary: the median wall time
  per place, ``all_identical`` and ``ray_available``. Logs, databases and plots go to a
  temporary directory that is removed after.
"""
from __future__ import annotations

import importlib.util
import statistics
import tempfile
import time
from typing import Any

from ..benchmarks.benchmark_options import load_benchmark_options
from ..benchmarks.run_benchmark import BenchmarkOutcome, prepare_benchmark, run_benchmark
from ..paths import config_file
from .common import emit, machine


def _figures(outcome: BenchmarkOutcome) -> dict[tuple[str, str], list[tuple[bool, str | None]]]:
    return {(query, f"{p.planner_id} ({p.pipeline})"): [(r.solved, r.properties.get("final_path_length REAL"))
                                                       for r in p.runs]
            for query, planners in outcome.results.items() for p in planners}


def bench_moveit_run_benchmark(repeat: int, seed: int) -> None:
    """See the module docstring."""
    ray_available = importlib.util.find_spec("ray") is not None
    places: list[tuple[str, dict[str, Any]]] = [("in_process", {"jobs": 1}), ("local_2", {"jobs": 2})]
    if ray_available:
        places.append(("ray_2", {"jobs": 2, "ray": "auto"}))
    walls: dict[str, list[float]] = {name: [] for name, _ in places}
    identical = True
    with tempfile.TemporaryDirectory(prefix="moveit_run_benchmark_") as tmp:
        for r in range(repeat):
            reference = None
            for name, kwargs in places:
                options = load_benchmark_options(config_file("benchmark.yaml"))
                options.output_directory = f"{tmp}/{r}_{name}"
                requests = prepare_benchmark(options)
                started = time.perf_counter()
                outcome = run_benchmark(options, requests, seed=seed + r, plots=False, **kwargs)
                wall = time.perf_counter() - started
                figures = _figures(outcome)
                reference = reference or figures
                same = figures == reference
                identical = identical and same
                walls[name].append(wall)
                emit({"scenario": "moveit_run_benchmark", "repeat": r, "place": name, "wall_s": round(wall, 3),
                      "identical": same, "planners": outcome.summary()["planners"], "failures": outcome.failures})
    emit({"scenario": "moveit_run_benchmark", "summary": True, "ray_available": ray_available,
          "all_identical": identical,
          **{f"{name}_wall_s": round(statistics.median(values), 3) for name, values in walls.items()},
          **machine()})


BENCHMARK_RUNNER_SCENARIOS = {"moveit_run_benchmark": bench_moveit_run_benchmark}
