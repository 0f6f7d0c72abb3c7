"""Run the benchmark's three Panda parts (IK, validity checks, joint-goal RRTConnect) with
roboplan 0.7.0 (run by the roboplan peer venv's Python).

The full story: docs/bench.md, section mycobot_planning.bench.peers.roboplan_runner.
"""
from __future__ import annotations

import json
import os
import sys
import time

PEER = "roboplan"


def _json_out():
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


def _version() -> str:
    try:
        import importlib.metadata as metadata

        return metadata.version("roboplan")
    except Exception:
        return "unknown"


def _quat_matrix(xyzw):
    import numpy as np

    x, y, z, w = (float(v) for v in xyzw)
    n = (x * x + y * y + z * z + w * w) ** 0.5
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def _pose_matrix(pose: dict):
    """The 4x4 transform of a ``{"position", "orientation_xyzw"}`` pose."""
    import numpy as np

    tform = np.eye(4)
    tform[:3, :3] = _quat_matrix(pose["orientation_xyzw"])
    tform[:3, 3] = pose["position"]
    return tform


def _scene(request: dict, boxes: list):
    """The roboplan scene of the request's URDF and SRDF, with ``boxes`` as obstacles."""
    import numpy as np
    from roboplan.core import Box, Scene, loadUrdfSceneDescription

    scene = Scene("panda", loadUrdfSceneDescription(request["urdf"]))
    with open(request["srdf"]) as handle:
        scene.importSrdf(handle.read())
    for box in boxes:
        scene.addBoxGeometry(box["id"], "universe", Box(*map(float, box["size"])), _pose_matrix(box),
                             np.array([0.5, 0.5, 0.5, 1.0]))
    return scene


def main() -> int:
    out = _json_out()
    request = _read_request()
    import numpy as np
    from roboplan.core import (CartesianConfiguration, JointConfiguration, PathShortcutter,
                               PathShortcuttingOptions)
    from roboplan.rrt import RRT, RRTOptions
    from roboplan.simple_ik import SimpleIk, SimpleIkOptions

    if "parts" not in request:
        return _run_pose_problems(out, request)
    parts = request["parts"]
    time_limit = float(request.get("time_limit", 1.0))
    started = time.perf_counter()
    scene = _scene(request, parts.get("obstacles", []))
    arm = list(parts["joint_names"])
    group = "arm"
    names = scene.getJointNames()  # actuated joints: the arm's, then panda_finger_joint1
    fingers = parts.get("finger_positions", {})
    arm_slots = [names.index(j) for j in arm]

    def full(values) -> np.ndarray:
        q = np.array([float(fingers.get(n, 0.0)) for n in names])
        q[arm_slots] = values
        return q

    start = np.asarray(parts["start"], dtype=float)
    scene.setJointPositions(full(start))  # fingers at the problem's value for IK and planning
    ik = SimpleIk(scene, SimpleIkOptions(group_name=group))  # roboplan's defaults, collisions checked
    ik.setRngSeed(int(request.get("seed", 0)) + 1)
    rrt = RRT(scene, RRTOptions(group_name=group, rrt_connect=True, max_planning_time=time_limit,
                                max_nodes=100_000))
    shortcutter = PathShortcutter(scene, PathShortcuttingOptions(group_name=group))
    base, tip = parts["base_frame"], parts["tip_link"]

    def solve_ik(problem: dict):
        tform = _pose_matrix(problem["goal"])
        goal = CartesianConfiguration(base, tip, tform)
        solution = JointConfiguration()
        t0 = time.perf_counter()
        ok = ik.solveIk(goal, JointConfiguration(arm, start.copy()), solution)
        seconds = time.perf_counter() - t0
        values = None
        if ok:
            by_name = dict(zip(solution.joint_names, solution.positions))
            values = [float(by_name[j]) for j in arm]
        return seconds, values

    def plan(problem: dict, seed: int):
        rrt.setRngSeed(seed)
        a = JointConfiguration(arm, np.asarray(problem["start"], dtype=float))
        b = JointConfiguration(arm, np.asarray(problem["goal"], dtype=float))
        t0 = time.perf_counter()
        try:
            path = rrt.plan(a, b)
        except RuntimeError as error:  # roboplan raises when it finds no path
            return time.perf_counter() - t0, 0.0, f"RRT failed: {error}", None
        t1 = time.perf_counter()
        if not path.positions:
            return t1 - t0, 0.0, "RRT failed", None
        path = shortcutter.shortcut(path)
        t2 = time.perf_counter()
        order = [list(path.joint_names).index(j) for j in arm]
        return t1 - t0, t2 - t1, "Success", [[float(q[i]) for i in order] for q in path.positions]

    setup_seconds = time.perf_counter() - started
    if parts["ik"]:  # warm-up, untimed
        solve_ik(parts["ik"][0])
    if parts["plan"]:
        plan(parts["plan"][0], 1)
    out.write(json.dumps({"meta": True, "peer": PEER, "version": _version(),
                          "setup_seconds": round(setup_seconds, 4)}) + "\n")

    for problem in parts["ik"]:
        record = {"part": "ik", "index": problem["index"]}
        try:
            record["seconds"], record["solution"] = solve_ik(problem)
        except Exception as error:  # one bad problem must not lose the others' results
            record.update(seconds=None, solution=None, status=f"error: {type(error).__name__}: {error}")
        out.write(json.dumps(record) + "\n")

    clock = time.perf_counter
    has_collisions = scene.hasCollisions
    states = [full(q) for q in parts["check"]]
    seconds, colliding = [], []
    for q in states:
        t0 = clock()
        hit = has_collisions(q)
        seconds.append(clock() - t0)
        colliding.append(bool(hit))
    out.write(json.dumps({"part": "check", "seconds": seconds, "colliding": colliding}) + "\n")

    for problem in parts["plan"]:
        record = {"part": "plan", "index": problem["index"]}
        try:
            plan_s, shortcut_s, status, path = plan(problem, problem["index"] + 1)
            record.update(seconds=plan_s + shortcut_s, plan_seconds=plan_s, shortcut_seconds=shortcut_s,
                          status=status, path=path)
        except Exception as error:
            record.update(seconds=None, status=f"error: {type(error).__name__}: {error}", path=None)
        out.write(json.dumps(record) + "\n")
    return 0


def _run_pose_problems(out, request: dict) -> int:
    """The pose-goal problems of ``python -m mycobot_planning.bench.peers``: SimpleIk from the
    start, then RRTConnect and the shortcutter, timed together (as the other runners do)."""
    import numpy as np
    from roboplan.core import (CartesianConfiguration, JointConfiguration, PathShortcutter,
                               PathShortcuttingOptions)
    from roboplan.rrt import RRT, RRTOptions
    from roboplan.simple_ik import SimpleIk, SimpleIkOptions

    problems = request["problems"]
    time_limit = float(request.get("time_limit", 1.0))
    started = time.perf_counter()
    first = problems[0] if problems else {"joint_names": [], "obstacles": [], "finger_positions": {}}
    scene = _scene(request, first.get("obstacles", []))
    arm = list(first["joint_names"])
    names = scene.getJointNames()
    fingers = first.get("finger_positions", {})
    arm_slots = [names.index(j) for j in arm]
    group = "arm"
    ik = SimpleIk(scene, SimpleIkOptions(group_name=group))
    rrt = RRT(scene, RRTOptions(group_name=group, rrt_connect=True, max_planning_time=time_limit,
                                max_nodes=100_000))
    shortcutter = PathShortcutter(scene, PathShortcuttingOptions(group_name=group))

    def solve(problem: dict):
        q = np.array([float(fingers.get(n, 0.0)) for n in names])
        q[arm_slots] = problem["start"]
        scene.setJointPositions(q)
        tform = _pose_matrix(problem["goal"])
        start = JointConfiguration(arm, np.asarray(problem["start"], dtype=float))
        t0 = time.perf_counter()
        goal = JointConfiguration()
        if not ik.solveIk(CartesianConfiguration(problem["base_frame"], problem["tip_link"], tform), start, goal):
            return time.perf_counter() - t0, "IK failed", None
        try:
            path = rrt.plan(start, goal)
        except RuntimeError as error:
            return time.perf_counter() - t0, f"RRT failed: {error}", None
        if not path.positions:
            return time.perf_counter() - t0, "RRT failed", None
        path = shortcutter.shortcut(path)
        seconds = time.perf_counter() - t0
        order = [list(path.joint_names).index(j) for j in arm]
        return seconds, "Success", [[float(q[i]) for i in order] for q in path.positions]

    setup_seconds = time.perf_counter() - started
    if problems:
        solve(problems[0])  # warm-up, untimed
    out.write(json.dumps({"meta": True, "peer": PEER, "version": _version(),
                          "setup_seconds": round(setup_seconds, 4)}) + "\n")
    for problem in problems:
        record = {"index": problem["index"], "success": False, "claimed_success": False}
        try:
            seconds, status, path = solve(problem)
            record.update(seconds=seconds, status=status, claimed_success=path is not None)
            if path is not None:
                arr = np.asarray(path, dtype=float)
                record["waypoints"] = int(len(arr))
                record["path_length"] = float(np.sum(np.linalg.norm(np.diff(arr, axis=0), axis=1)))
                record["path"] = path
        except Exception as error:  # one bad problem must not lose the others' results
            record.setdefault("seconds", None)
            record["status"] = f"error: {type(error).__name__}: {error}"
        out.write(json.dumps(record) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
