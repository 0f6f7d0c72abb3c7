"""Solve the benchmark's Panda pose-goal problems with pyroboplan (run by its peer venv's Python).

The full story: docs/bench.md, section mycobot_planning.bench.peers.pyroboplan_runner.
"""
from __future__ import annotations

import json
import os
import sys
import time

PEER = "pyroboplan"


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

        return metadata.version("pyroboplan")
    except Exception:
        return "unknown"


def _reduced_models(request: dict, spec: dict):
    """The arm-only pinocchio model and its collision model, with the spec's boxes as obstacles.

    ``spec`` holds ``joint_names``, ``finger_positions`` and ``obstacles`` (a pose problem or the
    parts); every joint that is not a planned arm joint (the fingers) is locked at its value.
    """
    import coal
    import numpy as np
    import pinocchio
    from pyroboplan.core.utils import set_collisions

    full_model, full_collision, _visual = pinocchio.buildModelsFromUrdf(request["urdf"])
    # Lock every joint that is not a planned arm joint (the fingers) at the problem's value.
    fixed = dict(spec.get("finger_positions", {}))
    q_ref = pinocchio.neutral(full_model)
    lock = []
    for joint_id in range(1, full_model.njoints):
        name = full_model.names[joint_id]
        if name not in spec["joint_names"]:
            lock.append(joint_id)
            q_ref[full_model.joints[joint_id].idx_q] = fixed.get(name, 0.0)
    model, (collision_model,) = pinocchio.buildReducedModel(full_model, [full_collision], lock, q_ref)
    if list(model.names)[1:] != list(spec["joint_names"]):
        raise RuntimeError(f"reduced model joints {list(model.names)[1:]} != {spec['joint_names']}")

    collision_model.addAllCollisionPairs()
    pinocchio.removeCollisionPairs(model, collision_model, request["srdf"])
    robot_geoms = [g.name for g in collision_model.geometryObjects]
    for box in spec.get("obstacles", []):
        x, y, z, w = box["orientation_xyzw"]
        rotation = pinocchio.Quaternion(w, x, y, z).normalized().matrix()
        placement = pinocchio.SE3(rotation, np.asarray(box["position"], dtype=float))
        collision_model.addGeometryObject(
            pinocchio.GeometryObject(box["id"], 0, placement, coal.Box(*map(float, box["size"]))))
        for geom in robot_geoms:
            set_collisions(model, collision_model, box["id"], geom, True)
    return model, collision_model


def main() -> int:
    out = _json_out()
    request = _read_request()
    if "parts" in request:
        return _run_parts(out, request)
    import numpy as np
    import pinocchio
    from pyroboplan.ik.differential_ik import DifferentialIk, DifferentialIkOptions
    from pyroboplan.planning.path_shortcutting import shortcut_path
    from pyroboplan.planning.rrt import RRTPlanner, RRTPlannerOptions

    time_limit = float(request.get("time_limit", 1.0))
    problems = request["problems"]
    started = time.perf_counter()
    first = problems[0] if problems else {"joint_names": [], "tip_link": "panda_hand"}
    tip = first["tip_link"]

    model, collision_model = _reduced_models(request, first)
    data = model.createData()
    collision_data = collision_model.createData()
    tip_id = model.getFrameId(tip)
    ik_options = DifferentialIkOptions(damping=0.0001, min_step_size=0.025, max_step_size=0.1)
    ik = DifferentialIk(model, data=data, collision_model=collision_model,
                        collision_data=collision_data, options=ik_options)
    rrt_options = RRTPlannerOptions(
        max_step_size=0.05, max_connection_dist=0.5, rrt_connect=True, bidirectional_rrt=True,
        rrt_star=False, max_planning_time=time_limit, fast_return=True,
        goal_biasing_probability=0.15, collision_distance_padding=0.0,
    )
    planner = RRTPlanner(model, collision_model, options=rrt_options)

    def goal_se3(problem: dict):
        x, y, z, w = problem["goal"]["orientation_xyzw"]
        rotation = pinocchio.Quaternion(w, x, y, z).normalized().matrix()
        return pinocchio.SE3(rotation, np.asarray(problem["goal"]["position"], dtype=float))

    def solve(problem: dict):
        q_start = np.asarray(problem["start"], dtype=float)
        target = goal_se3(problem)
        t0 = time.perf_counter()
        q_goal = ik.solve(tip, target, init_state=q_start.copy())  # solve() edits init_state
        if q_goal is None:
            return time.perf_counter() - t0, "IK failed", None
        path = planner.plan(q_start, q_goal)
        if not path:
            return time.perf_counter() - t0, "RRT failed", None
        path = shortcut_path(model, collision_model, path)
        return time.perf_counter() - t0, "Success", path

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
                record["path"] = [[float(v) for v in q] for q in arr]
                pinocchio.framesForwardKinematics(model, data, arr[-1])
                reached = data.oMf[tip_id]
                target = goal_se3(problem)
                record["goal_position_error"] = float(
                    np.linalg.norm(reached.translation - target.translation))
                record["goal_rotation_error"] = float(
                    np.linalg.norm(pinocchio.log3(target.rotation.T @ reached.rotation)))
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
    import pinocchio
    from pyroboplan.core.utils import check_collisions_at_state
    from pyroboplan.ik.differential_ik import DifferentialIk, DifferentialIkOptions
    from pyroboplan.planning.path_shortcutting import shortcut_path
    from pyroboplan.planning.rrt import RRTPlanner, RRTPlannerOptions

    parts = request["parts"]
    time_limit = float(request.get("time_limit", 1.0))
    np.random.seed(int(request.get("seed", 0)) + 1)  # pyroboplan's restarts and samples draw from numpy
    started = time.perf_counter()
    model, collision_model = _reduced_models(request, parts)
    data = model.createData()
    collision_data = collision_model.createData()
    tip = parts["tip_link"]
    ik = DifferentialIk(model, data=data, collision_model=collision_model, collision_data=collision_data,
                        options=DifferentialIkOptions(damping=0.0001, min_step_size=0.025, max_step_size=0.1))
    planner = RRTPlanner(model, collision_model, options=RRTPlannerOptions(
        max_step_size=0.05, max_connection_dist=0.5, rrt_connect=True, bidirectional_rrt=True,
        rrt_star=False, max_planning_time=time_limit, fast_return=True,
        goal_biasing_probability=0.15, collision_distance_padding=0.0))
    start = np.asarray(parts["start"], dtype=float)

    def solve_ik(problem: dict):
        x, y, z, w = problem["goal"]["orientation_xyzw"]
        target = pinocchio.SE3(pinocchio.Quaternion(w, x, y, z).normalized().matrix(),
                               np.asarray(problem["goal"]["position"], dtype=float))
        t0 = time.perf_counter()
        q = ik.solve(tip, target, init_state=start.copy())  # solve() edits init_state
        seconds = time.perf_counter() - t0
        return seconds, None if q is None else [float(v) for v in q]

    def plan(problem: dict):
        t0 = time.perf_counter()
        path = planner.plan(np.asarray(problem["start"], dtype=float), np.asarray(problem["goal"], dtype=float))
        if not path:
            return time.perf_counter() - t0, "RRT failed", None
        path = shortcut_path(model, collision_model, path)
        return time.perf_counter() - t0, "Success", [[float(v) for v in q] for q in path]

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
    clock = time.perf_counter
    seconds, colliding = [], []
    for q in [np.asarray(q, dtype=float) for q in parts["check"]]:
        t0 = clock()
        hit = check_collisions_at_state(model, collision_model, q, data, collision_data)
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


if __name__ == "__main__":
    sys.exit(main())
