"""What the simulator says about a pick and place: did the object slip in the hand while carried,
and does it stand at the place pose once the gripper has left.

The criteria (issue 31): the object's centre within 1 cm of the place pose, its axis within 5
degrees of upright, and never more than 5 mm of slip in the hand while carried. One
implementation for the ROS-free demo, the bench and (later) the ROS demo.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

#: m: how far from the place pose the object's centre may end
PLACE_TOLERANCE = 0.01
#: degrees: how far from upright the object's axis may end
TILT_TOLERANCE_DEG = 5.0
#: m: how far the object may move in the hand while carried
SLIP_TOLERANCE = 0.005


def tilt_deg(pose: np.ndarray, up: np.ndarray | None = None) -> float:
    """Angle (degrees) between the pose's z axis and the world's (or ``up``)."""
    axis = np.asarray(pose, dtype=float)[:3, 2]
    ref = np.array([0.0, 0.0, 1.0]) if up is None else np.asarray(up, dtype=float)
    cos = float(np.clip(axis @ ref / (np.linalg.norm(axis) * np.linalg.norm(ref)), -1.0, 1.0))
    return math.degrees(math.acos(cos))


class SlipMonitor:
    """The object's position in the hand frame, from the moment it is held (the first sample)
    on: slip is the largest distance it moved from there."""

    def __init__(self) -> None:
        self._start: np.ndarray | None = None
        self.slip = 0.0
        self.samples = 0

    def sample(self, hand_pose: np.ndarray, object_pose: np.ndarray) -> float:
        """Record one instant; returns the slip so far (m)."""
        hand = np.asarray(hand_pose, dtype=float)
        in_hand = hand[:3, :3].T @ (np.asarray(object_pose, dtype=float)[:3, 3] - hand[:3, 3])
        if self._start is None:
            self._start = in_hand
        self.slip = max(self.slip, float(np.linalg.norm(in_hand - self._start)))
        self.samples += 1
        return self.slip


@dataclass(frozen=True)
class PlaceOutcome:
    """The verdict: ``success`` when the place error, the tilt and the slip are all within
    their tolerances; ``message`` says which failed and by how much."""

    success: bool
    place_error: float  # m
    tilt_deg: float
    slip: float  # m (nan: never held)
    final_pose: np.ndarray
    message: str

    def figures(self) -> dict[str, float]:
        return {"place_error_mm": round(self.place_error * 1000, 2), "tilt_deg": round(self.tilt_deg, 2),
                "slip_mm": round(self.slip * 1000, 2) if math.isfinite(self.slip) else float("nan")}


def judge_place(final_pose: np.ndarray, place_pose: np.ndarray, slip: float) -> PlaceOutcome:
    """Compare the object's final pose with where it should be; ``slip`` from a SlipMonitor."""
    final = np.asarray(final_pose, dtype=float)
    error = float(np.linalg.norm(final[:3, 3] - np.asarray(place_pose, dtype=float)[:3, 3]))
    tilt = tilt_deg(final)
    problems = []
    if error > PLACE_TOLERANCE:
        problems.append(f"the object ended {error * 1000:.1f} mm from the place pose (tolerance "
                        f"{PLACE_TOLERANCE * 1000:.0f} mm)")
    if tilt > TILT_TOLERANCE_DEG:
        problems.append(f"the object ended {tilt:.1f} degrees from upright (tolerance {TILT_TOLERANCE_DEG:.0f})")
    if not math.isfinite(slip):
        problems.append("the object was never held")
    elif slip > SLIP_TOLERANCE:
        problems.append(f"the object slipped {slip * 1000:.1f} mm in the hand while carried (tolerance "
                        f"{SLIP_TOLERANCE * 1000:.0f} mm)")
    message = "; ".join(problems) if problems else (
        f"placed {error * 1000:.1f} mm from the place pose, {tilt:.1f} degrees from upright, "
        f"{slip * 1000:.1f} mm slip in the hand")
    return PlaceOutcome(not problems, error, tilt, slip, final, message)


#: m: a held object this far from where it was held has left the hand (the hold ends "lost")
LOST_DISTANCE = 0.02


@dataclass
class Hold:
    """One object held by the gripper: from ``start`` (s, the simulator's time) until ``end``
    (None while held); ``slip`` (m) the most it moved in the hand; ``ended``: "opened" (the
    gripper got a new command: let go on purpose) or "lost" (it left the hand, LOST_DISTANCE)."""

    object: str
    start: float
    end: float | None = None
    slip: float = 0.0
    ended: str = ""

    def as_dict(self) -> dict:
        return {"object": self.object, "start": round(self.start, 4),
                "end": None if self.end is None else round(self.end, 4), "slip_mm": round(self.slip * 1000, 3),
                "ended": self.ended}


class GraspWatch:
    """Which object the gripper holds and how much it slips, from samples of the simulated state
    (the ROS twin's counterpart of the ROS-free demo's SlipMonitor window). A hold starts once a
    gripper command has finished (reached or stalled) on an object: the one its pads touch, else
    the one between its pads when the command closed the gripper (``candidates``: a gripper that
    did not close enough still meant to hold it; closing: the command is farther from
    ``open_position`` than the gripper was when it came). At most one hold per command; it ends
    when the gripper gets its next command (the open: "opened") or when the object is
    LOST_DISTANCE from where it was held ("lost")."""

    def __init__(self, open_position: float | None = None) -> None:
        self.holds: list[Hold] = []
        self.open_position = open_position
        self._monitor: SlipMonitor | None = None
        self._command = None
        self._held_command = None
        self._position = None  # the gripper's position at the last sample
        self._closing = False  # whether the current command closes the gripper

    @property
    def current(self) -> Hold | None:
        return self.holds[-1] if self.holds and self.holds[-1].end is None else None

    def sample(self, now: float, gripper, hand_pose: np.ndarray, object_poses: dict[str, np.ndarray],
               candidates: Callable[[], Sequence[str]] | None = None) -> Hold | None:
        """One instant: ``gripper`` a GripperState, the hand link's pose, every object's pose, and
        (called only when a hold may start) the objects between the pads. Returns the hold that
        ended at this sample, if one did."""
        hold = self.current
        new_command = gripper.command is not None and gripper.command is not self._command
        if new_command:
            was = gripper.position if self._position is None else self._position
            self._closing = self.open_position is None or \
                abs(gripper.command.position - self.open_position) > abs(was - self.open_position) + 1e-6
        self._command = gripper.command
        self._position = gripper.position
        if hold is not None:
            if new_command or gripper.active:
                hold.end, hold.ended = now, "opened"
            elif hold.object in object_poses:
                hold.slip = self._monitor.sample(hand_pose, object_poses[hold.object])
                if hold.slip > LOST_DISTANCE:
                    hold.end, hold.ended = now, "lost"
            return hold if hold.end is not None else None
        if gripper.active or gripper.command is None or gripper.command is self._held_command:
            return None
        touched = [name for name in gripper.contacts if name in object_poses]
        if not touched and candidates is not None and self._closing:
            touched = [name for name in candidates() if name in object_poses]
        if touched:
            self._held_command = gripper.command
            self._monitor = SlipMonitor()
            self._monitor.sample(hand_pose, object_poses[touched[0]])
            self.holds.append(Hold(touched[0], now))
        return None

    def last_hold(self, name: str) -> Hold | None:
        """The latest hold of object ``name`` (None: never held)."""
        return next((h for h in reversed(self.holds) if h.object == name), None)
