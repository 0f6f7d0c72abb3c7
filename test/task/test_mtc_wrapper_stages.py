"""MTC's wrapper stages PassThrough and LimitSolutions, as the bindings export them."""
from __future__ import annotations

import pytest

from mycobot_planning.task import core, stages
from task_helpers import scene_at


def _alternatives(model, costs):
    """A generator of len(costs) solutions (fixed states) with the given costs."""
    alternatives = core.Alternatives("choices")
    for k, cost in enumerate(costs):
        fixed = stages.FixedState(f"state {k}", scene_at(model, "ready"))
        fixed.setCostTerm(core.Constant(cost))
        alternatives.add(fixed)
    return alternatives


def test_limit_solutions_passes_on_at_most_max_solutions_cheapest_first(mycobot):
    task = core.Task("limit", mycobot, scene_at(mycobot, "ready"))
    limit = stages.LimitSolutions("limit", _alternatives(mycobot, [3.0, 1.0, 2.0, 4.0]))
    limit.properties["max_solutions"] = 2
    task.add(limit)
    assert task.plan()
    assert len(task.solutions) == 2
    assert all(s.cost in (1.0, 2.0, 3.0, 4.0) for s in task.solutions)


def test_limit_solutions_needs_max_solutions(mycobot):
    task = core.Task("limit", mycobot, scene_at(mycobot, "ready"))
    task.add(stages.LimitSolutions("limit", _alternatives(mycobot, [1.0])))
    with pytest.raises(Exception, match="max_solutions"):
        task.init()


def test_pass_through_passes_every_solution_on(mycobot):
    task = core.Task("pass", mycobot, scene_at(mycobot, "ready"))
    task.add(stages.PassThrough("pass", _alternatives(mycobot, [2.0, 1.0])))
    assert task.plan()
    assert sorted(s.cost for s in task.solutions) == [1.0, 2.0]
