"""Solve the benchmark's Panda pose-goal problems with pyroboplan (run by its peer venv's Python).

The full story: docs/bench.md, section mycobot_planning.bench.peers.pyroboplan_runner.
"""
from __future__ import annotations

import functools
import sys
import time

from runner_protocol import run_parts, run_pose_problems, serve

PEER = "pyroboplan"


def _reduced_models(request: dict, spec: dict):
    """The arm-only pinocchio model and its collision model, with the spec's boxes as obstacles.

    ``spec`` holds ``joint_names``, ``finger_positions`` and ``obstacles`` (a pose problem or the
    parts); every joint that is not a planned arm joint (the fingers) is locked at its value.
    """
    import coal
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
        collision_model.addGeometryObject(
            pinocchio.GeometryObject(box["id"], 0, _se3(box), coal.Box(*map(float, box["size"]))))
        for geom in robot_geoms:
            set_collisions(model, collision_model, box["id"], geom, True)
    return model, collision_model


def _se3(pose: dict):
    """The pinocchio SE3 of a ``{"position", "orientation_xyzw"}`` pose."""
    import numpy as np
    import pinocchio

    x, y, z, w = pose["orientation_xyzw"]
    rotation = pinocchio.Quaternion(w, x, y, z).normalized().matrix()
    return pinocchio.SE3(rotation, np.asarray(pose["position"], dtype=float))


def _ik_and_planner(model, collision_model, data, collision_data, time_limit: float):
    """DifferentialIk and RRT-Connect with the settings of pyroboplan's Panda examples."""
    from pyroboplan.ik.differential_ik import DifferentialIk, DifferentialIkOptions
    from pyroboplan.planning.rrt import RRTPlanner, RRTPlannerOptions

    ik_options = DifferentialIkOptions(damping=0.0001, min_step_size=0.025, max_step_size=0.1)
    ik = DifferentialIk(model, data=data, collision_model=collision_model,
                        collision_data=collision_data, options=ik_options)
    rrt_options = RRTPlannerOptions(
        max_step_size=0.05, max_connection_dist=0.5, rrt_connect=True, bidirectional_rrt=True,
        rrt_star=False, max_planning_time=time_limit, fast_return=True,
        goal_biasing_probability=0.15, collision_distance_padding=0.0,
    )
    return ik, RRTPlanner(model, collision_model, options=rrt_options)


def main() -> int:
    return serve(_run_pose_problems, _run_parts)


def _run_pose_problems(out, request: dict) -> int:
    """The pose-goal problems: DifferentialIk from the start, then RRT-Connect and the
    shortcutter, timed together."""
    import numpy as np
    import pinocchio
    from pyroboplan.planning.path_shortcutting import shortcut_path

    time_limit = float(request.get("time_limit", 1.0))
    problems = request["problems"]
    started = time.perf_counter()
    first = problems[0] if problems else {"joint_names": [], "tip_link": "panda_hand"}
    tip = first["tip_link"]

    model, collision_model = _reduced_models(request, first)
    data = model.createData()
    ik, planner = _ik_and_planner(model, collision_model, data, collision_model.createData(), time_limit)
    tip_id = model.getFrameId(tip)

    def solve(problem: dict):
        q_start = np.asarray(problem["start"], dtype=float)
        target = _se3(problem["goal"])
        t0 = time.perf_counter()
        q_goal = ik.solve(tip, target, init_state=q_start.copy())  # solve() edits init_state
        if q_goal is None:
            return time.perf_counter() - t0, "IK failed", None
        path = planner.plan(q_start, q_goal)
        if not path:
            return time.perf_counter() - t0, "RRT failed", None
        path = shortcut_path(model, collision_model, path)
        return time.perf_counter() - t0, "Success", path

    def goal_errors(problem: dict, path: np.ndarray) -> tuple[float, float]:
        pinocchio.framesForwardKinematics(model, data, path[-1])
        reached = data.oMf[tip_id]
        target = _se3(problem["goal"])
        return (float(np.linalg.norm(reached.translation - target.translation)),
                float(np.linalg.norm(pinocchio.log3(target.rotation.T @ reached.rotation))))

    return run_pose_problems(out, PEER, time.perf_counter() - started, problems, solve, goal_errors)


def _run_parts(out, request: dict) -> int:
    """The three parts (IK, validity checks, joint-goal plans); see docs/bench.md."""
    import numpy as np
    from pyroboplan.core.utils import check_collisions_at_state
    from pyroboplan.planning.path_shortcutting import shortcut_path

    parts = request["parts"]
    time_limit = float(request.get("time_limit", 1.0))
    np.random.seed(int(request.get("seed", 0)) + 1)  # pyroboplan's restarts and samples draw from numpy
    started = time.perf_counter()
    model, collision_model = _reduced_models(request, parts)
    data = model.createData()
    collision_data = collision_model.createData()
    tip = parts["tip_link"]
    ik, planner = _ik_and_planner(model, collision_model, data, collision_data, time_limit)
    start = np.asarray(parts["start"], dtype=float)

    def solve_ik(problem: dict) -> dict:
        target = _se3(problem["goal"])
        t0 = time.perf_counter()
        q = ik.solve(tip, target, init_state=start.copy())  # solve() edits init_state
        seconds = time.perf_counter() - t0
        return {"seconds": seconds, "solution": None if q is None else [float(v) for v in q]}

    def plan(problem: dict) -> dict:
        t0 = time.perf_counter()
        path = planner.plan(np.asarray(problem["start"], dtype=float), np.asarray(problem["goal"], dtype=float))
        if not path:
            return {"seconds": time.perf_counter() - t0, "status": "RRT failed", "path": None}
        path = shortcut_path(model, collision_model, path)
        return {"seconds": time.perf_counter() - t0, "status": "Success",
                "path": [[float(v) for v in q] for q in path]}

    def state(q) -> np.ndarray:
        return np.asarray(q, dtype=float)

    # A partial, not a closure of ours: the timed call goes straight into pyroboplan.
    colliding = functools.partial(check_collisions_at_state, model, collision_model,
                                  data=data, collision_data=collision_data)
    return run_parts(out, PEER, time.perf_counter() - started, parts, solve_ik, state, colliding, plan)


if __name__ == "__main__":
    sys.exit(main())
