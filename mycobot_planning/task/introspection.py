"""Introspection: printState, explainFailure, a stage summary, and the task description and
statistics messages.

printState, in MTC's notation, one line per stage, indented two spaces per level::

      1  - ←   1 →   -  1 / Reusable Containers
      1  - ←   1 →   -  0 / current
      -  0 →   1 →   -  1 / move to ready

Columns: the number of states in the stage's *previous stage's end* interface it writes to
(``-`` if it writes nothing backward) and in its own *start* interface (``-`` if it reads
nothing from the start side); the start-side arrow; the number of solutions; the end-side
arrow; the number of states in its own *end* interface and in the *next stage's start*
interface it writes to. Arrows: ``→`` reads its start / writes the next start (forward flow),
``←`` writes the previous end / reads its end (backward flow), ``↔`` both, ``?`` unresolved.
So a generator shows ``← →``, a forward propagator ``→ →``, a backward one ``← ←`` and a
connector ``→ ←``.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from interfaces_py.msgs import StageDescription, StageStatistics, TaskDescription, TaskStatistics

from .stage import Stage
from .storage import flow_symbol_end, flow_symbol_start, interface_text

if TYPE_CHECKING:  # pragma: no cover
    from .task import Task

__all__ = ["explain_failure", "print_state", "stage_line", "stage_summary", "task_description", "task_statistics"]


def _count(interface) -> str:
    return f"{len(interface):>3}" if interface is not None else "  -"


def stage_line(stage: Stage) -> str:
    """One printState line for a stage (without indentation)."""
    flags = stage._interface_flags() | stage._required_interface()
    return (f"{_count(stage._prev_ends)}{_count(stage._starts)} {flow_symbol_start(flags)} "
            f"{len(stage._solutions):>3} {flow_symbol_end(flags)} {_count(stage._ends)}{_count(stage._next_starts)}"
            f" / {stage.name}")


def print_state(task: "Task") -> str:
    lines = [" " * (2 * depth) + stage_line(stage) for stage, depth in task.stages.traverseRecursively()]
    return "\n".join(lines) + "\n"


def explain_failure(task: "Task") -> str:
    body = task.stages._explain_failure()
    return "Failing stage(s):\n" + (body + "\n" if body else "")


def stage_summary(task: "Task") -> list[dict[str, Any]]:
    rows = []
    for stage, depth in task.stages.traverseRecursively():
        flags = stage._interface_flags() | stage._required_interface()
        best = stage._solutions[0].cost if stage._solutions else None
        rows.append({
            "id": stage.id,
            "name": stage.name,
            "path": stage.path,
            "depth": depth,
            "type": type(stage).__name__,
            "interface": interface_text(flags),
            "solutions": len(stage._solutions),
            "failures": stage._num_failures,
            "time_s": stage.total_compute_time,
            "best_cost": best,
            "failure_comment": stage._failures[0].comment if stage._failures else "",
        })
    return rows


def summary_text(task: "Task") -> str:
    """A readable table: stage, solutions, failures, time, best cost (the seeds' 'Stage summary')."""
    lines = []
    for row in stage_summary(task):
        cost = "-" if row["best_cost"] is None else f"{row['best_cost']:.4f}"
        lines.append(f"{'  ' * row['depth']}{row['name']}: {row['solutions']} solutions, {row['failures']} failures, "
                     f"{row['time_s']:.4f} s, best cost {cost}")
    return "\n".join(lines) + "\n"


def task_description(task: "Task") -> TaskDescription:
    stages = []
    for stage, _depth in task.stages.traverseRecursively():
        parent = stage.parent
        flags = stage._interface_flags() | stage._required_interface()
        stages.append(StageDescription(id=stage.id or 1, parent_id=parent.id if parent is not None else 0,
                                       name=stage.name, flags=flags & 0xF, type=type(stage).__name__))
    return TaskDescription(task_id=task.name, stages=stages)


def task_statistics(task: "Task") -> TaskStatistics:
    stages = []
    for stage, _depth in task.stages.traverseRecursively():
        solved = [s.id for s in stage._solutions]
        costs = [s.cost if math.isfinite(s.cost) else 0.0 for s in stage._solutions]
        stages.append(StageStatistics(id=stage.id or 1, solved=solved, failed=[s.id for s in stage._failures],
                                      cost=costs, num_failed=stage._num_failures,
                                      total_compute_time=stage.total_compute_time))
    return TaskStatistics(task_id=task.name, stages=stages)
