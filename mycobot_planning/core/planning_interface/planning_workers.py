"""Plans on more than one core: the planning pipeline run in worker processes.

Why processes: our planners call Python for every state they check (the validity callback, the
IK and constraint code), so threads of one process take turns on the interpreter lock and two
clients planning at once share one core. ``PlanningWorkers`` is a ``Planner`` (what a
PlanningContext solves with): it sends each request, with the scene it is planned in, to a
process that loaded the same robot model and pipeline, and hands the answer back. Semantics stay
those of the in-process pipeline: the same request with the same seed gives the same path, a
terminated context stops the worker's plan (PREEMPTED), and the worker keeps the planner
parameters the server was told since it started (``parameters_changed``).

What stays in the calling process: requests of a pipeline the workers do not have (a planner
registered at run time by ``register_planner``), and every request until the workers are ready
(they start in the background, so a server answers at once). A worker that dies is replaced;
its request is answered with a FAILURE that says so. docs/core.md, "Planning on several cores".
"""
from __future__ import annotations

import dataclasses
import hashlib
import math
import multiprocessing
import os
import signal
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from concurrent.futures import Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Callable, Mapping, Sequence

import numpy as np
from interfaces_py.msgs import MoveItErrorCode

from .planning_interface import MotionPlanRequest, MotionPlanResponse
from .planning_pipeline import PlanningPipeline
from ..planning_scene.planning_scene import PlanningScene
from ..robot_model.robot_model import RobotModel

__all__ = ["PlanningLoader", "PlanningSetup", "PlanningWorkers", "best_of_attempts", "split_attempts"]

#: builds (model, pipeline) in a worker: a picklable callable (a module-level function or a
#: functools.partial of one), called once per worker process
PlanningLoader = Callable[[], tuple[Any, Any]]

@dataclass(frozen=True)
class PlanningSetup:
    """A PlanningLoader from the robot's description and planner files, as a server reads them:
    ``urdf`` None means the package's myCobot 280 (its own config files)."""

    urdf: str | None = None
    srdf: str = ""
    joint_limits: Mapping | None = None
    kinematics: Mapping | None = None
    package_dirs: tuple[str, ...] = ()
    ompl_config: str | Path | Mapping | None = None
    cartesian_limits: str | Path | Mapping | None = None

    def robot_model(self) -> RobotModel:
        if self.urdf is None:
            return RobotModel.mycobot()
        return RobotModel.from_strings(self.urdf, self.srdf, self.joint_limits, self.kinematics,
                                       package_dirs=self.package_dirs)

    def planning_pipeline(self) -> PlanningPipeline:
        return PlanningPipeline(self.ompl_config, self.cartesian_limits)

    def __call__(self) -> tuple[RobotModel, PlanningPipeline]:
        return self.robot_model(), self.planning_pipeline()


#: s between two looks at a running request's cancel flag from the calling thread
CANCEL_POLL = 0.02
#: s between a worker's looks at whether its server is still alive
PARENT_POLL = 0.5


class _SharedFlag:
    """One slot of a shared byte array, read as an Event (``is_set``) by the worker's planner."""

    __slots__ = ("_flags", "_slot")

    def __init__(self, flags: Any, slot: int) -> None:
        self._flags, self._slot = flags, slot

    def is_set(self) -> bool:
        return bool(self._flags[self._slot])


# ------------------------------------------------------------------ the worker process side
_WORKER: dict[str, Any] = {}


def _exit_with_parent(parent: int) -> None:
    """A worker whose server died (even by SIGKILL, which runs no clean-up) exits too."""
    while os.getppid() == parent:
        time.sleep(PARENT_POLL)
    os._exit(0)


def _worker_init(loader: PlanningLoader, flags: Any, parent: int) -> None:
    # Ctrl-C in a terminal reaches the whole process group: the parent shuts its workers down,
    # so a worker ignores it instead of printing a KeyboardInterrupt traceback
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threading.Thread(target=_exit_with_parent, args=(parent,), name="parent watch", daemon=True).start()
    model, pipeline = loader()
    _WORKER.update(model=model, pipeline=pipeline, flags=flags, scene_key=None, scene=None, changes=0)


def _worker_pipeline_ids() -> list[str]:
    return list(_WORKER["pipeline"].pipeline_ids)


def _worker_scene(scene_key: str, scene_msg: Any, positions: Sequence[float]) -> PlanningScene:
    """The request's scene: the last one rebuilt only when its world changed (a compiled scene
    costs milliseconds per mesh), then set to the request's start positions."""
    if _WORKER["scene_key"] != scene_key:
        _WORKER["scene"] = PlanningScene.from_msg(_WORKER["model"], scene_msg)
        _WORKER["scene_key"] = scene_key
    scene = _WORKER["scene"].copy()
    scene.set_current_state(list(positions))
    return scene


def _worker_plan(slot: int, scene_key: str, scene_msg: Any, positions: Sequence[float], request: MotionPlanRequest,
                 changes: Sequence[tuple[str, str, Mapping[str, str], bool]]) -> MotionPlanResponse:
    pipeline = _WORKER["pipeline"]
    for pipeline_id, planner_id, params, replace in changes[_WORKER["changes"]:]:
        pipeline.manager(pipeline_id).set_planner_params(planner_id, params, replace)
    _WORKER["changes"] = len(changes)
    scene = _worker_scene(scene_key, scene_msg, positions)
    request = dataclasses.replace(request, start_state=scene.current_state.copy(),
                                  cancel=_SharedFlag(_WORKER["flags"], slot))
    response = pipeline.plan(scene, request)
    return dataclasses.replace(response, start_state=None)


# ------------------------------------------------------------------ attempts in several workers
def split_attempts(attempts: int, parts: int) -> list[tuple[int, int]]:
    """``attempts`` cut into ``parts`` runs of consecutive attempts, as (first attempt, count),
    the longer runs first; no run is empty."""
    parts = max(1, min(parts, attempts))
    size, extra = divmod(attempts, parts)
    runs, first = [], 0
    for k in range(parts):
        count = size + (1 if k < extra else 0)
        runs.append((first, count))
        first += count
    return runs


def _path_length(response: MotionPlanResponse) -> float:
    path = response.path
    if path is None or len(path) < 2:
        return 0.0 if path is not None else math.inf
    return float(np.sum(np.linalg.norm(np.diff(np.asarray(path, dtype=float), axis=0), axis=1)))


def best_of_attempts(responses: Sequence[MotionPlanResponse]) -> MotionPlanResponse:
    """The answer of a request whose attempts ran as several requests (in attempt order), as one
    process running them all would give it: the shortest path, ties to the earlier attempt; with
    no solution, the failure of the last attempts. Its planning_time is the longest part's."""
    if len(responses) == 1:
        return responses[0]
    solved = [r for r in responses if r.success and r.trajectory is not None]
    answer = min(solved, key=_path_length) if solved else responses[-1]
    return dataclasses.replace(answer, planning_time=max(r.planning_time for r in responses))


# ------------------------------------------------------------------ the calling process side
class PlanningWorkers:
    """A Planner that plans in ``processes`` worker processes (see the module docstring).

    ``pipeline`` is this process's own pipeline, built from the same configuration as the
    workers': it plans what the workers cannot (see above); its managers answer the planner
    queries and take the parameter changes, which ``parameters_changed`` passes on."""

    def __init__(self, pipeline: Any, loader: PlanningLoader, processes: int,
                 log: Callable[[str, str], None] | None = None, parallel_attempts: bool = True) -> None:
        if processes < 1:
            raise ValueError(f"PlanningWorkers needs at least 1 process, got {processes}")
        self.pipeline = pipeline
        self.processes = processes
        #: a request of several attempts (num_planning_attempts) of a planner with independent
        #: attempts is split between the workers free when it comes, as MoveIt runs attempts in
        #: parallel threads; the answer is the one a single process would give (best_of_attempts)
        self.parallel_attempts = parallel_attempts
        self._loader = loader
        self._log = log or (lambda level, text: None)
        context = multiprocessing.get_context("spawn")  # never fork a process that runs ROS threads
        self._flags = context.RawArray("b", processes)
        self._free = list(range(processes))
        self._slots = threading.Condition()
        self._changes: list[tuple[str, str, Mapping[str, str], bool]] = []
        #: the last scene sent: (its content_token, name, message without positions, key)
        self._last_scene: tuple[object, str, Any, str] | None = None
        self._lock = threading.Lock()
        self._context = context
        self._pool: ProcessPoolExecutor | None = None
        self._remote_ids: frozenset[str] = frozenset()
        self._ready = threading.Event()
        self._closed = False
        self._starting = threading.Thread(target=self._start, name="planning workers start", daemon=True)
        self._starting.start()

    # -------------------------------------------------------------- lifecycle
    def _start(self) -> None:
        try:
            pool = ProcessPoolExecutor(self.processes, mp_context=self._context, initializer=_worker_init,
                                       initargs=(self._loader, self._flags, os.getpid()))
            # one call per worker, so every worker has loaded the model before the first plan
            ids = [pool.submit(_worker_pipeline_ids) for _ in range(self.processes)]
            remote = frozenset(ids[0].result())
            for future in ids[1:]:
                future.result()
        except Exception as exc:  # the server keeps planning in-process
            self._log("error", f"planning workers did not start ({type(exc).__name__}: {exc}); "
                               "planning stays in the server's process")
            return
        with self._lock:
            if self._closed:
                pool.shutdown(wait=False, cancel_futures=True)
                return
            self._pool, self._remote_ids = pool, remote
        self._ready.set()
        self._log("info", f"planning on {self.processes} worker processes (pipelines: {', '.join(sorted(remote))})")

    def wait_ready(self, timeout: float | None = None) -> bool:
        """Whether the workers are ready (False: not within ``timeout``, or they failed to start)."""
        return self._ready.wait(timeout)

    def close(self) -> None:
        """Stop the workers (running plans are abandoned; their callers get a FAILURE)."""
        with self._lock:
            self._closed = True
            pool, self._pool = self._pool, None
            self._ready.clear()
        if pool is not None:
            for slot in range(self.processes):
                self._flags[slot] = 1
            pool.shutdown(wait=True, cancel_futures=True)

    def parameters_changed(self, pipeline_id: str, planner_id: str, params: Mapping[str, str], replace: bool) -> None:
        """Record a set_planner_params the local pipeline applied; workers apply it before their next plan."""
        with self._lock:
            self._changes.append((pipeline_id, planner_id, dict(params), replace))

    # -------------------------------------------------------------- planning
    def plan(self, scene: PlanningScene, request: MotionPlanRequest) -> MotionPlanResponse:
        with self._lock:
            pool = self._pool
            remote = (request.pipeline_id or "ompl") in self._remote_ids
            changes = list(self._changes)
        if pool is None or not remote:
            return self.pipeline.plan(scene, request)
        positions = [float(x) for x in scene.current_state.positions]
        token = scene.content_token
        with self._lock:
            last = self._last_scene
        if last is not None and last[0] is token and last[1] == scene.name:
            msg, scene_key = last[2], last[3]  # the same world: its message and key as last time (~0.3 ms)
        else:
            msg = scene.get_planning_scene_msg()
            msg.robot_state.positions = []
            scene_key = hashlib.blake2b(msg.to_json().encode(), digest_size=16).hexdigest()
            with self._lock:
                self._last_scene = (token, scene.name, msg, scene_key)
        slots = [self._take_slot()]
        if self.parallel_attempts and request.num_planning_attempts > 1 and self._independent_attempts(request):
            slots += self._take_free_slots(min(request.num_planning_attempts, self.processes) - 1)
        futures: list[Future] = []
        try:
            for slot, (first, count) in zip(slots, split_attempts(request.num_planning_attempts, len(slots))):
                self._flags[slot] = 0
                wire = dataclasses.replace(request, start_state=None, cancel=None, num_planning_attempts=count,
                                           first_attempt=request.first_attempt + first)
                try:
                    futures.append(pool.submit(_worker_plan, slot, scene_key, msg, positions, wire, changes))
                except (BrokenProcessPool, RuntimeError) as exc:
                    for started in slots[:len(futures)]:
                        self._flags[started] = 1  # those already sent end PREEMPTED; nobody waits for them
                    self._restart(pool, exc)
                    return self.pipeline.plan(scene, request)
            responses = self._answers(futures, pool, request, slots)
        finally:
            for slot in slots:
                self._give_slot(slot)
        return dataclasses.replace(best_of_attempts(responses), start_state=request.start_state)

    def _independent_attempts(self, request: MotionPlanRequest) -> bool:
        manager = self.pipeline.manager(request.pipeline_id or "ompl")
        return bool(getattr(manager, "independent_attempts", False))

    def _answers(self, futures: list[Future], pool: ProcessPoolExecutor, request: MotionPlanRequest,
                 slots: list[int]) -> list[MotionPlanResponse]:
        """The workers' answers, in the order sent; a cancel of the request reaches every worker."""
        cancel = request.cancel
        flagged = False
        try:
            while wait(futures, timeout=CANCEL_POLL).not_done:
                if not flagged and cancel is not None and cancel.is_set():
                    for slot in slots:
                        self._flags[slot] = 1
                    flagged = True
            return [future.result() for future in futures]
        except BrokenProcessPool as exc:
            for slot in slots:
                self._flags[slot] = 1
            self._restart(pool, exc)
            return [MotionPlanResponse(MoveItErrorCode(
                MoveItErrorCode.FAILURE, "the planning worker process ended during this plan (new workers are "
                "starting)"), group_name=request.group)]

    # -------------------------------------------------------------- slots (one per worker)
    def _take_slot(self) -> int:
        with self._slots:
            while not self._free:
                self._slots.wait()
            return self._free.pop()

    def _take_free_slots(self, count: int) -> list[int]:
        """Up to ``count`` more slots, only those free now (never waits)."""
        with self._slots:
            taken = self._free[len(self._free) - max(0, min(count, len(self._free))):]
            del self._free[len(self._free) - len(taken):]
            return taken

    def _give_slot(self, slot: int) -> None:
        with self._slots:
            self._free.append(slot)
            self._slots.notify()

    def _restart(self, broken: ProcessPoolExecutor, exc: BaseException) -> None:
        with self._lock:
            if self._pool is not broken or self._closed:
                return
            self._pool = None
            self._ready.clear()
        self._log("error", f"a planning worker process ended ({type(exc).__name__}: {exc}); starting new workers")
        broken.shutdown(wait=False, cancel_futures=True)
        self._starting = threading.Thread(target=self._start, name="planning workers restart", daemon=True)
        self._starting.start()
