"""Solve the benchmark's Panda pose-goal problems with mplib (run by the mplib peer venv's Python).

The full story: docs/bench.md, section mycobot_planning.bench.peers.mplib_runner.
"""
from __future__ import annotations

import math
import os
import re
import sys
import tempfile
import time

from runner_protocol import run_parts, run_pose_problems, serve

PEER = "mplib"


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


def _pose(pose: dict):
    """The mplib Pose of a ``{"position", "orientation_xyzw"}`` pose (mplib quaternions are wxyz)."""
    from mplib import Pose

    x, y, z, w = pose["orientation_xyzw"]
    return Pose(pose["position"], [w, x, y, z])


def _planner(request: dict, tip: str, boxes: list):
    """An mplib Planner of the request's URDF (a mesh-path-fixed copy) and SRDF, ``boxes`` added."""
    import numpy as np
    import mplib
    from mplib import Pose
    from mplib.collision_detection import fcl

    urdf = _relative_mesh_urdf(request["urdf"], tempfile.mkdtemp(prefix="mplib_peer_"))
    planner = mplib.Planner(urdf, tip, srdf=request["srdf"])
    for box in boxes:
        shape = fcl.CollisionObject(fcl.Box(np.asarray(box["size"], dtype=float)), Pose())
        planner.planning_world.add_object(fcl.FCLObject(box["id"], _pose(box), [shape], [Pose()]))
    return planner


def main() -> int:
    return serve(_run_pose_problems, _run_parts)


def _run_pose_problems(out, request: dict) -> int:
    """The pose-goal problems: ``Planner.plan_pose`` from the start, timed alone."""
    import numpy as np

    time_limit = float(request.get("time_limit", 1.0))
    problems = request["problems"]
    started = time.perf_counter()
    tip = problems[0]["tip_link"] if problems else "panda_hand"
    planner = _planner(request, tip, problems[0].get("obstacles", []) if problems else [])
    names = list(planner.user_joint_names)
    link_index = planner.link_name_2_idx[tip]
    arm = [names.index(j) for j in problems[0]["joint_names"]] if problems else []

    def full_qpos(problem: dict) -> np.ndarray:
        """All mplib joints (arm + both fingers) from the problem's arm start and finger values."""
        values = dict(zip(problem["joint_names"], problem["start"]))
        values.update(problem.get("finger_positions", {}))
        return np.array([values.get(name, 0.0) for name in names], dtype=float)

    def solve(problem: dict):
        qpos = full_qpos(problem)
        goal = _pose(problem["goal"])
        t0 = time.perf_counter()
        result = planner.plan_pose(goal, qpos, planning_time=time_limit)
        seconds = time.perf_counter() - t0
        status = result.get("status")
        return seconds, str(status), result["position"] if status == "Success" else None  # move-group joints only

    def goal_errors(problem: dict, path: np.ndarray) -> tuple[float, float]:
        final = full_qpos(problem)
        final[arm] = path[-1]
        planner.pinocchio_model.compute_forward_kinematics(final)
        reached = planner.pinocchio_model.get_link_pose(link_index)
        w, x, y, z = (float(v) for v in reached.q)
        return (float(np.linalg.norm(np.asarray(reached.p) - np.asarray(problem["goal"]["position"]))),
                _quat_angle([x, y, z, w], problem["goal"]["orientation_xyzw"]))

    return run_pose_problems(out, PEER, time.perf_counter() - started, problems, solve, goal_errors)


def _run_parts(out, request: dict) -> int:
    """The three parts (IK, validity checks, joint-goal plans); see docs/bench.md."""
    import numpy as np

    parts = request["parts"]
    time_limit = float(request.get("time_limit", 1.0))
    np.random.seed(int(request.get("seed", 0)) + 1)  # mplib's IK restarts and OMPL seeds draw from numpy
    started = time.perf_counter()
    planner = _planner(request, parts["tip_link"], parts.get("obstacles", []))
    names = list(planner.user_joint_names)
    arm = [names.index(j) for j in parts["joint_names"]]
    fingers = parts.get("finger_positions", {})

    def full(values) -> np.ndarray:
        q = np.array([float(fingers.get(n, 0.0)) for n in names])
        q[arm] = values
        return q

    start = full(parts["start"])

    def solve_ik(problem: dict) -> dict:
        goal = _pose(problem["goal"])
        t0 = time.perf_counter()
        status, result = planner.IK(goal, start.copy())  # 20 restarts, collision-checked
        seconds = time.perf_counter() - t0
        if status != "Success" or result is None or len(result) == 0:
            return {"seconds": seconds, "solution": None}
        return {"seconds": seconds, "solution": [float(v) for v in np.asarray(result[0], dtype=float)[arm]]}

    def plan(problem: dict) -> dict:
        t0 = time.perf_counter()
        result = planner.plan_qpos([np.asarray(problem["goal"], dtype=float)], full(problem["start"]),
                                   planning_time=time_limit)
        seconds = time.perf_counter() - t0
        if result.get("status") != "Success":
            return {"seconds": seconds, "status": str(result.get("status")), "path": None}
        return {"seconds": seconds, "status": "Success",
                "path": [[float(v) for v in q] for q in np.asarray(result["position"], dtype=float)]}

    robot_set_qpos, colliding_now = planner.robot.set_qpos, planner.planning_world.is_state_colliding

    def colliding(q: np.ndarray) -> bool:
        robot_set_qpos(q, True)  # as Planner.check_for_collision does, then one world query
        return colliding_now()

    return run_parts(out, PEER, time.perf_counter() - started, parts, solve_ik, full, colliding, plan)


if __name__ == "__main__":
    sys.exit(main())
