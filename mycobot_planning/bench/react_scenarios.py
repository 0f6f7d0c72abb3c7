"""Reacting while moving (issue 29): objects appearing on the path of a running motion, and stops.

Real processes (mock controllers, planning_server) on a domain of the bench's own. Each
intrusion: the arm moves to a random valid start, a move_action goal to a random valid goal runs
with replanning (replan, 3 attempts, velocity and acceleration scaling 0.5); the plan is read from
/planned_path and a 4 cm box is published on /collision_object where the flange will be at a
random 50-85 % of the plan (the start and the goal kept 2 cm clear of it), 0.6 s before the
plan would first touch it (the motion's start seen on /joint_states). Then:

* ``reaction_ms``: from the box's arrival at move_group (the scene change) to the stop command
  sent to the controllers, as move_group measures it (``get_state``: last_reaction_ms);
* ``min_clearance_m``: the smallest distance between the box and the robot over every
  /joint_states state recorded from the box's publication to the replan (the reaction and the
  stop), in every run (> 0: never touched); ``replanned_min_clearance_m`` the same over the
  replanned motions (the planner's own clearance: plans are checked at the validator's
  resolution, with no padding, as MoveIt's);
* ``replan_success_rate``: runs that ended SUCCESS at the goal (after stopping and replanning);
* ``stop_latency_ms``: separate runs: a "stop" on /trajectory_execution_event 30-60 % into a
  motion at full speed, to the first /joint_states message after which the arm stays still for
  two more (the controllers publish at 100 Hz: up to 20 ms late); ``stop_decel_ms`` is the stop's
  own deceleration time (from the result message) and ``stop_overhead_ms`` the difference.

Summary keys (a contract, keep them stable): reaction_ms (median), reaction_p90_ms,
min_clearance_m, replanned_min_clearance_m, replan_success_rate, stop_latency_ms (median), stop_decel_ms, stop_overhead_ms
(medians), intrusions, invalidated, plus the spread of per-repeat reaction medians and the machine.

Register in scenarios.SCENARIOS as "react".
"""
from __future__ import annotations

import re
import threading
import time
from typing import Any

import numpy as np

from .common import emit, machine, spread

INTRUSIONS = 20
#: s between the box's publication and the plan's first contact with it
LEAD = 0.6
STOPS = 10
BOX_SIZE = 0.04
REST_THRESHOLD = 1e-6
ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6",
       "link6_to_link6_flange"]


class _Probe:
    """A client node: move_action, /collision_object, /trajectory_execution_event, /planned_path
    and every /joint_states message with its arrival time."""

    def __init__(self) -> None:
        import rclpy
        from moveit_msgs.action import MoveGroup
        from moveit_msgs.msg import CollisionObject
        from rclpy.context import Context
        from rclpy.executors import MultiThreadedExecutor
        from rclpy.node import Node
        from rclpy.qos import DurabilityPolicy, QoSProfile
        from sensor_msgs.msg import JointState
        from std_msgs.msg import String
        from trajectory_msgs.msg import JointTrajectory

        from interfaces_py.action_client import ActionClient
        from interfaces_py.background_spin import BackgroundSpin

        self._rclpy = rclpy
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = Node("bench_react", context=self.context)
        self.executor = MultiThreadedExecutor(num_threads=2, context=self.context)
        self.executor.add_node(self.node)
        self.lock = threading.Lock()
        self.move = ActionClient(self.node, MoveGroup, "/move_action")
        self.objects = self.node.create_publisher(CollisionObject, "/collision_object", 10)
        self.events = self.node.create_publisher(String, "/trajectory_execution_event", 10)
        self.history: list[tuple[float, np.ndarray]] = []
        self.plans: list[Any] = []
        self.plan_times: list[float] = []
        self._index: list[int] | None = None
        self.node.create_subscription(JointState, "/joint_states", self._on_joint_state, 50)
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.node.create_subscription(JointTrajectory, "/planned_path", self._on_plan, latched)
        self.spinner = BackgroundSpin(self.executor, name="react bench probe")

    def _on_joint_state(self, msg: Any) -> None:
        now = time.perf_counter()
        if self._index is None:
            names = list(msg.name)
            if not all(j in names for j in ARM):
                return
            self._index = [names.index(j) for j in ARM]
        with self.lock:
            self.history.append((now, np.asarray(msg.position, dtype=float)[self._index]))
            if len(self.history) > 20000:
                del self.history[:10000]

    def _on_plan(self, msg: Any) -> None:
        with self.lock:
            self.plans.append(msg)
            self.plan_times.append(time.perf_counter())

    def arm(self) -> np.ndarray:
        with self.lock:
            return self.history[-1][1].copy()

    def since(self, t: float) -> list[tuple[float, np.ndarray]]:
        with self.lock:
            return [(s, p) for s, p in self.history if s >= t]

    def close(self) -> None:
        self.spinner.stop()
        self.node.destroy_node()
        self._rclpy.try_shutdown(context=self.context)


def _goal(values: np.ndarray, scaling: float, replan: bool) -> Any:
    from moveit_msgs.action import MoveGroup
    from moveit_msgs.msg import Constraints, JointConstraint

    goal = MoveGroup.Goal()
    r = goal.request
    r.group_name = "arm"
    r.allowed_planning_time = 5.0
    r.max_velocity_scaling_factor = scaling
    r.max_acceleration_scaling_factor = scaling
    r.goal_constraints = [Constraints(joint_constraints=[
        JointConstraint(joint_name=j, position=float(v), tolerance_above=1e-3, tolerance_below=1e-3, weight=1.0)
        for j, v in zip(ARM, values)])]
    goal.planning_options.replan = replan
    goal.planning_options.replan_attempts = 3 if replan else 0
    return goal


def _send(probe: _Probe, goal: Any, timeout: float = 60.0) -> Any:
    """Send a goal; returns the result future."""
    if not probe.move.wait_for_server(30.0):
        raise RuntimeError("move_action is not offered")
    handle_future = probe.move.send_goal_async(goal)
    _wait(handle_future.done, timeout, "the goal's acceptance")
    handle = handle_future.result()
    if not handle.accepted:
        raise RuntimeError("move_action refused the goal")
    return handle.get_result_async()


def _run(probe: _Probe, goal: Any, timeout: float = 90.0) -> Any:
    future = _send(probe, goal)
    _wait(future.done, timeout, "the goal's result")
    return future.result().result


def _wait(predicate, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise RuntimeError(f"timed out waiting for {what}")
        time.sleep(0.002)


def _box(object_id: str, position: np.ndarray | None, remove: bool = False) -> Any:
    from geometry_msgs.msg import Pose
    from moveit_msgs.msg import CollisionObject
    from shape_msgs.msg import SolidPrimitive

    obj = CollisionObject(id=object_id, operation=CollisionObject.REMOVE if remove else CollisionObject.ADD)
    obj.header.frame_id = "world"
    if not remove:
        obj.pose.position.x, obj.pose.position.y, obj.pose.position.z = (float(v) for v in position)
        obj.pose.orientation.w = 1.0
        obj.primitives = [SolidPrimitive(type=SolidPrimitive.BOX, dimensions=[BOX_SIZE] * 3)]
        obj.primitive_poses = [Pose()]
        obj.primitive_poses[0].orientation.w = 1.0
    return obj


def _random_pair(model: Any, scene: Any, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A valid start and goal 1-2.5 rad apart (joint 1 turning most), flange above the table."""
    from mycobot_planning.core import RobotState

    group = model.group("arm")
    low, high = model.lower_limits[group.variable_indices], model.upper_limits[group.variable_indices]
    while True:
        start = rng.uniform(low * 0.6, high * 0.6)
        goal = rng.uniform(low * 0.6, high * 0.6)
        goal[0] = start[0] + rng.choice([-1.0, 1.0]) * rng.uniform(1.0, 2.5)
        if not low[0] * 0.9 < goal[0] < high[0] * 0.9:
            continue
        ok = True
        for values in (start, goal):
            state = RobotState(model)
            state.set_group_positions("arm", values)
            if scene.is_state_colliding(state):
                ok = False
            if state.frame_pose("link6_flange")[2, 3] < 0.12:
                ok = False
        if ok:
            return start, goal


def _intrusion(model: Any, trajectory: Any, goal: np.ndarray, rng: np.random.Generator
               ) -> tuple[np.ndarray, float] | None:
    """Where to put the box (the flange's position at a random 50-85 % of the plan, keeping the
    goal and the start free and 2 cm clear) and when the plan first touches it (s from its start);
    None when 50 tries find no such place."""
    from interfaces_py.msgs import CollisionObject as SceneObject
    from mycobot_planning.core import PlanningScene, RobotState
    from mycobot_planning.core.trajectory_execution.path_ahead import PathAhead
    from mycobot_planning.core.transforms import make_pose

    path = PathAhead(model, trajectory)
    for _ in range(50):
        q = trajectory.sample(trajectory.times[0] + rng.uniform(0.5, 0.85) * trajectory.duration)[0]
        state = RobotState(model)
        state.set_joint_positions(dict(zip(trajectory.joint_names, q)))
        where = state.frame_pose("link6_flange")[:3, 3]
        scene = PlanningScene(model)
        scene.add_object(SceneObject.box("probe", [BOX_SIZE] * 3, make_pose(where)))
        ends = []
        for values in (trajectory.positions[0], goal):
            end = RobotState(model)
            end.set_joint_positions(dict(zip(ARM, values)))
            ends.append(scene.distance(end, include_self=False).min_distance)
        hit = path.first_collision(scene, 0.0)
        if hit is not None and min(ends) > 0.02 and hit.time > LEAD + 0.3:
            return where, hit.time
    return None


def _rest_time(history: list[tuple[float, np.ndarray]], asked: float) -> float:
    samples = [(t, p) for t, p in history if t >= asked]
    for i in range(len(samples) - 2):
        t, p = samples[i]
        if all(np.max(np.abs(samples[j][1] - p)) < REST_THRESHOLD for j in (i + 1, i + 2)):
            return t
    raise RuntimeError("the arm never came to rest after the stop")


def bench_react(repeat: int, seed: int) -> None:
    """See the module docstring."""
    from interfaces_py.clients import MoveGroupClient
    from mycobot_planning.core import PlanningScene, RobotModel, RobotState
    from mycobot_planning.core.robot_trajectory.robot_trajectory import joint_trajectory_to_timed
    from mycobot_planning.core.transforms import make_pose
    from interfaces_py.msgs import CollisionObject as SceneObject
    from interfaces_py.ros_conversions import joint_trajectory_from_msg
    from std_msgs.msg import String

    from .ros_scenarios import RobotProcesses, bench_domain_id

    rng = np.random.default_rng(seed)
    model = RobotModel.mycobot()
    free = PlanningScene(model)
    per_repeat = max(1, -(-INTRUSIONS // repeat))
    reactions: list[float] = []
    medians: list[float] = []
    clearances: list[float] = []
    replanned_clearances: list[float] = []
    outcomes: list[bool] = []
    invalidated = 0
    latencies, decels = [], []
    with RobotProcesses(bench_domain_id()):
        probe = _Probe()
        server = MoveGroupClient("arm", node=probe.node, timeout=15.0)
        try:
            if not server.wait_for_server(30.0):
                raise RuntimeError("the planning_server does not answer")
            _wait(lambda: server.call("get_state").get("joint_state_received"), 30.0, "joint states at the server")
            _wait(lambda: len(probe.history) > 0, 30.0, "/joint_states here")
            run = 0
            for index in range(repeat):
                repeat_reactions = []
                while len(outcomes) < (index + 1) * per_repeat:
                    run += 1
                    start, goal = _random_pair(model, free, rng)
                    if _run(probe, _goal(start, 1.0, False)).error_code.val != 1:
                        raise RuntimeError("could not move to the start")
                    with probe.lock:
                        probe.plans.clear()
                        probe.plan_times.clear()
                    before = server.call("get_state")["execution"]["invalidations"]
                    future = _send(probe, _goal(goal, 0.5, True))
                    _wait(lambda: probe.plans, 30.0, "the plan on /planned_path")
                    with probe.lock:
                        plan_msg = probe.plans[0]
                    trajectory = joint_trajectory_to_timed(joint_trajectory_from_msg(plan_msg))
                    found = _intrusion(model, trajectory, goal, rng)
                    if found is None:  # no place on this plan: let it finish, take another pair
                        _wait(future.done, 90.0, "the goal's result")
                        run -= 1
                        continue
                    where, t_contact = found
                    object_id = f"intruder{run}"
                    # the motion starts when the arm leaves the start (/joint_states)
                    _wait(lambda: future.done() or np.max(np.abs(probe.arm() - start)) > 1e-4, 30.0, "the motion")
                    publish_at = time.perf_counter() + t_contact - LEAD
                    _wait(lambda: time.perf_counter() >= publish_at or future.done(), 60.0, "the intrusion time")
                    published = time.perf_counter()
                    probe.objects.publish(_box(object_id, where))
                    _wait(future.done, 90.0, "the goal's result")
                    code = future.result().result.error_code
                    status = server.call("get_state")["execution"]
                    if status["invalidations"] > before:
                        invalidated += 1
                        reactions.append(status["last_reaction_ms"])
                        repeat_reactions.append(status["last_reaction_ms"])
                    time.sleep(0.05)
                    scene = PlanningScene(model)
                    scene.add_object(SceneObject.box(object_id, [BOX_SIZE] * 3, make_pose(where)))
                    with probe.lock:  # the replanned motion begins with the second plan
                        replanned_at = probe.plan_times[1] if len(probe.plan_times) > 1 else float("inf")
                    stopping, moving_on = [], []
                    for t, positions in probe.since(published):
                        state = RobotState(model)
                        state.set_joint_positions(dict(zip(ARM, positions)))
                        distance = scene.distance(state, include_self=False).min_distance
                        (stopping if t < replanned_at else moving_on).append(distance)
                    clearance = float(min(stopping)) if stopping else float("nan")
                    clearances.append(clearance)
                    if moving_on:
                        replanned_clearances.append(float(min(moving_on)))
                    arrived = code.val == 1 and np.max(np.abs(probe.arm() - goal)) < 0.02
                    outcomes.append(bool(arrived))
                    emit({"scenario": "react", "run": run, "code": int(code.val), "arrived": bool(arrived),
                          "min_clearance_m": round(clearance, 4),
                          "replanned_min_clearance_m": round(min(moving_on), 4) if moving_on else None,
                          "reaction_ms": status["last_reaction_ms"] if status["invalidations"] > before else None,
                          "message": code.message[:160]})
                    probe.objects.publish(_box(object_id, None, remove=True))
                    _wait(lambda: object_id not in server.call("get_objects").get("objects", {}), 10.0,
                          "the box's removal")
                if repeat_reactions:
                    medians.append(float(np.median(repeat_reactions)))
            for _ in range(STOPS):
                start, goal = _random_pair(model, free, rng)
                if _run(probe, _goal(start, 1.0, False)).error_code.val != 1:
                    raise RuntimeError("could not move to the start")
                with probe.lock:
                    probe.plans.clear()
                future = _send(probe, _goal(goal, 1.0, False))
                _wait(lambda: probe.plans, 30.0, "the plan on /planned_path")
                with probe.lock:
                    duration = joint_trajectory_to_timed(joint_trajectory_from_msg(probe.plans[0])).duration
                time.sleep(rng.uniform(0.3, 0.6) * duration)
                asked = time.perf_counter()
                probe.events.publish(String(data="stop"))
                _wait(future.done, 60.0, "the stopped goal's result")
                time.sleep(0.1)
                latencies.append((_rest_time(probe.since(asked), asked) - asked) * 1e3)
                found = re.search(r"after a ([0-9.]+) s stop", future.result().result.error_code.message)
                decels.append(float(found.group(1)) * 1e3 if found else float("nan"))
        finally:
            server.close()
            probe.close()
    overhead = [lat - dec for lat, dec in zip(latencies, decels)]
    emit({"scenario": "react", "summary": True,
          "reaction_ms": round(float(np.median(reactions)), 3) if reactions else None,
          "reaction_p90_ms": round(float(np.percentile(reactions, 90)), 3) if reactions else None,
          "min_clearance_m": round(float(np.nanmin(clearances)), 4) if clearances else None,
          "replanned_min_clearance_m": round(float(min(replanned_clearances)), 4) if replanned_clearances else None,
          "replan_success_rate": round(float(np.mean(outcomes)), 3) if outcomes else None,
          "stop_latency_ms": round(float(np.median(latencies)), 2) if latencies else None,
          "stop_decel_ms": round(float(np.nanmedian(decels)), 2) if decels else None,
          "stop_overhead_ms": round(float(np.nanmedian(overhead)), 2) if overhead else None,
          "intrusions": len(outcomes), "invalidated": invalidated, **spread(medians), **machine()})


REACT_SCENARIOS = {"react": bench_react}
