"""The viewer's Teleoperate panel (MoveIt Pro's teleoperation view, in the browser): joint jog
(per joint, −/+ held down), Cartesian jog (±x ±y ±z ±roll ±pitch ±yaw in the base or the tool
frame, held down), a speed slider, Stop, open/close gripper, and the waypoints: save the current
state under a name, move to a saved one.

ROS-free like the rest of the page: holding a jog button calls ``actions.jog`` repeatedly (the
browser repeats it while the button is held; the ROS side streams servo commands while the
repeats keep coming), the other buttons call the other ``actions``, ``on_*`` inputs take plain
data (the servo's status, the waypoint list, what the last request answered). ``state()``
reports what the panel shows, for tests.
"""
from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

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


def joint_label(index: int, sign: int) -> str:
    return f"J{index + 1}{'+' if sign > 0 else '−'}"


def axis_label(axis: str, sign: int) -> str:
    return f"{'+' if sign > 0 else '−'}{axis}"


class TeleopPanel:
    """The panel in a viser GUI; inputs from any thread, buttons call ``actions``."""

    def __init__(self, gui: Any, actions: TeleopActions, joint_names: Sequence[str]) -> None:
        self._actions = actions
        self._joints = list(joint_names)
        self._lock = threading.Lock()
        self._waypoints: list[str] = []
        self._servo_status = ""
        self._message = ""
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
            self._message_md = gui.add_markdown("")
        self._stop_button.on_click(lambda _: self.click_stop())
        self._open_button.on_click(lambda _: self._actions.gripper(True))
        self._close_button.on_click(lambda _: self._actions.gripper(False))
        self._save_button.on_click(lambda _: self.click_save())
        self._move_button.on_click(lambda _: self.click_move())

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
            if select in names:
                self._waypoint_dropdown.value = select

    def on_message(self, text: str) -> None:
        with self._lock:
            self._message = text
            self._message_md.content = text

    def state(self) -> dict[str, Any]:
        with self._lock:
            return {"servo_status": self._servo_status, "waypoints": list(self._waypoints),
                    "selected_waypoint": self._waypoint_dropdown.value, "message": self._message,
                    "jog_repeats": self._jogs, "speed": float(self._speed.value), "frame": self._frame.value,
                    "joints": list(self._joints)}
