"""``moveit_run_benchmark CONFIG.yaml`` (also ``python -m mycobot_planning.benchmarks``): MoveIt's
benchmark runner. Bad input ends with one line on stderr and exit status 2, before any run."""
from __future__ import annotations

import argparse
import json
import sys

from ..core.errors import PlanningError
from .benchmark_log import BenchmarkLogError
from .benchmark_options import BenchmarkConfigError, load_benchmark_options
from .benchmark_statistics import BenchmarkDatabaseError
from .distribution import DistributionError
from .run_benchmark import prepare_benchmark, run_benchmark

PROG = "moveit_run_benchmark"


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=PROG,
        description="Plan every query of a MoveIt benchmark configuration (benchmark_config: warehouse, parameters, "
                    "planning_pipelines) 'runs' times with each planner, and write OMPL benchmark logs, the Planner "
                    "Arena database and PNG plots. See docs/benchmarking.md.")
    p.add_argument("config", help="YAML file with benchmark_config (MoveIt's layout, or a ROS parameters file)")
    p.add_argument("--seed", type=int, default=0, help="base random seed: run r of query q gets seed+1+r+runs*q "
                                                       "(the same for every planner; default 0)")
    p.add_argument("--jobs", type=int, default=1, help="local processes running the runs (default 1: this process); "
                                                       "with --ray auto, the local Ray's CPUs")
    p.add_argument("--ray", metavar="auto|ADDRESS", help="spread the runs over Ray tasks: 'auto' starts a local Ray "
                                                         "for this benchmark, an address joins that cluster "
                                                         "(needs the 'ray' extra)")
    p.add_argument("--database", help="Planner Arena database to write (default <output_directory>/<name>.db)")
    p.add_argument("--append", action="store_true", help="add to an existing database instead of replacing it")
    p.add_argument("--no-plots", action="store_true", help="do not write the PNG plots")
    p.add_argument("--check", action="store_true", help="check the configuration, scenes and queries, run nothing")
    p.add_argument("--quiet", action="store_true", help="no progress line on a terminal's stderr")
    return p


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.jobs < 1:
        print(f"{PROG}: error: --jobs must be >= 1, got {args.jobs}", file=sys.stderr)
        return 2
    try:
        options = load_benchmark_options(args.config)
        requests = prepare_benchmark(options)
        total = len(requests) * options.planner_count * options.runs
        if args.check:
            print(json.dumps({"queries": [r.name for r in requests], "planners": options.planner_count,
                              "runs": total}))
            return 0
        done = [0]

        def progress(result: object) -> None:
            done[0] += 1
            if not args.quiet and sys.stderr.isatty():
                print(f"\r{PROG}: {done[0]}/{total} runs", end="" if done[0] < total else "\n", file=sys.stderr,
                      flush=True)

        outcome = run_benchmark(options, requests, seed=args.seed, jobs=args.jobs, ray=args.ray,
                                database=args.database, append=args.append, plots=not args.no_plots,
                                progress=progress)
    except (BenchmarkConfigError, BenchmarkDatabaseError, BenchmarkLogError, DistributionError,
            PlanningError) as exc:
        print(f"{PROG}: error: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}", file=sys.stderr)
        return 2
    except OSError as exc:  # an output directory or database that cannot be written
        print(f"{PROG}: error: cannot write the results: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    print(json.dumps(outcome.summary()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
