"""OMPL's benchmark log format: what we write reads back the same, OMPL's own reader (the ompl
wheel's ompl.tools.readBenchmarkLog, what ompl_benchmark_statistics.py runs) takes it, and a
file that is not a log is refused with the line at fault."""
from __future__ import annotations

import contextlib
import io
import sqlite3

import pytest

from mycobot_planning.benchmarks.benchmark_log import (BenchmarkLog, BenchmarkLogError, PlannerLog,
                                                       read_benchmark_log, write_benchmark_log)
from mycobot_planning.benchmarks.benchmark_statistics import (PLANNER_ARENA_SCHEMA, BenchmarkDatabaseError,
                                                              build_database, check_database)

PROPERTIES = ["final_path_length REAL", "solved BOOLEAN", "time REAL"]


def _log(name: str = "query_a") -> BenchmarkLog:
    return BenchmarkLog(
        "mycobot_planning", "0.1.0", name, "host1", "2026-11-28T10:00:00.000001",
        "Motion plan request:\n  group_name: arm\nPlanning scene:\n  scene_name: pillar\n", 7, 1.5, -1, 2, 0.25,
        [PlannerLog("RRTConnectkConfigDefault (ompl)", PROPERTIES, [["5.25", "1", "0.01"], ["", "0", "1.5"]]),
         PlannerLog("PTP (pilz_industrial_motion_planner)", ["solved BOOLEAN", "time REAL"], [["0", "0.002"]] * 2)])


def test_a_written_log_reads_back_the_same(tmp_path):
    path = write_benchmark_log(_log(), tmp_path / "a.log")
    text = path.read_text()
    assert text.startswith("mycobot_planning version 0.1.0\nExperiment query_a\nRunning on host1\n"
                           "Starting at 2026-11-28T10:00:00.000001\n<<<|\nMotion plan request:\n")
    assert "\n7 is the random seed\n1.5 seconds per run\n-1 MB per run\n2 runs per planner\n" in text
    assert "\n0 enum types\n2 planners\nRRTConnectkConfigDefault (ompl)\n0 common properties\n" \
           "3 properties for each run\nfinal_path_length REAL\nsolved BOOLEAN\ntime REAL\n2 runs\n" \
           "5.25; 1; 0.01; \n; 0; 1.5; \n.\n" in text
    assert read_benchmark_log(path) == _log()


def test_ompl_reads_our_logs_into_the_same_tables(tmp_path):
    """OMPL's own parser (moveitformat=False: the format OMPL's Benchmark writes) on our files."""
    tools = pytest.importorskip("ompl.tools", reason="the ompl wheel provides readBenchmarkLog")
    logs = [write_benchmark_log(_log(n), tmp_path / f"{n}.log") for n in ("query_a", "query_b")]
    theirs = tmp_path / "ompl.db"
    with contextlib.redirect_stdout(io.StringIO()):
        tools.readBenchmarkLog(str(theirs), [str(p) for p in logs], False)
    ours = build_database(tmp_path / "ours.db", [read_benchmark_log(p) for p in logs])
    query = ("SELECT e.name, p.name, r.solved, r.time, r.final_path_length FROM runs r JOIN experiments e "
             "ON r.experimentid = e.id JOIN plannerConfigs p ON r.plannerid = p.id "
             "WHERE e.name != 'all_experiments' ORDER BY r.id")
    with sqlite3.connect(theirs) as a, sqlite3.connect(ours) as b:
        rows = a.execute(query).fetchall()
        assert rows == b.execute(query).fetchall()
        assert len(rows) == 8 and rows[0] == ("query_a", "RRTConnectkConfigDefault (ompl)", 1, 0.01, 5.25)
        assert rows[1][4] is None  # an empty value is NULL, as OMPL stores it
        # OMPL types seed VARCHAR(24), MoveIt's script INTEGER (we build MoveIt's)
        experiment = "SELECT name, timelimit, memorylimit, runcount, version, hostname, CAST(seed AS INTEGER) " \
                     "FROM experiments WHERE name = 'query_b'"
        assert a.execute(experiment).fetchall() == b.execute(experiment).fetchall() == [
            ("query_b", 1.5, -1.0, 2, "mycobot_planning 0.1.0", "host1", 7)]
    tables = check_database(ours)
    for table, columns in PLANNER_ARENA_SCHEMA.items():
        assert list(tables[table][:len(columns)]) == list(columns)


@pytest.mark.parametrize("edit, fault", [
    (lambda t: t.replace("Experiment query_a", "Trial query_a"), "Experiment"),
    (lambda t: t.replace("|>>>\n", "", 1), "|>>>"),
    (lambda t: t.replace("2 planners", "two planners"), "planners"),
    (lambda t: t.replace("5.25; 1; 0.01; ", "5.25; 1; "), "3 values"),
    (lambda t: t.rsplit(".\n", 1)[0], "'.' ending the planner"),
])
def test_a_broken_log_is_refused_with_the_line(tmp_path, edit, fault):
    path = tmp_path / "broken.log"
    path.write_text(edit(write_benchmark_log(_log(), tmp_path / "a.log").read_text()))
    with pytest.raises(BenchmarkLogError, match="line [0-9]+") as info:
        read_benchmark_log(path)
    assert fault in str(info.value)


def test_a_corrupt_or_foreign_database_is_refused_never_read_as_empty(tmp_path):
    corrupt = tmp_path / "corrupt.db"
    corrupt.write_bytes(b"SQLite format 3\x00" + b"\xff" * 200)
    with pytest.raises(BenchmarkDatabaseError, match="not an SQLite database"):
        check_database(corrupt)
    text = tmp_path / "notes.db"
    text.write_text("hello\n" * 100)
    with pytest.raises(BenchmarkDatabaseError, match="not an SQLite database"):
        check_database(text)
    foreign = tmp_path / "foreign.db"
    with sqlite3.connect(foreign) as db:
        db.execute("CREATE TABLE experiments (id INTEGER, name TEXT)")
    with pytest.raises(BenchmarkDatabaseError, match="not a Planner Arena benchmark database"):
        check_database(foreign)
    # appending to them is refused too, and they are left as they were
    before = foreign.read_bytes()
    with pytest.raises(BenchmarkDatabaseError):
        build_database(foreign, [_log()], append=True)
    assert foreign.read_bytes() == before
    with pytest.raises(BenchmarkDatabaseError):
        build_database(corrupt, [_log()], append=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["corrupt.db", "foreign.db", "notes.db"]


def test_appending_adds_experiments_to_a_database(tmp_path):
    db = build_database(tmp_path / "b.db", [_log("query_a")])
    build_database(db, [_log("query_b")], append=True)
    with sqlite3.connect(db) as c:
        names = [n for (n,) in c.execute("SELECT name FROM experiments ORDER BY id")]
        assert names == ["all_experiments", "query_a", "all_experiments", "query_b"]
        assert c.execute("SELECT COUNT(*) FROM plannerConfigs").fetchone() == (2,)  # reused, not duplicated
        assert c.execute("SELECT COUNT(*) FROM bestPlannerConfigs").fetchone() == (2,)
