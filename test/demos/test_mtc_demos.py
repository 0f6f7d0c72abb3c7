"""The seeds' task demos: outcomes, tree shapes and printState counts, costs, validity, and the
task benchmarks."""
from __future__ import annotations

import io
import json
import math
from contextlib import redirect_stdout

import numpy as np
import pytest

from mycobot_planning.bench import task_scenarios
from mycobot_planning.core import PlanningScene
from mycobot_planning.demos.mtc_demos import (
    build_fallbacks_move_to_task,
    build_ik_clearance_cost_task,
    build_modular_task,
    ik_clearance_cost_scene,
    load_ik_clearance_cost_parameters,
)
from file_checks import assert_file_refused
from task_helpers import assert_solution_valid, chain_is_continuous

MODULE = [
    "    -  1 →   1 →   -  1 / Cartesian Path",
    "      -  0 →   1 →   -  0 / x +0.05",
    "      -  0 →   1 →   -  0 / y -0.02",
    "      -  0 →   1 →   -  0 / rz -18°",
    "      -  0 →   1 →   -  1 / moveTo ready",
]


def test_modular(mycobot):
    task = build_modular_task(mycobot, PlanningScene(mycobot))
    assert task.plan()
    assert task.numSolutions() == 1
    lines = task.printState(stream=None).splitlines()
    assert lines[:3] == [
        "  1  - ←   1 →   -  1 / Reusable Containers",
        "    1  - ←   1 →   -  0 / current",
        "    -  0 →   1 →   -  1 / move to ready",
    ]
    assert lines[3:23] == MODULE * 4
    assert lines[23:28] == [MODULE[0].replace("-  1 / Cartesian", "-  0 / Cartesian")] + MODULE[1:]
    assert lines[28:] == ["    -  0 →   1 →   -  1 / move to home"]
    summary = {row["path"]: row for row in task.stage_summary()}
    for name in ("current", "move to ready", "move to home"):
        assert (summary[name]["solutions"], summary[name]["failures"]) == (1, 0)
    solution = task.solutions[0]
    steps = solution.sub_trajectories()
    assert [s.creator.name for s in steps[:6]] == ["current", "move to ready", "x +0.05", "y -0.02", "rz -18°", "moveTo ready"]
    assert len(steps) == 23
    assert assert_solution_valid(solution) == 22
    chain_is_continuous(solution)
    assert np.allclose(solution.end.scene.current_state.group_positions("arm"), 0.0)
    # each module returns to 'ready' and moves the flange the same way
    first = steps[2].end.scene.current_state.frame_pose("link6_flange")
    start = steps[2].start.scene.current_state.frame_pose("link6_flange")
    assert np.allclose(first[:3, 3] - start[:3, 3], [0.05, 0.0, 0.0], atol=1e-5)


def test_modular_without_plan_reuse_gives_the_same_solution(mycobot):
    task = build_modular_task(mycobot, PlanningScene(mycobot))
    task.reuse_plans = False
    assert task.plan()
    reused = build_modular_task(mycobot, PlanningScene(mycobot))
    assert reused.plan()
    a = [s.trajectory.positions for s in task.solutions[0].sub_trajectories() if s.trajectory is not None]
    b = [s.trajectory.positions for s in reused.solutions[0].sub_trajectories() if s.trajectory is not None]
    assert len(a) == len(b) and all(np.allclose(x, y) for x, y in zip(a, b))
    assert task.solutions[0].cost == pytest.approx(reused.solutions[0].cost)


def test_fallbacks_move_to(mycobot):
    task = build_fallbacks_move_to_task(mycobot, PlanningScene(mycobot), seed=0)
    assert task.plan()
    assert task.numSolutions() == 3
    assert task.printState(stream=None).splitlines() == [
        "  3  - ←   3 →   -  3 / fallback strategies in MoveTo",
        "    3  - ←   3 →   -  0 / initial states",
        "      3  - ←   1 →   -  3 / 90 degree offset from target goal",
        "      3  - ←   1 →   -  3 / directly reachable without collision",
        "      3  - ←   1 →   -  3 / getting to target requires collision avoidance",
        "    -  0 →   3 →   -  3 / move to other side",
        "      -  0 →   0 →   -  3 / Cartesian path",
        "      -  0 →   2 →   -  3 / Pilz path",
        "      -  0 →   1 →   -  3 / OMPL path",
    ]
    cartesian, pilz, ompl = (task[f"move to other side/{n}"] for n in ("Cartesian path", "Pilz path", "OMPL path"))
    assert (len(cartesian.solutions), cartesian.numFailures()) == (0, 3)
    assert (len(pilz.solutions), pilz.numFailures()) == (2, 1)
    assert (len(ompl.solutions), ompl.numFailures()) == (1, 0)
    assert "Invalid states at index locations: [" in pilz.failures[0].comment
    assert "contact between 'box' (Object)" in pilz.failures[0].comment
    # which initial state each planner solved
    pairs = {(s.sub_trajectories()[1].creator.name, s.sub_trajectories()[0].creator.name) for s in task.solutions}
    assert pairs == {("Pilz path", "90 degree offset from target goal"),
                     ("Pilz path", "directly reachable without collision"),
                     ("OMPL path", "getting to target requires collision avoidance")}
    costs = [s.cost for s in task.solutions]
    assert costs == sorted(costs)
    target = dict(mycobot.named_state("ready", "arm"), link1_to_link2=math.tau / 8)
    for solution in task.solutions:
        assert_solution_valid(solution)
        end = solution.end.scene.current_state
        assert np.allclose([end.joint_position(j) for j in target], list(target.values()), atol=1e-4)
    assert task.explainFailure(stream=None).startswith("Failing stage(s):\n")


def test_fallbacks_move_to_is_reproducible(mycobot):
    def ompl_path(seed):
        task = build_fallbacks_move_to_task(mycobot, PlanningScene(mycobot), seed=seed)
        assert task.plan()
        solution = next(s for s in task.solutions if s.sub_trajectories()[1].creator.name == "OMPL path")
        return solution.sub_trajectories()[1].trajectory.positions

    assert np.array_equal(ompl_path(7), ompl_path(7))


def test_ik_clearance_cost(mycobot):
    task = build_ik_clearance_cost_task(mycobot, ik_clearance_cost_scene(mycobot), cumulative=False, with_world=True)
    assert task.plan(0)
    assert task.printState(stream=None).splitlines() == [
        "  2  - ←   2 →   -  2 / clearance IK",
        "    2  - ←   2 →   -  2 / IK",
        "      1  - ←   1 →   -  1 / initial state",
    ]
    ik = task["IK"]
    costs = [s.cost for s in task.solutions]
    assert costs == sorted(costs)
    for solution in ik.solutions:
        assert solution.comment.startswith("Clearance: distance 0.0150")
        assert solution.comment.endswith("between 'obstacle' and 'gripper_left1'")
        assert solution.cost == pytest.approx(66.53, abs=0.05)  # the seed's 66.5330
    for failure in ik.failures:
        assert failure.comment.startswith("Collision between '")
    positions = [s.end.scene.current_state.group_positions("arm") for s in ik.solutions]
    assert np.sum(np.abs(positions[0] - positions[1])) >= 0.1


def test_ik_clearance_cost_variants(mycobot):
    cumulative = build_ik_clearance_cost_task(mycobot, cumulative=True, with_world=True)
    assert cumulative.plan()
    assert cumulative["IK"].solutions[0].comment.startswith("Clearance: cumulative distance ")
    self_only = build_ik_clearance_cost_task(mycobot, cumulative=False, with_world=False)
    assert self_only.plan()
    comment = self_only["IK"].solutions[0].comment
    assert "obstacle" not in comment and comment.startswith("Clearance: distance ")
    assert self_only.solutions[0].cost != pytest.approx(66.53, abs=0.05)


def test_ik_clearance_cost_parameters_file(tmp_path):
    assert load_ik_clearance_cost_parameters() == {"cumulative": False, "with_world": True}
    custom = tmp_path / "p.yaml"
    custom.write_text("ik_clearance_cost_demo:\n  ros__parameters:\n    cumulative: true\n")
    assert load_ik_clearance_cost_parameters(custom) == {"cumulative": True, "with_world": True}
    for text, match in (("cumulativ: true", "unknown parameter 'cumulativ'"),
                        ("with_world: 'yes'", "'with_world' must be true or false")):
        assert_file_refused(load_ik_clearance_cost_parameters, ValueError, custom,
                            f"ik_clearance_cost_demo:\n  ros__parameters:\n    {text}\n", match)


@pytest.mark.parametrize("bench,solutions", [
    (task_scenarios.bench_modular, 1),
    (task_scenarios.bench_fallbacks_move_to, 3),
    (task_scenarios.bench_ik_clearance_cost, 2),
])
def test_task_benchmarks_report_total_time_and_solutions(monkeypatch, bench, solutions):
    monkeypatch.setattr(task_scenarios, "RUNS", 2)
    out = io.StringIO()
    with redirect_stdout(out):
        bench(repeat=1, seed=0)
    records = [json.loads(line) for line in out.getvalue().splitlines()]
    summary = records[-1]
    assert summary["summary"] is True
    assert summary["total_s"] > 0
    assert summary["solutions"] == solutions
