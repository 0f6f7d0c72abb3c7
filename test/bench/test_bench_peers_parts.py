"""The `peers` scenario's three parts (IK, checks, joint-goal plans): problems, the independent
judging, summaries and ratios, the runner protocol, and our own side on a tiny set.

No peer venv is created and no peer library is imported: the runner protocol is exercised with
a stand-in script run by this Python.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from mycobot_planning.bench.peers import parts as parts_mod
from mycobot_planning.bench.peers.parts import (
    OursParts, judge_parts, parts_ratios, recheck_path, reference_colliding, run_ours_parts,
    run_peer_parts, summarize_parts,
)
from mycobot_planning.bench.peers.problems import ARM_JOINTS, PARTS_BOX, checker_for, panda_parts_problems


@pytest.fixture(scope="module")
def small():
    return panda_parts_problems(0, ik_count=4, check_count=60, plan_count=3)


def test_parts_are_deterministic_plain_json_and_well_formed(small):
    assert small == panda_parts_problems(0, ik_count=4, check_count=60, plan_count=3)
    assert small != panda_parts_problems(1, ik_count=4, check_count=60, plan_count=3)
    assert json.loads(json.dumps(small)) == small
    assert small["joint_names"] == ARM_JOINTS and small["obstacles"] == [PARTS_BOX]
    assert [len(small[k]) for k in ("ik", "check", "plan")] == [4, 60, 3]
    checker = checker_for(small["obstacles"])
    finger = next(iter(small["finger_positions"].values()))
    for problem in small["ik"]:  # every IK goal is the pose of a collision-free configuration
        q = checker.full_q(np.asarray(problem["goal_joints"]), finger)
        assert not checker.in_collision(q)
        position, quat = checker.tip_pose(q)
        assert np.allclose(position, problem["goal"]["position"])
        assert abs(float(np.dot(quat, problem["goal"]["orientation_xyzw"]))) == pytest.approx(1.0)
    for problem in small["plan"]:
        for end in ("start", "goal"):
            assert not checker.in_collision(checker.full_q(np.asarray(problem[end]), finger))
    with pytest.raises(ValueError, match="plan_count"):
        panda_parts_problems(0, plan_count=-1)


def test_recheck_judges_ends_limits_and_collisions(small):
    problem = small["plan"][0]
    start, goal = np.asarray(problem["start"]), np.asarray(problem["goal"])
    assert recheck_path(small, problem, None) == (False, False, "no path")
    reaches, valid, _ = recheck_path(small, problem, [start, start])
    assert not reaches and valid
    # through a configuration that hits the box: found between the waypoints too
    reference = reference_colliding(small)
    hit = np.asarray(small["check"][reference.index(True)])
    reaches, valid, why = recheck_path(small, problem, [start, hit, goal])
    assert reaches and not valid and why in ("path collides", "path leaves the joint limits")
    outside = start.copy()
    outside[0] = 10.0
    assert recheck_path(small, problem, [start, outside, goal])[2] == "path leaves the joint limits"
    assert recheck_path(small, problem, [[0.0] * 3])[1] is False


def test_ik_answers_are_judged_by_our_fk_and_checker(small):
    problem = small["ik"][0]
    good = problem["goal_joints"]
    assert parts_mod._ik_ok(small, problem, good)
    off = list(good)
    off[0] += 0.01
    assert not parts_mod._ik_ok(small, problem, off)
    assert not parts_mod._ik_ok(small, problem, None)
    assert not parts_mod._ik_ok(small, problem, good[:3])


def _run(ik_seconds, ik_ok, check_seconds, plan_seconds, plan_valid):
    return {
        "ik": [{"seconds": s, "ok": ok} for s, ok in zip(ik_seconds, ik_ok)],
        "check": {"seconds": check_seconds, "colliding": [False] * len(check_seconds), "agree": len(check_seconds)},
        "plan": [{"seconds": s, "path": [[0.0]], "reaches": True, "valid": v} for s, v in zip(plan_seconds, plan_valid)],
    }


def test_summaries_and_ratios_on_synthetic_runs():
    ours = summarize_parts([_run([0.001, 0.003], [True, True], [2e-6, 4e-6], [0.01, 0.02, 0.03], [True] * 3)])
    peer = summarize_parts([_run([0.002, 0.004], [True, False], [4e-6, 4e-6], [0.02, 0.04, 0.5], [True, True, False])])
    assert ours["ik_success_rate"] == 1.0 and peer["ik_success_rate"] == 0.5
    assert ours["ik_median_ms"] == pytest.approx(2.0) and peer["ik_median_ms"] == pytest.approx(3.0)
    assert ours["check_median_us"] == pytest.approx(3.0) and ours["check_agreement"] == 1.0
    assert ours["plan_median_ms"] == pytest.approx(20.0) and ours["invalid_paths"] == 0
    assert peer["plan_solved"] == 2 and peer["invalid_paths"] == 1 and peer["plan_median_ms"] == pytest.approx(30.0)
    ratios = parts_ratios({"ours": ours, "roboplan": peer})
    assert ratios["ik_ratio"] == pytest.approx(2.0 / 3.0, abs=1e-4)
    assert ratios["check_ratio"] == pytest.approx(0.75)
    assert ratios["plan_ratio"] == pytest.approx(20.0 / 30.0, abs=1e-4)
    assert ratios["invalid_paths"] == {"ours": 0, "roboplan": 1}
    assert parts_ratios({"ours": ours})["plan_ratio"] is None


FAKE_PARTS_RUNNER = r'''
import json, sys
request = json.load(sys.stdin)
parts = request["parts"]
print("library noise")
print(json.dumps({"meta": True, "peer": "fake", "version": "9.9", "setup_seconds": 0.0}))
for p in parts["ik"][:-1]:  # the last IK problem gets no record
    print(json.dumps({"part": "ik", "index": p["index"], "seconds": 1e-4, "solution": p["goal_joints"]}))
print(json.dumps({"part": "check", "seconds": [1e-6] * len(parts["check"]),
                  "colliding": [False] * len(parts["check"])}))
for p in parts["plan"]:
    print(json.dumps({"part": "plan", "index": p["index"], "seconds": 0.01, "status": "Success",
                      "path": [p["start"], p["start"]]}))
'''


def test_run_peer_parts_parses_the_runner_and_fills_gaps(monkeypatch, tmp_path: Path, small):
    script = tmp_path / "fake.py"
    script.write_text(FAKE_PARTS_RUNNER)
    monkeypatch.setenv("MYCOBOT_PEERS_DIR", str(tmp_path / "peers"))
    monkeypatch.setattr(parts_mod, "ensure_peer_venv", lambda name: Path(sys.executable))
    monkeypatch.setattr(parts_mod, "runner_path", lambda name: script)
    run = run_peer_parts("roboplan", small)
    assert run["available"] and run["version"] == "9.9"
    assert [r["index"] for r in run["ik"]] == [0, 1, 2, 3]
    assert run["ik"][-1]["solution"] is None and "no result" in run["ik"][-1]["status"]
    judge_parts(small, run, reference_colliding(small))
    summary = summarize_parts([run])
    assert summary["ik_solved"] == 3
    assert summary["check_agreement"] == pytest.approx(1.0 - sum(reference_colliding(small)) / 60, abs=1e-4)
    # a path that stays at the start reaches no goal: claimed, valid, not solved
    assert summary["plan_solved"] == 0 and summary["paths_missing_goal"] == 3 and summary["invalid_paths"] == 0


def test_run_peer_parts_reports_an_unavailable_peer(monkeypatch, small):
    from mycobot_planning.bench.peers.venvs import PeerUnavailable

    def refuse(name):
        raise PeerUnavailable(name, "no wheel")

    monkeypatch.setattr(parts_mod, "ensure_peer_venv", refuse)
    assert run_peer_parts("roboplan", small) == {"available": False, "peer": "roboplan", "reason": "no wheel"}
    with pytest.raises(KeyError):
        run_peer_parts("moveit", small)


def test_our_side_solves_the_small_set_and_passes_the_independent_checks(small):
    run = run_ours_parts(small, seed=0)
    judge_parts(small, run, reference_colliding(small))
    summary = summarize_parts([run])
    assert summary["ik_solved"] == 4
    assert summary["check_agreement"] == 1.0
    assert summary["plan_solved"] == 3 and summary["invalid_paths"] == 0


def test_bench_records_and_summary_keys(monkeypatch):
    records = []
    summary = parts_mod.bench_peers_parts(1, 0, emit=records.append, peers=(), ik_count=2, check_count=20,
                                          plan_count=2)
    assert records[-1] is summary and summary["summary"] is True
    assert {"ik_ratio", "check_ratio", "plan_ratio", "invalid_paths", "planners"} <= set(summary)
    assert summary["invalid_paths"] == {"ours": 0}
    assert records[0]["planner"] == "ours" and records[0]["plan_solved"] == 2


def test_ours_parts_checker_agrees_with_the_reference_on_colliding_states(small):
    ours = OursParts(small)
    reference = reference_colliding(small)
    assert any(reference)
    assert [not ours.check(np.asarray(q)) for q in small["check"]] == reference


# ---------------------------------------------------------------- vamp (check and plan parts only)

def test_vamp_figures_and_ratios_on_synthetic_runs():
    ours = summarize_parts([_run([0.001], [True], [6e-6, 6e-6], [0.01, 0.02, 0.03], [True] * 3)])
    vamp = summarize_parts([_run([], [], [2e-6, 2e-6], [0.001, 0.002, 0.5], [True, True, False])])
    figures = parts_mod.vamp_figures({"ours": ours, "vamp": vamp})
    assert figures["vamp_check_us"] == pytest.approx(2.0) and figures["check_ratio_vamp"] == pytest.approx(3.0)
    assert figures["vamp_plan_ms"] == pytest.approx(1.5) and figures["plan_ratio_vamp"] == pytest.approx(20 / 1.5,
                                                                                                          abs=1e-3)
    assert figures["vamp_success_rate"] == pytest.approx(2 / 3, abs=1e-4) and figures["vamp_invalid_paths"] == 1
    unavailable = parts_mod.vamp_figures({"ours": ours})
    assert set(unavailable) == set(figures) and all(v is None for v in unavailable.values())


def test_vamp_is_asked_no_ik_and_its_summary_says_so(monkeypatch, tmp_path: Path, small):
    script = tmp_path / "fake.py"
    script.write_text(FAKE_PARTS_RUNNER.replace('print("library noise")',
                                                'print("library noise"); assert parts["ik"] == []'))
    monkeypatch.setenv("MYCOBOT_PEERS_DIR", str(tmp_path / "peers"))
    monkeypatch.setattr(parts_mod, "ensure_peer_venv", lambda name: Path(sys.executable))
    monkeypatch.setattr(parts_mod, "runner_path", lambda name: script)
    run = run_peer_parts("vamp", small)
    assert run["available"] and run["ik"] == [] and run["pins"][-1] == "vamp-planner==0.6.4"
    judge_parts(small, run, reference_colliding(small))
    summary = summarize_parts([run])
    assert summary["ik_problems"] == 0 and summary["ik_success_rate"] is None
    assert summary["check_states"] == 60 and summary["plan_problems"] == 3
    # the fake calls every state free: each colliding one is a miss
    assert summary["check_missed"] == sum(reference_colliding(small)) > 0


def test_bench_summary_has_the_vamp_keys_even_without_vamp():
    records = []
    summary = parts_mod.bench_peers_parts(1, 0, emit=records.append, peers=(), ik_count=1, check_count=5,
                                          plan_count=1)
    keys = {"vamp_check_us", "vamp_plan_ms", "vamp_success_rate", "vamp_invalid_paths", "check_ratio_vamp",
            "plan_ratio_vamp"}
    assert keys <= set(summary) and all(summary[k] is None for k in keys)
    assert "vamp" in parts_mod.PARTS_PEERS


def _rotation(xyzw) -> np.ndarray:
    x, y, z, w = np.asarray(xyzw, float) / np.linalg.norm(xyzw)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def test_vamp_cuboids_get_the_boxes_pose_and_half_sizes(monkeypatch):
    # the runner imports its sibling runner_protocol by plain name, as the peer venv runs it
    monkeypatch.syspath_prepend(str(Path(parts_mod.__file__).resolve().parent))
    from mycobot_planning.bench.peers.vamp_runner import cuboid_args

    rng = np.random.default_rng(3)
    for xyzw in [[0, 0, 0, 1], [0, 0, 0.7071068, 0.7071068], *rng.normal(size=(20, 4))]:
        center, (roll, pitch, yaw), half = cuboid_args({"size": [0.2, 0.4, 0.6], "position": [0.5, 0.0, 0.5],
                                                        "orientation_xyzw": list(xyzw)})
        cx, sx, cy, sy, cz, sz = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
        rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
        ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
        rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
        # vamp's factory: rotation = AngleAxis(yaw, Z) * AngleAxis(pitch, Y) * AngleAxis(roll, X)
        assert np.allclose(rz @ ry @ rx, _rotation(xyzw), atol=1e-9)
        assert center == [0.5, 0.0, 0.5] and half == pytest.approx([0.1, 0.2, 0.3])
