"""Separate virtual environments for the peer planners, created on demand by the bench tooling.

The peers (mplib, pyroboplan, roboplan, vamp, toppra) are benchmark-only: they are never
dependencies of the package, and they cannot share our venv anyway (mplib 0.2.1 needs numpy < 2;
pyroboplan pins pin==4.0.0 while we use pin 4.1). Each gets ``<root>/<name>`` made with
``python3 -m venv`` and exact pins (vamp is compiled from its sdist: see SourceBuild and
vamp_build_options), and a stamp file written last records what was installed: a venv whose
stamp matches is reused at once, anything else (no stamp, other pins, an interrupted install) is
deleted and built again.

``<root>`` is ``$MYCOBOT_PEERS_DIR`` if set, else ``<repo>/.venv-peers`` for a checkout (the
folder is gitignored), else ``~/.cache/mycobot_planning/peers`` for an installed package.

All progress goes to stderr: stdout of the bench is the JSON-lines contract.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

STAMP = ".peer-stamp.json"


@dataclass(frozen=True)
class PeerSpec:
    """What one peer venv holds.

    requirements: installed with their dependencies resolved by pip (exact pins where the version
        matters for the result or for installing on Python 3.11).
    no_deps: installed with ``--no-deps`` after ``requirements``; used for pyroboplan, whose
        declared dependencies include drake (~800 MB, only for its trajectory optimisation, which
        the benchmark does not touch), matplotlib, plyfile and toppra, none imported by the IK and
        RRT modules we call. ``requirements`` lists what those modules do import.
    check: Python statement that must succeed in the finished venv.
    """

    name: str
    requirements: tuple[str, ...]
    no_deps: tuple[str, ...] = ()
    check: str = ""
    version_of: str = ""  # distribution whose version is reported with the results
    # Built from its sdist (``--no-binary``) after the rest, at low priority; see SourceBuild.
    source_build: "SourceBuild | None" = None

    @property
    def pins(self) -> list[str]:
        """Every pinned requirement, as reported with the results."""
        built = [self.source_build.requirement] if self.source_build is not None else []
        return list(self.requirements) + list(self.no_deps) + built


@dataclass(frozen=True)
class SourceBuild:
    """A peer compiled from its PyPI sdist (no wheel for our Python), e.g. VAMP's C++ + nanobind.

    The build runs under ``nice -n 19`` with ``CMAKE_BUILD_PARALLEL_LEVEL`` from
    ``$MYCOBOT_PEERS_BUILD_JOBS`` (default 1): the benchmark machine has 2 shared cores.
    ``options(venv)`` gives the extra pip arguments (``--config-settings``) and environment of
    the build, computed when the venv exists (e.g. paths to its cmeel prefix).
    """

    requirement: str  # "name==version", fetched by pip from the index
    options: Callable[[Path], tuple[list[str], dict[str, str]]] | None = None


# VAMP's CMake fetches these from GitHub (CPM) at the commits its 0.6.4 sdist pins; a machine
# without GitHub access can point $MYCOBOT_VAMP_SOURCES at a folder holding them (docs/bench.md).
VAMP_GITHUB_SOURCES = ("nanobind", "nigh", "pdqsort", "SIMDxorshift")


def vamp_build_options(venv: Path) -> tuple[list[str], dict[str, str]]:
    """pip arguments and environment for building vamp-planner 0.6.4 from its sdist.

    Only the Panda robot module is compiled (the sdist's default is five robots, each a heavy
    template instantiation). Eigen comes from the venv's cmeel-eigen (PyPI), found through
    CMAKE_PREFIX_PATH. With ``$MYCOBOT_VAMP_SOURCES`` set, CPM takes CPM.cmake and the four
    GitHub dependencies from that folder instead of downloading them.
    """
    settings = {"cmake.define.VAMP_ROBOT_MODULES": "panda", "cmake.define.VAMP_ROBOT_STRUCTS": "Panda",
                "cmake.define.VAMP_LTO": "OFF"}
    prefixes = sorted(str(path) for path in venv.glob("lib/python*/site-packages/cmeel.prefix"))
    env = {"CMAKE_PREFIX_PATH": os.pathsep.join(prefixes)} if prefixes else {}
    sources = os.environ.get("MYCOBOT_VAMP_SOURCES")
    if sources:
        root = Path(sources).expanduser().resolve()
        missing = [n for n in ("CPM.cmake",) + VAMP_GITHUB_SOURCES if not (root / n).exists()]
        if missing:
            raise PeerUnavailable("vamp", f"MYCOBOT_VAMP_SOURCES={root} lacks {', '.join(missing)}")
        seed = cache_dir() / "vamp_cpm_seed.cmake"
        # file(DOWNLOAD) with EXPECTED_HASH skips the download when the file is there with that hash.
        seed.write_text(f'file(COPY "{root / "CPM.cmake"}" DESTINATION "${{CMAKE_BINARY_DIR}}/cmake")\n')
        settings["cmake.define.CMAKE_PROJECT_vamp_INCLUDE"] = str(seed)
        for dep in VAMP_GITHUB_SOURCES:
            settings[f"cmake.define.CPM_{dep}_SOURCE"] = str(root / dep)
    return [f"--config-settings={key}={value}" for key, value in settings.items()], env


PEERS: dict[str, PeerSpec] = {
    "mplib": PeerSpec(
        name="mplib",
        requirements=("mplib==0.2.1", "numpy==1.26.4", "toppra==0.6.10", "transforms3d==0.4.2",
                      "scipy==1.17.1"),
        check="import mplib, mplib.pymp",
        version_of="mplib",
    ),
    "pyroboplan": PeerSpec(
        name="pyroboplan",
        requirements=("pin==4.0.0", "numpy==2.4.6", "scipy==1.17.1", "meshcat==0.3.2"),
        no_deps=("pyroboplan==1.3.1",),
        check="import pinocchio, coal, pyroboplan.planning.rrt, pyroboplan.ik.differential_ik",
        version_of="pyroboplan",
    ),
    # C++ core (Pinocchio + Coal underneath) with nanobind bindings; its roboplan-* packages are
    # pinned to 0.7.0 by roboplan itself, pin/coal come from PyPI (cmeel) as its dependencies.
    "roboplan": PeerSpec(
        name="roboplan",
        requirements=("roboplan==0.7.0", "numpy==2.4.6"),
        check="import roboplan.core, roboplan.rrt, roboplan.simple_ik",
        version_of="roboplan",
    ),
    # Not a planner: the time_parameterization scenario compares our dense-path TOPP with it.
    # 0.6.10's wheel imports and solves under numpy 2.4.6 (checked); matplotlib comes as a dep.
    "toppra": PeerSpec(
        name="toppra",
        requirements=("toppra==0.6.10", "numpy==2.4.6", "scipy==1.17.1"),
        check="import toppra, toppra.algorithm, toppra.constraint",
        version_of="toppra",
    ),
    # VAMP (vector-accelerated sphere-model planner): C++ templates + nanobind, wheels only for
    # CPython >= 3.12 (abi3), so built from the pinned sdist; Panda only (vamp_build_options).
    "vamp": PeerSpec(
        name="vamp",
        requirements=("numpy==2.4.6", "cmeel-eigen==3.4.1"),
        source_build=SourceBuild("vamp-planner==0.6.4", options=vamp_build_options),
        check="import vamp; vamp.panda.validate",
        version_of="vamp-planner",
    ),
}


class PeerUnavailable(RuntimeError):
    """A peer venv could not be created or its library does not import; the message says why."""

    def __init__(self, name: str, reason: str):
        super().__init__(f"peer '{name}' unavailable: {reason}")
        self.name = name
        self.reason = reason


def log(message: str) -> None:
    print(f"[peers] {message}", file=sys.stderr, flush=True)


def peers_root() -> Path:
    """Folder holding one venv per peer plus a cache/ for generated files (see module doc)."""
    env = os.environ.get("MYCOBOT_PEERS_DIR")
    if env:
        return Path(env).expanduser().resolve()
    repo = Path(__file__).resolve().parents[3]
    if (repo / "setup.py").is_file() and (repo / "mycobot_planning").is_dir():
        return repo / ".venv-peers"
    return Path.home() / ".cache" / "mycobot_planning" / "peers"


def cache_dir() -> Path:
    path = peers_root() / "cache"
    path.mkdir(parents=True, exist_ok=True)
    return path


def venv_python(venv: Path) -> Path:
    return venv / "bin" / "python"


def _stamp_for(spec: PeerSpec) -> dict:
    stamp = {"requirements": list(spec.requirements), "no_deps": list(spec.no_deps),
             "python": sys.version.split()[0]}
    if spec.source_build is not None:  # only then, so the other peers' stamps stay valid
        stamp["source_build"] = spec.source_build.requirement
    return stamp


def read_stamp(name: str) -> dict | None:
    path = peers_root() / name / STAMP
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def _run(cmd: list[str], what: str, name: str, env: dict[str, str] | None = None) -> None:
    """Run an install step, its output on stderr; PeerUnavailable with the output tail on failure
    (preceded by the first compiler/CMake error lines, which a long build log would push out).
    ``env``: variables added to ours for this step."""
    proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          env=None if env is None else {**os.environ, **env})
    lines = [line for line in proc.stdout.splitlines()
             if "is ignored: it is neither a file nor a directory" not in line]
    for line in lines:
        print(f"[peers:{name}] {line}", file=sys.stderr)
    if proc.returncode != 0:
        raise PeerUnavailable(name, f"{what} failed (exit {proc.returncode}): {failure_excerpt(lines)}")


def failure_excerpt(lines: list[str], first_errors: int = 3, context: int = 4, tail: int = 15) -> str:
    """The first few error lines (``error:``, ``CMake Error``, ``fatal:``), each with up to
    ``context`` following non-blank lines (where CMake says why, e.g. a failed download's
    status), then the last ``tail`` lines; nothing twice."""
    marks = ("error:", "cmake error", "fatal:", "fatal error")
    end = lines[-tail:]
    seen = {line.strip() for line in end}
    head: list[str] = []
    errors = 0
    i = 0
    while i < len(lines) - tail and errors < first_errors:
        if any(m in lines[i].lower() for m in marks) and lines[i].strip() not in seen:
            errors += 1
            block = [lines[i]] + [line for line in lines[i + 1:i + 1 + context] if line.strip()]
            head += [line.strip() for line in block if line.strip() not in seen]
            seen.update(line.strip() for line in block)
            i += 1 + context
            continue
        i += 1
    return "\n".join(head + (["..."] if head else []) + end)


def ensure_peer_venv(name: str, python: str | None = None) -> Path:
    """Path of the peer's Python, creating and filling its venv first if needed.

    Idempotent and fast when the venv is already there with a matching stamp. Raises
    ``KeyError`` for an unknown peer and :class:`PeerUnavailable` (with pip's error text) when
    the venv cannot be built or the library does not import.
    """
    if name not in PEERS:
        raise KeyError(f"unknown peer '{name}'; known: {', '.join(PEERS)}")
    spec = PEERS[name]
    venv = peers_root() / name
    py = venv_python(venv)
    wanted = _stamp_for(spec)
    stamp = read_stamp(name)
    if py.is_file() and stamp is not None and {k: stamp.get(k) for k in wanted} == wanted:
        return py

    if venv.exists():
        log(f"{name}: venv at {venv} is stale or incomplete; rebuilding")
        shutil.rmtree(venv)
    venv.parent.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    log(f"{name}: creating venv {venv} (one-off; reused afterwards)")
    base = python or shutil.which("python3") or sys.executable
    _run([base, "-m", "venv", str(venv)], "python -m venv", name)
    pip = [str(py), "-m", "pip", "--disable-pip-version-check", "install", "-q"]
    log(f"{name}: pip install {' '.join(spec.requirements)}")
    _run(pip + list(spec.requirements), "pip install", name)
    if spec.no_deps:
        log(f"{name}: pip install --no-deps {' '.join(spec.no_deps)}")
        _run(pip + ["--no-deps"] + list(spec.no_deps), "pip install --no-deps", name)
    if spec.source_build is not None:
        _build_from_source(spec.source_build, venv, pip, name)
    if spec.check:
        _run([str(py), "-c", spec.check], "import check", name)
    elapsed = time.perf_counter() - started
    stamp = {**wanted, "created_seconds": round(elapsed, 1),
             "version": installed_version(py, spec.version_of or name)}
    (venv / STAMP).write_text(json.dumps(stamp, indent=1))
    log(f"{name}: venv ready in {elapsed:.0f} s")
    return py


def _build_from_source(build: SourceBuild, venv: Path, pip: list[str], name: str) -> None:
    """pip-install ``build.requirement`` from its sdist, niced, with SourceBuild's jobs and options."""
    extra, env = build.options(venv) if build.options is not None else ([], {})
    jobs = os.environ.get("MYCOBOT_PEERS_BUILD_JOBS", "1")
    env = {"CMAKE_BUILD_PARALLEL_LEVEL": jobs, **env}
    distribution = build.requirement.split("==")[0]
    nice = shutil.which("nice")
    low_priority = [nice, "-n", "19"] if nice else []
    log(f"{name}: building {build.requirement} from its sdist ({jobs} job(s), low priority; "
        "this takes minutes)")
    started = time.perf_counter()
    _run(low_priority + pip + ["--no-binary", distribution, build.requirement] + extra, "source build",
         name, env)
    log(f"{name}: {build.requirement} built in {time.perf_counter() - started:.0f} s")


def installed_version(py: Path, distribution: str) -> str:
    """Version of a distribution inside a peer venv (importlib.metadata, run by that Python)."""
    proc = subprocess.run(
        [str(py), "-c", f"import importlib.metadata as m; print(m.version({distribution!r}))"],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
    )
    return proc.stdout.strip() if proc.returncode == 0 else "unknown"


def run_runner(name: str, python_of: Callable[[str], Path], runner: Path, request: dict[str, Any],
               timeout: float) -> tuple[list[dict[str, Any]], subprocess.CompletedProcess] | dict[str, Any]:
    """Run a peer's runner script in its venv (``python_of(name)``, normally ensure_peer_venv)
    with ``request`` as JSON on stdin. Returns the JSON records it printed (its other stdout lines
    are library noise) and the finished process; or ``{"available": False, "peer", "reason"}``
    when the venv cannot be built, the runner times out, or it fails before printing a result.
    Never raises for a peer's own failure: one broken peer must not lose the others' figures."""
    try:
        python = python_of(name)
    except PeerUnavailable as error:
        log(str(error))
        return {"available": False, "peer": name, "reason": error.reason}
    except OSError as error:
        return {"available": False, "peer": name, "reason": f"venv creation failed: {error}"}
    started = time.perf_counter()
    try:
        proc = subprocess.run([str(python), str(runner)], input=json.dumps(request), stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"available": False, "peer": name, "reason": f"runner timed out after {timeout:.0f} s"}
    log(f"{name}: runner finished in {time.perf_counter() - started:.1f} s")
    records = []
    for line in proc.stdout.splitlines():
        line = line.strip()
        if line.startswith("{"):
            try:
                records.append(json.loads(line))
            except ValueError:
                continue
    if proc.returncode != 0 and all(r.get("meta") for r in records):
        tail = "\n".join(proc.stderr.strip().splitlines()[-15:])
        print(proc.stderr, file=sys.stderr)
        return {"available": False, "peer": name, "reason": f"runner exited with {proc.returncode}: {tail}"}
    return records, proc
