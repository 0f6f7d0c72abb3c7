"""Idle CPU (issue 27): the 100 Hz streams are read outside the executors.

In-process and fast: a TopicReader keeps the newest message only and wakes a waiting reader, or
gives every message in order (take_all);
robot_state_publisher's executor never waits on /joint_states, and it publishes /tf when the
joints change and once a second while they stand still (a late listener still gets the moving
frames); the idle_cpu benchmark is registered. The figures themselves come from
``python -m mycobot_planning.bench idle_cpu`` (no timing is asserted here).
"""
from __future__ import annotations

import threading

import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage

from interfaces_py.background_spin import BackgroundSpin
from mycobot_planning.bench.idle_scenarios import bench_idle_cpu, group_cpu_seconds
from mycobot_planning.bench.scenarios import SCENARIOS
from mycobot_planning.ros.topic_reader import TopicReader
from ros_testing import use_session_domain, wait_until


@pytest.fixture()
def node():
    use_session_domain()
    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node("idle_readers_test", context=context)
    yield node
    node.destroy_node()
    rclpy.try_shutdown(context=context)


def _joint_state(position: float) -> JointState:
    return JointState(name=["link1_to_link2"], position=[position])


def test_topic_reader_takes_the_newest_message_and_wakes(node):
    reader = TopicReader(node, JointState, "/idle_readers_test/joints", 1)
    publisher = node.create_publisher(JointState, "/idle_readers_test/joints", 10)
    assert wait_until(lambda: publisher.get_subscription_count() >= 1, 10.0)
    assert reader.take_latest() is None
    assert not reader.wait(0.01)
    seen: list[float] = []

    def newest_is(value: float) -> bool:
        taken = reader.take_latest()
        if taken is not None:
            seen.append(taken.position[0])
        return bool(seen) and seen[-1] == value

    for value in (0.1, 0.2, 0.3):
        publisher.publish(_joint_state(value))
    assert reader.wait(5.0)
    assert wait_until(lambda: newest_is(0.3), 5.0)
    assert len(seen) <= 3 and seen == sorted(seen)  # depth 1: never an older one after a newer one
    assert reader.take_latest() is None
    assert reader.last_taken is not None
    # wake() releases a wait with nothing to take
    waiter: dict = {}
    thread = threading.Thread(target=lambda: waiter.setdefault("got", reader.wait(30.0)))
    thread.start()
    reader.wake()
    thread.join(10.0)
    assert not thread.is_alive() and waiter["got"] is False
    # not an entity of the node: its executor never waits on it
    assert all(s.topic_name != "/idle_readers_test/joints" for s in node.subscriptions)
    reader.destroy()
    reader.destroy()  # idempotent
    assert reader.take_latest() is None and reader.wait(0.01) is False


def test_topic_reader_takes_every_message_in_order(node):
    """take_all (the controllers' command topics, read once per control cycle): every message of
    the queue, oldest first; then nothing."""
    reader = TopicReader(node, JointState, "/idle_readers_test/commands", 10)
    publisher = node.create_publisher(JointState, "/idle_readers_test/commands", 10)
    assert wait_until(lambda: publisher.get_subscription_count() >= 1, 10.0)
    assert reader.take_all() == []
    for value in (0.1, 0.2, 0.3):
        publisher.publish(_joint_state(value))
    seen: list[float] = []
    assert wait_until(lambda: seen.extend(m.position[0] for m in reader.take_all()) or len(seen) >= 3, 5.0)
    assert seen == [0.1, 0.2, 0.3] and reader.take_all() == []
    reader.destroy()
    assert reader.take_all() == []


def test_robot_state_publisher_publishes_on_change_and_keeps_alive(node):
    from mycobot_planning.ros.robot_state_publisher import RobotStatePublisher

    rsp = RobotStatePublisher(context=node.context)
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(rsp)
    executor.add_node(node)
    spin = BackgroundSpin(executor, name="rsp test")
    tf_messages: list[TFMessage] = []
    node.create_subscription(TFMessage, "/tf", tf_messages.append, 100)
    publisher = node.create_publisher(JointState, "/joint_states", 10)
    try:
        assert all(s.topic_name != "/joint_states" for s in rsp.subscriptions)  # read by its own thread
        assert wait_until(lambda: publisher.get_subscription_count() >= 1, 10.0)

        def link2_yaw_changes() -> bool:
            publisher.publish(_joint_state(0.7))
            return any(t.child_frame_id == "link2" and abs(t.transform.rotation.z) > 0.3
                       for m in list(tf_messages) for t in m.transforms)

        assert wait_until(link2_yaw_changes, 15.0), "no /tf for the changed joint"
        count = len(tf_messages)
        # standing still (the same state over and over): the once-a-second keep-alive only
        assert wait_until(lambda: (publisher.publish(_joint_state(0.7)), len(tf_messages) > count)[1], 10.0)
    finally:
        spin.stop()
        rsp.close()
        rsp.destroy_node()


def test_idle_cpu_benchmark_is_registered():
    assert SCENARIOS["idle_cpu"] is bench_idle_cpu
    import os

    assert group_cpu_seconds(os.getpgid(0)) > 0.0  # this test's own process group has used some CPU
