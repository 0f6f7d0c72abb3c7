"""Solve the benchmark's Panda pose-goal problems with mplib (run by the mplib peer venv's Python).

The full story: docs/bench.md, section mycobot_planning.bench.peers.mplib_runner.
"""
from __future__ import annotations

import json
import math
import os
import re
import sys
import tempfile
import time

PEER = "mplib"


def _json_out():
    """A writer on the original stdout; fd 1 (and sys.stdout) then go to stderr."""
    sys.stdout.flush()
    out = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    return out


def _read_request() -> dict:
    if len(sys.argv) > 1 and sys.argv[1] != "-":
        with open(sys.argv[1]) as handle:
            return json.load(handle)
    return json.load(sys.stdin)


def _relative_mesh_urdf(urdf: str, directory: str) -> str:
    """Copy of the URDF with mesh paths relative to ``directory``.

    mplib 0.2.1 joins every mesh filename onto the URDF's folder, even an absolute one
    ("/tmp/x/work/..."), so absolute mesh paths must be made relative to where the copy lives.
    """
    with open(urdf) as handle:
        text = handle.read()

    def fix(match: re.Match) -> str:
        path = match.group(1)
        if os.path.isabs(path):
            path = os.path.relpath(path, directory)
        return f'filename="{path}"'

    text = re.sub(r'filename="([^"]+)"', fix, text)
    out = os.path.join(directory, "panda_mplib.urdf")
    with open(out, "w") as handle:
        handle.write(text)
    return out


def _quat_angle(q1_xyzw, q2_xyzw) -> float:
    dot = abs(sum(a * b for a, b in zip(q1_xyzw, q2_xyzw)))
    return 2.0 * math.acos(min(1.0, dot))


def main() -> int:
    out = _json_out()
    request = _read_request()
    if "parts" in request:
        return _run_parts(out, request)
    import numpy as np
    import mplib
    from mplib import Pose
    from mplib.collision_detection import fcl

    time_limit = float(request.get("time_limit", 1.0))
    problems = request["problems"]
    workdir = tempfile.mkdtemp(prefix="mplib_peer_")
    started = time.perf_counter()
    urdf = _relative_mesh_urdf(request["urdf"], workdir)
    tip = problems[0]["tip_link"] if problems else "panda_hand"
    planner = mplib.Planner(urdf, tip, srdf=request["srdf"])
    names = list(planner.user_joint_names)
    link_index = planner.link_name_2_idx[tip]

    boxes = problems[0].get("obstacles", []) if problems else []
    for box in boxes:
        x, y, z, w = box["orientation_xyzw"]
        shape = fcl.CollisionObject(fcl.Box(np.asarray(box["size"], dtype=float)), Pose())
        obj = fcl.FCLObject(box["id"], Pose(box["position"], [w, x, y, z]), [shape], [Pose()])
        planner.planning_world.add_object(obj)

    def full_qpos(problem: dict) -> np.ndarray:
        """All mplib joints (arm + both fingers) from the problem's arm start and finger values."""
        values = dict(zip(problem["joint_names"], problem["start"]))
        values.update(problem.get("finger_positions", {}))
        return np.array([values.get(name, 0.0) for name in names], dtype=float)

    def goal_pose(problem: dict) -> Pose:
        x, y, z, w = problem["goal"]["orientation_xyzw"]
        return Pose(problem["goal"]["position"], [w, x, y, z])  # mplib quaternions are wxyz

    def solve(problem: dict) -> tuple[float, dict]:
        qpos = full_qpos(problem)
        goal = goal_pose(problem)
        t0 = time.perf_counter()
        result = planner.plan_pose(goal, qpos, planning_time=time_limit)
        return time.perf_counter() - t0, result

    setup_seconds = time.perf_counter() - started
    if problems:
        solve(problems[0])  # warm-up, untimed
    out.write(json.dumps({"meta": True, "peer": PEER, "version": _version(),
                          "setup_seconds": round(setup_seconds, 4)}) + "\n")

    arm = [names.index(j) for j in problems[0]["joint_names"]] if problems else []
    for problem in problems:
        record = {"index": problem["index"], "success": False, "claimed_success": False}
        try:
            seconds, result = solve(problem)
            record["seconds"] = seconds
            record["status"] = str(result.get("status"))
            record["claimed_success"] = result.get("status") == "Success"
            if record["claimed_success"]:
                path = np.asarray(result["position"], dtype=float)  # move-group joints only
                record["waypoints"] = int(len(path))
                record["path_length"] = float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
                record["path"] = [[float(v) for v in q] for q in path]
                final = full_qpos(problem)
                final[arm] = path[-1]
                planner.pinocchio_model.compute_forward_kinematics(final)
                reached = planner.pinocchio_model.get_link_pose(link_index)
                w, x, y, z = (float(v) for v in reached.q)
                record["goal_position_error"] = float(
                    np.linalg.norm(np.asarray(reached.p) - np.asarray(problem["goal"]["position"])))
                record["goal_rotation_error"] = _quat_angle(
                    [x, y, z, w], problem["goal"]["orientation_xyzw"])
                record["success"] = (record["goal_position_error"] < 1e-2
                                     and record["goal_rotation_error"] < 2e-2)
        except Exception as error:  # one bad problem must not lose the others' results
            record.setdefault("seconds", None)
            record["status"] = f"error: {type(error).__name__}: {error}"
        out.write(json.dumps(record) + "\n")
    return 0


def _run_parts(out, request: dict) -> int:
    """The three parts (IK, validity checks, joint-goal plans); see docs/bench.md."""
    import numpy as np
    import mplib
    from mplib import Pose
    from mplib.collision_detection import fcl

    parts = request["parts"]
    time_limit = float(request.get("time_limit", 1.0))
    np.random.seed(int(request.get("seed", 0)) + 1)  # mplib's IK restarts and OMPL seeds draw from numpy
    workdir = tempfile.mkdtemp(prefix="mplib_peer_")
    started = time.perf_counter()
    urdf = _relative_mesh_urdf(request["urdf"], workdir)
    planner = mplib.Planner(urdf, parts["tip_link"], srdf=request["srdf"])
    names = list(planner.user_joint_names)
    for box in parts.get("obstacles", []):
        x, y, z, w = box["orientation_xyzw"]
        shape = fcl.CollisionObject(fcl.Box(np.asarray(box["size"], dtype=float)), Pose())
        obj = fcl.FCLObject(box["id"], Pose(box["position"], [w, x, y, z]), [shape], [Pose()])
        planner.planning_world.add_object(obj)
    arm = [names.index(j) for j in parts["joint_names"]]
    fingers = parts.get("finger_positions", {})

    def full(values) -> np.ndarray:
        q = np.array([float(fingers.get(n, 0.0)) for n in names])
        q[arm] = values
        return q

    start = full(parts["start"])

    def solve_ik(problem: dict):
        x, y, z, w = problem["goal"]["orientation_xyzw"]
        goal = Pose(problem["goal"]["position"], [w, x, y, z])
        t0 = time.perf_counter()
        status, result = planner.IK(goal, start.copy())  # 20 restarts, collision-checked
        seconds = time.perf_counter() - t0
        if status != "Success" or result is None or len(result) == 0:
            return seconds, None
        return seconds, [float(v) for v in np.asarray(result[0], dtype=float)[arm]]

    def plan(problem: dict):
        t0 = time.perf_counter()
        result = planner.plan_qpos([np.asarray(problem["goal"], dtype=float)], full(problem["start"]),
                                   planning_time=time_limit)
        seconds = time.perf_counter() - t0
        if result.get("status") != "Success":
            return seconds, str(result.get("status")), None
        return seconds, "Success", [[float(v) for v in q] for q in np.asarray(result["position"], dtype=float)]

    setup_seconds = time.perf_counter() - started
    if parts["ik"]:
        solve_ik(parts["ik"][0])  # warm-up, untimed
    if parts["plan"]:
        plan(parts["plan"][0])
    out.write(json.dumps({"meta": True, "peer": PEER, "version": _version(),
                          "setup_seconds": round(setup_seconds, 4)}) + "\n")
    for problem in parts["ik"]:
        record = {"part": "ik", "index": problem["index"]}
        try:
            record["seconds"], record["solution"] = solve_ik(problem)
        except Exception as error:  # one bad problem must not lose the others' results
            record.update(seconds=None, solution=None, status=f"error: {type(error).__name__}: {error}")
        out.write(json.dumps(record) + "\n")
    robot_set_qpos, colliding_now = planner.robot.set_qpos, planner.planning_world.is_state_colliding
    clock = time.perf_counter
    seconds, colliding = [], []
    for q in [full(q) for q in parts["check"]]:
        t0 = clock()
        robot_set_qpos(q, True)  # as Planner.check_for_collision does, then one world query
        hit = colliding_now()
        seconds.append(clock() - t0)
        colliding.append(bool(hit))
    out.write(json.dumps({"part": "check", "seconds": seconds, "colliding": colliding}) + "\n")
    for problem in parts["plan"]:
        record = {"part": "plan", "index": problem["index"]}
        try:
            record["seconds"], record["status"], record["path"] = plan(problem)
        except Exception as error:
            record.update(seconds=None, status=f"error: {type(error).__name__}: {error}", path=None)
        out.write(json.dumps(record) + "\n")
    return 0


def _version() -> str:
    import importlib.metadata as metadata

    try:
        return metadata.version("mplib")
    except metadata.PackageNotFoundError:  # run from a source tree without package metadata
        return "unknown"


if __name__ == "__main__":
    sys.exit(main())
