"""The JSON-lines protocol the planner peers' runners speak (mplib_runner.py,
pyroboplan_runner.py, roboplan_runner.py), written once so the three report alike.

The runners run in a peer venv's Python that has no mycobot_planning; Python puts a script's
folder first on ``sys.path``, so they import this sibling module by its plain name. It therefore
imports only the standard library and numpy (which every peer venv has).

The full story: docs/bench.md, section mycobot_planning.bench.peers.runner_protocol.
"""
from __future__ import annotations

import importlib.metadata as metadata
import json
import os
import sys
import time
from typing import Any, Callable, Iterable, Optional, Sequence, TextIO

import numpy as np

#: What counts as reaching a pose goal (as mycobot_planning.bench.peers judges it).
GOAL_POSITION_TOLERANCE = 1e-2  # m
GOAL_ROTATION_TOLERANCE = 2e-2  # rad
#: The fields of a part's record when its solve call raised (the error becomes its status).
IK_FAILED = {"seconds": None, "solution": None}
PLAN_FAILED = {"seconds": None, "status": None, "path": None}

PoseSolve = Callable[[dict], "tuple[float, str, Optional[Any]]"]
GoalErrors = Callable[[dict, np.ndarray], "tuple[float, float]"]


def json_out() -> TextIO:
    """A writer on the original stdout; fd 1 (and sys.stdout) then go to stderr, so what the
    peer library prints (mplib's OMPL messages, pyroboplan's progress) cannot break the JSON."""
    sys.stdout.flush()
    out = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    return out


def read_request() -> dict:
    """The request: the JSON file named by the first argument, or stdin (no argument or ``-``)."""
    if len(sys.argv) > 1 and sys.argv[1] != "-":
        with open(sys.argv[1]) as handle:
            return json.load(handle)
    return json.load(sys.stdin)


def serve(pose_problems: Callable[[TextIO, dict], int], parts: Callable[[TextIO, dict], int]) -> int:
    """A runner's main: read the request, then answer it with ``parts(out, request)`` when it
    holds "parts", else with ``pose_problems(out, request)``; their exit code is the runner's."""
    out = json_out()
    request = read_request()
    return parts(out, request) if "parts" in request else pose_problems(out, request)


def peer_version(distribution: str) -> str:
    """The installed version of ``distribution``, "unknown" from a source tree without metadata."""
    try:
        return metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return "unknown"


def write_record(out: TextIO, record: dict) -> None:
    out.write(json.dumps(record) + "\n")


def write_meta(out: TextIO, peer: str, setup_seconds: float) -> None:
    """The first line: which peer (its distribution is named as the peer) and its set-up time."""
    write_record(out, {"meta": True, "peer": peer, "version": peer_version(peer),
                       "setup_seconds": round(setup_seconds, 4)})


def error_status(error: Exception) -> str:
    return f"error: {type(error).__name__}: {error}"


def run_pose_problems(out: TextIO, peer: str, setup_seconds: float, problems: Sequence[dict],
                      solve: PoseSolve, goal_errors: Optional[GoalErrors] = None) -> int:
    """The pose-goal problems after the runner's set-up: an untimed warm-up on the first problem,
    the meta line, then one line per problem.

    ``solve(problem)`` gives ``(seconds, status, path)``, ``path`` (arm waypoints) None when the
    peer claims no success. ``goal_errors(problem, path)`` gives the position and rotation error
    of the path's last state; without it ``success`` stays False (the parent judges the path).
    """
    if problems:
        solve(problems[0])  # warm-up, untimed
    write_meta(out, peer, setup_seconds)
    for problem in problems:
        record: dict[str, Any] = {"index": problem["index"], "success": False, "claimed_success": False}
        try:
            seconds, status, path = solve(problem)
            record.update(seconds=seconds, status=status, claimed_success=path is not None)
            if path is not None:
                arr = np.asarray(path, dtype=float)
                record["waypoints"] = int(len(arr))
                record["path_length"] = float(np.sum(np.linalg.norm(np.diff(arr, axis=0), axis=1)))
                record["path"] = [[float(v) for v in q] for q in arr]
                if goal_errors is not None:
                    position_error, rotation_error = goal_errors(problem, arr)
                    record["goal_position_error"] = float(position_error)
                    record["goal_rotation_error"] = float(rotation_error)
                    record["success"] = (record["goal_position_error"] < GOAL_POSITION_TOLERANCE
                                         and record["goal_rotation_error"] < GOAL_ROTATION_TOLERANCE)
        except Exception as error:  # one bad problem must not lose the others' results
            record.setdefault("seconds", None)
            record["status"] = error_status(error)
        write_record(out, record)
    return 0


def time_checks(states: Iterable[Any], colliding: Callable[[Any], Any]) -> tuple[list[float], list[bool]]:
    """Wall time of each ``colliding(state)`` call alone, and its verdicts."""
    clock = time.perf_counter
    seconds, verdicts = [], []
    for q in states:
        t0 = clock()
        hit = colliding(q)
        seconds.append(clock() - t0)
        verdicts.append(bool(hit))
    return seconds, verdicts


def write_part_records(out: TextIO, part: str, problems: Iterable[dict], solve: Callable[[dict], dict],
                       failed: dict) -> None:
    """One ``{"part", "index", ...}`` line per problem with ``solve(problem)``'s fields; when it
    raises, ``failed``'s fields and the error as the status."""
    for problem in problems:
        record = {"part": part, "index": problem["index"]}
        try:
            record.update(solve(problem))
        except Exception as error:  # one bad problem must not lose the others' results
            record.update(failed, status=error_status(error))
        write_record(out, record)


def run_parts(out: TextIO, peer: str, setup_seconds: float, parts: dict, solve_ik: Callable[[dict], dict],
              state: Callable[[Any], Any], colliding: Callable[[Any], Any], plan: Callable[[dict], dict]) -> int:
    """The three parts after the runner's set-up: untimed warm-ups (first IK, first plan), the
    meta line, one line per IK problem, one line with every check, one line per plan.

    ``solve_ik(problem)`` gives ``{"seconds", "solution"}``; ``state(q)`` turns a check's arm
    values into what ``colliding`` takes; ``plan(problem)`` gives ``{"seconds", ..., "status",
    "path"}``.
    """
    if parts["ik"]:
        solve_ik(parts["ik"][0])  # warm-up, untimed
    if parts["plan"]:
        plan(parts["plan"][0])
    write_meta(out, peer, setup_seconds)
    write_part_records(out, "ik", parts["ik"], solve_ik, IK_FAILED)
    seconds, verdicts = time_checks([state(q) for q in parts["check"]], colliding)
    write_record(out, {"part": "check", "seconds": seconds, "colliding": verdicts})
    write_part_records(out, "plan", parts["plan"], plan, PLAN_FAILED)
    return 0
