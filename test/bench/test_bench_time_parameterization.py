"""The time_parameterization benchmark without its toppra venv: our side of the scenario, the
runner's measures and its JSON contract (run with a stand-in solver in place of toppra)."""
from __future__ import annotations

import ast
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from mycobot_planning.bench import time_parameterization_scenarios as tps
from mycobot_planning.bench.peers import toppra_runner, venvs
from mycobot_planning.core import RobotModel
from mycobot_planning.core.trajectory_processing import time_parameterize

RECORD_KEYS = {"name", "set", "grid", "success", "status", "gridpoints", "compute_ms", "duration_s",
               "max_vel_ratio", "max_acc_ratio", "max_deviation", "samples"}


@pytest.fixture(scope="module")
def model() -> RobotModel:
    return RobotModel.mycobot()


def arc_path(count: int = 120) -> np.ndarray:
    """A dense, gently curved 6-joint path: what the "smooth" method is for."""
    u = np.linspace(0.0, 1.0, count)[:, None]
    return np.hstack([0.6 * np.sin(u), 0.6 * (1.0 - np.cos(u)), 0.3 * u, -0.2 * u, 0.1 * u**2, 0 * u])


class OursAsToppra:
    """Stand-in for toppra's result: our trajectory behind toppra's ``traj(ts, order)`` interface."""

    def __init__(self, pts: np.ndarray, vmax: np.ndarray, amax: np.ndarray) -> None:
        self.traj = time_parameterize(pts, vmax, amax, method="smooth")
        self.duration = self.traj.duration

    def __call__(self, ts: np.ndarray, order: int = 0) -> np.ndarray:
        return self.traj.sample(ts)[order]


def stand_in_solver(pts, vmax, amax, grid, dense_max_step):
    return OursAsToppra(pts, vmax, amax), 42 if grid == "default" else 99


# ---------------------------------------------------------------- runner: measures
def test_polyline_distance_is_the_distance_to_the_nearest_segment():
    waypoints = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    q = np.array([[0.5, 0.2], [1.3, 0.5], [2.0, 2.0], [0.0, 0.0], [-1.0, 0.0]])
    assert np.allclose(toppra_runner.polyline_distance(q, waypoints), [0.2, 0.3, math.sqrt(2.0), 0.0, 1.0])
    many = np.repeat(q, 200, axis=0)  # more samples than one block
    assert np.allclose(toppra_runner.polyline_distance(many, waypoints),
                       np.repeat([0.2, 0.3, math.sqrt(2.0), 0.0, 1.0], 200))


def test_path_helpers():
    pts = toppra_runner.clean_path([[0, 0], [1, 0], [1, 0], [1, 3]])
    assert pts.tolist() == [[0, 0], [1, 0], [1, 3]]
    s = toppra_runner.chord_parameter(pts)
    assert np.allclose(s, [0.0, 0.25, 1.0])
    grid = toppra_runner.dense_gridpoints(s, 0.1)
    assert set(s) <= set(grid) and np.all(np.diff(grid) <= 0.1 + 1e-12) and len(grid) == 1 + 3 + 8
    ts = toppra_runner.sample_times(0.0105, 1e-3)
    assert ts[0] == 0.0 and ts[-1] == 0.0105 and len(ts) == 12


def test_sampled_metrics_reports_limit_ratios():
    q = np.array([[0.0, 0.0], [0.5, 0.1]])
    out = toppra_runner.sampled_metrics(q, np.array([[1.0, -3.0], [0.0, 0.0]]), np.array([[4.0, 0.0], [0.0, -1.0]]),
                                        np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([2.0, 2.0]), np.array([2.0, 2.0]))
    assert out == pytest.approx({"max_vel_ratio": 1.5, "max_acc_ratio": 2.0, "max_deviation": 0.1, "samples": 2})


# ---------------------------------------------------------------- runner: JSON contract
def test_runner_imports_toppra_only_inside_its_solver():
    tree = ast.parse(Path(toppra_runner.__file__).read_text())
    top = set()
    for node in tree.body:
        if isinstance(node, ast.Import):
            top.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0
            top.add(node.module.split(".")[0])
    assert top <= set(sys.stdlib_module_names) | {"__future__", "numpy"}, top
    everywhere = {alias.name.split(".")[0] for node in ast.walk(tree) if isinstance(node, ast.Import)
                  for alias in node.names}
    assert "toppra" in everywhere and "mycobot_planning" not in everywhere


def test_runner_main_speaks_the_json_contract(model, tmp_path, monkeypatch, capsys):
    problem = tps.make_problem("arc", "synthetic", arc_path(), model, "arm")
    request_file = tmp_path / "request.json"
    request_file.write_text(json.dumps(tps.toppra_request([problem], repeat=2)))
    monkeypatch.setattr(toppra_runner, "solve_toppra", stand_in_solver)
    monkeypatch.setattr(sys, "argv", ["toppra_runner.py", str(request_file)])
    assert toppra_runner.main() == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert lines[0]["meta"] is True and lines[0]["peer"] == "toppra" and set(lines[0]) >= {"version", "numpy", "scipy"}
    results = lines[1:]
    assert [r["grid"] for r in results] == list(tps.TOPPRA_GRIDS)
    for result in results:
        assert set(result) == RECORD_KEYS, set(result) ^ RECORD_KEYS
        assert result["success"] and result["status"] == "ok" and len(result["compute_ms"]) == 2
        assert result["max_acc_ratio"] <= 1.0 + 1e-6 and result["max_deviation"] <= 1e-3
    assert [r["gridpoints"] for r in results] == [42, 99]

    records = tps.toppra_records([problem], results)
    assert [(r["method"], r["repeat"]) for r in records] == [
        ("toppra_default", 0), ("toppra_default", 1), ("toppra_dense", 0), ("toppra_dense", 1)]
    summary = tps.summarize(records + tps.run_ours(problem, repeat=2))["synthetic"]
    assert summary["toppra_duration_s"] == pytest.approx(summary["ours_duration_s"])  # same solver inside
    assert summary["toppra_gridpoints"] == 42 and summary["toppra_dense_gridpoints"] == 99
    assert set(summary["worst"]) >= {"ours_max_acc_ratio", "toppra_max_acc_ratio", "toppra_dense_max_deviation"}
    json.dumps(summary)


def test_runner_reports_a_failing_path_and_goes_on(model):
    good = tps.make_problem("arc", "synthetic", arc_path(), model, "arm")
    calls = []

    def flaky(pts, vmax, amax, grid, step):
        calls.append(grid)
        if len(pts) == 2:
            raise ValueError("no can do")
        return stand_in_solver(pts, vmax, amax, grid, step)

    bad = {**good, "name": "line", "waypoints": [[0.0] * 6, [0.1] * 6]}
    request = json.loads(json.dumps({**tps.toppra_request([bad, good], repeat=1), "grids": ["default"]}))
    results = list(toppra_runner.evaluate(request, flaky))
    assert [r["name"] for r in results] == ["line", "arc"]
    assert not results[0]["success"] and results[0]["status"] == "error: ValueError: no can do"
    assert results[1]["success"]


def test_toppra_peer_is_pinned():
    spec = venvs.PEERS["toppra"]
    assert "toppra==0.6.10" in spec.requirements
    assert all("==" in r for r in spec.requirements) and spec.check


def test_unavailable_toppra_is_reported_not_raised(monkeypatch):
    def refuse(name):
        raise venvs.PeerUnavailable(name, "pip install failed")

    monkeypatch.setattr(tps, "ensure_peer_venv", refuse)
    assert tps.run_toppra([], repeat=1) == {"available": False, "reason": "pip install failed"}


# ---------------------------------------------------------------- our side
def test_run_ours_times_the_smooth_method_within_limits(model):
    problem = tps.make_problem("arc", "synthetic", arc_path(), model, "arm")
    records = tps.run_ours(problem, repeat=3)
    assert [r["repeat"] for r in records] == [0, 1, 2]
    assert all(r["method"] == "ours" and r["compute_ms"] > 0 for r in records)
    first = records[0]
    assert first["duration_s"] > 0 and first["samples"] >= first["duration_s"] / tps.SAMPLE_PERIOD
    assert first["max_vel_ratio"] <= 1.0 + 1e-9 and first["max_acc_ratio"] <= 1.0 + 1e-9
    # the sampled distance never exceeds our exact bound, which stays within max_deviation
    assert first["max_deviation"] <= first["path_deviation"] + 1e-12 <= 1e-3
    json.dumps(records)


def test_cartesian_paths_are_timed_smooth_by_the_planner(model):
    problems = tps.cartesian_problems(model)
    assert [len(p["waypoints"]) for p in problems] == [1201, 301]
    for problem in problems:
        assert tps.is_timed_smooth(model, "arm", np.asarray(problem["waypoints"]))
        assert problem["vmax"] == model.velocity_limits[model.group("arm").variable_indices].tolist()


def test_sparse_corner_paths_are_not_picked(model):
    corners = np.array([[0.0] * 6, [0.5, 0, 0, 0, 0, 0], [0.5, 0.5, 0, 0, 0, 0]])
    assert not tps.is_timed_smooth(model, "arm", corners)
