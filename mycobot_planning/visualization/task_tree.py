"""The stage tree of a published task, as RViz's Motion Planning Tasks panel shows it.

A task node publishes three JSON streams (see ``mycobot_planning.ros.task.task_topics``): the
stage tree (``TaskDescription``), per-stage counts and times (``TaskStatistics``) and complete
solutions (``TaskSolution``). ``TaskTree`` merges them into rows — stage name indented by depth,
✓/✗, number of solutions and failures, compute time, best cost, comment — and tells, for any
stage, which parts of the published solutions it made (``solutions_of``), so selecting a stage's
solution can show exactly its steps.

Which steps belong to a stage: every sub-trajectory names the stage that created it
(``info.stage_id``). A stage's part of a complete solution is the steps created by the stage
or any stage below it: one step for a primitive stage, a contiguous run for a container, the
whole solution for the task's root.
"""
from __future__ import annotations

import html
import math
from dataclasses import dataclass, field

from interfaces_py.msgs import StageDescription, TaskDescription, TaskSolution, TaskStatistics

__all__ = ["StageRow", "SolutionEntry", "TaskTree", "TaskRegistry"]

MAX_SOLUTIONS = 32  # complete solutions remembered per task (the cheapest are kept)

CHECK = "✓"
CROSS = "✗"
PENDING = "·"


@dataclass
class StageRow:
    """One stage with its statistics (zeros until statistics arrive)."""

    id: int
    parent_id: int
    name: str
    type: str
    flags: int
    depth: int
    path: str
    solved: list[int] = field(default_factory=list)
    costs: list[float] = field(default_factory=list)
    failed: list[int] = field(default_factory=list)
    num_failed: int = 0
    time_s: float = 0.0
    comment: str = ""

    @property
    def num_solved(self) -> int:
        return len(self.solved)

    @property
    def status(self) -> str:
        """✓ when the stage has solutions, ✗ when it has none but failures, · before either."""
        if self.solved:
            return CHECK
        return CROSS if self.num_failed else PENDING

    @property
    def best_cost(self) -> float | None:
        finite = [c for c in self.costs if math.isfinite(c)]
        return min(finite) if finite else None

    def to_dict(self) -> dict:
        return {"id": self.id, "parent_id": self.parent_id, "name": self.name, "type": self.type, "depth": self.depth,
                "path": self.path, "status": self.status, "solutions": self.num_solved, "failures": self.num_failed,
                "time_s": round(self.time_s, 6), "cost": self.best_cost, "comment": self.comment}


@dataclass(frozen=True)
class SolutionEntry:
    """A stage's part of one published complete solution: which steps, their cost and comment."""

    stage_id: int
    solution_index: int  # index into TaskTree.solutions
    steps: tuple[int, ...]  # sub_trajectory indices, in execution order
    cost: float
    comment: str
    solution_id: int | None  # the stage's own solution id when the part is a single step

    @property
    def label(self) -> str:
        ident = f"#{self.solution_id}" if self.solution_id is not None else f"solution {self.solution_index + 1}"
        text = f"{ident}  cost {self.cost:.4g}"
        return f"{text}  {self.comment}" if self.comment else text


class TaskTree:
    """Description + statistics + solutions of one task of one node."""

    def __init__(self, source: str, task_id: str) -> None:
        self.source = source
        self.task_id = task_id
        self.description: TaskDescription | None = None
        self.statistics: TaskStatistics | None = None
        self.solutions: list[TaskSolution] = []
        self.version = 0  # bumped on every change, so a view redraws only when needed

    @property
    def key(self) -> str:
        return f"{self.source}: {self.task_id}" if self.task_id else self.source

    # ------------------------------------------------------------------ updates
    def set_description(self, msg: TaskDescription) -> None:
        if self.description is not None and _structure(self.description) != _structure(msg):
            self.solutions = []  # a different tree: old solutions refer to stages that no longer exist
            self.statistics = None
        self.description = msg
        self.version += 1

    def set_statistics(self, msg: TaskStatistics) -> None:
        self.statistics = msg
        self.version += 1

    def add_solution(self, msg: TaskSolution) -> bool:
        """Remember a complete solution (duplicates ignored, the cheapest MAX_SOLUTIONS kept);
        True when it was new."""
        key = _solution_key(msg)
        if any(_solution_key(s) == key for s in self.solutions):
            return False
        self.solutions.append(msg)
        self.solutions.sort(key=lambda s: s.cost)
        del self.solutions[MAX_SOLUTIONS:]
        self.version += 1
        return msg in self.solutions

    # ------------------------------------------------------------------ queries
    def rows(self) -> list[StageRow]:
        """The stages in tree order (parents before children, children in order)."""
        if self.description is None:
            return []
        stages = self.description.stages
        by_id: dict[int, StageDescription] = {s.id: s for s in stages}
        depth: dict[int, int] = {}
        path: dict[int, str] = {}
        for s in stages:
            parent = by_id.get(s.parent_id)
            depth[s.id] = depth[s.parent_id] + 1 if parent is not None else 0
            path[s.id] = s.name if parent is None or depth[s.id] == 1 else f"{path[s.parent_id]}/{s.name}"
        children: dict[int, list[int]] = {}
        roots = []
        for s in stages:
            (children.setdefault(s.parent_id, []) if s.parent_id in by_id else roots).append(s.id)
        order: list[int] = []

        def walk(stage_id: int) -> None:
            order.append(stage_id)
            for child in children.get(stage_id, []):
                walk(child)

        for root in roots:
            walk(root)
        stats = {s.id: s for s in self.statistics.stages} if self.statistics is not None else {}
        rows = []
        for stage_id in order:
            s = by_id[stage_id]
            row = StageRow(id=s.id, parent_id=s.parent_id, name=s.name, type=s.type, flags=s.flags,
                           depth=depth[s.id], path=path[s.id] if depth[s.id] else "")
            st = stats.get(s.id)
            if st is not None:
                row.solved, row.costs, row.failed = list(st.solved), list(st.cost), list(st.failed)
                row.num_failed, row.time_s = st.num_failed, st.total_compute_time
            entries = self.solutions_of(s.id)
            if entries:
                row.comment = entries[0].comment
            rows.append(row)
        return rows

    def descendants(self, stage_id: int) -> set[int]:
        """The stage and every stage below it."""
        if self.description is None:
            return {stage_id}
        out = {stage_id}
        for s in self.description.stages:  # parents come before children
            if s.parent_id in out:
                out.add(s.id)
        return out

    def solutions_of(self, stage_id: int) -> list[SolutionEntry]:
        """The stage's parts of the published solutions, cheapest first."""
        is_root = self.description is not None and any(
            s.id == stage_id and s.parent_id == 0 for s in self.description.stages)
        ids = self.descendants(stage_id)
        entries = []
        for index, solution in enumerate(self.solutions):
            if is_root:
                steps = tuple(range(len(solution.sub_trajectory)))
                cost, comment = solution.cost, solution.comment
            else:
                steps = tuple(k for k, sub in enumerate(solution.sub_trajectory) if sub.info.stage_id in ids)
                if not steps:
                    continue
                subs = [solution.sub_trajectory[k] for k in steps]
                cost = float(sum(sub.info.cost for sub in subs))
                comment = "; ".join(sub.info.comment for sub in subs if sub.info.comment)
            own = [solution.sub_trajectory[k].info.id for k in steps
                   if solution.sub_trajectory[k].info.stage_id == stage_id]
            solution_id = own[0] if len(steps) == 1 and own else None
            entries.append(SolutionEntry(stage_id, index, steps, cost, comment, solution_id))
        entries.sort(key=lambda e: e.cost)
        return entries

    def to_dict(self) -> dict:
        return {"key": self.key, "source": self.source, "task_id": self.task_id,
                "stages": [r.to_dict() for r in self.rows()], "solutions": len(self.solutions)}

    def html_table(self, selected_stage: int | None = None) -> str:
        """The tree as an HTML table for the viewer's side panel."""
        rows = self.rows()
        if not rows:
            return "<p><i>waiting for the task description…</i></p>"
        out = ['<table class="mp-task-tree" style="width:100%;border-collapse:collapse;font-size:0.8em">',
               '<tr style="text-align:right;color:#777"><th style="text-align:left">stage</th><th></th>'
               '<th title="solutions">sol</th><th title="failures">fail</th><th>time&nbsp;s</th><th>cost</th></tr>']
        for row in rows:
            colour = {CHECK: "#2b8a3e", CROSS: "#c92a2a"}.get(row.status, "#999")
            cost = "" if row.best_cost is None else f"{row.best_cost:.3g}"
            style = "background:#e7f5ff;" if row.id == selected_stage else ""
            title = html.escape(f"{row.type} #{row.id}" + (f": {row.comment}" if row.comment else ""), quote=True)
            out.append(
                f'<tr style="{style}border-top:1px solid #eee" data-stage-id="{row.id}" title="{title}">'
                f'<td style="padding-left:{0.2 + 0.9 * row.depth:.1f}em;text-align:left">{html.escape(row.name)}</td>'
                f'<td style="color:{colour};text-align:center">{row.status}</td>'
                f'<td style="text-align:right">{row.num_solved}</td>'
                f'<td style="text-align:right">{row.num_failed}</td>'
                f'<td style="text-align:right">{row.time_s:.3f}</td>'
                f'<td style="text-align:right">{cost}</td></tr>')
            if row.comment:
                out.append(f'<tr><td colspan="6" style="padding-left:{1.1 + 0.9 * row.depth:.1f}em;color:#777;'
                           f'font-style:italic">{html.escape(row.comment)}</td></tr>')
        out.append("</table>")
        return "".join(out)


class TaskRegistry:
    """Every task seen, keyed by (publishing node's prefix, task_id)."""

    def __init__(self) -> None:
        self.tasks: dict[tuple[str, str], TaskTree] = {}
        self.version = 0

    def _tree(self, source: str, task_id: str) -> TaskTree:
        key = (source, task_id)
        tree = self.tasks.get(key)
        if tree is None:
            tree = self.tasks[key] = TaskTree(source, task_id)
        return tree

    def on_description(self, source: str, msg: TaskDescription) -> TaskTree:
        tree = self._tree(source, msg.task_id)
        tree.set_description(msg)
        self.version += 1
        return tree

    def on_statistics(self, source: str, msg: TaskStatistics) -> TaskTree:
        tree = self._tree(source, msg.task_id)
        tree.set_statistics(msg)
        self.version += 1
        return tree

    def on_solution(self, source: str, msg: TaskSolution) -> TaskTree:
        tree = self._tree(source, msg.task_id)
        if tree.add_solution(msg):
            self.version += 1
        return tree

    def get(self, key: str) -> TaskTree | None:
        return next((t for t in self.tasks.values() if t.key == key), None)

    def keys(self) -> list[str]:
        return sorted(t.key for t in self.tasks.values())


def _structure(msg: TaskDescription) -> list[tuple]:
    return [(s.id, s.parent_id, s.name, s.type) for s in msg.stages]


def _solution_key(msg: TaskSolution) -> tuple:
    return (msg.task_id, round(msg.cost, 12), tuple((s.info.id, s.info.stage_id) for s in msg.sub_trajectory))
