"""Benchmarks of concurrent plans in the planning_server: its memory (RSS) with four plans at
once (``concurrent_plans``), and its plans per second for one and two clients (``concurrency``).

``concurrent_plans``: starts mock_controllers + planning_server (RobotProcesses, a ROS domain of
its own), puts a 5 cm box in the way (/apply_planning_scene), sends one plan, then rounds of four
/plan_kinematic_path requests at once: three OMPL RRTConnect plans around the box, each of
ATTEMPTS attempts (MoveIt keeps the shortest), so the plans overlap, and one industrial PTP; four
different goals. It reads the server's /proc status: ``rss_idle_mb`` after
the first plan, ``rss_after_mb`` after the rounds, ``hwm_mb`` its peak (VmHWM); ``round_ms`` the
wall time of one round. One server per repeat; summary keys are the medians. Every plan must
succeed (the server validates each trajectory).

Imports only what the bench package has had since before the planning contexts changed, so the
same file, run as a script, measures an older checkout (docs/bench.md says how).
"""
from __future__ import annotations

import itertools
import statistics
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

from mycobot_planning.bench.common import emit, machine, spread
from mycobot_planning.bench.ros_scenarios import RobotProcesses, bench_domain_id

ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6",
       "link6_to_link6_flange"]
#: (pipeline, planner, goal): four different goals, the first three behind the box
PLANS = (
    ("ompl", "RRTConnectkConfigDefault", [1.0, -1.0, -0.8, 0.3, 0.5, 0.8]),
    ("ompl", "RRTConnectkConfigDefault", [1.1, -0.9, -0.8, 0.2, 0.5, 0.7]),
    ("ompl", "RRTConnectkConfigDefault", [0.9, -1.1, -0.7, 0.3, 0.4, 0.8]),
    ("pilz_industrial_motion_planner", "PTP", [0.5, 0.2, 0.3, -0.2, 0.1, 0.2]),
)
BOX_CENTRE = (0.0, 0.15, 0.25)
BOX_SIZE = 0.05
ROUNDS = 3
ALLOWED_PLANNING_TIME = 10.0
ATTEMPTS = 10


def _status_mb(pid: int) -> dict[str, float]:
    """VmRSS and VmHWM of a process, in MB."""
    out = {}
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        key, _, value = line.partition(":")
        if key in ("VmRSS", "VmHWM"):
            out[key] = int(value.split()[0]) / 1024.0
    return out


def _request(pipeline: str, planner: str, goal: list[float]) -> Any:
    from moveit_msgs.msg import Constraints, JointConstraint
    from moveit_msgs.srv import GetMotionPlan

    request = GetMotionPlan.Request()
    r = request.motion_plan_request
    r.group_name, r.pipeline_id, r.planner_id = "arm", pipeline, planner
    r.allowed_planning_time = ALLOWED_PLANNING_TIME
    r.num_planning_attempts = ATTEMPTS if pipeline == "ompl" else 1
    r.max_velocity_scaling_factor = r.max_acceleration_scaling_factor = 0.5
    r.goal_constraints = [Constraints(joint_constraints=[JointConstraint(
        joint_name=j, position=v, tolerance_above=1e-3, tolerance_below=1e-3, weight=1.0)
        for j, v in zip(ARM, goal)])]
    return request


def _box_scene() -> Any:
    from moveit_msgs.msg import CollisionObject, PlanningScene
    from moveit_msgs.srv import ApplyPlanningScene
    from geometry_msgs.msg import Pose
    from shape_msgs.msg import SolidPrimitive

    box = CollisionObject(id="box", operation=CollisionObject.ADD)
    box.header.frame_id = "world"
    box.primitives = [SolidPrimitive(type=SolidPrimitive.BOX, dimensions=[BOX_SIZE] * 3)]
    pose = Pose()
    pose.position.x, pose.position.y, pose.position.z = BOX_CENTRE
    pose.orientation.w = 1.0
    box.primitive_poses = [pose]
    request = ApplyPlanningScene.Request(scene=PlanningScene(is_diff=True))
    request.scene.world.collision_objects = [box]
    return request


_CLIENT_NUMBERS = itertools.count()


class _Client:
    """A private rclpy context and node with the two service clients this benchmark calls."""

    def __init__(self) -> None:
        import rclpy
        from moveit_msgs.srv import ApplyPlanningScene, GetMotionPlan
        from rclpy.executors import SingleThreadedExecutor

        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node(f"bench_concurrent_plans_{next(_CLIENT_NUMBERS)}", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.plan = self.node.create_client(GetMotionPlan, "/plan_kinematic_path")
        self.apply = self.node.create_client(ApplyPlanningScene, "/apply_planning_scene")
        if not all(c.wait_for_service(timeout_sec=30.0) for c in (self.plan, self.apply)):
            self.close()
            raise RuntimeError("the planning_server offers no /plan_kinematic_path or /apply_planning_scene")

    def wait(self, futures: list, what: str, timeout: float = 120.0) -> list:
        deadline = time.monotonic() + timeout
        while not all(f.done() for f in futures):
            if time.monotonic() > deadline:
                raise RuntimeError(f"the planning_server did not answer {what}")
            self.executor.spin_once(timeout_sec=0.1)
        return [f.result() for f in futures]

    def plan_all(self, plans) -> None:
        """Send every plan at once; each must succeed."""
        answers = self.wait([self.plan.call_async(_request(*plan)) for plan in plans], "every plan")
        for plan, answer in zip(plans, answers):
            code = answer.motion_plan_response.error_code
            if code.val != 1:
                raise RuntimeError(f"{plan[0]}/{plan[1]} failed: {code.message}")

    def close(self) -> None:
        import rclpy

        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


def bench_concurrent_plans(repeat: int, seed: int) -> None:
    records: list[dict[str, Any]] = []
    for index in range(repeat):
        with RobotProcesses(bench_domain_id()) as robot:
            pid = robot.procs["planning_server"].pid
            client = _Client()
            try:
                if not client.wait([client.apply.call_async(_box_scene())], "the box")[0].success:
                    raise RuntimeError("the planning_server did not add the box")
                client.plan_all(PLANS[3:])
                time.sleep(3.0)  # start-up work in the server's background threads ends
                idle = _status_mb(pid)
                rounds = []
                for _ in range(ROUNDS):
                    t0 = time.perf_counter()
                    client.plan_all(PLANS)
                    rounds.append(time.perf_counter() - t0)
                after = _status_mb(pid)
            finally:
                client.close()
        record = {"scenario": "concurrent_plans", "repeat": index, "rss_idle_mb": round(idle["VmRSS"], 1),
                  "rss_after_mb": round(after["VmRSS"], 1), "hwm_mb": round(after["VmHWM"], 1),
                  "round_ms": round(1e3 * statistics.median(rounds), 1)}
        records.append(record)
        emit(record)
    summary: dict[str, Any] = {"scenario": "concurrent_plans", "summary": True}
    for key in ("rss_idle_mb", "rss_after_mb", "hwm_mb", "round_ms"):
        summary[key] = round(statistics.median(r[key] for r in records), 1)
    emit({**summary, **spread([r["rss_after_mb"] for r in records]), **machine()})


# ---------------------------------------------------------------------------- concurrency
#: plan requests per client count and server mode (the issue's "0 mixed-up answers of 100")
REQUESTS = 100
#: OMPL attempts per request: about 0.1 s of planning each, so a plan is mostly planner work
CONCURRENCY_ATTEMPTS = 4
#: worker processes of the "processes" server (planning_processes), one per core here
PROCESSES = 2
WORKERS_READY = "worker processes"
#: (mode, planning_processes, parallel_planning_attempts, client counts): the client scaling of
#: the server's threads and of the workers with each request on one worker, then one client whose
#: requests' attempts are split between the workers (the server's default with workers)
MODES = (("threads", 0, False, (1, 2)), ("processes", PROCESSES, False, (1, 2)), ("attempts", PROCESSES, True, (1,)))


def _goals(count: int, seed: int) -> list[list[float]]:
    """``count`` different joint goals behind the box: the three of PLANS, moved a little."""
    rng = np.random.default_rng(seed)
    bases = [np.asarray(goal) for pipeline, _, goal in PLANS if pipeline == "ompl"]
    return [list(np.round(bases[k % len(bases)] + rng.uniform(-0.08, 0.08, len(ARM)), 4)) for k in range(count)]


def _run_clients(clients: list[_Client], goals: list[list[float]]) -> dict[str, Any]:
    """Each client sends its share of ``goals`` one after the other, all clients at once: plans
    per second over the whole, and the answers whose path does not end at their own goal."""
    shares = [goals[k::len(clients)] for k in range(len(clients))]
    outcome = {"mixed": 0, "failed": 0, "solved": 0}
    lock = threading.Lock()

    def run(client: _Client, share: list[list[float]]) -> None:
        for goal in share:
            request = _request("ompl", "RRTConnectkConfigDefault", goal)
            request.motion_plan_request.num_planning_attempts = CONCURRENCY_ATTEMPTS
            answer = client.wait([client.plan.call_async(request)], "a plan")[0].motion_plan_response
            with lock:
                if answer.error_code.val != 1:
                    outcome["failed"] += 1
                    continue
                outcome["solved"] += 1
                points = answer.trajectory.joint_trajectory.points
                names = list(answer.trajectory.joint_trajectory.joint_names)
                end = [points[-1].positions[names.index(j)] for j in ARM] if points and set(ARM) <= set(names) else []
                if len(end) != len(goal) or not np.allclose(end, goal, atol=2e-3):
                    outcome["mixed"] += 1

    threads = [threading.Thread(target=run, args=(c, share)) for c, share in zip(clients, shares)]
    t0 = time.perf_counter()
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    wall = time.perf_counter() - t0
    return {**outcome, "wall_s": round(wall, 3), "plans_per_s": round(outcome["solved"] / wall, 3)}


def bench_concurrency(repeat: int, seed: int) -> None:
    """Plans per second of the planning_server for 1 and 2 clients planning at once over ROS
    (/plan_kinematic_path, OMPL around the box), with planning_processes 0 (the server's threads)
    and PROCESSES (worker processes, each request on one); ``speedup``: 2 clients' plans/s over 1
    client's. ``attempts_speedup``: one client's plans/s with each request's attempts split
    between the workers over the same without the split."""
    records: list[dict[str, Any]] = []
    for index in range(repeat):
        for mode, processes, parallel, counts in MODES:
            with RobotProcesses(bench_domain_id(), server_args=[
                    "-p", f"planning_processes:={processes}",
                    "-p", f"parallel_planning_attempts:={str(parallel).lower()}"]) as robot:
                if processes and not robot.robot["planning_server"].wait_for_output(WORKERS_READY, 120.0):
                    raise RuntimeError("the planning_server's workers did not start: " + robot.log("planning_server")[-2000:])
                clients = [_Client(), _Client()]
                try:
                    if not clients[0].wait([clients[0].apply.call_async(_box_scene())], "the box")[0].success:
                        raise RuntimeError("the planning_server did not add the box")
                    _run_clients(clients[:1], _goals(2 * PROCESSES, seed + 1000))  # warm-up: each worker's scene
                    for count in counts:
                        result = _run_clients(clients[:count], _goals(REQUESTS, seed + index))
                        record = {"scenario": "concurrency", "repeat": index, "mode": mode, "clients": count,
                                  **result}
                        records.append(record)
                        emit(record)
                finally:
                    for client in clients:
                        client.close()
    summary: dict[str, Any] = {"scenario": "concurrency", "summary": True, "clients": [1, 2],
                               "requests": REQUESTS, "processes": PROCESSES}

    def median(mode: str, count: int) -> float:
        return statistics.median(r["plans_per_s"] for r in records if r["mode"] == mode and r["clients"] == count)

    for mode, prefix in (("processes", ""), ("threads", "threads_")):
        rates = [round(median(mode, count), 3) for count in (1, 2)]
        summary[prefix + "plans_per_s"] = rates
        summary[prefix + "speedup"] = round(rates[1] / rates[0], 3) if rates[0] else 0.0
    alone = summary["plans_per_s"][0]
    summary["attempts_plans_per_s"] = round(median("attempts", 1), 3)
    summary["attempts_speedup"] = round(summary["attempts_plans_per_s"] / alone, 3) if alone else 0.0
    summary["mixed_answers"] = sum(r["mixed"] for r in records)
    summary["failed_plans"] = sum(r["failed"] for r in records)
    emit({**summary, **machine()})


CONCURRENCY_SCENARIOS = {"concurrent_plans": bench_concurrent_plans, "concurrency": bench_concurrency}

if __name__ == "__main__":  # to measure another checkout with this file (docs/bench.md)
    import argparse

    parser = argparse.ArgumentParser(description="bench concurrent_plans of the checkout whose venv runs this")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    options = parser.parse_args()
    bench_concurrent_plans(options.repeat, options.seed)
