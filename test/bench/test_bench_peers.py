"""The `peers` benchmark plumbing: problems, path checks, result comparison, runner isolation.

Fast unit tests only: no peer venv is created and no peer library is imported here. The
subprocess protocol is exercised with a stand-in runner script run by this Python.
"""
from __future__ import annotations

import ast
import io
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mycobot_planning.bench import peers
from mycobot_planning.bench.peers import problems as problems_mod
from mycobot_planning.bench.peers import runner_protocol
from mycobot_planning.bench.peers import venvs
from mycobot_planning.bench.peers.problems import (
    ARM_JOINTS, DEFAULT_BOXES, TIP_LINK, absolute_mesh_urdf_text, checker_for, panda_pose_problems,
    panda_srdf_path, srdf_group_state,
)
from mycobot_planning.core import RobotModel, RobotState
from mycobot_planning.core.transforms import pose_to_xyz_quat

PEERS_DIR = Path(peers.__file__).resolve().parent


def quat_angle(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return 2.0 * math.acos(min(1.0, abs(float(np.dot(a / np.linalg.norm(a), b / np.linalg.norm(b))))))


# ---------------------------------------------------------------- problems

def test_problems_are_deterministic_for_a_seed_and_differ_across_seeds():
    first = panda_pose_problems(6, seed=3)
    assert first == panda_pose_problems(6, seed=3)
    assert first != panda_pose_problems(6, seed=4)
    assert [p["index"] for p in first] == list(range(6))
    # A shorter list from the same seed is a prefix: counts can grow without changing problems.
    assert panda_pose_problems(3, seed=3) == first[:3]


def test_problems_are_plain_json():
    problems = panda_pose_problems(4, seed=0)
    assert json.loads(json.dumps(problems)) == problems


def test_problem_start_is_srdf_default_and_goal_fields_are_well_formed():
    default = srdf_group_state(panda_srdf_path(), "default")
    for problem in panda_pose_problems(5, seed=1):
        assert problem["joint_names"] == ARM_JOINTS
        assert problem["start"] == pytest.approx([default[j] for j in ARM_JOINTS])
        assert problem["tip_link"] == TIP_LINK == "panda_hand"
        assert problem["base_frame"] == "panda_link0"
        assert len(problem["goal"]["position"]) == 3
        assert np.linalg.norm(problem["goal"]["orientation_xyzw"]) == pytest.approx(1.0)
        assert problem["obstacles"] == DEFAULT_BOXES
    assert all(p["obstacles"] == [] for p in panda_pose_problems(3, seed=1, obstacles=False))


def test_goals_are_reachable_by_our_own_robot_model_fk(panda: RobotModel):
    """goal = FK(goal_joints) checked with mycobot_planning.core, a different code path."""
    for problem in panda_pose_problems(10, seed=2):
        state = RobotState(panda)
        state.set_joint_positions(dict(zip(problem["joint_names"], problem["goal_joints"])))
        xyz, quat = pose_to_xyz_quat(state.frame_pose(problem["tip_link"]))
        assert np.allclose(xyz, problem["goal"]["position"], atol=1e-6)
        assert quat_angle(quat, problem["goal"]["orientation_xyzw"]) < 1e-6
        assert state.satisfies_bounds()
        assert problem["goal"]["position"][2] >= problems_mod.MIN_GOAL_HEIGHT


def test_goal_configurations_are_collision_free_and_start_is_valid():
    problems = panda_pose_problems(10, seed=5)
    checker = checker_for(problems[0]["obstacles"])
    finger = problems[0]["finger_positions"]["panda_finger_joint1"]
    assert not checker.in_collision(checker.full_q(np.array(problems[0]["start"]), finger))
    for problem in problems:
        assert not checker.in_collision(checker.full_q(np.array(problem["goal_joints"]), finger))


def test_checker_sees_the_boxes():
    """A hand pushed into the front block collides; the same state without boxes does not."""
    problems = panda_pose_problems(1, seed=0)
    with_boxes = checker_for(problems[0]["obstacles"])
    without = checker_for([])
    rng = np.random.default_rng(0)
    low = with_boxes.model.lowerPositionLimit[:7]
    high = with_boxes.model.upperPositionLimit[:7]
    box_hits = 0
    for _ in range(400):
        q = with_boxes.full_q(rng.uniform(low, high), 0.001)
        if with_boxes.in_collision(q) and not without.in_collision(q):
            box_hits += 1
    assert box_hits > 0


def test_negative_count_is_rejected():
    with pytest.raises(ValueError, match="count"):
        panda_pose_problems(-1, seed=0)


def test_absolute_urdf_has_no_package_uris_and_points_at_real_meshes():
    text = absolute_mesh_urdf_text()
    assert "package://" not in text
    meshes = [part.split('"')[0] for part in text.split('filename="')[1:]]
    assert meshes and all(Path(m).is_absolute() and Path(m).is_file() for m in meshes)


def test_write_absolute_urdf_is_idempotent(tmp_path: Path):
    path = problems_mod.write_absolute_urdf(tmp_path)
    mtime = path.stat().st_mtime_ns
    assert problems_mod.write_absolute_urdf(tmp_path) == path
    assert path.stat().st_mtime_ns == mtime


# ---------------------------------------------------------------- path validation

def test_validate_path_accepts_a_still_path_and_rejects_bad_ones():
    problem = panda_pose_problems(1, seed=0)[0]
    start = problem["start"]
    assert peers.validate_path(problem, [start, start]) == (True, "")
    assert peers.validate_path(problem, None) == (False, "no path")
    moved = list(start)
    moved[0] += 0.5
    assert peers.validate_path(problem, [moved, moved])[1] == "path does not start at the start state"
    beyond = list(start)
    beyond[3] = 1.0  # panda_joint4 upper limit is -0.0698
    assert peers.validate_path(problem, [start, beyond])[1] == "path leaves the joint limits"
    assert "shape" in peers.validate_path(problem, [start[:6]])[1]


def test_validate_path_finds_a_collision_between_waypoints():
    """Both ends collision-free, the straight segment between them not: interpolation matters."""
    problem = panda_pose_problems(1, seed=0)[0]
    checker = checker_for(problem["obstacles"])
    start = np.array(problem["start"])
    for goal in (p["goal_joints"] for p in panda_pose_problems(30, seed=11)):
        goal = np.array(goal)
        hits = [checker.in_collision(checker.full_q(start + t * (goal - start), 0.001))
                for t in np.linspace(0, 1, 400)]
        if any(hits):
            break
    else:
        pytest.fail("no colliding straight segment among 30 problems")
    assert not hits[0] and not hits[-1]
    assert peers.validate_path(problem, [start.tolist(), goal.tolist()]) == (False, "path collides")


# ---------------------------------------------------------------- our side (injection point)

def test_run_ours_times_and_judges_results():
    problems = panda_pose_problems(3, seed=0)
    calls = []

    def plan(problem):
        calls.append(problem["index"])
        assert problem["time_limit"] == 0.5
        if problem["index"] == 0:
            return [problem["start"], problem["goal_joints"]]
        if problem["index"] == 1:
            return {"path": [problem["start"], problem["start"]], "status": "wrong goal"}
        raise RuntimeError("planner exploded")

    results = peers.run_ours(problems, plan, time_limit=0.5)
    assert calls == [0, 0, 1, 2]  # untimed warm-up on problem 0 first
    assert [r["index"] for r in results] == [0, 1, 2]
    assert results[0]["success"] and results[0]["goal_position_error"] < 1e-6
    assert results[0]["waypoints"] == 2 and results[0]["path_length"] > 0
    assert "path" not in results[0]
    assert not results[1]["success"] and results[1]["status"] == "wrong goal"
    assert results[1]["goal_position_error"] > 0.01
    assert not results[2]["success"] and "planner exploded" in results[2]["status"]
    assert all(r["seconds"] >= 0 for r in results)


# ---------------------------------------------------------------- compare

def _result(index, success, seconds):
    return {"index": index, "success": success, "seconds": seconds, "path_valid": success,
            "path_length": 1.0 if success else None}


def test_compare_math_on_synthetic_results():
    ours = [_result(0, True, 0.1), _result(1, True, 0.2), _result(2, True, 0.3), _result(3, False, 1.0)]
    peer_a = {"available": True, "version": "9.9", "results": [
        _result(0, True, 0.2), _result(1, True, 0.8), _result(2, False, 1.0), _result(3, True, 0.5)]}
    peer_b = [_result(i, False, 1.0) for i in range(4)]
    report = peers.compare(ours, {"a": peer_a, "b": peer_b,
                                  "c": {"available": False, "reason": "pip said no"}})
    assert report["ours"]["success_rate"] == 0.75
    assert report["ours"]["median_s"] == pytest.approx(0.2)
    assert report["ours"]["median_all_s"] == pytest.approx(0.25)
    a = report["peers"]["a"]
    assert a["version"] == "9.9" and a["available"]
    assert a["success_rate"] == 0.75 and a["solved"] == 3
    assert a["median_s"] == pytest.approx(0.5)          # of 0.2, 0.8, 0.5
    assert a["both_solved"] == 2                          # problems 0 and 1
    assert a["ours_median_both_s"] == pytest.approx(0.15)
    assert a["peer_median_both_s"] == pytest.approx(0.5)
    assert a["ratio_median_both"] == pytest.approx(0.3)
    assert a["ratio_median_overall"] == pytest.approx(0.4)  # 0.2 / 0.5
    assert a["ratio_paired_median"] == pytest.approx((0.5 + 0.25) / 2)
    b = report["peers"]["b"]
    assert b["success_rate"] == 0.0 and b["median_s"] is None
    assert b["both_solved"] == 0 and b["ratio_median_both"] is None and b["ratio_median_overall"] is None
    assert report["peers"]["c"] == {"available": False, "reason": "pip said no"}
    json.dumps(report, allow_nan=False)  # emit-able as strict JSON


def test_compare_without_ours_and_report_records():
    report = peers.compare(None, {"a": [_result(0, True, 0.1)]})
    assert report["ours"] is None
    assert "ratio_median_both" not in report["peers"]["a"]
    records = peers.report_records(peers.compare([_result(0, True, 0.1)], {"a": [_result(0, True, 0.2)]}))
    assert [r["planner"] for r in records] == ["ours", "a"]
    assert all(r["scenario"] == "peers" for r in records)


# ---------------------------------------------------------------- runner isolation and protocol

@pytest.mark.parametrize("runner", ["mplib_runner.py", "pyroboplan_runner.py", "roboplan_runner.py",
                                    "runner_protocol.py", "vamp_runner.py"])
def test_runner_scripts_import_only_stdlib_numpy_and_their_peer(runner: str):
    # The runners run in a peer venv without mycobot_planning: besides their peer they may import
    # only their sibling runner_protocol (by plain name, from the script's folder), which itself
    # imports only the standard library and numpy.
    tree = ast.parse((PEERS_DIR / runner).read_text())
    imported = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imported.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, f"{runner} has a relative import"
            imported.add(node.module.split(".")[0])
    peer_libs = {"mplib_runner.py": {"mplib"}, "pyroboplan_runner.py": {"pyroboplan", "pinocchio", "coal"},
                 "roboplan_runner.py": {"roboplan"}, "runner_protocol.py": set(), "vamp_runner.py": {"vamp"}}
    allowed = set(sys.stdlib_module_names) | {"__future__", "numpy"} | peer_libs[runner]
    if runner != "runner_protocol.py":
        allowed.add("runner_protocol")
    assert "mycobot_planning" not in imported
    assert imported <= allowed, imported - allowed


def test_runner_protocol_parts_lines_keep_going_past_a_failing_problem():
    parts = {"ik": [{"index": 0}, {"index": 1}], "check": [[0.0], [2.0]], "plan": [{"index": 0}, {"index": 1}]}
    calls = []

    def solve_ik(problem):
        calls.append(("ik", problem["index"]))
        if problem["index"] == 1:
            raise ValueError("no model")
        return {"seconds": 0.5, "solution": [0.1]}

    def plan(problem):
        calls.append(("plan", problem["index"]))
        if problem["index"] == 1:
            raise RuntimeError("crashed")
        return {"seconds": 0.25, "status": "Success", "path": [[0.0], [1.0]]}

    out = io.StringIO()
    assert runner_protocol.run_parts(out, "peer_that_is_not_installed", 1.23456, parts, solve_ik,
                                     lambda q: q[0], lambda x: x > 1.0, plan) == 0
    lines = [json.loads(line) for line in out.getvalue().splitlines()]
    assert lines[0] == {"meta": True, "peer": "peer_that_is_not_installed", "version": "unknown",
                        "setup_seconds": 1.2346}
    assert lines[1] == {"part": "ik", "index": 0, "seconds": 0.5, "solution": [0.1]}
    assert lines[2] == {"part": "ik", "index": 1, "seconds": None, "solution": None,
                        "status": "error: ValueError: no model"}
    assert lines[3]["part"] == "check" and lines[3]["colliding"] == [False, True]
    assert len(lines[3]["seconds"]) == 2
    assert lines[4] == {"part": "plan", "index": 0, "seconds": 0.25, "status": "Success", "path": [[0.0], [1.0]]}
    assert list(lines[5]) == ["part", "index", "seconds", "status", "path"]
    assert lines[5]["status"] == "error: RuntimeError: crashed" and lines[5]["path"] is None
    assert calls[:2] == [("ik", 0), ("plan", 0)]  # the untimed warm-ups come before the meta line


def test_runner_protocol_pose_lines_judge_the_goal_errors():
    problems = [{"index": 0}, {"index": 1}, {"index": 2}]
    paths = {0: [[0.0, 0.0], [3.0, 4.0]], 1: None}

    def solve(problem):
        if problem["index"] == 2:
            raise RuntimeError("lost")
        return 0.1, "Success" if paths[problem["index"]] else "IK failed", paths[problem["index"]]

    out = io.StringIO()
    runner_protocol.run_pose_problems(out, "x", 0.0, problems, solve, lambda problem, path: (0.005, 0.03))
    records = [json.loads(line) for line in out.getvalue().splitlines()][1:]
    assert records[0]["waypoints"] == 2 and records[0]["path_length"] == 5.0
    assert records[0]["claimed_success"] and not records[0]["success"]  # 0.03 rad is past 0.02
    assert records[1] == {"index": 1, "success": False, "claimed_success": False, "seconds": 0.1,
                          "status": "IK failed"}
    assert records[2] == {"index": 2, "success": False, "claimed_success": False, "seconds": None,
                          "status": "error: RuntimeError: lost"}


def test_every_peer_has_a_runner_and_pinned_spec():
    # The planner peers of the "peers" scenario (vamp only in its parts: it has no IK for the
    # pose-goal problems), plus toppra, which the time_parameterization scenario runs through its
    # own runner.
    assert set(peers.PEER_NAMES) | {"vamp"} == set(peers.RUNNERS)
    assert set(venvs.PEERS) == set(peers.RUNNERS) | {"toppra"}
    for name, spec in venvs.PEERS.items():
        runner = peers.runner_path(name) if name in peers.RUNNERS else peers.runner_path("mplib").with_name("toppra_runner.py")
        assert runner.is_file(), name
        assert all("==" in req for req in spec.pins), name
    assert venvs.PEERS["vamp"].pins[-1] == "vamp-planner==0.6.4"


def test_run_peer_reports_an_unavailable_peer_instead_of_raising(monkeypatch):
    def refuse(name):
        raise venvs.PeerUnavailable(name, "pip install failed (exit 1): no matching distribution")

    monkeypatch.setattr(peers, "ensure_peer_venv", refuse)
    runs = peers.run_peers(panda_pose_problems(1, seed=0), peers=["mplib"])
    assert runs == {"mplib": {"available": False, "peer": "mplib",
                              "reason": "pip install failed (exit 1): no matching distribution"}}


FAKE_RUNNER = r'''
import json, os, sys
request = json.load(sys.stdin)
print("library noise on stdout that must be ignored")
print(json.dumps({"meta": True, "peer": "fake", "version": "1.2.3", "setup_seconds": 0.01}))
for p in request["problems"][:-1]:  # leaves the last problem without a result
    path = [p["start"], p["goal_joints"]] if p["index"] == 0 else None
    rec = {"index": p["index"], "claimed_success": path is not None, "success": path is not None,
           "seconds": 0.05, "status": "ok" if path else "failed"}
    if path:
        rec["path"] = path
    print(json.dumps(rec))
print(request["time_limit"], file=sys.stderr)
'''


def test_run_peer_parses_runner_output_and_fills_gaps(monkeypatch, tmp_path: Path):
    script = tmp_path / "fake_runner.py"
    script.write_text(FAKE_RUNNER)
    monkeypatch.setenv("MYCOBOT_PEERS_DIR", str(tmp_path / "peers"))
    monkeypatch.setattr(peers, "ensure_peer_venv", lambda name: Path(sys.executable))
    monkeypatch.setattr(peers, "runner_path", lambda name: script)
    problems = panda_pose_problems(3, seed=0)
    run = peers.run_peer("mplib", problems, time_limit=0.25)
    assert run["available"] and run["version"] == "1.2.3"
    results = run["results"]
    assert [r["index"] for r in results] == [0, 1, 2]
    assert results[0]["success"] and results[0]["goal_position_error"] < 1e-6
    assert "path" not in results[0] and results[0]["path_valid"] in (True, False)
    assert not results[1]["success"] and results[1]["path_problem"] == "no path"
    assert not results[2]["success"] and "no result" in results[2]["status"]
    assert (tmp_path / "peers" / "cache" / "panda_abs.urdf").is_file()


def test_run_peer_reports_a_crashing_runner(monkeypatch, tmp_path: Path):
    script = tmp_path / "crash.py"
    script.write_text("import sys\nprint('ImportError: libfoo.so missing', file=sys.stderr)\nsys.exit(3)\n")
    monkeypatch.setenv("MYCOBOT_PEERS_DIR", str(tmp_path / "peers"))
    monkeypatch.setattr(peers, "ensure_peer_venv", lambda name: Path(sys.executable))
    monkeypatch.setattr(peers, "runner_path", lambda name: script)
    run = peers.run_peer("pyroboplan", panda_pose_problems(1, seed=0))
    assert run["available"] is False
    assert "exited with 3" in run["reason"] and "libfoo.so missing" in run["reason"]


# ---------------------------------------------------------------- venvs (no venv is created)

def test_ensure_peer_venv_rejects_unknown_peer():
    with pytest.raises(KeyError, match="unknown peer 'moveit'"):
        venvs.ensure_peer_venv("moveit")


def test_ensure_peer_venv_reuses_a_stamped_venv_without_running_anything(monkeypatch, tmp_path: Path):
    monkeypatch.setenv("MYCOBOT_PEERS_DIR", str(tmp_path))
    venv = tmp_path / "mplib"
    (venv / "bin").mkdir(parents=True)
    (venv / "bin" / "python").write_text("")
    (venv / venvs.STAMP).write_text(json.dumps(venvs._stamp_for(venvs.PEERS["mplib"])))

    def no_subprocess(*args, **kwargs):
        raise AssertionError("a stamped venv must be reused without running pip")

    monkeypatch.setattr(venvs.subprocess, "run", no_subprocess)
    assert venvs.ensure_peer_venv("mplib") == venv / "bin" / "python"


def test_stale_stamp_triggers_a_rebuild(monkeypatch, tmp_path: Path):
    monkeypatch.setenv("MYCOBOT_PEERS_DIR", str(tmp_path))
    venv = tmp_path / "mplib"
    (venv / "bin").mkdir(parents=True)
    (venv / "bin" / "python").write_text("")
    (venv / venvs.STAMP).write_text(json.dumps({"requirements": ["mplib==0.1.0"]}))
    commands = []

    class Done:
        returncode = 1
        stdout = "ERROR: could not create venv"

    def fake_run(cmd, **kwargs):
        commands.append(cmd)
        return Done()

    monkeypatch.setattr(venvs.subprocess, "run", fake_run)
    with pytest.raises(venvs.PeerUnavailable, match="could not create venv"):
        venvs.ensure_peer_venv("mplib")
    assert not (venv / venvs.STAMP).exists()  # the stale venv was removed before rebuilding
    assert commands and commands[0][1:3] == ["-m", "venv"]


def test_peers_root_defaults_to_the_gitignored_checkout_folder(monkeypatch):
    monkeypatch.delenv("MYCOBOT_PEERS_DIR", raising=False)
    root = venvs.peers_root()
    repo = PEERS_DIR.parents[2]
    if (repo / "setup.py").is_file():
        assert root == repo / ".venv-peers"
        assert ".venv-peers/" in (repo / ".gitignore").read_text()


# ---------------------------------------------------------------- vamp: built from its sdist

def _fake_venv(root: Path, name: str) -> Path:
    venv = root / name
    (venv / "bin").mkdir(parents=True)
    (venv / "bin" / "python").write_text("")
    return venv


def test_other_peers_stamps_do_not_change_with_source_builds():
    assert "source_build" not in venvs._stamp_for(venvs.PEERS["mplib"])
    assert venvs._stamp_for(venvs.PEERS["vamp"])["source_build"] == "vamp-planner==0.6.4"


def test_vamp_build_options_build_the_panda_only_and_find_the_venvs_eigen(monkeypatch, tmp_path: Path):
    monkeypatch.delenv("MYCOBOT_VAMP_SOURCES", raising=False)
    venv = tmp_path / "vamp"
    prefix = venv / "lib" / "python3.11" / "site-packages" / "cmeel.prefix"
    prefix.mkdir(parents=True)
    args, env = venvs.vamp_build_options(venv)
    assert "--config-settings=cmake.define.VAMP_ROBOT_MODULES=panda" in args
    assert "--config-settings=cmake.define.VAMP_ROBOT_STRUCTS=Panda" in args
    assert not any("CPM_" in a for a in args)
    assert env == {"CMAKE_PREFIX_PATH": str(prefix)}


def test_vamp_sources_folder_replaces_the_github_downloads(monkeypatch, tmp_path: Path):
    sources = tmp_path / "src"
    monkeypatch.setenv("MYCOBOT_PEERS_DIR", str(tmp_path / "peers"))
    monkeypatch.setenv("MYCOBOT_VAMP_SOURCES", str(sources))
    sources.mkdir()
    (sources / "CPM.cmake").write_text("# cpm")
    with pytest.raises(venvs.PeerUnavailable, match="lacks nanobind, nigh, pdqsort, SIMDxorshift"):
        venvs.vamp_build_options(tmp_path / "vamp")
    for dep in venvs.VAMP_GITHUB_SOURCES:
        (sources / dep).mkdir()
    args, _ = venvs.vamp_build_options(tmp_path / "vamp")
    settings = dict(a.removeprefix("--config-settings=").split("=", 1) for a in args)
    for dep in venvs.VAMP_GITHUB_SOURCES:
        assert settings[f"cmake.define.CPM_{dep}_SOURCE"] == str(sources / dep)
    seed = Path(settings["cmake.define.CMAKE_PROJECT_vamp_INCLUDE"])
    assert seed.is_file() and str(sources / "CPM.cmake") in seed.read_text()
    assert "${CMAKE_BINARY_DIR}/cmake" in seed.read_text()  # where vamp's FetchInitCPM downloads it


class _Proc:
    def __init__(self, returncode: int = 0, stdout: str = ""):
        self.returncode, self.stdout = returncode, stdout


def test_vamp_venv_is_compiled_niced_with_one_job_and_stamped(monkeypatch, tmp_path: Path):
    monkeypatch.setenv("MYCOBOT_PEERS_DIR", str(tmp_path))
    monkeypatch.delenv("MYCOBOT_VAMP_SOURCES", raising=False)
    monkeypatch.delenv("MYCOBOT_PEERS_BUILD_JOBS", raising=False)
    calls = []

    def fake_run(cmd, **kwargs):
        calls.append((cmd, kwargs.get("env")))
        if cmd[1:3] == ["-m", "venv"]:
            _fake_venv(tmp_path, "vamp")
        if "importlib.metadata" in " ".join(cmd):
            return _Proc(0, "0.6.4\n")
        return _Proc()

    monkeypatch.setattr(venvs.subprocess, "run", fake_run)
    python = venvs.ensure_peer_venv("vamp")
    assert python == tmp_path / "vamp" / "bin" / "python"
    build = [(cmd, env) for cmd, env in calls if "--no-binary" in cmd]
    assert len(build) == 1
    cmd, env = build[0]
    assert cmd[1:3] == ["-n", "19"] and cmd[cmd.index("--no-binary") + 1] == "vamp-planner"
    assert "vamp-planner==0.6.4" in cmd and env["CMAKE_BUILD_PARALLEL_LEVEL"] == "1"
    stamp = venvs.read_stamp("vamp")
    assert stamp["source_build"] == "vamp-planner==0.6.4" and stamp["version"] == "0.6.4"
    calls.clear()
    assert venvs.ensure_peer_venv("vamp") == python and calls == []  # reused, nothing run


def test_a_failed_vamp_build_makes_it_unavailable_with_the_compiler_error(monkeypatch, tmp_path: Path):
    monkeypatch.setenv("MYCOBOT_PEERS_DIR", str(tmp_path))
    monkeypatch.delenv("MYCOBOT_VAMP_SOURCES", raising=False)
    log = ["Building wheel for vamp-planner (pyproject.toml): started",
           "  CMake Error at cmake/FetchInitCPM.cmake:1 (file):",
           "    file DOWNLOAD cannot compute hash on failed download", "",
           '      status: [6;"Could not resolve hostname"]']
    log += [f"  noise line {i}" for i in range(40)]
    log += ["error: subprocess-exited-with-error", "ERROR: Failed to build installable wheels for some "
            "pyproject.toml based projects (vamp-planner)"]

    def fake_run(cmd, **kwargs):
        if cmd[1:3] == ["-m", "venv"]:
            _fake_venv(tmp_path, "vamp")
        return _Proc(1, "\n".join(log)) if "--no-binary" in cmd else _Proc()

    monkeypatch.setattr(venvs.subprocess, "run", fake_run)
    with pytest.raises(venvs.PeerUnavailable) as caught:
        venvs.ensure_peer_venv("vamp")
    reason = caught.value.reason
    assert reason.startswith("source build failed (exit 1)")
    assert "CMake Error at cmake/FetchInitCPM.cmake" in reason  # the cause, far above the tail
    assert 'status: [6;"Could not resolve hostname"]' in reason  # and why
    assert reason.endswith("(vamp-planner)")
    assert venvs.read_stamp("vamp") is None  # not stamped: rebuilt next time


def test_failure_excerpt_keeps_first_errors_with_their_context_and_the_tail_once():
    lines = ["a", "x.cc:1: error: no member", "  named foo", "", "b", "c", "d", "e", "error: last"]
    assert venvs.failure_excerpt(lines, context=2, tail=2) == (
        "x.cc:1: error: no member\nnamed foo\n...\ne\nerror: last")
    assert venvs.failure_excerpt(["ok", "done"], tail=5) == "ok\ndone"


def test_vamp_pose_problems_are_answered_not_supported(tmp_path: Path):
    # The runner's pose-goal branch imports neither vamp nor numpy: run it with this Python.
    request = {"problems": [{"index": 0}, {"index": 1}]}
    proc = subprocess.run([sys.executable, str(PEERS_DIR / "vamp_runner.py")], input=json.dumps(request),
                          capture_output=True, text=True, check=True)
    records = [json.loads(line) for line in proc.stdout.splitlines()]
    assert records[0]["meta"] and [r["index"] for r in records[1:]] == [0, 1]
    assert all("no IK" in r["status"] for r in records[1:])
