"""moveit_benchmark_statistics.py (OMPL's ompl_benchmark_statistics.py as MoveIt ships it): the
benchmark logs into the SQLite database Planner Arena (plannerarena.org) reads, and PNG plots.

The database is built as that script builds it: tables ``experiments`` (id, name, totaltime,
timelimit, memorylimit, runcount, version, hostname, cpuinfo, date, seed, setup),
``plannerConfigs`` (id, name, settings), ``enums`` (name, value, description), ``runs`` (id,
experimentid, plannerid, then one column per run property, its name with spaces made '_', typed
as the log types it), ``progress`` (runid, time); an ``all_experiments`` row that holds every run
again; the views ``bestPlannerConfigsPerExperiment`` and ``bestPlannerConfigs``. It is written to
a temporary file and moved into place, so a failed build leaves no half database; ``append``
adds to an existing one, which is checked first: a file that is not SQLite, or an SQLite file
without Planner Arena's tables, is refused (``BenchmarkDatabaseError``), never written into."""
from __future__ import annotations

import os
import re
import sqlite3
import tempfile
from pathlib import Path
from typing import Sequence

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from .benchmark_log import BenchmarkLog

__all__ = ["BenchmarkDatabaseError", "PLANNER_ARENA_SCHEMA", "build_database", "check_database", "plot_database"]

#: Planner Arena's tables and the columns each has before any run property is added.
PLANNER_ARENA_SCHEMA: dict[str, tuple[str, ...]] = {
    "experiments": ("id", "name", "totaltime", "timelimit", "memorylimit", "runcount", "version", "hostname",
                    "cpuinfo", "date", "seed", "setup"),
    "plannerConfigs": ("id", "name", "settings"),
    "enums": ("name", "value", "description"),
    "runs": ("id", "experimentid", "plannerid"),
    "progress": ("runid", "time"),
}
ALL_EXPERIMENTS = "all_experiments"

_CREATE = """CREATE TABLE IF NOT EXISTS experiments
    (id INTEGER PRIMARY KEY ON CONFLICT REPLACE AUTOINCREMENT, name VARCHAR(512),
    totaltime REAL, timelimit REAL, memorylimit REAL, runcount INTEGER,
    version VARCHAR(128), hostname VARCHAR(1024), cpuinfo TEXT,
    date DATETIME, seed INTEGER, setup TEXT);
    CREATE TABLE IF NOT EXISTS plannerConfigs
    (id INTEGER PRIMARY KEY AUTOINCREMENT,
    name VARCHAR(512) NOT NULL, settings TEXT);
    CREATE TABLE IF NOT EXISTS enums
    (name VARCHAR(512), value INTEGER, description TEXT,
    PRIMARY KEY (name, value));
    CREATE TABLE IF NOT EXISTS runs
    (id INTEGER PRIMARY KEY AUTOINCREMENT, experimentid INTEGER, plannerid INTEGER,
    FOREIGN KEY (experimentid) REFERENCES experiments(id) ON DELETE CASCADE,
    FOREIGN KEY (plannerid) REFERENCES plannerConfigs(id) ON DELETE CASCADE);
    CREATE TABLE IF NOT EXISTS progress
    (runid INTEGER, time REAL, PRIMARY KEY (runid, time),
    FOREIGN KEY (runid) REFERENCES runs(id) ON DELETE CASCADE)"""
_TYPES = {"REAL", "INTEGER", "BOOLEAN", "ENUM", "VARCHAR", "TEXT", "STRING"}
_COLUMN = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


class BenchmarkDatabaseError(ValueError):
    """A database that cannot be read or written as Planner Arena's; the message says why."""


def check_database(path: str | Path) -> dict[str, list[str]]:
    """The tables and columns of the Planner Arena database at ``path``, after checking that it
    is one: an SQLite file with every table and base column of PLANNER_ARENA_SCHEMA."""
    path = Path(path)
    if not path.is_file():
        raise BenchmarkDatabaseError(f"benchmark database '{path}' does not exist")
    try:
        db = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)
        try:
            tables = {name: [row[1] for row in db.execute(f'PRAGMA table_info("{name}")')]
                      for (name,) in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        finally:
            db.close()
    except sqlite3.Error as exc:
        raise BenchmarkDatabaseError(f"'{path}' is not an SQLite database: {exc}") from None
    for table, columns in PLANNER_ARENA_SCHEMA.items():
        if table not in tables:
            raise BenchmarkDatabaseError(f"'{path}' is not a Planner Arena benchmark database: it has no '{table}' "
                                         f"table (tables: {', '.join(sorted(tables)) or 'none'})")
        missing = [c for c in columns if c not in tables[table]]
        if missing:
            raise BenchmarkDatabaseError(f"'{path}' is not a Planner Arena benchmark database: table '{table}' "
                                         f"lacks columns {missing}")
    return tables


def _value(value: str) -> str | None:
    return None if value in ("", "nan", "-nan", "inf", "-inf") else value


def _insert_logs(db: sqlite3.Connection, logs: Sequence[BenchmarkLog]) -> None:
    """moveit_benchmark_statistics.py's readBenchmarkLog on parsed logs."""
    c = db.cursor()
    c.execute("PRAGMA FOREIGN_KEYS = ON")
    c.executescript(_CREATE)
    totals = {"totaltime": 0.0, "timelimit": 0.0, "memorylimit": 0.0, "runcount": 0, "version": "0.0.0",
              "hostname": "", "cpuinfo": "", "date": 0, "seed": 0, "setup": ""}
    c.execute("INSERT INTO experiments VALUES (?,?,?,?,?,?,?,?,?,?,?,?)",
              (None, ALL_EXPERIMENTS, *totals.values()))
    all_id = c.lastrowid
    for i, log in enumerate(logs):
        version = f"{log.library} {log.version}"
        if log.run_count >= 0:
            totals["runcount"] += log.run_count
        totals["totaltime"] += log.total_time
        totals["timelimit"] = max(totals["timelimit"], log.time_limit)
        totals["memorylimit"] = max(totals["memorylimit"], log.memory_limit)
        if i == 0:
            totals.update(version=version, date=log.date, setup=log.setup, hostname=log.hostname,
                          cpuinfo=log.cpuinfo or "")
        for enum in log.enums:
            if c.execute("SELECT 1 FROM enums WHERE name = ?", (enum[0],)).fetchone() is None:
                c.executemany("INSERT INTO enums VALUES (?,?,?)", [(enum[0], j, d) for j, d in enumerate(enum[1:])])
        c.execute("INSERT INTO experiments VALUES (?,?,?,?,?,?,?,?,?,?,?,?)",
                  (None, log.experiment, log.total_time, log.time_limit, log.memory_limit, log.run_count, version,
                   log.hostname, log.cpuinfo, log.date, log.seed, log.setup))
        experiment_id = c.lastrowid
        for planner in log.planners:
            settings = "".join(f"{line};" for line in planner.common)
            row = c.execute("SELECT id FROM plannerConfigs WHERE (name=? AND settings=?)",
                            (planner.name, settings)).fetchone()
            if row is None:
                c.execute("INSERT INTO plannerConfigs VALUES (?,?,?)", (None, planner.name, settings))
                planner_id = c.lastrowid
            else:
                planner_id = row[0]
            columns = {r[1] for r in c.execute("PRAGMA table_info(runs)")}
            names = ["experimentid", "plannerid"]
            for prop in planner.properties:
                parts = prop.split()
                name, kind = "_".join(parts[:-1]), parts[-1]
                if not _COLUMN.match(name) or kind.upper() not in _TYPES:
                    raise BenchmarkDatabaseError(f"experiment '{log.experiment}', planner '{planner.name}': "
                                                 f"cannot store property {prop!r}")
                if name not in columns:
                    c.execute(f"ALTER TABLE runs ADD {name} {kind}")
                    columns.add(name)
                names.append(name)
            insert = f"INSERT INTO runs ({','.join(names)}) VALUES ({','.join('?' * len(names))})"
            for run in planner.runs:
                values = [_value(v) for v in run]
                c.execute(insert, (experiment_id, planner_id, *values))
                c.execute(insert, (all_id, planner_id, *values))
    c.execute("UPDATE experiments SET totaltime=?, timelimit=?, memorylimit=?, runcount=?, version=?, hostname=?, "
              "cpuinfo=?, date=?, seed=?, setup=? WHERE id=?", (*totals.values(), all_id))


def _compute_views(db: sqlite3.Connection) -> None:
    """computeViews: the best planner configuration per experiment and overall."""
    columns = {r[1] for r in db.execute("PRAGMA table_info(runs)")}
    total = "time + simplification_time" if "simplification_time" in columns else "time"
    s0 = (f"SELECT plannerid, plannerConfigs.name AS plannerName, experimentid, solved, {total} AS total_time "
          "FROM plannerConfigs INNER JOIN experiments INNER JOIN runs "
          "ON plannerConfigs.id=runs.plannerid AND experiments.id=runs.experimentid")
    for view, by in (("bestPlannerConfigsPerExperiment", ["experimentid"]), ("bestPlannerConfigs", [])):
        keys = "".join(f", {key}" for key in by)
        s1 = (f"SELECT plannerid, plannerName{keys}, AVG(solved) AS avg_solved, AVG(total_time) AS avg_total_time "
              f"FROM ({s0}) GROUP BY plannerid{keys}")
        s2 = (f"SELECT plannerid{keys}, MIN(avg_solved) AS avg_solved, avg_total_time "
              f"FROM ({s1}) GROUP BY plannerName{keys} ORDER BY avg_solved DESC, avg_total_time ASC")
        db.execute(f"DROP VIEW IF EXISTS {view}")
        db.execute(f"CREATE VIEW IF NOT EXISTS {view} AS {s2}")


def build_database(path: str | Path, logs: Sequence[BenchmarkLog], append: bool = False) -> Path:
    """Write ``logs`` into the Planner Arena database at ``path`` (a new one unless ``append``)."""
    path = Path(path)
    if append and path.exists():
        check_database(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(handle)
    try:
        if append and path.exists():
            with open(path, "rb") as source, open(temp, "wb") as target:
                target.write(source.read())
        else:
            os.unlink(temp)
        db = sqlite3.connect(temp)
        try:
            _insert_logs(db, logs)
            _compute_views(db)
            db.commit()
        except sqlite3.Error as exc:
            raise BenchmarkDatabaseError(f"cannot write benchmark database '{path}': {exc}") from None
        finally:
            db.close()
        os.replace(temp, path)
    except BaseException:
        if os.path.exists(temp):
            os.unlink(temp)
        raise
    return path


def plot_database(path: str | Path, directory: str | Path, attributes: Sequence[str] = ("time", "final_path_length"),
                  prefix: str = "") -> list[Path]:
    """One PNG box plot per attribute over every planner's runs (the all_experiments rows), as
    moveit_benchmark_statistics.py's plotAttribute draws them; plus the solved share as bars.
    Returns the files written."""
    check_database(path)
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    db = sqlite3.connect(f"{Path(path).resolve().as_uri()}?mode=ro", uri=True)
    written = []
    try:
        row = db.execute("SELECT id FROM experiments WHERE name = ?", (ALL_EXPERIMENTS,)).fetchone()
        experiment = row[0] if row else None
        where = "experimentid = ?" if experiment is not None else "experimentid IS NOT ?"
        planners = db.execute("SELECT id, name FROM plannerConfigs ORDER BY id").fetchall()
        columns = {r[1] for r in db.execute("PRAGMA table_info(runs)")}
        for attribute in (*attributes, "solved"):
            if attribute not in columns:
                continue
            labels, data = [], []
            for planner_id, name in planners:
                values = [v for (v,) in db.execute(
                    f"SELECT {attribute} FROM runs WHERE plannerid = ? AND {where} AND {attribute} IS NOT NULL",
                    (planner_id, experiment))]
                if values:
                    labels.append(name)
                    data.append([float(v) for v in values])
            if not data:
                continue
            fig = Figure(figsize=(max(6.0, 1.4 * len(labels)), 4.5))
            FigureCanvasAgg(fig)
            ax = fig.add_subplot()
            if attribute == "solved":
                ax.bar(range(len(data)), [100.0 * sum(d) / len(d) for d in data], 0.5)
                ax.set_xticks(range(len(data)))
                ax.set_ylabel("solved (%)")
            else:
                ax.boxplot(data)
                ax.set_xticks(range(1, len(data) + 1))
                ax.set_ylabel(attribute.replace("_", " ") + (" (s)" if attribute.endswith("time") else ""))
            ax.set_xticklabels(labels, rotation=30, fontsize=8, ha="right")
            ax.set_xlabel("Motion planning algorithm")
            ax.yaxis.grid(True, linestyle="-", color="lightgrey", alpha=0.5)
            fig.tight_layout()
            out = directory / f"{prefix}{attribute}.png"
            fig.savefig(out, dpi=100)
            written.append(out)
    finally:
        db.close()
    return written
