"""A subscription its owner reads when it wants to, outside the node's executor.

rclpy's executors rebuild their whole wait set in Python at every wake-up: a 100 Hz stream such as
/joint_states costs a node 7 % (single-threaded executor) to 27 % (multi-threaded) of a core
while nothing happens at all, where receiving the same stream costs the middleware under 1 %.
A node that needs the newest message only at its own pace (robot_state_publisher at its
publish_frequency, the planning_server's state monitor while the robot stands still, a
controller's heartbeat when an execution asks whether it is alive) reads it through a
``TopicReader``: a subscription the executor never waits on, with a queue of ``depth`` (1: the
newest message only) that ``take_latest`` drains, and ``wait`` that blocks until a message is
there (or ``wake`` is called) for the times a reader wants every message.

Subscriptions are created through rclpy's implementation layer (as rclpy.wait_for_message does
with its wait set), so they are real subscriptions in the ROS graph (``ros2 topic info`` counts
them) but not entities of the node's executor.
"""
from __future__ import annotations

import threading
import time
from typing import Any

from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.type_support import check_is_valid_msg_type


class TopicReader:
    """See the module docstring. ``raw``: messages are taken as serialized bytes (liveness only)."""

    def __init__(self, node: Node, msg_type: Any, topic: str, qos: QoSProfile | int = 1, raw: bool = False) -> None:
        check_is_valid_msg_type(msg_type)
        profile = qos if isinstance(qos, QoSProfile) else QoSProfile(depth=int(qos))
        self.topic = node.resolve_topic_name(topic)
        self._msg_type = msg_type
        self._raw = raw
        self._context = node.context
        self._lock = threading.Lock()  # take/wait/destroy never overlap on the handles
        self._handle = _rclpy.Subscription(node.handle, msg_type, topic, profile.get_c_qos_profile())
        self._wake = _rclpy.GuardCondition(self._context.handle)
        self._wait_set: Any = None
        self._closed = False
        #: time.monotonic() when the newest message was taken, None before any
        self.last_taken: float | None = None
        #: the middleware's reception time of the newest message taken (ns since the epoch, 0: unknown)
        self.last_received_ns = 0

    def take_latest(self) -> Any:
        """The newest message received since the last take (older ones dropped), or None."""
        taken = self.take_all()
        return taken[-1] if taken else None

    def take_all(self) -> list[Any]:
        """Every message received since the last take, oldest first (at most the queue's depth)."""
        taken_all: list[Any] = []
        info = None
        with self._lock:
            if self._closed:
                return taken_all
            while True:
                taken = self._handle.take_message(self._msg_type, self._raw)
                if taken is None:
                    break
                taken_all.append(taken[0])
                info = taken[1]
        if taken_all:
            self.last_taken = time.monotonic()
            self.last_received_ns = int((info or {}).get("received_timestamp", 0) or 0)
        return taken_all

    def wait(self, timeout: float) -> bool:
        """Block until a message can be taken, ``wake`` is called or ``timeout`` s pass; True when
        a message is there. Meant for one reading thread."""
        with self._lock:
            if self._closed:
                return False
            if self._wait_set is None:
                self._wait_set = _rclpy.WaitSet(1, 1, 0, 0, 0, 0, self._context.handle)
            wait_set = self._wait_set
            wait_set.clear_entities()
            wait_set.add_subscription(self._handle)
            wait_set.add_guard_condition(self._wake)
            handle, wake = self._handle, self._wake
        with handle, wake:  # held in use: destroy() waits for the end of this wait
            wait_set.wait(max(0, int(timeout * 1e9)))
        with self._lock:
            if self._closed:
                return False
            return self._handle.pointer in wait_set.get_ready_entities("subscription")

    def wake(self) -> None:
        """Release a ``wait`` in progress (e.g. to stop the reading thread)."""
        with self._lock:
            if not self._closed:
                self._wake.trigger_guard_condition()

    def destroy(self) -> None:
        """Destroy the subscription (before its node). Idempotent."""
        self.wake()
        with self._lock:
            if self._closed:
                return
            self._closed = True
            self._handle.destroy_when_not_in_use()
            self._wake.destroy_when_not_in_use()
