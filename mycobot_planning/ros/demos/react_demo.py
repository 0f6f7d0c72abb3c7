"""The reacting-while-moving demo (scripts/react_demo.sh, issue 29) and the client it shares with
the `react` benchmark: a move_group user's node that sends MoveGroup goals, publishes collision
objects the way perception_server does, and records /joint_states.

    python -m mycobot_planning.ros.demos.react_demo

The arm sweeps joint 1 from -1.2 to +1.2 rad (30 % speed) with replanning on (planning_options:
replan, 3 attempts); 0.5 s into the motion a 6 cm box appears on /collision_object where the
flange would pass at mid-sweep. move_group re-checks the path ahead, stops the arm short of the box
along its path, plans again from where it stopped and arrives. The demo prints what happened, the
smallest clearance between the robot and the box over every recorded state, and exits 0 only if
the arm arrived and never touched the box.
"""
from __future__ import annotations

import sys
import threading
import time
from typing import Any

import numpy as np
import rclpy
from geometry_msgs.msg import Pose
from moveit_msgs.action import MoveGroup
from moveit_msgs.msg import CollisionObject, Constraints, JointConstraint
from rclpy.context import Context
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile
from sensor_msgs.msg import JointState
from shape_msgs.msg import SolidPrimitive
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory

from interfaces_py.action_client import ActionClient
from interfaces_py.background_spin import BackgroundSpin
from interfaces_py.msgs import CollisionObject as SceneObject
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.transforms import make_pose
from mycobot_planning.ros.demos.robot_demos import Demo, run_demo
from mycobot_planning.ros.executors import MultiThreadedExecutor

ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6",
       "link6_to_link6_flange"]
SWEEP_START = [-1.2, -0.8, -0.6, 0.0, 0.0, 0.0]
SWEEP_END = [1.2, -0.8, -0.6, 0.0, 0.0, 0.0]
#: s into the motion when the box appears
INTRUSION_AFTER = 0.5
INTRUDER_SIZE = 0.06


class ReactProbe:
    """A client node: move_action, /collision_object, /trajectory_execution_event, /planned_path
    and every /joint_states message with its time.

    A state's time is its header stamp when that is on this machine's wall clock (the mock
    controllers stamp with it), else its arrival: on a loaded machine this client's executor can
    run late, and arrival times then place states after events that came later than they did.
    Compare them with ``now()`` (wall clock seconds)."""

    #: s: a stamp further than this from the wall clock is on another clock (simulated time)
    STAMP_SKEW = 5.0

    def __init__(self) -> None:
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = Node("react_probe", context=self.context)
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

    @staticmethod
    def now() -> float:
        """The wall clock (s), the clock of the recorded states' times."""
        return time.time()

    def _on_joint_state(self, msg: Any) -> None:
        now = time.time()
        stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        if abs(stamp - now) < self.STAMP_SKEW:
            now = stamp
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
            self.plan_times.append(time.time())

    def arm(self) -> np.ndarray:
        with self.lock:
            return self.history[-1][1].copy()

    def since(self, t: float) -> list[tuple[float, np.ndarray]]:
        with self.lock:
            return [(s, p) for s, p in self.history if s >= t]

    def left(self, start: Any, after: float, tolerance: float = 1e-4) -> float | None:
        """The time of the first state at or after ``after`` more than ``tolerance`` from
        ``start`` (the motion's start), or None while there is none."""
        start = np.asarray(start, dtype=float)
        for t, p in self.since(after):
            if np.max(np.abs(p - start)) > tolerance:
                return t
        return None

    def close(self) -> None:
        self.spinner.stop()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)



def joint_goal(values: Any, scaling: float, replan: bool, attempts: int = 3) -> Any:
    """A MoveGroup goal for the arm's joint values (plan and execute)."""

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
    goal.planning_options.replan_attempts = attempts if replan else 0
    return goal


def wait_for(predicate: Any, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise RuntimeError(f"timed out waiting for {what}")
        time.sleep(0.002)


def send_goal(probe: ReactProbe, goal: Any, timeout: float = 60.0, feedback: Any = None) -> Any:
    """Send a MoveGroup goal; returns its result future."""
    if not probe.move.wait_for_server(30.0):
        raise RuntimeError("move_action is not offered")
    handle_future = probe.move.send_goal_async(goal, feedback_callback=feedback)
    wait_for(handle_future.done, timeout, "the goal's acceptance")
    handle = handle_future.result()
    if not handle.accepted:
        raise RuntimeError("move_action refused the goal")
    return handle.get_result_async()


def run_goal(probe: ReactProbe, goal: Any, timeout: float = 90.0) -> Any:
    future = send_goal(probe, goal)
    wait_for(future.done, timeout, "the goal's result")
    return future.result().result


def box_msg(object_id: str, position: Any, size: float, remove: bool = False) -> Any:
    """A moveit_msgs CollisionObject box in the world frame (or its removal)."""

    obj = CollisionObject(id=object_id, operation=CollisionObject.REMOVE if remove else CollisionObject.ADD)
    obj.header.frame_id = "world"
    if not remove:
        obj.pose.position.x, obj.pose.position.y, obj.pose.position.z = (float(v) for v in position)
        obj.pose.orientation.w = 1.0
        obj.primitives = [SolidPrimitive(type=SolidPrimitive.BOX, dimensions=[float(size)] * 3)]
        obj.primitive_poses = [Pose()]
        obj.primitive_poses[0].orientation.w = 1.0
    return obj


def clearances(model: Any, states: list[np.ndarray], object_id: str, position: Any, size: float) -> list[float]:
    """The robot's distance to a box at ``position`` in each of ``states`` (arm joint values)."""

    scene = PlanningScene(model)
    scene.add_object(SceneObject.box(object_id, [size] * 3, make_pose(position)))
    out = []
    for values in states:
        state = RobotState(model)
        state.set_joint_positions(dict(zip(ARM, values)))
        out.append(float(scene.distance(state, include_self=False).min_distance))
    return out


def flange_position(model: Any, values: Any) -> np.ndarray:

    state = RobotState(model)
    state.set_joint_positions(dict(zip(ARM, values)))
    return state.frame_pose("link6_flange")[:3, 3]


def react(say: Any) -> int:
    """The demo on a running robot (see the module docstring); its exit code."""

    model = RobotModel.mycobot()
    middle = list(SWEEP_START)
    middle[0] = 0.0
    where = flange_position(model, middle)
    probe = ReactProbe()
    try:
        wait_for(lambda: len(probe.history) > 0, 30.0, "/joint_states")
        say("moving to the start of the sweep (joint 1 at -1.2 rad)")
        if run_goal(probe, joint_goal(SWEEP_START, 1.0, False)).error_code.val != 1:
            say("FAILED: could not reach the start")
            return 1
        states: list[str] = []

        def on_feedback(msg: Any) -> None:
            if not states or states[-1] != msg.feedback.state:
                states.append(msg.feedback.state)
                if states.count("PLANNING") == 2 and msg.feedback.state == "PLANNING":
                    say(f"move_action feedback: PLANNING (again: the arm stopped at joint 1 = {probe.arm()[0]:+.3f} "
                        "rad, short of the box at 0.0; planning from there)")
                else:
                    say(f"move_action feedback: {msg.feedback.state}")

        say("sweeping joint 1 to +1.2 rad at 30 % speed, replanning on (3 attempts)")
        future = send_goal(probe, joint_goal(SWEEP_END, 0.3, True), feedback=on_feedback)
        wait_for(lambda: future.done() or np.max(np.abs(probe.arm() - np.array(SWEEP_START))) > 1e-4, 30.0,
                 "the motion")
        time.sleep(INTRUSION_AFTER)
        published = probe.now()
        probe.objects.publish(box_msg("intruder", where, INTRUDER_SIZE))
        say(f"a {INTRUDER_SIZE * 100:.0f} cm box 'intruder' appears on /collision_object at "
            f"({where[0]:.3f}, {where[1]:.3f}, {where[2]:.3f}), where the flange passes at mid-sweep")
        wait_for(future.done, 120.0, "the goal's result")
        code = future.result().result.error_code
        time.sleep(0.1)
        recorded = [p for _, p in probe.since(published)]
        distances = clearances(model, recorded, "intruder", where, INTRUDER_SIZE)
        smallest = min(distances) if distances else float("nan")
        final = probe.arm()
        arrived = bool(np.max(np.abs(final - np.array(SWEEP_END))) < 0.02)
        say(f"result: {'SUCCESS' if code.val == 1 else code.val}: {code.message}")
        say(f"smallest clearance between the robot and the box: {smallest * 1000:.1f} mm "
            f"over {len(distances)} recorded joint states")
        say(f"the arm ends at joint 1 = {final[0]:+.3f} rad ({'at the goal' if arrived else 'NOT at the goal'})")
        probe.objects.publish(box_msg("intruder", None, INTRUDER_SIZE, remove=True))
        ok = code.val == 1 and arrived and smallest > 0.0
        say("the arm stopped short of the box, replanned and arrived" if ok else "FAILED")
        return 0 if ok else 1
    finally:
        probe.close()


def main(argv: list[str] | None = None) -> int:

    demo = Demo("react demo", "react-demo")

    def body() -> int:
        demo.say("starting the mock controllers and the planning_server")
        demo.start_robot()
        return react(demo.say)

    return run_demo(demo, body)


if __name__ == "__main__":
    sys.exit(main())
