"""MoveIt's BenchmarkExecutor: each query planned ``runs`` times by each planner of each
pipeline, in-process (the planning pipeline behind a move_group context, no ROS), and the
figures MoveIt collects per run (collectMetrics, computeAveragePathSimilarities).

A run is a self-contained task (``RunTask``: scene, query, pipeline, planner id, seed), so runs
can go anywhere: this process, a pool of local processes, or Ray workers (distribution.py).
Every run carries its own seed, ``seed + 1 + run + runs * query`` (the same for every planner,
so planners meet the same random streams), and every worker process builds its own model and
pipeline: a run's result depends on its task only, which is what makes a Ray run and a local
run of the same experiment agree (times aside). Sampling planners are reproducible under a
seed when they stop at their first solution, as ours do (docs/ompl.md)."""
from __future__ import annotations

import math
import os
import time
import traceback
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from interfaces_py.msgs import MoveItErrorCode

from ..capabilities import plan
from ..capabilities.json_face import MoveGroupJsonFace
from ..capabilities.move_group_context import RequestError, planning_only
from ..core.planning_interface.planning_pipeline import PlanningPipeline
from ..core.planning_scene.planning_scene import PlanningScene
from ..core.robot_model.robot_model import RobotModel
from ..core.robot_state.robot_state import RobotState
from .benchmark_options import BenchmarkConfigError, BenchmarkOptions
from .benchmark_queries import BenchmarkRequest

__all__ = ["PlannerResults", "RunResult", "RunTask", "average_waypoint_distances", "benchmark_context",
           "check_benchmark", "make_tasks", "path_length", "run_task", "smoothness"]

#: what a run's path is called in its property names (MoveIt's response description "plan")
PATH_DESCRIPTION = "plan"


@dataclass(frozen=True)
class RunTask:
    """One run: where it belongs (query, planner, run indices) and everything it needs."""

    query_index: int
    planner_index: int
    run_index: int
    scene: dict[str, Any]
    request: dict[str, Any]  # a complete JSON plan request (pipeline, planner id, seed, start state)


@dataclass
class RunResult:
    """What a run measured: MoveIt's per-run properties ("name TYPE" -> value as written)."""

    query_index: int
    planner_index: int
    run_index: int
    solved: bool
    properties: dict[str, str]
    started_at: float  # wall clock (s since the epoch) when the run began
    positions: list[list[float]] = field(default_factory=list)  # the solved trajectory's waypoints
    message: str = ""
    worker: int = 0  # the process id that ran it


@dataclass
class PlannerResults:
    """One planner's runs on one query, in run order."""

    pipeline: str
    planner_id: str
    runs: list[RunResult]


_CONTEXT: dict[str, Any] = {}


def benchmark_context() -> MoveGroupJsonFace:
    """This process's move_group context on the myCobot (built once per process)."""
    face = _CONTEXT.get("face")
    if face is None:
        model = RobotModel.mycobot()
        face = planning_only(MoveGroupJsonFace, model, PlanningPipeline(), log=lambda level, text: None)
        _CONTEXT["face"] = face
        _CONTEXT["scene"] = None
    return face


def _use_scene(face: MoveGroupJsonFace, scene: Mapping[str, Any]) -> None:
    """Make ``scene`` the context's scene (a full replacement; skipped when it is already)."""
    if _CONTEXT.get("scene") == scene:
        return
    face.apply_planning_scene_json({**scene, "is_diff": False})
    _CONTEXT["scene"] = scene


# ------------------------------------------------------------------------------------------ setup
def check_benchmark(options: BenchmarkOptions, requests: Sequence[BenchmarkRequest], face: MoveGroupJsonFace) -> None:
    """MoveIt's pipelinesExist and more, before anything runs: the group, every pipeline and
    planner id, every scene and every query as the planning_server would read them.
    BenchmarkConfigError says what is wrong."""
    model = face.model
    if not model.has_group(options.group):
        raise BenchmarkConfigError(f"unknown planning group '{options.group}'; known: {', '.join(model.group_names)}")
    pipeline = face.pipeline
    for entry in options.pipelines:
        manager = pipeline.managers.get(entry.pipeline)
        if manager is None:
            raise BenchmarkConfigError(f"planning pipeline '{entry.pipeline}' (of '{entry.id}') does not exist; "
                                       f"known: {', '.join(pipeline.pipeline_ids)}")
        for planner in entry.planners:
            problem = manager.planner_id_problem(planner, [options.group])
            if problem is not None:
                raise BenchmarkConfigError(f"planner '{planner}' of pipeline '{entry.pipeline}': {problem}")
    for request in requests:
        try:
            _use_scene(face, request.scene)
        except (RequestError, ValueError) as exc:
            raise BenchmarkConfigError(f"planning scene '{request.scene_name}': {exc}") from None
        params = _plan_params(options, request, face.model, options.pipelines[0].pipeline,
                              options.pipelines[0].planners[0], 1)
        try:
            face.plan_request(params)
        except (RequestError, ValueError) as exc:
            raise BenchmarkConfigError(f"query '{request.name}' of scene '{request.scene_name}': {exc}") from None


def _start_state(model: RobotModel, request: BenchmarkRequest) -> dict[str, Any]:
    """The run's complete start state: the scene's robot state, then the query's start state,
    then the picked start state, over the model's default positions."""
    state = RobotState(model)
    joints: dict[str, float] = {}
    scene_state = request.scene.get("robot_state") or {}
    query_state = request.request.get("start_state") or {}
    for source in (scene_state, query_state):
        if isinstance(source, Mapping):
            joints.update(zip(source.get("joint_names") or [], source.get("positions") or []))
    joints.update(request.start_state or {})
    names = list(model.variable_names)
    values = dict(zip(names, (float(v) for v in state.positions)))
    unknown = sorted(set(joints) - set(values) - set(model.mimic_joint_names))
    if unknown:
        raise BenchmarkConfigError(f"query '{request.name}': start state names joints {unknown} that robot "
                                   f"'{model.name}' does not have")
    values.update({k: float(v) for k, v in joints.items() if k in values})
    out: dict[str, Any] = {"joint_names": names, "positions": [values[n] for n in names]}
    if isinstance(query_state, Mapping) and query_state.get("attached_collision_objects"):
        out["attached_collision_objects"] = query_state["attached_collision_objects"]
    return out


def _plan_params(options: BenchmarkOptions, request: BenchmarkRequest, model: RobotModel, pipeline: str,
                 planner_id: str, seed: int) -> dict[str, Any]:
    """The query as run: MoveIt overrides its group, time and attempts with the options'."""
    params = {k: v for k, v in request.request.items() if k != "display"}
    params.update(group=options.group, pipeline_id=pipeline, planner_id=planner_id,
                  allowed_planning_time=options.timeout, num_planning_attempts=1, seed=seed,
                  start_state=_start_state(model, request), display=False)
    return params


def run_seed(base_seed: int, runs: int, query_index: int, run_index: int) -> int:
    """The seed of a run: equal across planners, distinct across runs and queries."""
    return (base_seed + 1 + run_index + runs * query_index) % (2**31 - 1) or 1


def make_tasks(options: BenchmarkOptions, requests: Sequence[BenchmarkRequest], model: RobotModel,
               base_seed: int) -> list[RunTask]:
    """Every run of the benchmark, query by query, planner by planner, run by run."""
    tasks = []
    for qi, request in enumerate(requests):
        planners = [(p.pipeline, planner) for p in options.pipelines for planner in p.planners]
        for pi, (pipeline, planner) in enumerate(planners):
            for run in range(options.runs):
                seed = run_seed(base_seed, options.runs, qi, run)
                tasks.append(RunTask(qi, pi, run, request.scene,
                                     _plan_params(options, request, model, pipeline, planner, seed)))
    return tasks


# ------------------------------------------------------------------------------------------ a run
def run_task(task: RunTask) -> RunResult:
    """Plan one run and measure it (MoveIt's runBenchmark body and collectMetrics). Never raises
    for a planning failure: an unsolved run is a result too."""
    face = benchmark_context()
    started_at = time.time()
    _use_scene(face, task.scene)
    started = time.perf_counter()
    response, scene, message = None, None, ""
    try:
        request, start, frame, path = face.plan_request(dict(task.request))
        scene = plan.complete_request(face, request, start, frame, path)
        response = face.plan_in_context(scene, request)
    except RequestError as exc:
        message = exc.message
    except Exception as exc:  # a planner promises not to raise; count it as unsolved, say why
        message = f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}"
    total = time.perf_counter() - started
    solved = bool(response is not None and response.success and response.trajectory is not None)
    if response is not None and not solved:
        message = str(response.error_code)
    properties = {"time REAL": _real(total), "solved BOOLEAN": _boolean(solved)}
    positions: list[list[float]] = []
    if solved and scene is not None:
        trajectory = response.trajectory
        positions = np.asarray(trajectory.positions, dtype=float).tolist()
        properties.update(_path_metrics(scene, trajectory.joint_names, positions, response.planning_time, total))
    return RunResult(task.query_index, task.planner_index, task.run_index, solved, properties, started_at,
                     positions, message, os.getpid())


def _path_metrics(scene: PlanningScene, joint_names: Sequence[str], positions: list[list[float]],
                  planning_time: float, total: float) -> dict[str, str]:
    """collectMetrics for one path: correct (no waypoint in collision or out of bounds), length,
    clearance (mean of each waypoint's positive distance to the world), smoothness, time."""
    state = scene.current_state.copy()
    correct = True
    clearance = 0.0
    has_world = bool(scene.world_objects())
    for row in positions:
        state.set_joint_positions(dict(zip(joint_names, row)))
        if scene.check_collision(state).collision or not state.satisfies_bounds(1e-9):
            correct = False
        if has_world:
            distance = scene.distance(state, include_self=False, include_world=True).min_distance
            if distance > 0.0 and math.isfinite(distance):
                clearance += distance
    clearance = clearance / len(positions) if has_world and positions else math.inf  # no obstacle to be near
    figures = {"correct BOOLEAN": _boolean(correct), "length REAL": _real(path_length(positions)),
               "clearance REAL": _real(clearance), "smoothness REAL": _real(smoothness(positions)),
               "time REAL": _real(planning_time)}
    out = {f"path_{PATH_DESCRIPTION}_{k}": v for k, v in figures.items()}
    out.update({f"final_path_{k}": v for k, v in figures.items()})
    out["process_time REAL"] = _real(max(0.0, total - planning_time))
    return out


def _distance(a: Sequence[float], b: Sequence[float]) -> float:
    """MoveIt's RobotState::distance: the sum of the joints' distances."""
    return float(np.sum(np.abs(np.asarray(a, dtype=float) - np.asarray(b, dtype=float))))


def path_length(positions: Sequence[Sequence[float]]) -> float:
    """robot_trajectory::pathLength: the sum of the distances between consecutive waypoints."""
    return sum(_distance(positions[i - 1], positions[i]) for i in range(1, len(positions)))


def smoothness(positions: Sequence[Sequence[float]]) -> float:
    """robot_trajectory::smoothness: the mean squared doubled outside angle at each waypoint
    (0 for paths of fewer than three waypoints, as MoveIt writes then)."""
    if len(positions) < 3:
        return 0.0
    total = 0.0
    a = _distance(positions[0], positions[1])
    for k in range(2, len(positions)):
        b = _distance(positions[k - 1], positions[k])
        c = _distance(positions[k - 2], positions[k])
        if a > 0.0 and b > 0.0:
            cosine = (a * a + b * b - c * c) / (2.0 * a * b)
            if -1.0 < cosine < 1.0:
                u = 2.0 * (math.pi - math.acos(cosine))
                total += u * u
        a = b
    return total / len(positions)


def _trajectory_distance(first: Sequence[Sequence[float]], second: Sequence[Sequence[float]]) -> float:
    """computeTrajectoryDistance: walk both waypoint lists, each step advancing whichever side
    (or both) gives the nearer next pair; the mean pair distance."""
    i = j = 0
    last_i, last_j = len(first) - 1, len(second) - 1
    current = _distance(first[0], second[0])
    total, steps = 0.0, 0
    while True:
        total += current
        steps += 1
        if i == last_i and j == last_j:
            break
        up_i, up_j = i < last_i, j < last_j
        both = _distance(first[i + 1], second[j + 1]) if up_i and up_j else math.inf
        only_i = _distance(first[i + 1], second[j]) if up_i else math.inf
        only_j = _distance(first[i], second[j + 1]) if up_j else math.inf
        if up_i and up_j and both < only_i and both < only_j:
            i, j, current = i + 1, j + 1, both
        elif (up_i and only_i < only_j) or not up_j:
            i, current = i + 1, only_i
        else:
            j, current = j + 1, only_j
    return total / steps


def average_waypoint_distances(runs: Sequence[RunResult]) -> list[float]:
    """computeAveragePathSimilarities: per solved run, the mean trajectory distance to the other
    solved runs of the planner (inf for an unsolved run, nan when no other run solved)."""
    solved = [r.solved and len(r.positions) > 0 for r in runs]
    count = sum(solved)
    out = [0.0 if s else math.inf for s in solved]
    for a in range(len(runs)):
        if not solved[a]:
            continue
        for b in range(a + 1, len(runs)):
            if solved[b]:
                d = _trajectory_distance(runs[a].positions, runs[b].positions)
                out[a] += d
                out[b] += d
    return [v / (count - 1) if s and count > 1 else (math.nan if s else v) for v, s in zip(out, solved)]


def _real(value: float) -> str:
    value = float(value)
    if math.isnan(value):
        return "nan"
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return repr(value)


def _boolean(value: bool) -> str:
    """OMPL's writing of a boolean (std::to_string: 1 or 0): what the database averages."""
    return "1" if value else "0"


def failure_summary(results: Sequence[RunResult]) -> dict[str, int]:
    """How many runs failed with each error code (the message's head), for the runner's summary."""
    counts: dict[str, int] = {}
    for result in results:
        if not result.solved:
            key = (result.message or str(MoveItErrorCode(MoveItErrorCode.FAILURE))).split(":")[0].strip()
            counts[key] = counts.get(key, 0) + 1
    return counts
