"""mycobot_planning.ros.executors.MultiThreadedExecutor, the executor every node of the package
spins on: each handler goes to the thread pool once, even when messages come faster than the
workers start them (rclpy's own queued them again and again while they waited, rclpy #1452),
every message is handled, and a callback suspended in an ``await`` still resumes when the
executor next wakes (as in rclpy 7.1.5, which does not wake it for that itself: rclpy #1469).
Checked against rclpy's own class: 599 hand-overs of the 300 messages."""
from __future__ import annotations

import threading
from typing import Any, Iterator

import pytest
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.qos import QoSProfile
from rclpy.task import Future
from std_msgs.msg import String

from mycobot_planning.ros.executors import MultiThreadedExecutor
from ros_testing import ProbeNode, use_session_domain, wait_until

MESSAGES = 300


class Spun(ProbeNode):
    """A probe node on the executor, spinning in the background; every hand-over to the pool is
    recorded."""

    def __init__(self) -> None:
        super().__init__("executor_probe", executor=lambda context: MultiThreadedExecutor(num_threads=4, context=context))
        self.handed: list[Any] = []
        submit = self.executor._executor.submit

        def recorded(fn: Any, *args: Any) -> Any:
            self.handed.append(args[0] if args else fn)  # the handler task
            return submit(fn, *args)

        self.executor._executor.submit = recorded
        self.spin_in_background()


@pytest.fixture
def spun() -> Iterator[Spun]:
    use_session_domain()
    spun = Spun()
    yield spun
    spun.close()


def _publisher(spun: Spun, topic: str) -> Any:
    publisher = spun.node.create_publisher(String, topic, QoSProfile(depth=MESSAGES))
    assert wait_until(lambda: publisher.get_subscription_count() > 0, 10.0)
    return publisher


def test_each_handler_goes_to_the_pool_once_and_every_message_is_handled(spun):
    handled: list[str] = []
    lock = threading.Lock()

    def busy(msg: String) -> None:  # holds the interpreter a while, as a request handler does
        sum(i * i for i in range(20000))
        with lock:
            handled.append(msg.data)

    spun.node.create_subscription(String, "executor_probe/busy", busy, QoSProfile(depth=MESSAGES),
                                  callback_group=ReentrantCallbackGroup())
    publisher = _publisher(spun, "executor_probe/busy")
    for k in range(MESSAGES):
        publisher.publish(String(data=str(k)))
    assert wait_until(lambda: len(handled) == MESSAGES, 60.0), f"{len(handled)} of {MESSAGES} handled"
    assert sorted(handled, key=int) == [str(k) for k in range(MESSAGES)]
    assert len(spun.handed) == MESSAGES  # one hand-over per message
    assert len({id(task) for task in spun.handed}) == MESSAGES  # never the same task twice


def test_a_callback_suspended_in_an_await_resumes(spun):
    results: list[str] = []
    pending: list[Future] = []

    async def waits(msg: String) -> None:
        if msg.data == "wake up":
            return
        future = Future(executor=spun.executor)
        pending.append(future)
        results.append(f"{msg.data}: {await future}")

    spun.node.create_subscription(String, "executor_probe/waits", waits, 10, callback_group=ReentrantCallbackGroup())
    publisher = _publisher(spun, "executor_probe/waits")
    publisher.publish(String(data="asked"))
    assert wait_until(lambda: len(pending) == 1, 10.0)
    assert results == []  # suspended
    pending[0].set_result("answered")
    publisher.publish(String(data="wake up"))
    assert wait_until(lambda: results == ["asked: answered"], 10.0), results
