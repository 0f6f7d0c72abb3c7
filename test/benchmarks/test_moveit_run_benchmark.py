"""moveit_run_benchmark on the myCobot: OMPL (two planners), Pilz and STOMP over the package's
pillar scene, the logs parsed back, the Planner Arena database checked against its schema,
the same seeds giving the same results in this process, in two local processes and on a local
Ray with two workers, and bad input refused before anything runs."""
from __future__ import annotations

import importlib.util
import json
import os
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from mycobot_planning.benchmarks.__main__ import main
from mycobot_planning.benchmarks.benchmark_executor import path_length
from mycobot_planning.benchmarks.benchmark_log import read_benchmark_log
from mycobot_planning.benchmarks.benchmark_options import BenchmarkConfigError, load_benchmark_options
from mycobot_planning.benchmarks.benchmark_statistics import PLANNER_ARENA_SCHEMA, check_database
from mycobot_planning.benchmarks.run_benchmark import prepare_benchmark, run_benchmark
from mycobot_planning.core.warehouse.planning_scene_storage import PlanningSceneStorage
from mycobot_planning.paths import config_file

QUERIES = Path(config_file("benchmark_queries.yaml"))
PLANNERS = ["RRTConnectkConfigDefault (ompl)", "RRTstarkConfigDefault (ompl)", "PTP (pilz_industrial_motion_planner)",
            "STOMP (stomp)"]
#: the around_the_pillar query: the base turns from -1.2 to 1.2 rad, the rest stays
START = [-1.2, 0.0, 1.5708, 1.5708, 0.0, 0.0]
GOAL = [1.2, 0.0, 1.5708, 1.5708, 0.0, 0.0]


def _config(tmp_path: Path, host: Path = QUERIES, runs: int = 2, timeout: float = 1.0, regex: str = ".*",
            planners: dict | None = None, **parameters) -> dict:
    pipelines = planners or {"OMPL": {"name": "ompl", "planners": ["RRTConnectkConfigDefault", "RRTstarkConfigDefault"]},
                             "PILZ": {"name": "pilz_industrial_motion_planner", "planners": ["PTP"]},
                             "STOMP": {"name": "stomp", "planners": ["STOMP"]}}
    return {"benchmark_config": {
        "warehouse": {"host": str(host), "scene_name": "pillar"},
        "parameters": {"name": "test", "runs": runs, "group": "arm", "timeout": timeout,
                       "output_directory": str(tmp_path / "out"), "queries_regex": regex, **parameters},
        "planning_pipelines": {"pipelines": list(pipelines), **pipelines}}}


def _write(tmp_path: Path, config: dict, name: str = "benchmark.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(config))
    return path


def _figures(outcome) -> dict:
    """Per (query, planner): each run's solved flag and final path length (what must not depend
    on where the runs went)."""
    return {(query, f"{p.planner_id} ({p.pipeline})"): [(r.solved, r.properties.get("final_path_length REAL"))
                                                       for r in p.runs]
            for query, planners in outcome.results.items() for p in planners}


def _runs(outcome) -> list:
    return [p for planners in outcome.results.values() for p in planners]


@pytest.fixture(scope="module")
def local_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("bench")
    options = load_benchmark_options(_config(tmp))
    return options, run_benchmark(options, seed=11)


def test_every_query_planner_and_run_is_logged_and_parses_back(local_run):
    options, outcome = local_run
    assert [p.name for p in outcome.logs] == sorted(p.name for p in Path(options.output_directory).glob("*.log"))
    assert len(outcome.logs) == 2
    for path in outcome.logs:
        log = read_benchmark_log(path)
        assert path.name.startswith(f"test_{log.experiment}_{log.hostname}_")
        assert log.experiment in ("around_the_pillar", "to_home")
        assert (log.run_count, log.time_limit, log.memory_limit, log.seed) == (2, 1.0, -1, 11)
        assert "group_name: arm" in log.setup and "scene_name: pillar" in log.setup
        assert [p.name for p in log.planners] == PLANNERS
        for planner in log.planners:
            assert len(planner.runs) == 2
            assert {"time REAL", "solved BOOLEAN"} <= set(planner.properties)
            for values in planner.runs:
                run = dict(zip(planner.properties, values))
                assert float(run["time REAL"]) > 0
                if run["solved BOOLEAN"] == "1":  # MoveIt's figures of a solved run
                    for key in ("final_path_correct BOOLEAN", "final_path_length REAL", "final_path_clearance REAL",
                                "final_path_smoothness REAL", "final_path_time REAL", "path_plan_length REAL",
                                "process_time REAL", "average_waypoint_distance REAL"):
                        assert run[key] != "", key
                    assert run["final_path_correct BOOLEAN"] == "1"
                    assert run["final_path_length REAL"] == run["path_plan_length REAL"]
                    assert float(run["final_path_clearance REAL"]) > 0  # the pillar is never touched
                else:
                    assert run["solved BOOLEAN"] == "0" and run.get("final_path_length REAL", "") == ""


def test_the_planners_behave_as_they_should_around_the_pillar(local_run):
    _, outcome = local_run
    figures = _figures(outcome)
    straight = path_length([START, GOAL])
    for planner in PLANNERS[:2]:  # OMPL goes round the pillar: always solved, longer than the straight line
        runs = figures[("around_the_pillar", planner)]
        assert all(solved for solved, _ in runs)
        assert all(float(length) > straight + 0.1 for _, length in runs)
    # PTP moves on the straight joint-space line, through the pillar: refused every time
    assert figures[("around_the_pillar", PLANNERS[2])] == [(False, None), (False, None)]
    for planner in PLANNERS:  # to_home is free: everybody solves it, PTP and STOMP on the straight line
        assert all(solved for solved, _ in figures[("to_home", planner)]), planner
    assert float(figures[("to_home", PLANNERS[2])][0][1]) == pytest.approx(1.2 + 2 * 1.5708, abs=1e-6)
    assert outcome.failures.get("INVALID_MOTION_PLAN") == 2


def test_the_database_has_planner_arenas_schema_and_every_run(local_run):
    options, outcome = local_run
    assert outcome.database == Path(options.output_directory) / "test.db"
    tables = check_database(outcome.database)
    with sqlite3.connect(outcome.database) as db:
        names = {n for (n,) in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        assert set(PLANNER_ARENA_SCHEMA) <= names
        for table, columns in PLANNER_ARENA_SCHEMA.items():
            assert tables[table][:len(columns)] == list(columns)
        columns = {r[1]: r[2] for r in db.execute("PRAGMA table_info(runs)")}
        assert columns["time"] == "REAL" and columns["solved"] == "BOOLEAN"
        assert columns["final_path_length"] == "REAL" and columns["final_path_correct"] == "BOOLEAN"
        experiments = [n for (n,) in db.execute("SELECT name FROM experiments ORDER BY id")]
        assert experiments == ["all_experiments", "around_the_pillar", "to_home"]
        assert db.execute("SELECT name FROM plannerConfigs ORDER BY id").fetchall() == [(p,) for p in PLANNERS]
        per_experiment = dict(db.execute(
            "SELECT e.name, COUNT(*) FROM runs r JOIN experiments e ON r.experimentid = e.id GROUP BY e.name"))
        assert per_experiment == {"all_experiments": 16, "around_the_pillar": 8, "to_home": 8}
        solved = db.execute("SELECT SUM(solved) FROM runs r JOIN experiments e ON r.experimentid = e.id "
                            "WHERE e.name = 'around_the_pillar' AND r.plannerid = 3").fetchone()
        assert solved == (0,)
        best = db.execute("SELECT COUNT(*) FROM bestPlannerConfigsPerExperiment").fetchone()
        assert best == (12,)  # 4 planners in each of the 3 experiments
    assert [p.name for p in outcome.plots] == ["test_time.png", "test_final_path_length.png", "test_solved.png"]
    for picture in outcome.plots:
        assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_two_local_processes_give_the_same_results_as_one(local_run, tmp_path):
    options, outcome = local_run
    # the deterministic planners on both queries: OMPL's and Pilz's (STOMP stops at its clock
    # when it fails, so its failed runs depend on the machine's speed)
    config = _config(tmp_path, planners={"OMPL": {"name": "ompl", "planners": ["RRTConnectkConfigDefault",
                                                                               "RRTstarkConfigDefault"]},
                                         "PILZ": {"name": "pilz_industrial_motion_planner", "planners": ["PTP"]}})
    pooled = run_benchmark(load_benchmark_options(config), seed=11, jobs=2, plots=False)
    assert pooled.distribution == "local:2"
    assert len({r.worker for p in _runs(pooled) for r in p.runs} - {os.getpid()}) == 2  # two other processes
    ours = {k: v for k, v in _figures(outcome).items() if "STOMP" not in k[1]}
    assert _figures(pooled) == ours
    other_seed = run_benchmark(load_benchmark_options(config), seed=12, plots=False)
    assert _figures(other_seed) != ours  # the seed matters: OMPL's paths differ


@pytest.mark.skipif(importlib.util.find_spec("ray") is None,
                    reason="Ray is not installed: scripts/setup.sh installs ray==2.40.0 (scripts/requirements.txt); "
                           "users get it with the extra mycobot_planning[ray]")
def test_a_local_ray_with_two_workers_gives_the_same_results(local_run, tmp_path):
    _, outcome = local_run
    options = load_benchmark_options(_config(tmp_path, regex="around_the_pillar"))
    on_ray = run_benchmark(options, seed=11, jobs=2, ray="auto", plots=False)
    assert on_ray.distribution == "ray:auto"
    assert len({r.worker for p in _runs(on_ray) for r in p.runs} - {os.getpid()}) == 2  # two Ray workers
    ours = {k: v for k, v in _figures(outcome).items() if k[0] == "around_the_pillar"}
    theirs = _figures(on_ray)
    stomp = ("around_the_pillar", "STOMP (stomp)")
    if not all(solved for solved, _ in ours[stomp] + theirs[stomp]):
        ours.pop(stomp), theirs.pop(stomp)  # a STOMP run that ran out of time ends where the clock stopped it
    assert theirs == ours
    assert [read_benchmark_log(p).experiment for p in on_ray.logs] == ["around_the_pillar"]
    check_database(on_ray.database)


def test_the_warehouse_gives_the_same_benchmark_as_the_queries_file(tmp_path):
    content = yaml.safe_load(QUERIES.read_text())
    storage = PlanningSceneStorage(tmp_path / "warehouse.sqlite")
    for name, scene in content["scenes"].items():
        storage.add_planning_scene(name, scene)
        for query, request in content["queries"][name].items():
            storage.add_planning_query(name, query, request)
    storage.close()
    planners = {"OMPL": {"name": "ompl", "planners": ["RRTConnectkConfigDefault"]},
                "PILZ": {"name": "pilz_industrial_motion_planner", "planners": ["PTP"]}}
    warehouse = _config(tmp_path, host=tmp_path / "warehouse.sqlite", runs=1, planners=planners)
    from_warehouse = run_benchmark(load_benchmark_options(warehouse), seed=3, plots=False)
    from_file = run_benchmark(load_benchmark_options(_config(tmp_path, runs=1, planners=planners)), seed=3, plots=False)
    assert _figures(from_warehouse) == _figures(from_file)
    assert list(from_warehouse.results) == ["around_the_pillar", "to_home"]


def test_start_states_are_combined_with_every_query(tmp_path):
    options = load_benchmark_options(_config(tmp_path, start_states_regex="^ready$"))
    requests = prepare_benchmark(options)
    assert [r.name for r in requests] == ["ready_around_the_pillar", "ready_to_home"]
    assert requests[0].start_state["link3_to_link4"] == pytest.approx(1.5708)


@pytest.mark.parametrize("change, message", [
    (lambda c: c["planning_pipelines"].update(P={"name": "no_such_pipeline", "planners": ["X"]}, pipelines=["P"]),
     "planning pipeline 'no_such_pipeline' (of 'P') does not exist"),
    (lambda c: c["planning_pipelines"]["OMPL"].update(planners=["RRTConnectkConfigDefault", "NoSuchPlanner"]),
     "planner 'NoSuchPlanner' of pipeline 'ompl'"),
    (lambda c: c["parameters"].update(group="legs"), "unknown planning group 'legs'"),
    (lambda c: c["warehouse"].update(scene_name="kitchen"), "unknown planning scene 'kitchen'"),
    (lambda c: c["parameters"].update(queries_regex="^nothing$"), "no query matches queries_regex"),
    (lambda c: c["parameters"].update(runs=0), "runs must be an integer >= 1"),
    (lambda c: c["parameters"].update(rnus=3), "unknown keys ['rnus']"),
    (lambda c: c["parameters"].update(path_constraints_regex="upright"), "path_constraints_regex is not supported"),
    (lambda c: c["parameters"].update(start_states_regex="nowhere"), "matches no start state"),
])
def test_bad_configurations_end_with_one_line_before_anything_runs(tmp_path, capsys, change, message):
    config = _config(tmp_path)
    change(config["benchmark_config"])
    assert main([str(_write(tmp_path, config)), "--no-plots"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and captured.err.startswith("moveit_run_benchmark: error: ")
    assert message in captured.err
    assert not (tmp_path / "out").exists()  # nothing ran, nothing was written


def test_a_corrupt_or_foreign_warehouse_is_an_error_not_an_empty_benchmark(tmp_path, capsys):
    corrupt = tmp_path / "corrupt.sqlite"
    corrupt.write_bytes(b"SQLite format 3\x00" + os.urandom(64) * 8)
    foreign = tmp_path / "foreign.sqlite"
    with sqlite3.connect(foreign) as db:
        db.execute("CREATE TABLE robot_states (name TEXT, robot TEXT, state BLOB)")
    for host, message in ((corrupt, "cannot open warehouse database"),
                          (foreign, "is not a planning-scene warehouse: it has no motion_plan_requests or "
                                    "planning_scenes table"),
                          (tmp_path / "missing.sqlite", "does not exist")):
        before = host.read_bytes() if host.exists() else None
        assert main([str(_write(tmp_path, _config(tmp_path, host=host)))]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, err
        assert (host.read_bytes() if host.exists() else None) == before  # opened read-only


def test_the_command_runs_as_a_module_and_fails_without_a_traceback(tmp_path):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(__file__).resolve().parents[2]),
                                                        os.environ.get("PYTHONPATH", "")])}
    bad = _config(tmp_path)
    bad["benchmark_config"]["planning_pipelines"]["OMPL"]["planners"] = ["Nope"]
    run = subprocess.run([sys.executable, "-m", "mycobot_planning.benchmarks", str(_write(tmp_path, bad))],
                         capture_output=True, text=True, timeout=300, env=env)
    assert run.returncode == 2 and "Traceback" not in run.stderr
    assert run.stderr.strip().splitlines() == [run.stderr.strip()]
    check = subprocess.run([sys.executable, "-m", "mycobot_planning.benchmarks", str(_write(tmp_path, _config(tmp_path))),
                            "--check"], capture_output=True, text=True, timeout=300, env=env)
    assert check.returncode == 0, check.stderr
    assert json.loads(check.stdout) == {"queries": ["around_the_pillar", "to_home"], "planners": 4, "runs": 16}


def test_the_options_file_may_be_a_ros_parameters_file(tmp_path):
    config = {"moveit_run_benchmark": {"ros__parameters": _config(tmp_path)}}
    options = load_benchmark_options(_write(tmp_path, config))
    assert [p.id for p in options.pipelines] == ["OMPL", "PILZ", "STOMP"] and options.planner_count == 4
    with pytest.raises(BenchmarkConfigError, match="no benchmark_config found"):
        load_benchmark_options(_write(tmp_path, {"something": {"else": 1}}, "other.yaml"))


def test_ray_asked_for_but_not_installed_is_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # what a missing package looks like to import
    assert main([str(_write(tmp_path, _config(tmp_path, runs=1))), "--ray", "auto", "--no-plots"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--ray needs Ray" in err and "mycobot_planning[ray]" in err


def test_an_output_directory_that_cannot_be_written_is_one_line(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    config = _config(tmp_path, runs=1, planners={"PILZ": {"name": "pilz_industrial_motion_planner",
                                                          "planners": ["PTP"]}})
    config["benchmark_config"]["parameters"]["output_directory"] = str(blocker / "out")
    assert main([str(_write(tmp_path, config)), "--no-plots"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot write the results" in err


def test_a_query_name_with_a_blank_is_refused(tmp_path, capsys):
    queries = yaml.safe_load(QUERIES.read_text())
    queries["queries"]["pillar"]["to home"] = queries["queries"]["pillar"].pop("to_home")
    host = tmp_path / "queries.yaml"
    host.write_text(yaml.safe_dump(queries))
    assert main([str(_write(tmp_path, _config(tmp_path, host=host)))]) == 2
    assert "query names ['to home'] contain blanks" in capsys.readouterr().err
