"""The viewer's Pose target panel fed from the planning_server: "Plan to target" is the
planning_server's JSON ``plan`` with a pose goal for the tool link (planned collision-free, within
the limits, and shown on /planned_path, which the viewer animates as the orange preview); "Execute
previewed plan" sends that very trajectory to its ``execute`` (checked against the current scene
and the arm's state before anything moves, watched while it moves, stopped by Stop like any
execution). Only the plan answered for the target still shown can be executed.

Calls run on worker threads: nothing here blocks a ROS callback or the page."""
from __future__ import annotations

import threading
from typing import Any

import numpy as np
from rclpy.node import Node

from interfaces_py.json_rpc import JsonRpcClient, RpcError
from mycobot_planning.core.transforms import matrix_to_quat
from mycobot_planning.ros.servo.teleop_view import TeleopView
from mycobot_planning.visualization.pose_target import PoseTargetActions, PoseTargetPanel

#: s the planning_server may take to plan (its own allowed_planning_time bounds it first)
PLAN_TIMEOUT = 60.0
#: s an execution may take
EXECUTE_TIMEOUT = 120.0


class PoseTargetView:
    """Connects a viewer's PoseTargetPanel to ``planning_server`` for ``group``'s ``link``."""

    def __init__(self, node: Node, planning_server: str, group: str, link: str) -> None:
        self.node = node
        self.group = group
        self.link = link
        self.panel: PoseTargetPanel | None = None
        self._rpc = JsonRpcClient(node, planning_server)
        self._lock = threading.Lock()
        self._plans: dict[int, Any] = {}  # token -> the trajectory answered (the newest only)

    def actions(self) -> PoseTargetActions:
        return PoseTargetActions(plan=self.plan, execute=self.execute)

    def attach(self, panel: PoseTargetPanel) -> None:
        self.panel = panel

    def _answer(self, token: int, ok: bool, text: str) -> None:
        if self.panel is not None:
            self.panel.on_plan(token, ok, text)

    def _say(self, text: str) -> None:
        if self.panel is not None:
            self.panel.on_message(text)

    def plan(self, token: int, pose: np.ndarray, scaling: float) -> None:
        x, y, z = (float(v) for v in pose[:3, 3])
        qx, qy, qz, qw = (float(v) for v in matrix_to_quat(pose))
        params = {"group": self.group, "goal": {"pose": [x, y, z, qx, qy, qz, qw], "link": self.link},
                  "max_velocity_scaling_factor": scaling, "max_acceleration_scaling_factor": scaling,
                  "display": True}

        def work() -> None:
            try:
                result = self._rpc.call("plan", params, timeout=PLAN_TIMEOUT)
            except RpcError as exc:
                self._answer(token, False, f"planning to the target failed: {exc}")
                return
            problem = TeleopView.outcome(result)
            trajectory = result.get("trajectory") if isinstance(result, dict) else None
            if problem is not None or trajectory is None:
                self._answer(token, False, f"no plan to the target: {problem or 'no trajectory'}")
                return
            with self._lock:
                self._plans = {token: trajectory}
            points = trajectory.get("joint_trajectory", {}).get("points", [])
            duration = float(points[-1].get("time_from_start", 0.0)) if points else 0.0
            self._answer(token, True, f"planned in {float(result.get('planning_time', 0.0)):.3f} s: a {duration:.2f} s "
                                      "move, previewed by the orange robot; Execute to run it")
        threading.Thread(target=work, name="pose target plan", daemon=True).start()

    def execute(self, token: int) -> None:
        with self._lock:
            trajectory = self._plans.pop(token, None)
        if trajectory is None:
            self._say("that plan is no longer offered: plan again")
            return

        def work() -> None:
            self._say("executing the previewed plan")
            try:
                result = self._rpc.call("execute", {"trajectory": trajectory, "wait": True}, timeout=EXECUTE_TIMEOUT)
            except RpcError as exc:
                self._say(f"executing the previewed plan failed: {exc}")
                return
            problem = TeleopView.outcome(result)
            self._say("at the target" if problem is None else f"executing the previewed plan ended {problem}")
        threading.Thread(target=work, name="pose target execute", daemon=True).start()
