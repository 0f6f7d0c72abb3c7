"""What the MuJoCo twin says about a pick and place run through the real nodes (demo.sh --sim
mujoco and its test): the object's true pose once it has come to rest, from mujoco_sim's
/mujoco_sim/object_poses, and its slip in the hand from the gripper's holds in /mujoco_sim/status,
judged by the one implementation of the criteria (simulation.grasp_monitor.judge_place: within
1 cm of the place pose, upright within 5 degrees, never more than 5 mm of slip while carried).
"""
from __future__ import annotations

import json
import math
import threading
import time
from collections import deque
from dataclasses import replace

import numpy as np
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from mycobot_planning.core.transforms import quat_to_matrix
from mycobot_planning.demos.pick_place import PickPlaceParameters, expected_place_pose
from mycobot_planning.paths import use_fast_discovery
from mycobot_planning.ros.controllers.mujoco_sim import OBJECT_POSES_TOPIC, POSES_QOS, STATUS_QOS, STATUS_TOPIC
from mycobot_planning.simulation.grasp_monitor import PlaceOutcome, judge_place

#: s (wall): an object counts as at rest when it moved less than REST_TOLERANCE over this long
REST_WINDOW = 0.5
#: m
REST_TOLERANCE = 2e-4


class TwinObserver:
    """Listens to mujoco_sim's object poses and status (in a context and thread of its own);
    use as a context manager."""

    def __init__(self, name: str = "twin_observer") -> None:
        use_fast_discovery()
        self._context = Context()
        rclpy.init(args=[], context=self._context)
        self._node = Node(name, context=self._context)
        self._lock = threading.Lock()
        self._poses: deque[tuple[float, dict[str, np.ndarray]]] = deque(maxlen=400)
        self._status: tuple[float, dict] | None = None
        self._node.create_subscription(TFMessage, OBJECT_POSES_TOPIC, self._on_poses, POSES_QOS)
        self._node.create_subscription(String, STATUS_TOPIC, self._on_status, STATUS_QOS)
        self._executor = SingleThreadedExecutor(context=self._context)
        self._executor.add_node(self._node)
        self._thread = threading.Thread(target=self._spin, name="twin observer", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while self._context.ok():
            try:
                self._executor.spin_once(timeout_sec=0.1)
            except Exception:  # noqa: BLE001 - the context went down while spinning (close)
                return

    def _on_poses(self, msg: TFMessage) -> None:
        poses = {}
        for t in msg.transforms:
            pose = np.eye(4)
            r, p = t.transform.rotation, t.transform.translation
            pose[:3, :3] = quat_to_matrix([r.x, r.y, r.z, r.w])
            pose[:3, 3] = [p.x, p.y, p.z]
            poses[t.child_frame_id] = pose
        with self._lock:
            self._poses.append((time.monotonic(), poses))

    def _on_status(self, msg: String) -> None:
        with self._lock:
            self._status = (time.monotonic(), json.loads(msg.data))

    def pose(self, name: str) -> np.ndarray | None:
        """The latest true pose of object ``name`` (None: none received yet)."""
        with self._lock:
            return self._poses[-1][1].get(name) if self._poses else None

    def wait_for_pose(self, name: str, timeout: float) -> np.ndarray | None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            pose = self.pose(name)
            if pose is not None:
                return pose
            time.sleep(0.05)
        return None

    def wait_for_rest(self, name: str, timeout: float) -> np.ndarray | None:
        """The object's pose once it moved less than REST_TOLERANCE over REST_WINDOW s (None
        when that did not happen within ``timeout`` s)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self._lock:
                samples = [(t, p[name]) for t, p in self._poses if name in p]
            if samples and samples[-1][0] - samples[0][0] >= REST_WINDOW:
                last_t, last = samples[-1]
                recent = [p for t, p in samples if last_t - t <= REST_WINDOW]
                if max(float(np.linalg.norm(p[:3, 3] - last[:3, 3])) for p in recent) < REST_TOLERANCE:
                    return last
            time.sleep(0.05)
        return None

    def status_after(self, since: float, timeout: float) -> dict | None:
        """The first status received after ``since`` (time.monotonic()), waiting up to ``timeout`` s."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self._lock:
                if self._status is not None and self._status[0] > since:
                    return self._status[1]
            time.sleep(0.05)
        return None

    def close(self) -> None:
        self._executor.shutdown(timeout_sec=1.0)
        self._node.destroy_node()
        rclpy.try_shutdown(context=self._context)
        self._thread.join(2.0)

    def __enter__(self) -> "TwinObserver":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def twin_verdict(observer: TwinObserver, params: PickPlaceParameters, timeout: float = 10.0) \
        -> tuple[PlaceOutcome | None, str]:
    """The simulator's verdict on the object ``params`` name against ``params``' place pose, once
    the object is at rest (an object still moving after ``timeout`` s is judged where it is and
    fails); (None, why) when the twin did not tell."""
    name = params.object_name
    final = observer.wait_for_rest(name, timeout)
    moving = final is None
    if moving:
        final = observer.pose(name)
        if final is None:
            return None, f"no pose of '{name}' from mujoco_sim on {OBJECT_POSES_TOPIC} within {timeout:g} s"
    status = observer.status_after(time.monotonic(), timeout)
    if status is None:
        return None, f"no status from mujoco_sim on {STATUS_TOPIC} within {timeout:g} s"
    holds = [h for h in status.get("holds", []) if h["object"] == name]
    slip = holds[-1]["slip_mm"] / 1000 if holds else math.nan
    outcome = judge_place(final, expected_place_pose(params), slip)
    if moving:
        outcome = replace(outcome, success=False,
                          message=f"the object is still moving {timeout:g} s after the robot finished; " + (
                              "where it is now: " + outcome.message if outcome.success else outcome.message))
    return outcome, outcome.message


def verdict_lines(outcome: PlaceOutcome | None, reason: str) -> tuple[bool, list[str]]:
    """(success, the lines demo.sh prints)."""
    if outcome is None:
        return False, [f"FAILED: the simulator gave no verdict: {reason}"]
    figures = ", ".join(f"{k} {v}" for k, v in outcome.figures().items())
    p = outcome.final_pose[:3, 3]
    lines = [f"Simulated object at ({p[0]:.4f}, {p[1]:.4f}, {p[2]:.4f}) m; figures: {figures}"]
    if outcome.success:
        lines.append(f"SUCCESS: the simulator says the object stands at the place pose: {outcome.message}")
    else:
        lines.append(f"FAILED: the simulator says: {outcome.message}")
    return outcome.success, lines
