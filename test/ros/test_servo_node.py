"""servo_node (MoveIt Servo's interface) against mock_controllers + planning_server in real
processes, one bring-up for the module: twist, joint jog and pose tracking move the arm as
commanded; collision, singularity and joint-limit halts; a stopped stream halts; pause,
switch_command_type and Humble's start/stop as MoveIt's; bad input refused with INVALID and a log
line, never a jump; pymoveit2 5.0.0's MoveIt2Servo with both interfaces; the keyboard teleop on
a pseudo-terminal.

Every motion is judged on /joint_states (what the controllers did) and our own forward
kinematics; the halts also on the servo's own output stamps (no wall-clock assertion)."""
from __future__ import annotations

import math
import os
import pty
import select
import subprocess
import sys
import time

import numpy as np
import pytest
from control_msgs.msg import JointJog
from geometry_msgs.msg import Pose, PoseStamped, TwistStamped
from moveit_msgs.msg import CollisionObject, ServoStatus
from moveit_msgs.srv import ServoCommandType
from rclpy.executors import MultiThreadedExecutor
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from shape_msgs.msg import SolidPrimitive
from std_srvs.srv import SetBool
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from interfaces_py.msgs import CollisionObject as CoreCollisionObject
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.servo import StatusCode
from mycobot_planning.core.transforms import make_pose, matrix_to_quat
from mycobot_planning.paths import config_file
from ros_testing import NodeProcess, ProbeNode, REPO, ros_env, robot_processes, wait_until

ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6",
       "link6_to_link6_flange"]
TIP = "link6_flange"
WORK = [0.0, -0.5, -1.0, -0.2, 0.3, 0.0]  # +y from here extends the arm: the elbow singularity
START = [0.0, 0.3, -1.6, 0.0, 0.3, 0.0]  # room (10 cm) along +y and -x before any singularity
PERIOD, TIMEOUT = 0.01, 0.1
VMAX = 2.792527


class Probe(ProbeNode):
    def __init__(self) -> None:
        super().__init__("servo_test_probe", executor=lambda c: MultiThreadedExecutor(num_threads=3, context=c))
        self.listen_to_joint_states()
        self.states: list[tuple[float, np.ndarray]] = []
        self.node.create_subscription(JointState, "/joint_states", self._record, 100)
        self.status = self.collect(ServoStatus, "/servo_node/status", 100)
        self.out = self.collect(JointTrajectory, "/arm_controller/joint_trajectory", 1000)
        self.twist = self.node.create_publisher(TwistStamped, "/servo_node/delta_twist_cmds", 10)
        self.jog = self.node.create_publisher(JointJog, "/servo_node/delta_joint_cmds", 10)
        self.pose = self.node.create_publisher(PoseStamped, "/servo_node/pose_target_cmds", 10)
        self.command = self.node.create_publisher(JointTrajectory, "/arm_controller/joint_trajectory", 10)
        self.objects = self.node.create_publisher(CollisionObject, "/collision_object", 10)
        self.spin_in_background()

    def _record(self, msg) -> None:
        index = {n: i for i, n in enumerate(msg.name)}
        if all(j in index for j in ARM):
            stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
            with self.lock:
                self.states.append((time.monotonic(), np.array([msg.position[index[j]] for j in ARM]), stamp))

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

    def send_twist(self, linear, angular=(0.0, 0.0, 0.0), frame="base_link") -> None:
        msg = TwistStamped()
        msg.header.stamp, msg.header.frame_id = self.stamp(), frame
        msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z = (float(v) for v in linear)
        msg.twist.angular.x, msg.twist.angular.y, msg.twist.angular.z = (float(v) for v in angular)
        self.twist.publish(msg)

    def send_jog(self, names, velocities) -> None:
        msg = JointJog()
        msg.header.stamp = self.stamp()
        msg.joint_names, msg.velocities = list(names), [float(v) for v in velocities]
        self.jog.publish(msg)

    def send_pose(self, pose: np.ndarray, frame="base_link") -> None:
        msg = PoseStamped()
        msg.header.stamp, msg.header.frame_id = self.stamp(), frame
        p, q = pose[:3, 3], matrix_to_quat(pose[:3, :3])
        msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = (float(v) for v in p)
        (msg.pose.orientation.x, msg.pose.orientation.y, msg.pose.orientation.z,
         msg.pose.orientation.w) = (float(v) for v in q)
        self.pose.publish(msg)

    def stream(self, send, seconds: float, rate: float = 50.0) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            send()
            time.sleep(1.0 / rate)

    def settle(self, timeout: float = 10.0) -> np.ndarray:
        """Wait until the arm has not moved for 0.3 s; its positions."""
        def still() -> bool:
            with self.lock:
                recent = [q for t, q, _ in self.states if t > time.monotonic() - 0.3]
            return len(recent) > 5 and np.max(np.ptp(np.array(recent), axis=0)) < 1e-6
        assert wait_until(still, timeout), "the arm did not come to rest"
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
        assert wait_until(quiet, 5.0), "servo_node keeps commanding the arm"
        distance = float(np.max(np.abs(np.asarray(arm) - self.arm())))
        msg = JointTrajectory()
        msg.joint_names = ARM
        msg.points = [JointTrajectoryPoint(positions=[float(v) for v in arm],
                                           velocities=[0.0] * 6)]
        duration = max(0.5, 2.0 * distance)
        msg.points[0].time_from_start.sec = int(duration)
        msg.points[0].time_from_start.nanosec = int((duration % 1) * 1e9)
        self.command.publish(msg)
        assert wait_until(lambda: np.max(np.abs(self.arm() - arm)) < 1e-4, duration + 5.0), (self.arm(), arm)
        self.settle()

    def statuses_since(self, index: int) -> list[int]:
        with self.lock:
            return [m.code for m in self.status[index:]]


@pytest.fixture(scope="module")
def model() -> RobotModel:
    return RobotModel.mycobot()


def tip_pose(model: RobotModel, arm) -> np.ndarray:
    state = RobotState(model)
    state.set_joint_positions(dict(zip(ARM, arm)))
    return state.frame_pose(TIP)


def angle_deg(a, b) -> float:
    return math.degrees(math.acos(np.clip(np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)), -1, 1)))


@pytest.fixture(scope="module")
def servo():
    with robot_processes():
        node = NodeProcess("mycobot_planning.nodes.servo_node",
                           ["--ros-args", "--params-file", str(config_file("servo_node.yaml"))])
        probe = Probe()
        try:
            assert wait_until(lambda: "servo_node ready" in node.output(), 60.0), node.output()[-3000:]
            assert wait_until(lambda: probe.joints() != {} and len(probe.status) >= 0, 10.0)
            assert probe.client(ServoCommandType, "/servo_node/switch_command_type").wait_for_service(timeout_sec=15)
            yield probe, node
        finally:
            probe.close()
            node.stop()
            assert "Traceback" not in node.output(), node.output()[-3000:]


def test_commands_are_ignored_until_the_command_type_is_set(servo):
    probe, node = servo
    probe.move_to(WORK)
    before = probe.arm()
    outputs = len(probe.out)
    probe.stream(lambda: probe.send_twist((0.0, 0.0, 1.0)), 0.3)
    after = probe.settle()
    assert np.max(np.abs(after - before)) < 1e-9 and len(probe.out) == outputs
    assert "Command type has not been set, cannot accept input" in node.output()


def test_twist_moves_the_flange_along_the_command(servo, model):
    probe, _ = servo
    probe.move_to(START)
    assert probe.switch(ServoCommandType.Request.TWIST)
    start = tip_pose(model, probe.arm())
    first = len(probe.status)
    probe.stream(lambda: probe.send_twist((0.0, 1.0, 0.0)), 0.2)
    end = tip_pose(model, probe.settle())
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
    probe.stream(lambda: probe.send_jog(["link1_to_link2"], [1.0]), 0.4)
    moved = probe.settle() - before
    assert 0.1 < moved[0] < 0.5 * (0.4 + TIMEOUT) + 0.03  # scale.joint 0.5 rad/s for 0.4 s + the timeout
    assert np.all(np.abs(moved[1:]) < 1e-9)


def test_pose_tracking_ends_within_the_tolerances(servo, model):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.POSE)
    target = tip_pose(model, probe.arm())
    target[:3, 3] += [-0.03, 0.02, -0.02]
    target[:3, :3] = target[:3, :3] @ make_pose(rpy=[0.1, 0.0, -0.1])[:3, :3]

    def reached() -> bool:
        pose = tip_pose(model, probe.arm())
        cos = (np.trace(pose[:3, :3].T @ target[:3, :3]) - 1) / 2
        return np.linalg.norm(pose[:3, 3] - target[:3, 3]) <= 0.001 and math.acos(min(1.0, cos)) <= 0.01

    end = time.monotonic() + 10.0
    while time.monotonic() < end and not reached():
        probe.send_pose(target)
        time.sleep(0.02)
    probe.settle()
    assert reached(), tip_pose(model, probe.arm())


def test_a_stopped_command_stream_halts(servo):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.JOINT_JOG)
    first = len(probe.out)
    last_sent = [0.0]

    def send() -> None:
        probe.send_jog(["link1_to_link2"], [1.0])
        last_sent[0] = time.time()  # the stamp's clock (ROS time = system time)

    probe.stream(send, 0.5)
    probe.settle()
    with probe.lock:
        outputs = probe.out[first:]
    deadline = last_sent[0] + TIMEOUT + PERIOD
    stamp = lambda m: m.header.stamp.sec + m.header.stamp.nanosec * 1e-9  # noqa: E731
    before = [m for m in outputs if stamp(m) <= deadline]
    after = [m for m in outputs if stamp(m) > deadline]
    assert before and after, "no servo output around the deadline"
    # what moves after the deadline is the smoothing's decaying tail, then nothing
    tail = after[-1].points[0].positions[0] - before[-1].points[0].positions[0]
    assert abs(tail) < 0.5 * PERIOD * 1.5
    assert after[-1].points[0].positions == after[-2].points[0].positions  # at rest
    assert len(after) <= 20, "the servo kept publishing long after the arm came to rest"


def test_pause_and_switch_command_type_behave_as_moveits(servo):
    probe, node = servo
    ready(probe, ServoCommandType.Request.JOINT_JOG)
    assert not probe.switch(7)
    assert "Unknown command type 7" in node.output()
    before = probe.arm()
    probe.pause(True)
    outputs = len(probe.out)
    probe.stream(lambda: probe.send_jog(["link1_to_link2"], [1.0]), 0.3)
    assert np.max(np.abs(probe.settle() - before)) < 1e-9 and len(probe.out) == outputs
    probe.pause(False)
    # twists are ignored while the type is JOINT_JOG
    probe.stream(lambda: probe.send_twist((1.0, 0.0, 0.0)), 0.3)
    assert np.max(np.abs(probe.settle() - before)) < 1e-9
    probe.stream(lambda: probe.send_jog(["link1_to_link2"], [-1.0]), 0.3)
    assert probe.settle()[0] < before[0] - 0.05


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


def test_humble_start_and_stop_servo(servo):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.POSE)
    assert probe.trigger("/servo_node/stop_servo").success
    before = probe.arm()
    probe.stream(lambda: probe.send_jog(["link1_to_link2"], [1.0]), 0.3)
    assert np.max(np.abs(probe.settle() - before)) < 1e-9
    assert probe.trigger("/servo_node/start_servo").success
    # Humble's servo takes twists and joint jogs alike, without switch_command_type
    probe.stream(lambda: probe.send_jog(["link1_to_link2"], [1.0]), 0.3)
    jogged = probe.settle()
    assert jogged[0] > before[0] + 0.05
    probe.stream(lambda: probe.send_twist((-1.0, 0.0, 0.0)), 0.2)
    assert np.max(np.abs(probe.settle() - jogged)) > 0.01


def test_toward_a_box_the_arm_decelerates_and_halts_short_of_it(servo, model):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.TWIST)
    tip = tip_pose(model, probe.arm())[:3, 3]
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
    time.sleep(1.0)  # move_group applies the box and publishes the monitored scene
    first = len(probe.status)
    try:
        end = time.monotonic() + 30.0
        while time.monotonic() < end and StatusCode.HALT_FOR_COLLISION not in probe.statuses_since(first):
            probe.send_twist((0.0, 1.0, 0.0))
            time.sleep(0.02)
        statuses = probe.statuses_since(first)
        assert StatusCode.DECELERATE_FOR_COLLISION in statuses and StatusCode.HALT_FOR_COLLISION in statuses
        assert statuses.index(StatusCode.DECELERATE_FOR_COLLISION) < statuses.index(StatusCode.HALT_FOR_COLLISION)
        final = probe.settle()
        scene = PlanningScene(model)
        scene.add_object(CoreCollisionObject.box("servo_box", [0.1, 0.04, 0.1], make_pose(center)))
        state = RobotState(model)
        state.set_joint_positions(dict(zip(ARM, final)))
        clearance = scene.distance(state, include_self=False).min_distance
        assert 0.0 < clearance < 0.005
    finally:
        box.operation = CollisionObject.REMOVE
        probe.objects.publish(box)
        probe.set_parameters("servo_node", [Parameter("moveit_servo.collision_check_rate", value=10.0)])
        time.sleep(0.5)


def test_toward_a_singularity_the_arm_halts(servo):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.TWIST, arm=WORK)
    first = len(probe.status)
    end = time.monotonic() + 10.0
    while time.monotonic() < end and StatusCode.HALT_FOR_SINGULARITY not in probe.statuses_since(first):
        probe.send_twist((0.0, 1.0, 0.0))
        time.sleep(0.02)
    statuses = probe.statuses_since(first)
    assert StatusCode.DECELERATE_FOR_APPROACHING_SINGULARITY in statuses
    assert StatusCode.HALT_FOR_SINGULARITY in statuses
    held = probe.settle()
    probe.stream(lambda: probe.send_twist((0.0, 1.0, 0.0)), 0.3)
    assert np.max(np.abs(probe.settle() - held)) < 1e-3  # it stays halted


def test_toward_a_joint_limit_the_joint_halts_inside_it(servo, model):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.JOINT_JOG, arm=[2.5, *START[1:]])
    upper = model.joint("link1_to_link2").upper
    first = len(probe.status)
    probe.stream(lambda: probe.send_jog(["link1_to_link2"], [1.0]), 1.5)
    final = probe.settle()
    assert StatusCode.JOINT_BOUND in probe.statuses_since(first)
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
    first = len(probe.status)
    for _ in range(5):
        send(probe)
        time.sleep(0.02)
    assert wait_until(lambda: StatusCode.INVALID in probe.statuses_since(first), 5.0)
    with probe.lock:
        invalid = [m.message for m in probe.status[first:] if m.code == StatusCode.INVALID]
    assert words in invalid[0]
    assert wait_until(lambda: words in node.output(), 5.0)
    assert np.max(np.abs(probe.settle() - before)) < 1e-9
    assert no_jump(probe, started) < 1e-4  # (nothing moved)


def test_a_command_flood_moves_the_arm_smoothly(servo):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.TWIST, arm=[0.0, 0.3, -1.6, 0.0, 0.3, 0.0])
    started = time.monotonic()
    first = len(probe.status)
    outputs = len(probe.out)
    messages = []
    for linear in ((1.0, 0.0, 0.0), (1.0, 0.0, 0.0), (math.nan, 0.0, 0.0)):
        msg = TwistStamped()
        msg.header.stamp, msg.header.frame_id = probe.stamp(), "base_link"
        msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z = linear
        messages.append(msg)
    sent, begin = 0, time.perf_counter()
    while time.perf_counter() < begin + 1.0:  # up to 10 kHz, a NaN every third
        if sent < (time.perf_counter() - begin) * 10000:
            if sent % 100 == 0:
                for msg in messages:
                    msg.header.stamp = probe.stamp()
            probe.twist.publish(messages[sent % 3])
            sent += 1
    probe.settle()
    print(f"flood: {sent} twists in 1 s")
    assert sent > 1000
    assert len(probe.statuses_since(first)) > 50  # the loop kept running
    with probe.lock:
        commanded = [(m.header.stamp.sec + m.header.stamp.nanosec * 1e-9, m.points[0].positions) for m in probe.out[outputs:]]
    assert len(commanded) > 50
    steps = np.abs(np.diff(np.array([q for _, q in commanded]), axis=0))
    assert np.max(steps) <= VMAX * PERIOD * 1.001  # one loop iteration never commands more
    assert no_jump(probe, started) <= 1.05  # and the controller follows without one


def pymoveit2_twist(probe: Probe, model, legacy: bool) -> None:
    pymoveit2 = pytest.importorskip("pymoveit2")
    from rclpy.callback_groups import ReentrantCallbackGroup

    client = pymoveit2.MoveIt2Servo(node=probe.node, frame_id="base_link", callback_group=ReentrantCallbackGroup(),
                                    legacy_interface=legacy)
    try:
        assert client.uses_legacy_interface == legacy
        start = tip_pose(model, probe.arm())
        moved = 0
        end = time.monotonic() + 10.0
        while time.monotonic() < end and moved < 10:  # 10 twists published: 0.2 s of motion
            if client.servo(linear=(0.0, 1.0, 0.0)):
                moved += 1
            time.sleep(0.02)
        assert moved == 10
        final = tip_pose(model, probe.settle())
    finally:
        client.destroy()  # it pauses (stops) the servo, asynchronously: let that land before the next test
        time.sleep(0.5)
    direction = final[:3, 3] - start[:3, 3]
    assert np.linalg.norm(direction) > 0.02
    assert angle_deg(direction, [0.0, 1.0, 0.0]) <= 2.0


def test_pymoveit2_servo_moves_the_arm_with_the_jazzy_interface(servo, model):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.JOINT_JOG)  # pymoveit2 switches to TWIST itself
    pymoveit2_twist(probe, model, legacy=False)


def test_pymoveit2_servo_moves_the_arm_with_the_legacy_interface(servo, model):
    probe, _ = servo
    ready(probe, ServoCommandType.Request.POSE)
    probe.pause(True)  # Humble clients start the servo with start_servo
    pymoveit2_twist(probe, model, legacy=True)


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


def test_keyboard_teleop_drives_the_arm(servo, model):
    probe, _ = servo
    probe.pause(False)
    probe.move_to(START)
    terminal = Terminal()
    try:
        assert wait_until(lambda: "twist mode" in terminal.read(), 30.0), terminal.read()
        assert "Use arrow keys and the '.' and ';' keys to Cartesian jog" in terminal.text
        start = tip_pose(model, probe.arm())
        terminal.press("\x1b[C", times=10)  # right arrow: +y in the base frame
        after_twist = probe.settle()
        moved = tip_pose(model, after_twist)[:3, 3] - start[:3, 3]
        assert np.linalg.norm(moved) > 0.01 and angle_deg(moved, [0.0, 1.0, 0.0]) <= 5.0
        terminal.press("j")
        assert wait_until(lambda: "joint jog mode" in terminal.read(), 5.0)
        time.sleep(0.3)  # the switch is asynchronous
        terminal.press("1", times=10)
        after_jog = probe.settle()
        assert after_jog[0] > after_twist[0] + 0.02 and np.all(np.abs(after_jog[1:] - after_twist[1:]) < 1e-9)
        terminal.press("r")
        terminal.press("1", times=10)
        assert probe.settle()[0] < after_jog[0] - 0.02
        terminal.press("q")
        assert terminal.proc.wait(10) == 0
    finally:
        terminal.close()
