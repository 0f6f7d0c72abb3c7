"""Readiness by ROS discovery: a node is up when the ROS graph shows it, with the services,
actions and topics it offers (what a client needs before its first request), not when its log
says so. Files (the emulated arm's port) count for processes that are no ROS node."""
from __future__ import annotations

import os
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable

import rclpy
from rclpy.context import Context
from rclpy.node import Node

from mycobot_planning.paths import use_fast_discovery


@dataclass(frozen=True)
class Readiness:
    """What must be discoverable: node names (with namespace, e.g. "/move_group"), services,
    action servers, published topics, and paths that must exist."""

    nodes: tuple[str, ...] = ()
    services: tuple[str, ...] = ()
    actions: tuple[str, ...] = ()
    topics: tuple[str, ...] = ()
    paths: tuple[str, ...] = ()


class GraphProbe:
    """A node on a private context that reads the ROS graph (nothing to spin: the graph cache
    fills from discovery in the middleware's own threads). ``GraphProbe.shared()`` is the one a
    process keeps for its ROS domain (see there)."""

    _shared: dict[tuple[str | None, ...], "GraphProbe"] = {}
    _shared_lock = threading.Lock()

    def __init__(self, name: str = "bringup_probe") -> None:
        use_fast_discovery()
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = Node(f"{name}", context=self.context, start_parameter_services=False)
        self._keep = False

    @classmethod
    def shared(cls) -> "GraphProbe":
        """The process's probe for the ROS domain and discovery settings of its environment,
        made on first use and kept until the process ends (its ``close`` does nothing). Why:
        a probe made and destroyed per bring-up once hung a test run for good: rclpy's
        destroy_node waited in native code, holding the GIL, so no timeout could end it; one
        probe a process also spares a DDS participant's discovery per wait."""
        key = tuple(os.environ.get(k) for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE",
                                                 "ROS_STATIC_PEERS", "ROS_LOCALHOST_ONLY",
                                                 "RMW_IMPLEMENTATION"))
        with cls._shared_lock:
            probe = cls._shared.get(key)
            if probe is None:
                probe = cls(f"bringup_probe_{os.getpid()}")
                probe._keep = True
                cls._shared[key] = probe
            return probe

    def missing(self, readiness: Readiness) -> list[str]:
        """What of ``readiness`` the graph (and the file system) does not show yet."""
        gaps = [f"file {p}" for p in readiness.paths if not Path(p).exists()]
        if readiness.nodes:
            known = {f"{ns.rstrip('/')}/{name}" for name, ns in self.node.get_node_names_and_namespaces()}
            gaps += [f"node {n}" for n in readiness.nodes if n not in known]
        if readiness.services or readiness.actions:
            services = {name for name, _ in self.node.get_service_names_and_types()}
            gaps += [f"service {s}" for s in readiness.services if s not in services]
            # an action server offers its goal service under <action>/_action/send_goal
            gaps += [f"action {a}" for a in readiness.actions if f"{a}/_action/send_goal" not in services]
        if readiness.topics:
            gaps += [f"topic {t}" for t in readiness.topics if not self.node.count_publishers(t)]
        return gaps

    def wait(self, readiness: Readiness, timeout: float, alive: Callable[[], bool] = lambda: True,
             period: float = 0.1) -> list[str]:
        """Wait until nothing is missing (returns []) or ``timeout`` s passed or ``alive()`` says
        no (returns what is still missing)."""
        deadline = time.monotonic() + timeout
        while True:
            gaps = self.missing(readiness)
            if not gaps or time.monotonic() >= deadline or not alive():
                return gaps
            time.sleep(period)

    def close(self) -> None:
        if self._keep:
            return
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)

    def __enter__(self) -> "GraphProbe":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def describe(gaps: Iterable[str]) -> str:
    return ", ".join(gaps)
