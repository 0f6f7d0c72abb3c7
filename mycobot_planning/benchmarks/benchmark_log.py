"""OMPL's benchmark log format, as MoveIt's BenchmarkExecutor::writeOutput writes it (one file per
query) and ompl_benchmark_statistics.py / moveit_benchmark_statistics.py read it:

    <library> version <version>
    Experiment <name>
    Running on <host>
    Starting at <date>
    <<<|
    <setup, several lines>
    |>>>
    <seed> is the random seed
    <time limit> seconds per run
    <memory limit> MB per run
    <runs> runs per planner
    <seconds> seconds spent to collect the data
    0 enum types
    <n> planners
    <planner> (<pipeline>)          -- then, per planner:
    0 common properties
    <k> properties for each run
    <name> <TYPE>                   -- k lines, e.g. "time REAL", "solved BOOLEAN"
    <r> runs
    <v1>; <v2>; ...; <vk>;          -- r lines (a missing value is empty)
    .

``read_benchmark_log`` parses it back by the same rules (and refuses anything else with the line
at fault), which is how the database builder and the tests read it."""
from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["BenchmarkLog", "BenchmarkLogError", "PlannerLog", "read_benchmark_log", "write_benchmark_log"]


class BenchmarkLogError(ValueError):
    """A file that is not a benchmark log (or a broken one); the message names the line."""


@dataclass
class PlannerLog:
    """One planner's block: its name ("<planner> (<pipeline>)"), properties ("name TYPE") and runs."""

    name: str
    properties: list[str]
    runs: list[list[str]]
    common: list[str] = field(default_factory=list)


@dataclass
class BenchmarkLog:
    """One experiment (a query) with every planner's runs."""

    library: str
    version: str
    experiment: str
    hostname: str
    date: str
    setup: str
    seed: int
    time_limit: float
    memory_limit: float
    run_count: int
    total_time: float
    planners: list[PlannerLog]
    cpuinfo: str | None = None
    enums: list[list[str]] = field(default_factory=list)

    def planner(self, name: str) -> PlannerLog:
        for planner in self.planners:
            if planner.name == name:
                return planner
        raise KeyError(name)


def write_benchmark_log(log: BenchmarkLog, path: str | Path) -> Path:
    """Write ``log`` in OMPL's format to ``path`` (its directory is created)."""
    out = io.StringIO()
    out.write(f"{log.library} version {log.version}\n")
    out.write(f"Experiment {log.experiment}\n")
    out.write(f"Running on {log.hostname}\n")
    out.write(f"Starting at {log.date}\n")
    setup = log.setup if log.setup.endswith("\n") or not log.setup else log.setup + "\n"
    out.write(f"<<<|\n{setup}|>>>\n")
    if log.cpuinfo is not None:
        cpuinfo = log.cpuinfo if log.cpuinfo.endswith("\n") or not log.cpuinfo else log.cpuinfo + "\n"
        out.write(f"<<<|\n{cpuinfo}|>>>\n")
    out.write(f"{log.seed} is the random seed\n")
    out.write(f"{log.time_limit:g} seconds per run\n")
    out.write(f"{log.memory_limit:g} MB per run\n")
    out.write(f"{log.run_count} runs per planner\n")
    out.write(f"{log.total_time!r} seconds spent to collect the data\n")
    out.write(f"{len(log.enums)} enum types\n")
    for enum in log.enums:
        out.write("|".join(enum) + "\n")
    out.write(f"{len(log.planners)} planners\n")
    for planner in log.planners:
        out.write(f"{planner.name}\n")
        out.write(f"{len(planner.common)} common properties\n")
        for line in planner.common:
            out.write(f"{line}\n")
        out.write(f"{len(planner.properties)} properties for each run\n")
        for prop in planner.properties:
            out.write(f"{prop}\n")
        out.write(f"{len(planner.runs)} runs\n")
        for run in planner.runs:
            if len(run) != len(planner.properties):
                raise ValueError(f"planner {planner.name}: a run has {len(run)} values for "
                                 f"{len(planner.properties)} properties")
            out.write("".join(f"{value}; " for value in run) + "\n")
        out.write(".\n")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(out.getvalue(), encoding="utf-8")
    return path


class _Lines:
    def __init__(self, text: str, where: str) -> None:
        self.lines = text.splitlines()
        self.index = 0
        self.where = where

    def fail(self, what: str) -> BenchmarkLogError:
        line = self.lines[self.index] if self.index < len(self.lines) else "<end of file>"
        return BenchmarkLogError(f"{self.where}: line {self.index + 1}: expected {what}, found {line!r}")

    def peek(self) -> str | None:
        return self.lines[self.index] if self.index < len(self.lines) else None

    def next(self, what: str) -> str:
        if self.index >= len(self.lines):
            raise self.fail(what)
        line = self.lines[self.index]
        self.index += 1
        return line

    def tokens(self, what: str, tail: tuple[str, ...]) -> list[str]:
        """The next line's tokens, which must end with ``tail``."""
        tokens = (self.peek() or "").split()
        if len(tokens) <= len(tail) - 1 or tuple(tokens[len(tokens) - len(tail):]) != tail:
            raise self.fail(what)
        self.index += 1
        return tokens

    def number(self, what: str, tail: tuple[str, ...], kind: type = float) -> float:
        tokens = self.tokens(what, tail)
        try:
            return kind(tokens[0])
        except ValueError:
            self.index -= 1
            raise self.fail(what) from None

    def block(self, what: str) -> str:
        if self.next(what) != "<<<|":
            self.index -= 1
            raise self.fail(what)
        lines = []
        while True:
            line = self.next(f"the end of {what} ('|>>>')")
            if line.startswith("|>>>"):
                return "".join(f"{x}\n" for x in lines)
            lines.append(line)


def read_benchmark_log(path: str | Path) -> BenchmarkLog:
    """Parse a benchmark log (OMPL's or MoveIt's writing of it); BenchmarkLogError when it is not one."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise BenchmarkLogError(f"cannot read benchmark log '{path}': {exc}") from None
    lines = _Lines(text, str(path))
    first = (lines.peek() or "").split()
    library, version = "OMPL", "0.0.0"
    if len(first) >= 3 and first[1] == "version":
        library, version = first[0], first[-1]
        lines.index += 1
    tokens = lines.tokens("'Experiment <name>'", ())
    if not tokens or tokens[0] != "Experiment" or len(tokens) < 2:
        lines.index -= 1
        raise lines.fail("'Experiment <name>'")
    experiment = tokens[-1]
    peek = (lines.peek() or "").split()
    if len(peek) >= 3 and peek[-2:] == ["experiment", "properties"]:
        lines.index += 1
        for _ in range(int(peek[0])):
            lines.next("an experiment property")
    tokens = lines.tokens("'Running on <host>'", ())
    if tokens[:2] != ["Running", "on"] or len(tokens) < 3:
        lines.index -= 1
        raise lines.fail("'Running on <host>'")
    hostname = tokens[-1]
    start = lines.next("'Starting at <date>'")
    if not start.startswith("Starting"):
        lines.index -= 1
        raise lines.fail("'Starting at <date>'")
    date = " ".join(start.split()[2:])
    setup = lines.block("the experiment setup ('<<<|')")
    cpuinfo = lines.block("cpu information") if lines.peek() == "<<<|" else None
    seed = int(lines.number("'<seed> is the random seed'", ("random", "seed"), int))
    time_limit = lines.number("'<t> seconds per run'", ("seconds", "per", "run"))
    memory_limit = lines.number("'<m> MB per run'", ("MB", "per", "run"))
    run_count = -1
    peek = (lines.peek() or "").split()
    if peek[-3:] == ["runs", "per", "planner"]:
        run_count = int(lines.number("'<n> runs per planner'", ("runs", "per", "planner"), int))
    total_time = lines.number("'<s> seconds spent to collect the data'", ("collect", "the", "data"))
    enums: list[list[str]] = []
    peek = (lines.peek() or "").split()
    if len(peek) >= 2 and peek[-2] == "enum":
        lines.index += 1
        enums = [lines.next("an enum line").split("|") for _ in range(int(peek[0]))]
    count = int(lines.number("'<n> planners'", ("planners",), int))
    planners = []
    for _ in range(count):
        name = lines.next("a planner name")
        common_count = int(lines.number("'<n> common properties'", ("common", "properties"), int))
        common = [lines.next("a common property") for _ in range(common_count)]
        prop_count = int(lines.number("'<k> properties for each run'", ("properties", "for", "each", "run"), int))
        properties = []
        for _ in range(prop_count):
            field_tokens = lines.next("a property ('<name> <TYPE>')").split()
            if len(field_tokens) < 2:
                lines.index -= 1
                raise lines.fail("a property ('<name> <TYPE>')")
            properties.append(" ".join(field_tokens))
        run_total = int(lines.number("'<r> runs'", ("runs",), int))
        runs = []
        for _ in range(run_total):
            values = lines.next("a run's values").split("; ")[:-1]
            if len(values) != prop_count:
                lines.index -= 1
                raise lines.fail(f"{prop_count} values each followed by '; '")
            runs.append(values)
        end = lines.next("'.' ending the planner").strip()
        if end != ".":
            lines.index -= 1
            raise lines.fail("'.' ending the planner (progress properties are not read)")
        planners.append(PlannerLog(name, properties, runs, common))
    return BenchmarkLog(library, version, experiment, hostname, date, setup, seed, time_limit, memory_limit,
                        run_count, total_time, planners, cpuinfo, enums)
