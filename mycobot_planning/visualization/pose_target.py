"""The viewer's Pose target panel (MoveIt Pro's interactive marker, RViz's MotionPlanning goal
marker): a draggable 3D gizmo for the tool's goal pose, a plan to it previewed before anything
moves, and an Execute button that runs exactly the previewed plan once the user approves it.

Why a preview first: a pose goal can be reached in ways a user does not expect (an elbow flip, a
wide swing); MoveIt users plan, watch the orange robot, then execute. Moving the target (by the
gizmo or the text field) withdraws the preview: Execute runs only a plan of the pose shown.

ROS-free like the rest of the page: ``actions.plan`` and ``actions.execute`` return at once and
the outcome arrives through ``on_plan`` / ``on_message``; ``state()`` reports what is shown.
"""
from __future__ import annotations

import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.transforms import make_pose, matrix_to_quat, matrix_to_rpy
from .panel_message import PanelMessage

__all__ = ["PoseTargetActions", "PoseTargetPanel", "format_pose", "parse_pose"]

#: the gizmo's size (m)
GIZMO_SCALE = 0.12
#: the plan's velocity and acceleration scaling to begin with (RViz's MotionPlanning panel's 0.1)
DEFAULT_SCALING = 0.1


@dataclass
class PoseTargetActions:
    """What the panel's buttons do (each returns at once)."""

    #: plan (no motion) to the tool pose (4x4, world frame) at a velocity and acceleration
    #: scaling factor; the answer comes as on_plan(token, ...)
    plan: Callable[[int, np.ndarray, float], None]
    #: execute the plan answered for ``token`` (the one previewed)
    execute: Callable[[int], None]


def format_pose(pose: np.ndarray) -> str:
    """'x y z roll pitch yaw' in m and degrees, as the text field shows it."""
    roll, pitch, yaw = matrix_to_rpy(pose)
    x, y, z = pose[:3, 3]
    return f"{x:.4f} {y:.4f} {z:.4f} {math.degrees(roll):.2f} {math.degrees(pitch):.2f} {math.degrees(yaw):.2f}"


def parse_pose(text: str) -> np.ndarray:
    """The 4x4 pose of 'x y z roll pitch yaw' (m, degrees; commas allowed); ValueError naming
    the problem otherwise."""
    parts = text.replace(",", " ").split()
    if len(parts) != 6:
        raise ValueError(f"the target needs 6 numbers 'x y z roll pitch yaw' (m, degrees), got {len(parts)}")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ValueError(f"the target '{text}' is not 6 numbers") from None
    if not all(math.isfinite(v) for v in values):
        raise ValueError("the target's numbers must be finite")
    return make_pose(values[:3], [math.radians(v) for v in values[3:]])


def _wxyz(pose: np.ndarray) -> tuple[float, float, float, float]:
    x, y, z, w = matrix_to_quat(pose)
    return (float(w), float(x), float(y), float(z))


def _matrix(position: Any, wxyz: Any) -> np.ndarray:
    w, x, y, z = (float(v) for v in wxyz)
    return make_pose([float(v) for v in position], quat_xyzw=[x, y, z, w])


class PoseTargetPanel:
    """The panel in a viser GUI and its gizmo in the scene; inputs from any thread."""

    def __init__(self, gui: Any, scene: Any, actions: PoseTargetActions,
                 tool_pose: Callable[[], np.ndarray | None], tool_name: str = "the tool") -> None:
        self._actions = actions
        self._tool_pose = tool_pose
        self._scene = scene
        self._lock = threading.Lock()
        self._target: np.ndarray | None = None
        self._token = 0  # the target's version: a plan answered for an older one is not offered
        self._planned: int | None = None  # the token whose plan is previewed and may be executed
        self._gizmo: Any = None
        self._setting = False  # the panel itself moves the gizmo or the field: not a user's edit
        with gui.add_folder("Pose target"):
            self._place_button = gui.add_button("Target at the tool",
                                                hint=f"put the draggable target where {tool_name} is now")
            self._text = gui.add_text("Target pose", initial_value="",
                                      hint="x y z (m) roll pitch yaw (degrees) in the world frame; "
                                           "drag the target in the scene or type here")
            self._scaling = gui.add_slider("Velocity scaling", min=0.01, max=1.0, step=0.01,
                                           initial_value=DEFAULT_SCALING,
                                           hint="the plan's max velocity and acceleration scaling factor, as in "
                                                "RViz's MotionPlanning panel")
            self._plan_button = gui.add_button("Plan to target", disabled=True,
                                               hint="plan a collision-free move there and preview it (nothing moves)")
            self._execute_button = gui.add_button("Execute previewed plan", disabled=True, color="green",
                                                  hint="run the plan shown in orange")
            self._message = PanelMessage(gui)
        self._place_button.on_click(lambda _: self.place_at_tool())
        self._plan_button.on_click(lambda _: self.click_plan())
        self._execute_button.on_click(lambda _: self.click_execute())
        self._text.on_update(lambda e: getattr(e, "client", None) is not None and self.type_pose(str(e.target.value)))

    # -- the target ------------------------------------------------------------------------
    def place_at_tool(self) -> None:
        pose = self._tool_pose()
        if pose is None:
            self.on_message("no joint states yet: the tool's pose is not known")
            return
        self.set_target(pose)

    def type_pose(self, text: str) -> None:
        try:
            pose = parse_pose(text)
        except ValueError as exc:
            self.on_message(str(exc))
            return
        self.set_target(pose, from_text=True)

    def set_target(self, pose: np.ndarray, from_text: bool = False, from_gizmo: bool = False) -> None:
        """A new target (any source): the gizmo and the field show it, a previewed plan is withdrawn."""
        pose = np.array(pose, dtype=float)
        with self._lock:
            self._target = pose
            self._token += 1
            withdrawn = self._planned is not None
            self._planned = None
            self._setting = True
        try:
            if not from_gizmo:
                if self._gizmo is None:
                    self._gizmo = self._scene.add_transform_controls(
                        "/pose_target", scale=GIZMO_SCALE, position=tuple(pose[:3, 3]), wxyz=_wxyz(pose))
                    self._gizmo.on_update(lambda _: self.gizmo_moved())
                else:
                    self._gizmo.position, self._gizmo.wxyz = tuple(pose[:3, 3]), _wxyz(pose)
            if not from_text:
                self._text.value = format_pose(pose)
        finally:
            with self._lock:
                self._setting = False
        self._plan_button.disabled = False
        self._execute_button.disabled = True
        if withdrawn:
            self.on_message("the target moved: the previewed plan is withdrawn, plan again")

    @property
    def gizmo(self) -> Any:
        """The target's transform controls in the scene (None until the target is placed)."""
        return self._gizmo

    def gizmo_moved(self) -> None:
        """The user dragged the gizmo (viser's on_update): its pose is the new target."""
        with self._lock:
            if self._setting or self._gizmo is None:
                return
        self.set_target(_matrix(self._gizmo.position, self._gizmo.wxyz), from_gizmo=True)

    # -- plan and execute ------------------------------------------------------------------
    def click_plan(self) -> None:
        with self._lock:
            target, token = self._target, self._token
        if target is None:
            self.on_message("place the target first")
            return
        self._execute_button.disabled = True
        self.on_message("planning to the target …")
        self._actions.plan(token, target.copy(), float(self._scaling.value))

    def on_plan(self, token: int, ok: bool, message: str) -> None:
        """The answer to plan(token): offered for execution only while the target is unchanged."""
        with self._lock:
            current = token == self._token
            if ok and current:
                self._planned = token
        if not current:
            return  # the target moved meanwhile: its own plan, if any, is what counts
        self._execute_button.disabled = not ok
        self.on_message(message)

    def click_execute(self) -> None:
        with self._lock:
            token = self._planned
        if token is None:
            self.on_message("no previewed plan of this target: plan first")
            return
        self._execute_button.disabled = True
        self._actions.execute(token)

    def on_message(self, text: str) -> None:
        self._message.show(text)

    def state(self) -> dict[str, Any]:
        with self._lock:
            return {"target": None if self._target is None else format_pose(self._target),
                    "token": self._token, "previewed": self._planned is not None, "message": self._message.text,
                    "scaling": float(self._scaling.value)}
