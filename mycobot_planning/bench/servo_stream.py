"""The teleoperation client of bench ``servo``, in a process of its own (as a keyboard teleop or a
joystick node would be): streams joint jog commands to servo_node and records the header stamps
of the servo's commands to the controller.

``python -m mycobot_planning.bench.servo_stream SECONDS``: prints ``streaming`` once the servo's
output topic is matched and the stream has started, streams for SECONDS (joint 1 at 0.5 unitless,
reversing every second, 50 Hz, stamped as sent), then prints the stamps (s, space separated).
Kept out of the bench's own process so that process does the same work (plans, /joint_states)
whether the servo runs or not: plan_ms_while_servoing differs from plan_ms_idle by the servo's
load on the machine, not by the bench's own callbacks.
"""
from __future__ import annotations

import sys
import threading
import time

import rclpy
from control_msgs.msg import JointJog
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from trajectory_msgs.msg import JointTrajectory

JOG_TOPIC = "/servo_node/delta_joint_cmds"
OUTPUT_TOPIC = "/arm_controller/joint_trajectory"
JOINT = "link1_to_link2"
RATE_HZ = 50.0


def main(argv: list[str]) -> int:
    seconds = float(argv[0])
    rclpy.init()
    node = Node("bench_servo_stream")
    stamps: list[float] = []
    lock = threading.Lock()

    def on_output(msg: JointTrajectory) -> None:
        with lock:
            stamps.append(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)

    node.create_subscription(JointTrajectory, OUTPUT_TOPIC, on_output, 1000)
    jog = node.create_publisher(JointJog, JOG_TOPIC, 10)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    deadline = time.monotonic() + 10.0
    while (jog.get_subscription_count() == 0 or node.count_publishers(OUTPUT_TOPIC) == 0) \
            and time.monotonic() < deadline:
        time.sleep(0.01)
    begin = time.monotonic()
    print("streaming", flush=True)
    tick = begin
    while time.monotonic() - begin < seconds:
        msg = JointJog()
        msg.header.stamp = node.get_clock().now().to_msg()
        msg.joint_names = [JOINT]
        msg.velocities = [0.5 if int(time.monotonic() - begin) % 2 == 0 else -0.5]
        jog.publish(msg)
        tick += 1.0 / RATE_HZ
        time.sleep(max(0.0, tick - time.monotonic()))
    time.sleep(0.3)  # the last outputs arrive
    with lock:
        out = list(stamps)
    print(" ".join(f"{t:.6f}" for t in out), flush=True)
    executor.shutdown()
    spinner.join(2.0)
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
