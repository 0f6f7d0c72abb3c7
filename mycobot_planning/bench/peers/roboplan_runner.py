"""Run the benchmark's three Panda parts (IK, validity checks, joint-goal RRTConnect) with
roboplan 0.7.0 (run by the roboplan peer venv's Python).

The full story: docs/bench.md, section mycobot_planning.bench.peers.roboplan_runner.
"""
from __future__ import annotations

import sys
import time

from runner_protocol import run_parts, run_pose_problems, serve

PEER = "roboplan"
GROUP = "arm"


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


def _solvers(scene, time_limit: float):
    """SimpleIk (roboplan's defaults, collisions checked), RRT-Connect and the path shortcutter
    on the arm group."""
    from roboplan.core import PathShortcutter, PathShortcuttingOptions
    from roboplan.rrt import RRT, RRTOptions
    from roboplan.simple_ik import SimpleIk, SimpleIkOptions

    ik = SimpleIk(scene, SimpleIkOptions(group_name=GROUP))
    rrt = RRT(scene, RRTOptions(group_name=GROUP, rrt_connect=True, max_planning_time=time_limit,
                                max_nodes=100_000))
    return ik, rrt, PathShortcutter(scene, PathShortcuttingOptions(group_name=GROUP))


def _full_state(names: list, fingers: dict, arm: list):
    """Arm values -> positions of all the scene's actuated ``names``, fingers at their values."""
    import numpy as np

    arm_slots = [names.index(j) for j in arm]

    def full(values) -> np.ndarray:
        q = np.array([float(fingers.get(n, 0.0)) for n in names])
        q[arm_slots] = values
        return q

    return full


def _arm_path(path, arm: list) -> list:
    """A roboplan JointPath's waypoints as lists of the ``arm`` joints' values, in that order."""
    order = [list(path.joint_names).index(j) for j in arm]
    return [[float(q[i]) for i in order] for q in path.positions]


def main() -> int:
    return serve(_run_pose_problems, _run_parts)


def _run_parts(out, request: dict) -> int:
    """The three parts (IK, validity checks, joint-goal plans); see docs/bench.md."""
    import numpy as np
    from roboplan.core import CartesianConfiguration, JointConfiguration

    parts = request["parts"]
    time_limit = float(request.get("time_limit", 1.0))
    started = time.perf_counter()
    scene = _scene(request, parts.get("obstacles", []))
    arm = list(parts["joint_names"])
    # actuated joints: the arm's, then panda_finger_joint1
    full = _full_state(scene.getJointNames(), parts.get("finger_positions", {}), arm)
    start = np.asarray(parts["start"], dtype=float)
    scene.setJointPositions(full(start))  # fingers at the problem's value for IK and planning
    ik, rrt, shortcutter = _solvers(scene, time_limit)
    ik.setRngSeed(int(request.get("seed", 0)) + 1)
    base, tip = parts["base_frame"], parts["tip_link"]

    def solve_ik(problem: dict) -> dict:
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
        return {"seconds": seconds, "solution": values}

    def plan_and_shortcut(problem: dict):
        rrt.setRngSeed(problem["index"] + 1)
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
        return t1 - t0, t2 - t1, "Success", _arm_path(path, arm)

    def plan(problem: dict) -> dict:
        plan_s, shortcut_s, status, path = plan_and_shortcut(problem)
        return {"seconds": plan_s + shortcut_s, "plan_seconds": plan_s, "shortcut_seconds": shortcut_s,
                "status": status, "path": path}

    return run_parts(out, PEER, time.perf_counter() - started, parts, solve_ik, full, scene.hasCollisions, plan)


def _run_pose_problems(out, request: dict) -> int:
    """The pose-goal problems of ``python -m mycobot_planning.bench.peers``: SimpleIk from the
    start, then RRTConnect and the shortcutter, timed together (as the other runners do)."""
    import numpy as np
    from roboplan.core import CartesianConfiguration, JointConfiguration

    problems = request["problems"]
    time_limit = float(request.get("time_limit", 1.0))
    started = time.perf_counter()
    first = problems[0] if problems else {"joint_names": [], "obstacles": [], "finger_positions": {}}
    scene = _scene(request, first.get("obstacles", []))
    arm = list(first["joint_names"])
    full = _full_state(scene.getJointNames(), first.get("finger_positions", {}), arm)
    ik, rrt, shortcutter = _solvers(scene, time_limit)

    def solve(problem: dict):
        scene.setJointPositions(full(problem["start"]))
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
        return seconds, "Success", _arm_path(path, arm)

    return run_pose_problems(out, PEER, time.perf_counter() - started, problems, solve)


if __name__ == "__main__":
    sys.exit(main())
