"""Where the runs of a benchmark execute: this process (``jobs=1``), a pool of local processes
(``jobs=N``), or Ray tasks on a local Ray (``ray="auto"``) or a cluster (``ray=<address>``).

Each run is a RunTask planned by benchmark_executor.run_task in a worker process with its own
model and pipeline, so the results do not depend on where a run went. Local processes are
spawned (not forked: the parent may hold OMPL and threads). Ray is an optional dependency
(``pip install mycobot_planning[ray]``); it is imported only when asked for, and a missing Ray
is a clear error, not a traceback. On a cluster every node needs this package installed (the
workers import it); a local Ray's workers inherit this process's environment (PYTHONPATH)."""
from __future__ import annotations

import importlib
import multiprocessing
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Callable, Sequence

from .benchmark_executor import RunResult, RunTask, run_task

__all__ = ["DistributionError", "RayUnavailable", "run_local", "run_on_ray"]


class DistributionError(RuntimeError):
    """The runs could not be carried out where they were sent (a worker died, Ray failed)."""


class RayUnavailable(DistributionError):
    """--ray was asked for, but Ray cannot be imported or reached."""


def run_local(tasks: Sequence[RunTask], jobs: int = 1,
              progress: Callable[[RunResult], None] | None = None) -> list[RunResult]:
    """Every task, in this process (``jobs`` <= 1) or ``jobs`` spawned processes; task order."""
    results: list[RunResult] = []
    if jobs <= 1:
        for task in tasks:
            results.append(run_task(task))
            if progress:
                progress(results[-1])
        return results
    try:
        with ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
            for result in pool.map(run_task, tasks):
                results.append(result)
                if progress:
                    progress(result)
    except BrokenProcessPool as exc:
        raise DistributionError(f"a benchmark worker process died after {len(results)} of {len(tasks)} runs "
                                f"({exc}); a script calling run_benchmark with jobs > 1 needs an "
                                "'if __name__ == \"__main__\":' guard") from None
    return results


def _ray() -> Any:
    try:
        return importlib.import_module("ray")
    except ImportError as exc:
        raise RayUnavailable(f"--ray needs Ray, which is not installed ({exc}); install the extra: "
                             "pip install 'mycobot_planning[ray]'") from None


def run_on_ray(tasks: Sequence[RunTask], address: str = "auto", num_cpus: int | None = None,
               progress: Callable[[RunResult], None] | None = None) -> list[RunResult]:
    """Every task as a Ray task (one CPU each); task order. ``address`` "auto" starts a local
    Ray for this call (``num_cpus`` workers, no dashboard) and stops it after; any other
    address joins that cluster and leaves it running."""
    ray = _ray()
    local = address == "auto"
    try:
        if local:
            ray.init(address="local", num_cpus=num_cpus, include_dashboard=False, log_to_driver=False,
                     configure_logging=False)
        else:
            ray.init(address=address, log_to_driver=False, configure_logging=False)
    except Exception as exc:  # Ray raises ConnectionError, RuntimeError, ValueError... for a bad address
        raise RayUnavailable(f"cannot {'start a local Ray' if local else f'join the Ray cluster at {address}'}: "
                             f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}") from None
    try:
        remote = ray.remote(num_cpus=1)(run_task)
        pending = {remote.remote(task): i for i, task in enumerate(tasks)}
        results: list[RunResult | None] = [None] * len(tasks)
        waiting = list(pending)
        while waiting:
            done, waiting = ray.wait(waiting, num_returns=1)
            for ref in done:
                try:
                    result = ray.get(ref)
                except Exception as exc:  # a worker that died or could not import the package
                    raise DistributionError(f"a Ray task failed: {type(exc).__name__}: "
                                            f"{str(exc).strip().splitlines()[-1] if str(exc).strip() else ''}") from None
                results[pending[ref]] = result
                if progress:
                    progress(result)
        return [r for r in results if r is not None]
    finally:
        ray.shutdown()
