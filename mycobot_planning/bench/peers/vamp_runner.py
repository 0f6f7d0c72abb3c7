"""Run the benchmark's validity checks and joint-goal RRTConnect plans with VAMP 0.6.4 (run by the
vamp peer venv's Python; VAMP has no IK, so the IK part is not asked of it).

VAMP plans with its own fixed sphere model of the Panda (``vamp.panda``), not with our URDF: the
runner only maps the problem's boxes to ``vamp.Cuboid``\\ s. Every path it returns is rechecked
by the bench with our exact mesh model, which is where the two models' differences show.

The full story: docs/bench.md, section mycobot_planning.bench.peers.vamp_runner.
"""
from __future__ import annotations

import json
import math
import sys
import time

from runner_protocol import json_out, peer_version, read_request  # this script's sibling (docstring there)

PEER = "vamp"
DISTRIBUTION = "vamp-planner"


def euler_xyz(xyzw) -> list[float]:
    """(roll, pitch, yaw) of a quaternion with R = Rz(yaw) Ry(pitch) Rx(roll): the angles
    ``vamp.Cuboid(center, euler_xyz, half_extents)`` expects (its collision/factory.hh)."""
    x, y, z, w = (float(v) for v in xyzw)
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return [roll, pitch, yaw]


def cuboid_args(box: dict) -> tuple[list[float], list[float], list[float]]:
    """(center, euler_xyz, half_extents) of one benchmark box ``{size, position, orientation_xyzw}``."""
    return ([float(v) for v in box["position"]], euler_xyz(box.get("orientation_xyzw", (0, 0, 0, 1))),
            [0.5 * float(v) for v in box["size"]])


def _environment(boxes: list):
    import vamp

    env = vamp.Environment()
    for box in boxes:
        cuboid = vamp.Cuboid(*cuboid_args(box))
        cuboid.name = str(box.get("id", "box"))
        env.add_cuboid(cuboid)
    return env


def main() -> int:
    out = json_out()
    request = read_request()
    if "parts" not in request:  # the pose-goal problems need IK, which VAMP does not have
        out.write(json.dumps({"meta": True, "peer": PEER, "version": peer_version(DISTRIBUTION), "setup_seconds": 0.0}) + "\n")
        for problem in request.get("problems", []):
            out.write(json.dumps({"index": problem["index"], "success": False, "claimed_success": False,
                                  "seconds": None, "status": "not supported: VAMP has no IK for pose goals"})
                      + "\n")
        return 0
    import numpy as np
    import vamp

    started = time.perf_counter()
    parts = request["parts"]
    time_limit = float(request.get("time_limit", 1.0))
    env = _environment(parts.get("obstacles", []))
    # VAMP's own settings for the Panda (RRT range 1.0, 1e6 iterations, default simplification).
    robot, rrtc, settings, simplify_settings = vamp.configure_robot_and_planner_with_kwargs("panda", "rrtc")
    rng = robot.halton()

    def plan(problem: dict, seed: int):
        rng.reset()
        rng.skip(seed)
        a = np.asarray(problem["start"], dtype=np.float32)
        b = np.asarray(problem["goal"], dtype=np.float32)
        # Its spheres cover more than the meshes: an end free on ours may collide in VAMP's model,
        # and rrtc then gives up at once; say so rather than "failed".
        for what, q in (("start", a), ("goal", b)):
            if not robot.validate(q, env):
                return 0.0, 0.0, f"{what} state collides in VAMP's sphere model", None
        t0 = time.perf_counter()
        result = rrtc(a, b, env, settings, rng)
        t1 = time.perf_counter()
        if not result.solved:
            return t1 - t0, 0.0, f"RRTConnect failed after {result.iterations} iterations", None
        simplified = robot.simplify(result.path, env, simplify_settings, rng)
        t2 = time.perf_counter()
        path = simplified.path if len(simplified.path) >= 2 else result.path
        if t2 - t0 > time_limit:  # VAMP has no time limit; the others stop at it
            return t1 - t0, t2 - t1, f"over the {time_limit} s time limit", None
        return t1 - t0, t2 - t1, "Success", path.numpy().astype(float).tolist()

    setup_seconds = time.perf_counter() - started
    if parts["plan"]:  # warm-up, untimed
        plan(parts["plan"][0], 1)
    out.write(json.dumps({"meta": True, "peer": PEER, "version": peer_version(DISTRIBUTION),
                          "setup_seconds": round(setup_seconds, 4)}) + "\n")

    for problem in parts.get("ik", []):
        out.write(json.dumps({"part": "ik", "index": problem["index"], "seconds": None, "solution": None,
                              "status": "not supported: VAMP has no IK"}) + "\n")

    clock, validate = time.perf_counter, robot.validate
    states = [np.asarray(q, dtype=np.float32) for q in parts["check"]]
    if states:
        validate(states[0], env)  # warm-up
    seconds, colliding = [], []
    for q in states:
        t0 = clock()
        free = validate(q, env)
        seconds.append(clock() - t0)
        colliding.append(not free)
    out.write(json.dumps({"part": "check", "seconds": seconds, "colliding": colliding}) + "\n")

    for problem in parts["plan"]:
        record = {"part": "plan", "index": problem["index"]}
        try:
            plan_s, simplify_s, status, path = plan(problem, problem["index"] + 1)
            record.update(seconds=plan_s + simplify_s, plan_seconds=plan_s, shortcut_seconds=simplify_s,
                          status=status, path=path)
        except Exception as error:  # one bad problem must not lose the others' results
            record.update(seconds=None, status=f"error: {type(error).__name__}: {error}", path=None)
        out.write(json.dumps(record) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
