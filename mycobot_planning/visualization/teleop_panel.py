"""The viewer's Teleoperate panel (MoveIt Pro's teleoperation view, in the browser): joint jog
(per joint, −/+ held down), Cartesian jog (±x ±y ±z ±roll ±pitch ±yaw in the base or the tool
frame, held down), joint sliders (one per joint, within its limits, showing where it is; a
slider let rest moves the arm there through a planned move), a speed slider, Stop, open/close
gripper, and the waypoints: save the current state under a name, move to, rename, erase a saved
one.

ROS-free like the rest of the page: holding a jog button calls ``actions.jog`` repeatedly (the
browser repeats it while the button is held; the ROS side streams servo commands while the
repeats keep coming), the other buttons call the other ``actions``, ``on_*`` inputs take plain
data (the servo's status, the waypoint list, what the last request answered). ``state()``
reports what the panel shows, for tests.
"""
from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from .panel_message import PanelMessage

NO_WAYPOINTS = "(no waypoints)"
#: Cartesian jog buttons: label -> (linear, angular) unit twist
CARTESIAN = {
    "x": ((1.0, 0.0, 0.0), (0.0, 0.0, 0.0)), "y": ((0.0, 1.0, 0.0), (0.0, 0.0, 0.0)),
    "z": ((0.0, 0.0, 1.0), (0.0, 0.0, 0.0)), "roll": ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)),
    "pitch": ((0.0, 0.0, 0.0), (0.0, 1.0, 0.0)), "yaw": ((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
}
FRAMES = ("base", "tool")
#: how often the browser repeats a held jog button (Hz)
HOLD_HZ = 20.0
#: joint sliders: step (rad), how long a dragged slider must keep still before the arm moves
#: there (the page sends no "released"), and the least time between two refreshes from the arm
SLIDER_STEP = 0.01
SLIDER_SETTLE = 0.3
SLIDER_REFRESH = 0.1
#: s within which a second click on "Erase waypoint" erases the selected waypoint
ERASE_CONFIRM = 5.0


@dataclass
class TeleopActions:
    """What the panel's buttons do (each returns at once; outcomes arrive as inputs)."""

    #: ("joint", joint name, ±1 × speed) or ("twist", "base" | "tool", (linear, angular) × speed):
    #: called repeatedly while a jog button is held
    jog: Callable[[str, Any, Any], None]
    stop: Callable[[], None]
    gripper: Callable[[bool], None]  # True: open
    save_waypoint: Callable[[str], None]
    move_to_waypoint: Callable[[str], None]
    refresh_waypoints: Callable[[], None]
    #: {joint: position} for every joint of the group: a planned move there (joint sliders)
    move_joints: Callable[[dict[str, float]], None]
    rename_waypoint: Callable[[str, str], None]  # (old name, new name)
    erase_waypoint: Callable[[str], None]


def joint_label(index: int, sign: int) -> str:
    return f"J{index + 1}{'+' if sign > 0 else '−'}"


def axis_label(axis: str, sign: int) -> str:
    return f"{'+' if sign > 0 else '−'}{axis}"


def slider_range(bounds: tuple[float, float]) -> tuple[float, float]:
    """A joint's limits rounded inward to SLIDER_STEP: a slider cannot ask for a position outside them."""
    lo, hi = bounds
    return (round(math.ceil(lo / SLIDER_STEP - 1e-9) * SLIDER_STEP, 6),
            round(math.floor(hi / SLIDER_STEP + 1e-9) * SLIDER_STEP, 6))


class TeleopPanel:
    """The panel in a viser GUI; inputs from any thread, buttons call ``actions``."""

    def __init__(self, gui: Any, actions: TeleopActions, joint_names: Sequence[str],
                 limits: Mapping[str, tuple[float, float]] | None = None) -> None:
        self._actions = actions
        self._joints = list(joint_names)
        self._lock = threading.Lock()
        self._slider_cond = threading.Condition(self._lock)
        self._ranges = {j: slider_range((limits or {}).get(j, (-math.pi, math.pi))) for j in self._joints}
        self._positions: dict[str, float] = {}  # the arm's, from the joint states
        self._shown: dict[str, float] = {}  # what each slider was last set to from the arm
        self._targets: dict[str, float] = {}  # sliders the user moved, until the arm's moves end
        self._commit_at: float | None = None
        self._slider_thread: threading.Thread | None = None
        self._last_refresh = 0.0
        self._erase_armed: tuple[str, float] | None = None
        self._last_goal: dict[str, float] = {}  # the sliders' last move
        self._waypoints: list[str] = []
        self._servo_status = ""
        self._jogs = 0
        with gui.add_folder("Teleoperate"):
            self._speed = gui.add_slider("Jog speed", min=0.05, max=1.0, step=0.05, initial_value=0.3,
                                         hint="fraction of the servo's scale.joint / scale.linear / scale.rotational")
            self._stop_button = gui.add_button("Stop arm", color="red", hint="stops the servo's jog and any execution")
            self._status_md = gui.add_markdown("servo: **waiting**")
            with gui.add_folder("Joint jog"):
                for i, name in enumerate(self._joints):
                    for sign in (-1, 1):
                        button = gui.add_button(joint_label(i, sign), hint=f"hold: move {name} {'+' if sign > 0 else '−'}")
                        button.on_hold(lambda _, n=name, s=sign: self.hold_joint(n, s), callback_hz=HOLD_HZ)
            with gui.add_folder("Joint positions"):
                self._sliders = {}
                for name in self._joints:
                    lo, hi = self._ranges[name]
                    slider = gui.add_slider(name, min=lo, max=hi, step=SLIDER_STEP,
                                            initial_value=min(max(0.0, lo), hi),
                                            hint=f"where {name} is (rad); drag and let go: the arm moves it there "
                                                 "(a planned, collision-free move)")
                    slider.on_update(lambda e, n=name: getattr(e, "client", None) is not None
                                     and self.drag_joint(n, float(e.target.value)))
                    self._sliders[name] = slider
            with gui.add_folder("Cartesian jog"):
                self._frame = gui.add_dropdown("Jog frame", FRAMES, initial_value="base",
                                               hint="base: the robot's base frame; tool: the end effector's")
                for axis in CARTESIAN:
                    for sign in (-1, 1):
                        button = gui.add_button(axis_label(axis, sign), hint=f"hold: {axis_label(axis, sign)}")
                        button.on_hold(lambda _, a=axis, s=sign: self.hold_axis(a, s), callback_hz=HOLD_HZ)
            with gui.add_folder("Gripper"):
                self._open_button = gui.add_button("Open gripper")
                self._close_button = gui.add_button("Close gripper")
            with gui.add_folder("Waypoints"):
                self._name = gui.add_text("Waypoint name", initial_value="")
                self._save_button = gui.add_button("Save current state")
                self._waypoint_dropdown = gui.add_dropdown("Saved waypoint", (NO_WAYPOINTS,))
                self._move_button = gui.add_button("Move to waypoint", disabled=True)
                self._rename_button = gui.add_button("Rename waypoint", disabled=True,
                                                     hint="the saved waypoint takes the name typed above")
                self._erase_button = gui.add_button("Erase waypoint", disabled=True,
                                                    hint="click twice to erase the saved waypoint")
            self._message = PanelMessage(gui)
        self._stop_button.on_click(lambda _: self.click_stop())
        self._open_button.on_click(lambda _: self._actions.gripper(True))
        self._close_button.on_click(lambda _: self._actions.gripper(False))
        self._save_button.on_click(lambda _: self.click_save())
        self._move_button.on_click(lambda _: self.click_move())
        self._rename_button.on_click(lambda _: self.click_rename())
        self._erase_button.on_click(lambda _: self.click_erase())

    # -- buttons (viser's threads, or tests) ---------------------------------------------------
    def hold_joint(self, joint: str, sign: int) -> None:
        with self._lock:
            self._jogs += 1
        self._actions.jog("joint", joint, float(sign) * float(self._speed.value))

    def hold_axis(self, axis: str, sign: int) -> None:
        linear, angular = CARTESIAN[axis]
        scale = float(sign) * float(self._speed.value)
        with self._lock:
            self._jogs += 1
        self._actions.jog("twist", self._frame.value,
                          (tuple(v * scale for v in linear), tuple(v * scale for v in angular)))

    def click_stop(self) -> None:
        self._actions.stop()

    def click_save(self, name: str | None = None) -> None:
        name = (name if name is not None else self._name.value).strip()
        if not name:
            self.on_message("give the waypoint a name first")
            return
        self._actions.save_waypoint(name)

    def click_move(self, name: str | None = None) -> None:
        name = name or self._waypoint_dropdown.value
        if name and name != NO_WAYPOINTS:
            self._actions.move_to_waypoint(name)

    def _selected(self) -> str | None:
        name = self._waypoint_dropdown.value
        return name if name and name != NO_WAYPOINTS else None

    def click_rename(self, new_name: str | None = None) -> None:
        """Rename the selected waypoint to the typed name (the planning_server checks the name)."""
        old = self._selected()
        new = (new_name if new_name is not None else self._name.value).strip()
        if old is None:
            self.on_message("no waypoint to rename")
        elif not new:
            self.on_message("type the new name in 'Waypoint name' first")
        elif new != old:
            self._actions.rename_waypoint(old, new)

    def click_erase(self) -> None:
        """The first click arms, a second one within ERASE_CONFIRM on the same waypoint erases it."""
        name = self._selected()
        if name is None:
            return
        now = time.monotonic()
        with self._lock:
            armed, self._erase_armed = self._erase_armed, None
            confirmed = armed is not None and armed[0] == name and now < armed[1]
            if not confirmed:
                self._erase_armed = (name, now + ERASE_CONFIRM)
        if confirmed:
            self._actions.erase_waypoint(name)
        else:
            self.on_message(f"click Erase waypoint again within {ERASE_CONFIRM:g} s to erase '{name}'")

    # -- joint sliders ------------------------------------------------------------------------
    def drag_joint(self, joint: str, value: float) -> None:
        """A slider the user moved: once it keeps still SLIDER_SETTLE, the arm moves there (the
        other joints to where their sliders ask, or stay)."""
        if joint not in self._ranges:
            return
        lo, hi = self._ranges[joint]
        with self._slider_cond:
            self._targets[joint] = min(max(float(value), lo), hi)
            self._commit_at = time.monotonic() + SLIDER_SETTLE
            if self._slider_thread is None:
                self._slider_thread = threading.Thread(target=self._commit_sliders, name="teleop sliders",
                                                       daemon=True)
                self._slider_thread.start()
            self._slider_cond.notify()

    def _commit_sliders(self) -> None:
        while True:
            with self._slider_cond:
                while self._commit_at is None or self._commit_at > time.monotonic():
                    self._slider_cond.wait(None if self._commit_at is None else self._commit_at - time.monotonic())
                self._commit_at = None
                goal = {j: self._targets.get(j, self._positions.get(j)) for j in self._joints}
                self._last_goal = dict(goal)
            if any(v is None for v in goal.values()):
                self.on_message("no joint states yet: the sliders cannot move the arm")
                self.on_joint_moves_idle()
                continue
            self._actions.move_joints(goal)

    def on_joint_positions(self, names: Sequence[str], positions: Sequence[float]) -> None:
        """The arm's joint positions (any rate): the sliders the user is not moving follow them,
        at most every SLIDER_REFRESH."""
        now = time.monotonic()
        updates = []
        with self._lock:
            self._positions.update(zip(names, (float(p) for p in positions)))
            if now - self._last_refresh < SLIDER_REFRESH:
                return
            self._last_refresh = now
            for joint in self._joints:
                if joint in self._targets or joint not in self._positions:
                    continue
                lo, hi = self._ranges[joint]
                value = round(min(max(self._positions[joint], lo), hi), 3)
                if self._shown.get(joint) != value:
                    self._shown[joint] = value
                    updates.append((joint, value))
        for joint, value in updates:
            self._sliders[joint].value = value

    def on_joint_moves_idle(self) -> None:
        """The sliders' moves ended (done, failed or stopped): the sliders follow the arm again,
        except one the user is still moving."""
        with self._lock:
            if self._commit_at is None:
                self._targets.clear()
                self._shown.clear()
                self._last_refresh = 0.0

    # -- inputs (ROS callbacks) ---------------------------------------------------------------
    def on_servo_status(self, text: str) -> None:
        with self._lock:
            if text == self._servo_status:
                return
            self._servo_status = text
            self._status_md.content = f"servo: **{text}**"

    def on_waypoints(self, names: Sequence[str], select: str | None = None) -> None:
        with self._lock:
            names = list(names)
            if names != self._waypoints:
                self._waypoints = names
                self._waypoint_dropdown.options = tuple(names) or (NO_WAYPOINTS,)
                self._move_button.disabled = not names
                self._rename_button.disabled = not names
                self._erase_button.disabled = not names
            if select in names:
                self._waypoint_dropdown.value = select

    def on_message(self, text: str) -> None:
        self._message.show(text)

    def state(self) -> dict[str, Any]:
        with self._lock:
            return {"servo_status": self._servo_status, "waypoints": list(self._waypoints),
                    "selected_waypoint": self._waypoint_dropdown.value, "message": self._message.text,
                    "jog_repeats": self._jogs, "speed": float(self._speed.value), "frame": self._frame.value,
                    "joints": list(self._joints), "sliders": {j: float(s.value) for j, s in self._sliders.items()},
                    "slider_ranges": {j: list(r) for j, r in self._ranges.items()},
                    "slider_targets": dict(self._targets), "slider_goal": dict(self._last_goal)}
