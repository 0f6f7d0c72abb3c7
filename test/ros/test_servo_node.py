"""servo_node (MoveIt Servo's interface) against mock_controllers + planning_server in real
processes, one bring-up for the module: twist, joint jog and pose tracking move the arm as
commanded; collision, singularity and joint-limit halts; a stopped stream halts; pause,
switch_command_type and Humble's start/stop as MoveIt's; bad input refused with INVALID and a log
line, never a jump; pymoveit2 5.0.0's MoveIt2Servo with both interfaces; the keyboard teleop on
a pseudo-terminal.

Every motion is judged on /joint_states (what the controllers did) and our own forward
kinematics; the halts also on the servo's own output stamps (no wall-clock assertion).

Timing: a loaded machine delays every process, so no test judges after a fixed time. Commands are
stamped as they are sent and republished at 50 Hz (five per incoming_command_timeout) until the
servo's own output (its JointTrajectory commands, stamped at its loop tick, or its status) shows
that what the test waits for happened; then the test waits for the servo's at-rest command and
for the arm to reach it (``Probe.drive`` / ``Probe.wait_rest``), each with a generous deadline.
Outputs are told apart by their stamps, not by when the probe happened to receive them."""
from __future__ import annotations

import math
import os
import pty
import select
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from control_msgs.msg import JointJog
from geometry_msgs.msg import Pose, PoseStamped, TwistStamped
from moveit_msgs.msg import CollisionObject, PlanningScene as PlanningSceneMsg, ServoStatus
from moveit_msgs.srv import ServoCommandType
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from shape_msgs.msg import SolidPrimitive
from std_srvs.srv import SetBool
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from interfaces_py.msgs import CollisionObject as CoreCollisionObject
from mycobot_planning.core import PlanningScene, RobotState
from mycobot_planning.core.servo import StatusCode
from mycobot_planning.core.transforms import make_pose, matrix_to_quat
from mycobot_planning.paths import config_file
from mycobot_arm import ARM, tip_pose
from ros_testing import NodeProcess, ProbeNode, REPO, ros_env, robot_processes, wait_until

WORK = [0.0, -0.5, -1.0, -0.2, 0.3, 0.0]  # +y from here extends the arm: the elbow singularity
START = [0.0, 0.3, -1.6, 0.0, 0.3, 0.0]  # room (10 cm) along +y and -x before any singularity
PERIOD, TIMEOUT = 0.01, 0.1
VMAX = 2.792527


def stamp_of(msg) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


class Probe(ProbeNode):
    def __init__(self) -> None:
        # one thread: every callback of this node is in its default (mutually exclusive) group
        # anyway, and rclpy's multi-threaded executor costs several times more per message -- on
        # a loaded machine the probe fell behind the 300 messages/s it receives
        super().__init__("servo_test_probe", executor=lambda c: SingleThreadedExecutor(context=c))
        self.states: list[tuple[float, np.ndarray, float]] = []
        self.lags: list[float] = []
        self.node.create_subscription(JointState, "/joint_states", self._record, 100)
        self.status = self.collect(ServoStatus, "/servo_node/status", 1000)
        self.out = self.collect(JointTrajectory, "/arm_controller/joint_trajectory", 1000)
        self.scenes = self.collect(PlanningSceneMsg, "/monitored_planning_scene",
                                   QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                                              durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self.twist = self.node.create_publisher(TwistStamped, "/servo_node/delta_twist_cmds", 10)
        self.jog = self.node.create_publisher(JointJog, "/servo_node/delta_joint_cmds", 10)
        self.pose = self.node.create_publisher(PoseStamped, "/servo_node/pose_target_cmds", 10)
        self.command = self.node.create_publisher(JointTrajectory, "/arm_controller/joint_trajectory", 10)
        self.objects = self.node.create_publisher(CollisionObject, "/collision_object", 10)
        self.spin_in_background()

    def _record(self, msg) -> None:
        index = {n: i for i, n in enumerate(msg.name)}
        if all(j in index for j in ARM):
            stamp = stamp_of(msg)
            with self.lock:
                self.states.append((time.monotonic(), np.array([msg.position[index[j]] for j in ARM]), stamp))
                self.lags.append(time.time() - stamp)
                del self.lags[:-500]

    def lag(self) -> str:
        """How late the probe has been receiving /joint_states lately (for failure messages)."""
        with self.lock:
            lags = list(self.lags)
        return f"probe lag on /joint_states: max {max(lags, default=0.0):.3f} s over the last {len(lags)}"

    def arm(self) -> np.ndarray:
        with self.lock:
            return self.states[-1][1].copy()

    def stamp(self):
        return self.node.get_clock().now().to_msg()

    def switch(self, kind: int) -> bool:
        return self.call(ServoCommandType, "/servo_node/switch_command_type",
                         ServoCommandType.Request(command_type=kind)).success

    def pause(self, value: bool) -> None:
        assert self.call(SetBool, "/servo_node/pause_servo", SetBool.Request(data=value)).success

    # Each send_* stamps its command as it publishes it and returns that stamp (s, system time).
    def send_twist(self, linear, angular=(0.0, 0.0, 0.0), frame="base_link") -> float:
        msg = TwistStamped()
        msg.header.stamp, msg.header.frame_id = self.stamp(), frame
        msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z = (float(v) for v in linear)
        msg.twist.angular.x, msg.twist.angular.y, msg.twist.angular.z = (float(v) for v in angular)
        self.twist.publish(msg)
        return stamp_of(msg)

    def send_jog(self, names, velocities) -> float:
        msg = JointJog()
        msg.header.stamp = self.stamp()
        msg.joint_names, msg.velocities = list(names), [float(v) for v in velocities]
        self.jog.publish(msg)
        return stamp_of(msg)

    def send_pose(self, pose: np.ndarray, frame="base_link") -> float:
        msg = PoseStamped()
        msg.header.stamp, msg.header.frame_id = self.stamp(), frame
        p, q = pose[:3, 3], matrix_to_quat(pose[:3, :3])
        msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = (float(v) for v in p)
        (msg.pose.orientation.x, msg.pose.orientation.y, msg.pose.orientation.z,
         msg.pose.orientation.w) = (float(v) for v in q)
        self.pose.publish(msg)
        return stamp_of(msg)

    def stream(self, send, seconds: float, rate: float = 50.0) -> None:
        """Only where nothing may happen (commands the servo must ignore): send for ``seconds``."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            send()
            time.sleep(1.0 / rate)

    def drive(self, send, done, what: str, timeout: float = 30.0, rate: float = 50.0) -> float:
        """Send fresh commands at ``rate`` until ``done()`` (the servo's own output shows that what
        the test waits for has happened): the stamp of the last command sent."""
        deadline = time.monotonic() + timeout
        while True:
            last = send()
            if done():
                return last
            assert time.monotonic() < deadline, f"{what} within {timeout} s ({self.lag()})"
            time.sleep(1.0 / rate)

    def outputs_after(self, t: float) -> list:
        """The servo's commands stamped after ``t`` (s, system time)."""
        with self.lock:
            return [m for m in self.out if stamp_of(m) > t]

    def commanded_after(self, t: float) -> np.ndarray | None:
        """The positions of the newest servo command stamped after ``t``, None before one came."""
        outputs = self.outputs_after(t)
        return np.array(outputs[-1].points[0].positions) if outputs else None

    def wait_rest(self, after: float, timeout: float = 30.0) -> np.ndarray:
        """Wait until the servo has published its at-rest command (one stamped after ``after``
        that repeats the command before it), the arm has reached it and is still; the arm."""
        def at_rest() -> bool:
            outputs = self.outputs_after(after)
            return len(outputs) >= 2 and list(outputs[-1].points[0].positions) == list(outputs[-2].points[0].positions)
        assert wait_until(at_rest, timeout), f"the servo did not bring the arm to rest ({self.lag()})"
        target = self.commanded_after(after)
        assert wait_until(lambda: np.max(np.abs(self.arm() - target)) < 1e-6, timeout), (self.arm(), target)
        return self.settle()

    def settle(self, timeout: float = 30.0) -> np.ndarray:
        """Wait until the arm has not moved for 0.3 s; its positions."""
        def still() -> bool:
            with self.lock:
                recent = [q for t, q, _ in self.states if t > time.monotonic() - 0.3]
            return len(recent) > 5 and np.max(np.ptp(np.array(recent), axis=0)) < 1e-6
        assert wait_until(still, timeout), f"the arm did not come to rest ({self.lag()})"
        return self.arm()

    def move_to(self, arm) -> None:
        """Straight to ``arm`` on the controller's topic, once the servo has gone quiet on it."""
        self.settle()
        with self.lock:
            count = [len(self.out), time.monotonic()]

        def quiet() -> bool:
            with self.lock:
                if len(self.out) != count[0]:
                    count[:] = [len(self.out), time.monotonic()]
            return time.monotonic() - count[1] > 0.2
        assert wait_until(quiet, 30.0), "servo_node keeps commanding the arm"
        distance = float(np.max(np.abs(np.asarray(arm) - self.arm())))
        msg = JointTrajectory()
        msg.joint_names = ARM
        msg.points = [JointTrajectoryPoint(positions=[float(v) for v in arm],
                                           velocities=[0.0] * 6)]
        duration = max(0.5, 2.0 * distance)
        msg.points[0].time_from_start.sec = int(duration)
        msg.points[0].time_from_start.nanosec = int((duration % 1) * 1e9)
        self.command.publish(msg)
        assert wait_until(lambda: np.max(np.abs(self.arm() - arm)) < 1e-4, duration + 30.0), (self.arm(), arm)
        self.settle()

    def statuses_since(self, index: int) -> list[int]:
        with self.lock:
            return [m.code for m in self.status[index:]]

    def mark_status(self, quiet: int = 20) -> int:
        """Wait until the servo's newest ``quiet`` statuses are all NO_WARNING (what an earlier
        test's commands caused has passed, whenever the probe received it); the index after them."""
        def calm() -> bool:
            with self.lock:
                recent = [m.code for m in self.status[-quiet:]]
            return len(recent) == quiet and set(recent) == {StatusCode.NO_WARNING}
        assert wait_until(calm, 30.0), f"the servo keeps reporting {self.statuses_since(-quiet)}"
        return len(self.status)

    def scene_has(self, name: str) -> bool:
        """Whether move_group's newest monitored scene (the servo's input) holds object ``name``."""
        with self.lock:
            scene = self.scenes[-1] if self.scenes else None
        return scene is not None and any(o.id == name for o in scene.world.collision_objects)


def angle_deg(a, b) -> float:
    return math.degrees(math.acos(np.clip(np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)), -1, 1)))


@pytest.fixture(scope="module")
def servo():
    with robot_processes():
        node = NodeProcess("mycobot_planning.nodes.servo_node",
                           ["--ros-args", "--params-file", str(config_file("servo_node.yaml"))])
        probe = Probe()
        try:
            assert wait_until(lambda: "servo_node ready" in node.output(), 90.0), node.output()[-3000:]
            assert wait_until(lambda: len(probe.states) > 0, 30.0), "no /joint_states"
            assert probe.client(ServoCommandType, "/servo_node/switch_command_type").wait_for_service(timeout_sec=30)
            yield probe, node
        finally:
            probe.close()
            node.stop()
            assert "Traceback" not in node.output(), node.output()[-3000:]


def logged_after(node, mark: int, words: str) -> bool:
    return words in node.output()[mark:]


def tip_moved(mycobot, probe: Probe, start_tip: np.ndarray, since: float, distance: float) -> bool:
    """Whether the servo's newest command (stamped after ``since``) puts the flange ``distance``
    from ``start_tip``."""
    commanded = probe.commanded_after(since)
    return commanded is not None and np.linalg.norm(tip_pose(mycobot, commanded)[:3, 3] - start_tip) >= distance


def joint_moved(probe: Probe, joint: int, start: np.ndarray, since: float, distance: float) -> bool:
    """Whether the servo's newest command (stamped after ``since``) has joint ``joint`` moved by
    ``distance`` (signed) from ``start``."""
    commanded = probe.commanded_after(since)
    return commanded is not None and (commanded[joint] - start[joint]) * math.copysign(1.0, distance) >= abs(distance)


def jog_first_joint(probe: Probe, start: np.ndarray, since: float, distance: float, failure: str) -> float:
    """Jog link1_to_link2 at full speed (the sign of ``distance``) until the servo's newest
    command has it ``distance`` from ``start``; the stamp of the last command sent."""
    speed = math.copysign(1.0, distance)
    return probe.drive(lambda: probe.send_jog(["link1_to_link2"], [speed]),
                       lambda: joint_moved(probe, 0, start, since, distance), failure)


def assert_commands_ignored(probe: Probe, node, send, says: str, before: np.ndarray, since: float,
                            failure: str) -> None:
    """``send`` commands until the servo logs ``says``, and as long again: the arm stays at
    ``before`` and the servo publishes nothing after ``since``."""
    mark = len(node.output())
    probe.drive(send, lambda: logged_after(node, mark, says), failure)
    probe.stream(send, 0.3)
    assert np.max(np.abs(probe.settle() - before)) < 1e-9 and probe.outputs_after(since) == []


def test_commands_are_ignored_until_the_command_type_is_set(servo):
    probe, node = servo
    probe.move_to(WORK)
    before = probe.arm()
    since = time.time()
    mark = len(node.output())
    # until the servo says it refused them (it logs at most once a second) ...
    probe.drive(lambda: probe.send_twist((0.0, 0.0, 1.0)),
                lambda: logged_after(node, mark, "Command type has not been set, cannot accept input"),
                "the servo did not say it ignores commands before switch_command_type")
    # ... and for as long again after that: nothing was commanded, nothing moved
    probe.stream(lambda: probe.send_twist((0.0, 0.0, 1.0)), 0.3)
    after = probe.settle()
    assert np.max(np.abs(after - before)) < 1e-9 and probe.outputs_after(since) == []


def test_twist_moves_the_flange_along_the_command(servo, mycobot):
    probe, _ = servo
    probe.move_to(START)
    assert probe.switch(ServoCommandType.Request.TWIST)
    start = tip_pose(mycobot, probe.arm())
    first = probe.mark_status()
    since = time.time()
    last = probe.drive(lambda: probe.send_twist((0.0, 1.0, 0.0)),
                       lambda: tip_moved(mycobot, probe, start[:3, 3], since, 0.06),
                       "the servo did not command 6 cm of motion")
    end = tip_pose(mycobot, probe.wait_rest(last))
    moved = end[:3, 3] - start[:3, 3]
    assert set(probe.statuses_since(first)) == {StatusCode.NO_WARNING}
    assert np.linalg.norm(moved) > 0.03
    assert angle_deg(moved, [0.0, 1.0, 0.0]) <= 2.0


def ready(probe: Probe, kind: int, arm=START) -> None:
    probe.pause(False)
    probe.move_to(arm)
    assert probe.switch(kind)


def test_joint_jog_moves_only_the_jogged_joint(servo):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.JOINT_JOG)
    before = probe.arm()
    since = time.time()
    last = jog_first_joint(probe, before, since, 0.15, "the servo did not jog the joint by 0.15 rad")
    moved = probe.wait_rest(last) - before
    steps = [np.array(m.points[0].positions) for m in probe.outputs_after(since)]
    assert 0.1 < moved[0] <= 0.5 * PERIOD * len(steps) + 1e-9  # scale.joint: 0.5 rad/s, period by period
    assert np.max(np.abs(np.diff(np.array(steps), axis=0)[:, 0])) <= 0.5 * PERIOD * 1.001
    assert np.all(np.abs(moved[1:]) < 1e-9)


def test_pose_tracking_ends_within_the_tolerances(servo, mycobot):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.POSE)
    target = tip_pose(mycobot, probe.arm())
    target[:3, 3] += [-0.03, 0.02, -0.02]
    target[:3, :3] = target[:3, :3] @ make_pose(rpy=[0.1, 0.0, -0.1])[:3, :3]

    def reached(arm) -> bool:
        pose = tip_pose(mycobot, arm)
        cos = (np.trace(pose[:3, :3].T @ target[:3, :3]) - 1) / 2
        return np.linalg.norm(pose[:3, 3] - target[:3, 3]) <= 0.001 and math.acos(min(1.0, cos)) <= 0.01

    since = time.time()
    last = probe.drive(lambda: probe.send_pose(target),
                       lambda: probe.commanded_after(since) is not None and reached(probe.commanded_after(since)),
                       "the servo did not command the pose target")
    final = probe.wait_rest(last)
    assert reached(final), tip_pose(mycobot, final)


def test_a_stopped_command_stream_halts(servo):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.JOINT_JOG)
    start = probe.arm()
    since = time.time()
    last_sent = jog_first_joint(probe, start, since, 0.2, "the servo did not jog the joint by 0.2 rad")
    probe.wait_rest(last_sent)
    outputs = probe.outputs_after(since)
    deadline = last_sent + TIMEOUT + PERIOD  # the last command's stamp: the servo's clock of its age
    before = [m for m in outputs if stamp_of(m) <= deadline]
    after = [m for m in outputs if stamp_of(m) > deadline]
    assert before and after, "no servo output around the deadline"
    # what moves after the deadline is the smoothing's decaying tail, then nothing
    tail = after[-1].points[0].positions[0] - before[-1].points[0].positions[0]
    assert abs(tail) < 0.5 * PERIOD * 1.5
    assert after[-1].points[0].positions == after[-2].points[0].positions  # at rest
    assert len(after) <= 20, "the servo kept publishing long after the arm came to rest"


def test_pause_and_switch_command_type_behave_as_moveits(servo):
    probe, node = servo
    ready(probe, ServoCommandType.Request.JOINT_JOG)
    mark = len(node.output())
    assert not probe.switch(7)
    assert wait_until(lambda: logged_after(node, mark, "Unknown command type 7"), 30.0)
    before = probe.arm()
    probe.pause(True)
    since = time.time()
    # paused: until the servo says it drops them, and as long again, nothing may happen
    assert_commands_ignored(probe, node, lambda: probe.send_jog(["link1_to_link2"], [1.0]),
                            "ignoring a command sent while servoing was paused", before, since,
                            "the paused servo did not say it drops commands")
    probe.pause(False)
    # twists are ignored while the type is JOINT_JOG: until the servo says so, and as long again
    since = time.time()
    assert_commands_ignored(probe, node, lambda: probe.send_twist((1.0, 0.0, 0.0)),
                            "ignoring a TWIST command: the command type is JOINT_JOG", before, since,
                            "the servo did not say it ignores twists in JOINT_JOG")
    since = time.time()
    last = jog_first_joint(probe, before, since, -0.08, "the servo did not jog the joint after the pause")
    assert probe.wait_rest(last)[0] < before[0] - 0.05


def test_parameters_are_checked_one_by_one_and_together(servo):
    probe, node = servo
    result = probe.set_param("servo_node", Parameter("moveit_servo.lower_singularity_threshold", value=500.0))
    assert not result.successful and "hard_stop_singularity_threshold must be greater" in result.reason
    result = probe.set_param("servo_node", Parameter("moveit_servo.command_in_type", value="furlongs"))
    assert not result.successful and "command_in_type must be one of" in result.reason
    result = probe.set_param("servo_node", Parameter("moveit_servo.publish_period", value=0.02))
    assert not result.successful  # read-only, as MoveIt's
    result = probe.set_param("servo_node", Parameter("moveit_servo.scale.joint", value=0.4))
    assert result.successful
    assert probe.set_param("servo_node", Parameter("moveit_servo.scale.joint", value=0.5)).successful


def test_humble_start_and_stop_servo(servo, mycobot):
    probe, node = servo
    ready(probe, ServoCommandType.Request.POSE)
    assert probe.trigger("/servo_node/stop_servo").success
    before = probe.arm()
    since = time.time()
    # stopped: until the servo says it drops them, and as long again, nothing may happen
    assert_commands_ignored(probe, node, lambda: probe.send_jog(["link1_to_link2"], [1.0]),
                            "ignoring a command sent while servoing was paused", before, since,
                            "the stopped servo did not say it drops commands")
    assert probe.trigger("/servo_node/start_servo").success
    # Humble's servo takes twists and joint jogs alike, without switch_command_type
    since = time.time()
    last = jog_first_joint(probe, before, since, 0.08, "the started servo did not jog the joint")
    jogged = probe.wait_rest(last)
    assert jogged[0] > before[0] + 0.05
    start = tip_pose(mycobot, jogged)[:3, 3]
    since = time.time()
    last = probe.drive(lambda: probe.send_twist((-1.0, 0.0, 0.0)),
                       lambda: tip_moved(mycobot, probe, start, since, 0.03),
                       "the started servo did not follow the twist")
    assert np.max(np.abs(probe.wait_rest(last) - jogged)) > 0.01


def test_toward_a_box_the_arm_decelerates_and_halts_short_of_it(servo, mycobot):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.TWIST)
    tip = tip_pose(mycobot, probe.arm())[:3, 3]
    center = tip + [0.0, 0.10, 0.0]
    box = CollisionObject()
    box.id, box.header.frame_id, box.operation = "servo_box", "world", CollisionObject.ADD
    box.primitives = [SolidPrimitive(type=SolidPrimitive.BOX, dimensions=[0.1, 0.04, 0.1])]
    box.pose.position.x, box.pose.position.y, box.pose.position.z = (float(v) for v in center)
    box.pose.orientation.w = 1.0
    box.primitive_poses = [Pose()]
    box.primitive_poses[0].orientation.w = 1.0
    probe.objects.publish(box)
    # At 0.4 m/s a 10 Hz monitor samples every 4 cm and can miss the 2 cm band (the per-step
    # check still stops the arm short of the box, without the slow-down first): 100 Hz, set live
    results = probe.set_parameters("servo_node", [Parameter("moveit_servo.collision_check_rate", value=100.0)])
    assert all(r.successful for r in results)
    # move_group applies the box and publishes the monitored scene (the servo's input)
    assert wait_until(lambda: probe.scene_has("servo_box"), 30.0), "move_group did not publish the box"
    first = probe.mark_status()
    try:
        last = probe.drive(lambda: probe.send_twist((0.0, 1.0, 0.0)),
                           lambda: StatusCode.HALT_FOR_COLLISION in probe.statuses_since(first),
                           "the servo did not halt for the box", timeout=60.0)
        final = probe.wait_rest(last)
        statuses = probe.statuses_since(first)
        assert StatusCode.DECELERATE_FOR_COLLISION in statuses and StatusCode.HALT_FOR_COLLISION in statuses
        assert statuses.index(StatusCode.DECELERATE_FOR_COLLISION) < statuses.index(StatusCode.HALT_FOR_COLLISION)
        scene = PlanningScene(mycobot)
        scene.add_object(CoreCollisionObject.box("servo_box", [0.1, 0.04, 0.1], make_pose(center)))
        state = RobotState(mycobot)
        state.set_joint_positions(dict(zip(ARM, final)))
        clearance = scene.distance(state, include_self=False).min_distance
        assert 0.0 < clearance < 0.005
    finally:
        box.operation = CollisionObject.REMOVE
        probe.objects.publish(box)
        probe.set_parameters("servo_node", [Parameter("moveit_servo.collision_check_rate", value=10.0)])
        assert wait_until(lambda: not probe.scene_has("servo_box"), 30.0), "move_group kept the box"


def test_toward_a_singularity_the_arm_halts(servo):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.TWIST, arm=WORK)
    first = probe.mark_status()
    last = probe.drive(lambda: probe.send_twist((0.0, 1.0, 0.0)),
                       lambda: StatusCode.HALT_FOR_SINGULARITY in probe.statuses_since(first),
                       "the servo did not halt for the singularity")
    statuses = probe.statuses_since(first)
    assert StatusCode.DECELERATE_FOR_APPROACHING_SINGULARITY in statuses
    assert StatusCode.HALT_FOR_SINGULARITY in statuses
    held = probe.wait_rest(last)
    # pushed on: it answers HALT_FOR_SINGULARITY again and stays where it is
    first = probe.mark_status()
    last = probe.drive(lambda: probe.send_twist((0.0, 1.0, 0.0)),
                       lambda: probe.statuses_since(first).count(StatusCode.HALT_FOR_SINGULARITY) >= 30,
                       "the servo did not keep the arm halted at the singularity")
    assert np.max(np.abs(probe.wait_rest(last) - held)) < 1e-3


def test_toward_a_joint_limit_the_joint_halts_inside_it(servo, mycobot):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.JOINT_JOG, arm=[2.5, *START[1:]])
    upper = mycobot.joint("link1_to_link2").upper
    first = probe.mark_status()
    last = probe.drive(lambda: probe.send_jog(["link1_to_link2"], [1.0]),
                       lambda: StatusCode.JOINT_BOUND in probe.statuses_since(first),
                       "the servo did not report JOINT_BOUND")
    final = probe.wait_rest(last)
    assert upper - 0.1 - 0.02 < final[0] <= upper


def no_jump(probe: Probe, since: float) -> float:
    """The largest joint displacement between two /joint_states received after ``since``, over
    what the velocity limit allows in the time between their stamps plus one controller period
    (a loaded machine stamps late by up to that): above 1 is a jump."""
    with probe.lock:
        states = [(q, stamp) for t, q, stamp in probe.states if t >= since]
    if len(states) < 2:
        return 0.0
    q = np.array([s[0] for s in states])
    stamps = np.array([s[1] for s in states])
    return float(np.max(np.abs(np.diff(q, axis=0)) / (VMAX * (np.diff(stamps) + PERIOD))[:, None]))


@pytest.mark.parametrize("kind, send, words", [
    (1, lambda p: p.send_twist((math.nan, 0.0, 0.0)), "NaN or infinite"),
    (1, lambda p: p.send_twist((0.0, 0.0, 0.0), (math.inf, 0.0, 0.0)), "NaN or infinite"),
    (1, lambda p: p.send_twist((0.5, 0.0, 0.0), frame="no_such_frame"), "unknown frame 'no_such_frame'"),
    (0, lambda p: p.send_jog(["no_such_joint"], [0.5]), "['no_such_joint'], not joints of group 'arm'"),
    (0, lambda p: p.send_jog(["link1_to_link2", "link2_to_link3"], [0.5]), "2 joint_names and 1 velocities"),
    (0, lambda p: p.send_jog(["link1_to_link2"], [math.nan]), "NaN or infinite"),
    (2, lambda p: p.send_pose(make_pose([0.0, 0.0, 3.0])), "pose target is unreachable"),
    (2, lambda p: p.send_pose(make_pose([0.1, 0.0, 0.2]), frame="nowhere"), "unknown frame 'nowhere'"),
])
def test_bad_input_is_refused_with_invalid_and_a_log_line(servo, kind, send, words):
    probe, node = servo
    probe.pause(False)
    assert probe.switch(kind)
    before = probe.settle()
    started = time.monotonic()
    since = time.time()
    first = probe.mark_status()  # the previous case's INVALID answers are behind us
    for _ in range(5):
        send(probe)
        time.sleep(0.02)
    assert wait_until(lambda: StatusCode.INVALID in probe.statuses_since(first), 30.0), probe.lag()
    with probe.lock:
        invalid = [m.message for m in probe.status[first:] if m.code == StatusCode.INVALID]
    assert words in invalid[0]
    assert wait_until(lambda: words in node.output(), 30.0)
    assert np.max(np.abs(probe.settle() - before)) < 1e-9 and probe.outputs_after(since) == []
    assert no_jump(probe, started) < 1e-4  # (nothing moved)


def test_a_command_flood_moves_the_arm_smoothly(servo):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.TWIST, arm=[0.0, 0.3, -1.6, 0.0, 0.3, 0.0])
    started = time.monotonic()
    since = time.time()
    first = probe.mark_status()
    messages = []
    for linear in ((1.0, 0.0, 0.0), (1.0, 0.0, 0.0), (math.nan, 0.0, 0.0)):
        msg = TwistStamped()
        msg.header.stamp, msg.header.frame_id = probe.stamp(), "base_link"
        msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z = linear
        messages.append(msg)
    sent, begin, last = 0, time.perf_counter(), 0.0
    while time.perf_counter() < begin + 1.0:  # up to 10 kHz, a NaN every third
        if sent < (time.perf_counter() - begin) * 10000:
            if sent % 100 == 0:
                for msg in messages:
                    msg.header.stamp = probe.stamp()
                last = stamp_of(messages[0])
            probe.twist.publish(messages[sent % 3])
            sent += 1
    probe.wait_rest(last)
    print(f"flood: {sent} twists in 1 s")
    assert sent > 1000
    assert len(probe.statuses_since(first)) > 50  # the loop kept running
    commanded = [m.points[0].positions for m in probe.outputs_after(since)]
    assert len(commanded) > 50
    steps = np.abs(np.diff(np.array(commanded), axis=0))
    assert np.max(steps) <= VMAX * PERIOD * 1.001  # one loop iteration never commands more
    assert no_jump(probe, started) <= 1.05  # and the controller follows without one


def pymoveit2_twist(probe: Probe, mycobot, legacy: bool) -> None:
    pymoveit2 = pytest.importorskip("pymoveit2", reason="pymoveit2 5.0.0 comes with scripts/requirements.txt")
    from rclpy.callback_groups import ReentrantCallbackGroup

    client = pymoveit2.MoveIt2Servo(node=probe.node, frame_id="base_link", callback_group=ReentrantCallbackGroup(),
                                    legacy_interface=legacy)
    try:
        assert client.uses_legacy_interface == legacy
        start = tip_pose(mycobot, probe.arm())
        since = time.time()
        last = [since]

        def send() -> float:
            if client.servo(linear=(0.0, 1.0, 0.0)):  # False until the client has enabled the servo
                last[0] = time.time()  # at or after the twist's stamp
            return last[0]

        sent = probe.drive(send, lambda: tip_moved(mycobot, probe, start[:3, 3], since, 0.05),
                           "pymoveit2's twists did not move the arm 5 cm")
        final = tip_pose(mycobot, probe.wait_rest(sent))
    finally:
        # pymoveit2 pauses (stops) the servo asynchronously, and only when no request of its own is
        # in flight: the test's own pause, answered, leaves the servo paused whatever it did (the
        # next test resumes it)
        client.destroy()
        probe.pause(True)
    direction = final[:3, 3] - start[:3, 3]
    assert np.linalg.norm(direction) > 0.02
    assert angle_deg(direction, [0.0, 1.0, 0.0]) <= 2.0


def test_pymoveit2_servo_moves_the_arm_with_the_jazzy_interface(servo, mycobot):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.JOINT_JOG)  # pymoveit2 switches to TWIST itself
    pymoveit2_twist(probe, mycobot, legacy=False)


def test_pymoveit2_servo_moves_the_arm_with_the_legacy_interface(servo, mycobot):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.POSE)
    probe.pause(True)  # Humble clients start the servo with start_servo
    pymoveit2_twist(probe, mycobot, legacy=True)


class Terminal:
    """servo_keyboard_input on a pseudo-terminal, as a user runs it."""

    def __init__(self) -> None:
        self.master, slave = pty.openpty()
        self.proc = subprocess.Popen([sys.executable, "-m", "mycobot_planning.nodes.servo_keyboard_input"],
                                     stdin=slave, stdout=slave, stderr=slave, cwd=REPO, env=ros_env(),
                                     start_new_session=True)
        os.close(slave)
        self.text = ""

    def read(self) -> str:
        while select.select([self.master], [], [], 0.0)[0]:
            try:
                chunk = os.read(self.master, 4096)
            except OSError:
                break
            if not chunk:
                break
            self.text += chunk.decode("utf-8", "replace")
        return self.text

    def press(self, keys: str, times: int = 1, every: float = 0.03) -> None:
        for _ in range(times):
            os.write(self.master, keys.encode())
            time.sleep(every)

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(5)
        os.close(self.master)


def test_keyboard_teleop_drives_the_arm(servo, mycobot):
    probe, node = servo
    probe.pause(False)
    probe.move_to(START)
    terminal = Terminal()

    def press(keys: str):
        def send() -> float:
            terminal.press(keys, every=0.0)
            return time.time()  # at or before the stamp the teleop gives the command
        return send

    try:
        assert wait_until(lambda: "twist mode" in terminal.read(), 60.0), terminal.read()
        assert "Use arrow keys and the '.' and ';' keys to Cartesian jog" in terminal.text
        start = tip_pose(mycobot, probe.arm())
        since = time.time()
        # right arrow: +y in the base frame, pressed (as a held key repeats) until the servo moved 2 cm
        last = probe.drive(press("\x1b[C"), lambda: tip_moved(mycobot, probe, start[:3, 3], since, 0.02),
                           "the arrow key did not move the arm", rate=33.0)
        after_twist = probe.wait_rest(last)
        moved = tip_pose(mycobot, after_twist)[:3, 3] - start[:3, 3]
        assert np.linalg.norm(moved) > 0.01 and angle_deg(moved, [0.0, 1.0, 0.0]) <= 5.0
        mark = len(node.output())
        terminal.press("j")
        assert wait_until(lambda: "joint jog mode" in terminal.read(), 30.0)
        assert wait_until(lambda: logged_after(node, mark, "command type is now JOINT_JOG"), 30.0)
        since = time.time()
        last = probe.drive(press("1"), lambda: joint_moved(probe, 0, after_twist, since, 0.04),
                           "key 1 did not jog the first joint", rate=33.0)
        after_jog = probe.wait_rest(last)
        assert after_jog[0] > after_twist[0] + 0.02 and np.all(np.abs(after_jog[1:] - after_twist[1:]) < 1e-9)
        terminal.press("r")
        since = time.time()
        last = probe.drive(press("1"), lambda: joint_moved(probe, 0, after_jog, since, -0.04),
                           "key 1 after r did not jog the first joint back", rate=33.0)
        assert probe.wait_rest(last)[0] < after_jog[0] - 0.02
        terminal.press("q")
        assert terminal.proc.wait(30) == 0
    finally:
        terminal.close()


def _fifo_allowed() -> bool:
    """Whether a thread of this machine's processes may take SCHED_FIFO (a short-lived thread of
    the test process tries; it ends at once, nothing else changes)."""
    allowed: list[bool] = []

    def attempt() -> None:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
            allowed.append(True)
        except OSError:
            allowed.append(False)

    thread = threading.Thread(target=attempt)
    thread.start()
    thread.join()
    return allowed[0]


def test_the_loop_runs_sched_fifo_at_thread_priority_when_the_system_allows(servo):
    """As MoveIt's servo: the loop thread under SCHED_FIFO at thread_priority (default 40), the
    node's other threads one below; without the right, a warning and normal scheduling."""
    probe, node = servo
    threads = set()
    for task in Path(f"/proc/{node.proc.pid}/task").iterdir():
        fields = (task / "stat").read_text().rsplit(")", 1)[1].split()
        threads.add((int(fields[38]), int(fields[37])))  # (policy, rt_priority): stat fields 41, 40
    if _fifo_allowed():
        assert (os.SCHED_FIFO, 40) in threads and (os.SCHED_FIFO, 39) in threads, threads
    else:
        assert "Could not enable FIFO RT scheduling policy" in node.output()
        assert all(policy != os.SCHED_FIFO for policy, _ in threads), threads
