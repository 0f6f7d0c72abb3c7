"""Benchmarks of the ROS layer with real processes: execution latency and scene updates.

Each scenario starts the mock controllers and the planning_server as subprocesses on a ROS
domain of its own (localhost discovery only), talks to them through the interfaces_py clients
from this process, and stops them (their whole process groups) at the end, even on failure.

* ``exec_latency``: time from sending an execute request to the first controller motion seen on
  /joint_states (a change of an arm joint beyond 1e-6 rad), over executions of short planned
  motions back and forth. Summary key ``median_ms``. Includes the JSON-RPC round to the server,
  its start-tolerance check, the command to the controller, the controller's next cycle (100 Hz,
  so up to 10 ms) and the /joint_states delivery back here.
* ``scene_update``: apply 50 box collision objects and read them back (get_objects), checking
  every pose. Summary key ``median_ms`` is the batched form (one apply_collision_object request
  carrying all 50, what PlanningSceneInterface.apply_collision_objects sends);
  ``one_by_one_median_ms`` is 50 separate requests (add_object per box) plus the read.

Register in scenarios.SCENARIOS as "exec_latency" and "scene_update".
"""
from __future__ import annotations

import os
import subprocess
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

from interfaces_py.msgs import CollisionObject, Pose, RobotState as RobotStateMsg
from mycobot_planning.polling import wait_until
from mycobot_planning.ros.bringup import robot as bringup

from .common import emit, machine, spread, stats

ARM_JOINTS = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6",
              "link6_to_link6_flange"]
EXECUTIONS_PER_REPEAT = 10
SCENE_RUNS_PER_REPEAT = 10
SCENE_OBJECTS = 50
MOTION_THRESHOLD = 1e-6  # rad: an arm joint moved


def bench_domain_id() -> int:
    """A ROS domain for this benchmark run (env MYCOBOT_BENCH_DOMAIN_ID overrides): 120..219,
    away from the test sessions' 1..100."""
    override = os.environ.get("MYCOBOT_BENCH_DOMAIN_ID")
    return int(override) if override else 120 + os.getpid() % 100


class RobotProcesses:
    """mock_controllers + planning_server on ``domain``, brought up by the bring-up module
    (mycobot_planning.ros.bringup); a context manager that always stops their process groups.
    Logs go to a temporary folder (kept when start-up fails)."""

    def __init__(self, domain: int, server_args: list[str] | None = None, timeout: float = 60.0,
                 extra_nodes: dict[str, tuple[list[str], str]] | None = None) -> None:
        """``extra_nodes``: more nodes of the package, name -> (arguments, a log line to wait for
        once discovery shows the node: what it must have done before the benchmark runs, "" for
        nothing), started after the two."""
        self.domain = domain
        self.timeout = timeout
        self.log_dir = Path(tempfile.mkdtemp(prefix="mycobot_bench_"))
        self.awaited = {name: text for name, (_, text) in (extra_nodes or {}).items() if text}
        nodes = [bringup.mock_controllers(), bringup.planning_server(server_args or [])]
        nodes += [bringup.extra_node(name, args) for name, (args, _) in (extra_nodes or {}).items()]
        env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
        env.pop("ROS_LOCALHOST_ONLY", None)
        self.robot = bringup.Robot(nodes, self.log_dir, env=env)
        self.procs: dict[str, subprocess.Popen] = {}

    def __enter__(self) -> "RobotProcesses":
        try:
            self.robot.start(self.timeout)
            self.procs = {name: process.proc for name, process in self.robot.processes.items()}
            for name, text in self.awaited.items():
                if not self.robot[name].wait_for_output(text, self.timeout):
                    raise RuntimeError(f"{name} did not get to '{text}'; its log ({self.log_dir / (name + '.log')}):\n"
                                       + self.log(name)[-2000:])
        except bringup.BringupError as exc:
            self.close()
            raise RuntimeError(str(exc)) from None
        except BaseException:
            self.close()
            raise
        return self

    def log(self, name: str) -> str:
        return self.robot[name].output()

    def close(self) -> None:
        self.robot.close()

    def __exit__(self, *exc: Any) -> None:
        self.close()


class _JointWatcher:
    """/joint_states on a private node: the latest arm positions and when motion first appeared."""

    def __init__(self) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from sensor_msgs.msg import JointState
        from interfaces_py.background_spin import BackgroundSpin

        self._rclpy = rclpy
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = Node("bench_joint_watcher", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.lock = threading.Lock()
        self.latest: np.ndarray | None = None
        self._reference: np.ndarray | None = None
        self.moved_at: float | None = None
        self._index: list[int] | None = None
        #: called with (perf_counter time, arm positions) for every message
        self.listeners: list[Any] = []
        self.node.create_subscription(JointState, "/joint_states", self._on_joint_state, 10)
        self.spinner = BackgroundSpin(self.executor, name="joint state probe")

    def _on_joint_state(self, msg: Any) -> None:
        now = time.perf_counter()
        if self._index is None:
            names = list(msg.name)
            if not all(j in names for j in ARM_JOINTS):
                return
            self._index = [names.index(j) for j in ARM_JOINTS]
        positions = np.asarray(msg.position, dtype=float)[self._index]
        with self.lock:
            self.latest = positions
            if self._reference is not None and self.moved_at is None:
                if np.max(np.abs(positions - self._reference)) > MOTION_THRESHOLD:
                    self.moved_at = now
        for listener in self.listeners:
            listener(now, positions)

    def arm(self) -> None:
        """Record the current position as the reference; the next change sets ``moved_at``."""
        with self.lock:
            self._reference = None if self.latest is None else self.latest.copy()
            self.moved_at = None

    def close(self) -> None:
        self.spinner.stop()
        self.node.destroy_node()
        self._rclpy.try_shutdown(context=self.context)


def _wait(predicate, timeout: float, what: str) -> None:
    if not wait_until(predicate, timeout, 0.005):
        raise RuntimeError(f"timed out waiting for {what}")


def robot_ready(arm: Any, joint_states_here: Any) -> None:
    """Wait until the planning_server answers and has joint states, and ``joint_states_here()``."""
    if not arm.wait_for_server(30.0):
        raise RuntimeError("the planning_server does not answer")
    _wait(lambda: arm.call("get_state").get("joint_state_received"), 30.0, "joint states at the server")
    _wait(joint_states_here, 30.0, "/joint_states here")


def bench_exec_latency(repeat: int, seed: int) -> None:
    """Execute request -> first controller motion on /joint_states (see module docstring)."""
    from interfaces_py.clients import MoveGroupClient

    rng = np.random.default_rng(seed)
    with RobotProcesses(bench_domain_id()):
        watcher = _JointWatcher()
        arm = MoveGroupClient("arm", node=watcher.node, timeout=15.0)
        try:
            robot_ready(arm, lambda: watcher.latest is not None)
            arm.set_max_velocity_scaling_factor(1.0)
            all_samples: list[float] = []
            medians: list[float] = []
            sign = 1.0
            for index in range(repeat):
                samples = []
                for _ in range(EXECUTIONS_PER_REPEAT):
                    # a short joint move around "ready" (0.1-0.2 rad per joint), alternating sides
                    goal = np.array([0.0, 0.0, 1.5708, 1.5708, 0.0, 0.0]) + sign * rng.uniform(0.1, 0.2, 6)
                    sign = -sign
                    arm.set_joint_value_target(goal)
                    ok, trajectory, code = arm.plan()
                    if not ok:
                        raise RuntimeError(f"planning failed: {code}")
                    # let the robot settle at the start, so the watcher's reference is exact
                    _wait(lambda: not arm.call("get_state")["execution"]["executing"], 30.0, "the previous execution")
                    time.sleep(0.05)
                    watcher.arm()
                    result: dict[str, Any] = {}
                    started = time.perf_counter()
                    thread = threading.Thread(target=lambda: result.setdefault("code", arm.execute(trajectory)))
                    thread.start()
                    _wait(lambda: watcher.moved_at is not None, 30.0, "the first controller motion")
                    samples.append(watcher.moved_at - started)
                    thread.join(60.0)
                    if not result.get("code"):
                        raise RuntimeError(f"execution failed: {result.get('code')}")
                record = {"scenario": "exec_latency", "repeat": index, "executions": len(samples)}
                record.update(stats(samples, 1e3, "ms"))
                medians.append(record["median_ms"])
                emit(record)
                all_samples += samples
        finally:
            arm.close()
            watcher.close()
    summary = {"scenario": "exec_latency", "summary": True}
    summary.update({k: v for k, v in stats(all_samples, 1e3, "ms").items() if k in ("median_ms", "p90_ms")})
    emit({**summary, **spread(medians), **machine()})


def _boxes(rng: np.random.Generator, prefix: str) -> list[CollisionObject]:
    """50 small boxes at random poses around the robot (never touching it matters not: world
    objects are not checked against each other)."""
    boxes = []
    for k in range(SCENE_OBJECTS):
        position = [float(rng.uniform(0.15, 0.3)), float(rng.uniform(-0.25, 0.25)), float(rng.uniform(0.0, 0.3))]
        yaw = float(rng.uniform(-np.pi, np.pi))
        boxes.append(CollisionObject.box(f"{prefix}{k}", [float(v) for v in rng.uniform(0.01, 0.05, 3)],
                                         Pose.from_xyz_rpy(position, (0.0, 0.0, yaw))))
    return boxes


def _check_read_back(objects: dict[str, CollisionObject], boxes: list[CollisionObject]) -> None:
    missing = [b.id for b in boxes if b.id not in objects]
    if missing:
        raise RuntimeError(f"objects missing after the update: {missing[:5]}...")
    for box in boxes:
        if not np.allclose(objects[box.id].pose.position, box.pose.position, atol=1e-9):
            raise RuntimeError(f"object '{box.id}' read back at {objects[box.id].pose.position}, "
                               f"applied at {box.pose.position}")


def bench_scene_update(repeat: int, seed: int) -> None:
    """Apply 50 objects and read them back: batched (summary) and one by one (see module)."""
    from interfaces_py.clients import PlanningSceneInterface

    rng = np.random.default_rng(seed)
    with RobotProcesses(bench_domain_id()):
        with PlanningSceneInterface(timeout=30.0) as scene:
            if not scene.wait_for_server(30.0):
                raise RuntimeError("the planning_server does not answer")
            remove = lambda boxes: scene.apply_collision_objects(  # noqa: E731
                [CollisionObject(id=b.id, operation=CollisionObject.REMOVE) for b in boxes])
            warm = _boxes(rng, "warm_")  # first requests pay for discovery and caches: untimed
            scene.apply_collision_objects(warm)
            _check_read_back(scene.get_objects(), warm)
            remove(warm)
            batched_all: list[float] = []
            single_all: list[float] = []
            medians: list[float] = []
            for index in range(repeat):
                batched, single = [], []
                for run in range(SCENE_RUNS_PER_REPEAT):
                    boxes = _boxes(rng, f"box_{index}_{run}_")
                    start = time.perf_counter()
                    scene.apply_collision_objects(boxes)
                    objects = scene.get_objects()
                    batched.append(time.perf_counter() - start)
                    _check_read_back(objects, boxes)
                    remove(boxes)

                    boxes = _boxes(rng, f"one_{index}_{run}_")
                    start = time.perf_counter()
                    for box in boxes:
                        scene.add_object(box)
                    objects = scene.get_objects()
                    single.append(time.perf_counter() - start)
                    _check_read_back(objects, boxes)
                    remove(boxes)
                record = {"scenario": "scene_update", "repeat": index, "runs": len(batched), "objects": SCENE_OBJECTS}
                record.update(stats(batched, 1e3, "ms"))
                record.update({f"one_by_one_{k}": v for k, v in stats(single, 1e3, "ms").items()})
                medians.append(record["median_ms"])
                emit(record)
                batched_all += batched
                single_all += single
    summary = {"scenario": "scene_update", "summary": True, "objects": SCENE_OBJECTS}
    summary.update({k: v for k, v in stats(batched_all, 1e3, "ms").items() if k in ("median_ms", "p90_ms")})
    summary["one_by_one_median_ms"] = stats(single_all, 1e3, "ms")["median_ms"]
    summary["batch_speedup"] = round(summary["one_by_one_median_ms"] / summary["median_ms"], 2)
    emit({**summary, **spread(medians), **machine()})


ROS_SCENARIOS = {"exec_latency": bench_exec_latency, "scene_update": bench_scene_update}


# ----------------------------------------------------------------------------- moveit_api
MOVEIT_API_CALLS = 20  # per repeat, for each of plan and IK
_ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6",
        "link6_to_link6_flange"]
_GOALS = ([0.0, -0.3, 0.6, 0.2, 0.0, 0.0], [1.0, -1.0, -0.8, 0.3, 0.5, 0.8])


def bench_moveit_api(repeat: int, seed: int) -> None:
    """move_group's services end to end (GetMotionPlan with a joint goal and GetPositionIK, myCobot,
    empty scene) from a client process, against the same typed capability calls in-process
    (capabilities.plan.plan, capabilities.kinematics.compute_ik: what the moveit_msgs face calls):
    the difference is what the moveit_msgs face and ROS transport cost."""
    import rclpy
    from moveit_msgs.msg import Constraints, JointConstraint
    from moveit_msgs.srv import GetMotionPlan, GetPositionIK
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    from mycobot_planning.core.planning_interface.planning_pipeline import PlanningPipeline
    from mycobot_planning.capabilities import kinematics, plan
    from mycobot_planning.capabilities.move_group_context import MoveGroupContext, planning_only
    from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest
    from mycobot_planning.core.robot_model.robot_model import RobotModel
    from mycobot_planning.core.robot_state.robot_state import RobotState

    model = RobotModel.mycobot()
    local = planning_only(MoveGroupContext, model, PlanningPipeline())
    poses = []
    for goal in _GOALS:
        state = RobotState(model)
        state.set_joint_positions(dict(zip(_ARM, goal)))
        poses.append(Pose.from_matrix(state.frame_pose("link6_flange")))

    def plan_request(goal: list[float]) -> Any:
        request = GetMotionPlan.Request()
        r = request.motion_plan_request
        r.group_name, r.allowed_planning_time, r.num_planning_attempts = "arm", 5.0, 1
        r.goal_constraints = [Constraints(joint_constraints=[JointConstraint(
            joint_name=j, position=v, tolerance_above=1e-3, tolerance_below=1e-3, weight=1.0)
            for j, v in zip(_ARM, goal)])]
        return request

    def ik_request(pose: Pose) -> Any:
        request = GetPositionIK.Request()
        request.ik_request.group_name = "arm"
        request.ik_request.pose_stamped.header.frame_id = "world"
        p = request.ik_request.pose_stamped.pose
        p.position.x, p.position.y, p.position.z = pose.position
        p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w = pose.orientation
        return request

    # the in-process calls start where the mock robot stands (every joint at 0), stated in full
    start = RobotStateMsg(joint_names=list(model.variable_names), positions=[0.0] * len(model.variable_names))
    pose_matrices = [p.to_matrix() for p in poses]

    def plan_local(goal: list[float]) -> Any:
        return plan.plan(local, MotionPlanRequest("arm", JointGoal(dict(zip(_ARM, goal)), 1e-3),
                                                  allowed_planning_time=5.0, num_planning_attempts=1),
                         start, display=False)
    with RobotProcesses(bench_domain_id()):
        context = rclpy.Context()
        rclpy.init(context=context)
        node = Node("bench_moveit_api", context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        plan_client = node.create_client(GetMotionPlan, "/plan_kinematic_path")
        ik_client = node.create_client(GetPositionIK, "/compute_ik")
        try:
            for client in (plan_client, ik_client):
                if not client.wait_for_service(timeout_sec=30.0):
                    raise RuntimeError(f"{client.srv_name} is not offered")

            def call(client: Any, request: Any) -> Any:
                # spin_once until the answer, as a client that wants it soon waits: rclpy's
                # spin_until_future_complete adds 3-9 ms to any call here (node_waiter.spin_until_done)
                future = client.call_async(request)
                deadline = time.monotonic() + 30.0
                while not future.done() and time.monotonic() < deadline:
                    executor.spin_once(timeout_sec=0.1)
                if not future.done():
                    raise RuntimeError(f"{client.srv_name} did not answer")
                return future.result()

            def ok_plan(response: Any) -> None:
                if response.motion_plan_response.error_code.val != 1:
                    raise RuntimeError(f"plan failed: {response.motion_plan_response.error_code.message}")

            def ok_ik(response: Any) -> None:
                if response.error_code.val != 1:
                    raise RuntimeError(f"IK failed: {response.error_code.message}")

            for i in range(3):  # warm-up: discovery, caches, IK seed tables (untimed)
                ok_plan(call(plan_client, plan_request(_GOALS[i % 2])))
                ok_ik(call(ik_client, ik_request(poses[i % 2])))
                plan_local(_GOALS[i % 2])
                kinematics.compute_ik(local, "arm", pose_matrices[i % 2], seed=start)
            samples: dict[str, list[float]] = {"plan": [], "plan_local": [], "ik": [], "ik_local": []}
            medians: list[float] = []
            for index in range(repeat):
                run: dict[str, list[float]] = {k: [] for k in samples}
                for k in range(MOVEIT_API_CALLS):
                    goal, pose = _GOALS[k % 2], poses[k % 2]
                    t0 = time.perf_counter()
                    ok_plan(call(plan_client, plan_request(goal)))
                    t1 = time.perf_counter()
                    result = plan_local(goal)
                    t2 = time.perf_counter()
                    if result.error_code.val != 1:
                        raise RuntimeError(f"in-process plan failed: {result.error_code.message}")
                    ok_ik(call(ik_client, ik_request(pose)))
                    t3 = time.perf_counter()
                    code, _ = kinematics.compute_ik(local, "arm", pose_matrices[k % 2], seed=start)
                    t4 = time.perf_counter()
                    if code.val != 1:
                        raise RuntimeError(f"in-process IK failed: {code.message}")
                    for key, value in (("plan", t1 - t0), ("plan_local", t2 - t1), ("ik", t3 - t2),
                                       ("ik_local", t4 - t3)):
                        run[key].append(value)
                record = {"scenario": "moveit_api", "repeat": index, "calls": MOVEIT_API_CALLS}
                for key, values in run.items():
                    record[f"{key}_median_ms"] = round(float(np.median(values)) * 1e3, 3)
                    samples[key] += values
                medians.append(record["plan_median_ms"])
                emit(record)
        finally:
            executor.shutdown()
            node.destroy_node()
            rclpy.try_shutdown(context=context)
    med = {key: float(np.median(values)) * 1e3 for key, values in samples.items()}
    summary = {
        "scenario": "moveit_api", "summary": True, "calls": len(samples["plan"]),
        "plan_median_ms": round(med["plan"], 3), "plan_in_process_median_ms": round(med["plan_local"], 3),
        "ik_median_ms": round(med["ik"], 3), "ik_in_process_median_ms": round(med["ik_local"], 3),
        "plan_overhead_ms": round(med["plan"] - med["plan_local"], 3),
        "ik_overhead_ms": round(med["ik"] - med["ik_local"], 3),
    }
    summary["overhead_ms"] = max(summary["plan_overhead_ms"], summary["ik_overhead_ms"])
    emit({**summary, **spread(medians), **machine()})


ROS_SCENARIOS["moveit_api"] = bench_moveit_api
