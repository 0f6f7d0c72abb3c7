"""Geometry of the seeds' move_group workflows, adapted to the myCobot 280 (no ROS in here).

The seed workflows were written for a UR arm (ROSCon 2024 exercise 1: a hot dog assembled and
decorated with mustard) and for an industrial workcell (Scan-N-Plan: a camera localises a part,
the robot moves its tool there). Their distances are those of a 0.85 m reach arm; the myCobot
reaches about 0.28 m from its base axis, so every position here was chosen inside that reach,
with the tool pointing down, and checked for reachability and a collision-free approach (see
test/test_seed_workflows.py). The workflow nodes (move_group_exercise_1_1, move_group_exercise_1_2,
fake_marker_publisher, part_localizer, scan_n_plan) take these values as parameter defaults and
build their scene from the functions below, so the nodes stay thin and this logic is testable
without processes.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from interfaces_py.msgs import AttachedCollisionObject, CollisionObject, Pose
from interfaces_py.pose_conversion import pose_message

# Links of the myCobot's gripper: an object held by (or hanging from) the flange may touch them.
GRIPPER_TOUCH_LINKS = (
    "link6_flange", "gripper_base", "gripper_left1", "gripper_left2", "gripper_left3",
    "gripper_right1", "gripper_right2", "gripper_right3",
)


def tool_down_quaternion(yaw: float = 0.0) -> list[float]:
    """Orientation (x, y, z, w) of a tool frame whose +z axis points straight down, turned by
    ``yaw`` about the world's vertical: Rz(yaw) * Rx(pi). The myCobot's flange points along its +z,
    so this is a top-down approach."""
    half = yaw / 2.0
    return [math.cos(half), math.sin(half), 0.0, 0.0]


def tool_down_pose(position: Sequence[float], yaw: float = 0.0) -> Pose:
    """Tool pose at ``position`` (world frame) pointing down."""
    return Pose(position=[float(v) for v in position], orientation=tool_down_quaternion(yaw))


def _check_vector(name: str, values: Sequence[float], size: int = 3) -> np.ndarray:
    arr = np.asarray(values, dtype=float).reshape(-1)
    if arr.shape != (size,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be {size} finite numbers, got {list(values)!r}")
    return arr


def _check_positive(name: str, value: float) -> float:
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be a positive number of metres, got {value!r}")
    return float(value)


# ---------------------------------------------------------------------------- exercise 1
@dataclass(frozen=True)
class HotDogScenario:
    """The scene of ROSCon exercise 1 at myCobot scale.

    A sausage (cylinder lying along the world y axis) waits on the table top (z = 0) at
    ``pick_position`` (its centre); the bun (a box) stands at ``bun_position`` (its centre). The
    UR version places these ~0.5 m from the robot; here they sit 0.17-0.20 m in front of the
    myCobot, on either side, where the flange can point straight down at both.

    Exercise 1-1: the flange goes to ``pick_pose()`` (``grasp_height`` above the sausage, as the
    seed plans to "a pose above" the object: there is no grasp, the object is attached where it
    is), the sausage is attached, the flange goes to ``place_pose()``, the sausage is detached
    and "drops" ``drop_height`` into the bun, ending at ``place_position()``. Planning the place
    pose exactly at the bun would put the carried sausage in contact with the bun, which a
    collision-aware planner refuses; the seed's final drop is why the pose is above it.

    Exercise 1-2: the hot dog is assembled (sausage at ``place_position()``), the robot holds a
    mustard bottle, moves to ``mustard_start_pose()`` and zig-zags along the sausage.
    """

    pick_position: tuple[float, float, float] = (0.17, -0.10, 0.008)
    bun_position: tuple[float, float, float] = (0.20, 0.06, 0.0075)
    sausage_length: float = 0.05
    sausage_radius: float = 0.008
    bun_size: tuple[float, float, float] = (0.04, 0.07, 0.015)
    grasp_height: float = 0.10  # m: flange above the sausage's centre when it is picked and placed
    drop_height: float = 0.01  # m: gap the sausage falls through into the bun after detaching
    yaw: float = 0.0  # rad: tool yaw at pick and place (same at both: the sausage keeps its heading)
    # exercise 1-2
    mustard_start_height: float = 0.12  # m: flange above the sausage's centre at the zig-zag start
    mustard_length: float = 0.05  # m: zig-zag extent along the sausage (its length)
    mustard_amplitude: float = 0.01  # m: sideways offset of the zig-zag corners
    mustard_strokes: int = 6  # straight segments of the zig-zag
    bottle_height: float = 0.05
    bottle_radius: float = 0.012
    bottle_offset: float = 0.06  # m: bottle centre below the flange, between the gripper fingers

    sausage_id: str = "sausage"
    bun_id: str = "bun"
    bottle_id: str = "mustard_bottle"
    mustard_id: str = "mustard"

    def __post_init__(self) -> None:
        _check_vector("pick_position", self.pick_position)
        _check_vector("bun_position", self.bun_position)
        _check_vector("bun_size", self.bun_size)
        if np.any(np.asarray(self.bun_size) <= 0):
            raise ValueError(f"bun_size must be positive, got {list(self.bun_size)}")
        for name in ("sausage_length", "sausage_radius", "grasp_height", "mustard_start_height",
                     "mustard_length", "bottle_height", "bottle_radius"):
            _check_positive(name, getattr(self, name))
        for name in ("drop_height", "mustard_amplitude", "bottle_offset", "yaw"):
            if not math.isfinite(getattr(self, name)) or (name != "yaw" and getattr(self, name) < 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {getattr(self, name)!r}")
        if isinstance(self.mustard_strokes, bool) or not isinstance(self.mustard_strokes, int) or self.mustard_strokes < 1:
            raise ValueError(f"mustard_strokes must be an integer >= 1, got {self.mustard_strokes!r}")
        if self.grasp_height <= self.sausage_radius:
            raise ValueError(f"grasp_height ({self.grasp_height} m) must exceed the sausage radius "
                             f"({self.sausage_radius} m): the flange would be inside the sausage")

    # ---- poses
    def _sausage_orientation(self) -> list[float]:
        # cylinders extend along their local z: roll by pi/2 lays the sausage along world y
        return Pose.from_xyz_rpy((0, 0, 0), (math.pi / 2, 0.0, 0.0)).orientation

    def place_position(self) -> np.ndarray:
        """Where the sausage's centre ends: resting on top of the bun."""
        bun = np.asarray(self.bun_position, dtype=float)
        return bun + [0.0, 0.0, self.bun_size[2] / 2.0 + self.sausage_radius]

    def pick_pose(self) -> Pose:
        """Flange pose above the sausage at the pick location (tool pointing down)."""
        return tool_down_pose(np.asarray(self.pick_position) + [0.0, 0.0, self.grasp_height], self.yaw)

    def place_pose(self) -> Pose:
        """Flange pose above the bun: the carried sausage hangs ``drop_height`` over its place."""
        return tool_down_pose(self.place_position() + [0.0, 0.0, self.grasp_height + self.drop_height], self.yaw)

    # ---- objects
    def sausage(self, position: Sequence[float] | None = None) -> CollisionObject:
        """The sausage at its pick position (or ``position``)."""
        centre = self.pick_position if position is None else position
        return CollisionObject.cylinder(
            self.sausage_id, self.sausage_length, self.sausage_radius,
            Pose(position=[float(v) for v in centre], orientation=self._sausage_orientation()))

    def bun(self) -> CollisionObject:
        return CollisionObject.box(self.bun_id, list(self.bun_size), Pose(position=list(self.bun_position)))

    def dropped_sausage_pose(self, carried: Pose) -> Pose:
        """Where a detached sausage lands: straight down by ``drop_height`` (orientation kept)."""
        return Pose(position=[carried.position[0], carried.position[1], carried.position[2] - self.drop_height],
                    orientation=list(carried.orientation))

    def mustard_bottle(self) -> AttachedCollisionObject:
        """The bottle the robot holds in exercise 1-2: a cylinder hanging below the flange."""
        obj = CollisionObject.cylinder(self.bottle_id, self.bottle_height, self.bottle_radius,
                                       Pose(position=[0.0, 0.0, self.bottle_offset]), frame_id="link6_flange")
        return AttachedCollisionObject(link_name="link6_flange", object=obj, touch_links=list(GRIPPER_TOUCH_LINKS))

    def mustard_stripe(self) -> CollisionObject:
        """What the seed's applyMustard() shows: a thin stripe on top of the sausage."""
        top = self.place_position() + [0.0, 0.0, self.sausage_radius + 0.001]
        return CollisionObject.box(self.mustard_id, [2 * self.mustard_amplitude, self.mustard_length, 0.002],
                                   Pose(position=top.tolist()))

    def mustard_start_pose(self) -> Pose:
        """Flange pose above the assembled hot dog where the zig-zag starts."""
        return tool_down_pose(self.place_position() + [0.0, 0.0, self.mustard_start_height], self.yaw)

    def mustard_waypoints(self, start: Pose | None = None) -> list[Pose]:
        """Zig-zag along the sausage (world y), corners alternating ``mustard_amplitude`` to
        either side (world x), at the start pose's height and orientation. As in MoveIt, the
        start pose itself is not a waypoint: the path starts wherever the robot is."""
        return zigzag_waypoints(start or self.mustard_start_pose(), self.mustard_length,
                                self.mustard_amplitude, self.mustard_strokes)


def zigzag_waypoints(start: Pose, length: float, amplitude: float, strokes: int,
                     along: Sequence[float] = (0.0, 1.0, 0.0), across: Sequence[float] = (1.0, 0.0, 0.0)) -> list[Pose]:
    """``strokes + 1`` poses zig-zagging over ``length`` (centred on ``start``) along ``along``,
    alternating ``-amplitude`` / ``+amplitude`` along ``across``; orientation of ``start``."""
    _check_positive("length", length)
    if isinstance(strokes, bool) or not isinstance(strokes, int) or strokes < 1:
        raise ValueError(f"strokes must be an integer >= 1, got {strokes!r}")
    if not math.isfinite(amplitude) or amplitude < 0:
        raise ValueError(f"amplitude must be a finite number >= 0, got {amplitude!r}")
    u = _check_vector("along", along)
    v = _check_vector("across", across)
    if np.linalg.norm(u) < 1e-9 or np.linalg.norm(v) < 1e-9:
        raise ValueError("along and across must be non-zero directions")
    u, v = u / np.linalg.norm(u), v / np.linalg.norm(v)
    centre = np.asarray(start.position, dtype=float)
    poses = []
    for k in range(strokes + 1):
        offset = -length / 2.0 + k * length / strokes
        side = amplitude if k % 2 else -amplitude
        poses.append(Pose(position=(centre + offset * u + side * v).tolist(), orientation=list(start.orientation)))
    return poses


# ---------------------------------------------------------------------------- Scan-N-Plan
#: Camera mounted 0.5 m above the table, looking straight down (its +z towards the table), over
#: the myCobot's workspace. The seed's workcell has the camera on a stand next to a bigger robot.
DEFAULT_CAMERA_POSE = (0.20, 0.0, 0.50, 1.0, 0.0, 0.0, 0.0)
#: The marker on the part as the camera sees it: 0.4 m in front of the lens, so 0.10 m above the
#: table, within the myCobot's reach; turned 0.3 rad about the camera axis. With the camera looking
#: down, the marker's +z points down too: the tool frame goes there pointing at the part.
DEFAULT_MARKER_POSE = (0.02, 0.05, 0.40, 0.0, 0.0, math.sin(0.15), math.cos(0.15))


def pose_from_list(values: Sequence[float], what: str) -> Pose:
    """Pose from [x, y, z, qx, qy, qz, qw] (a ROS parameter); PoseError (a ValueError) naming ``what``."""
    return pose_message(values, what)


def pose_list_check(what: str) -> Callable[[Any], str | None]:
    """A parameter validator for a pose list named ``what``: None when pose_from_list takes the
    value, else why not."""

    def problem(value: Any) -> str | None:
        try:
            pose_from_list(value, what)
        except (ValueError, TypeError) as exc:
            return str(exc)
        return None

    return problem


def pose_to_list(pose: Pose) -> list[float]:
    return [float(v) for v in (*pose.position, *pose.orientation)]


def localize(marker_in_camera: Pose, camera_in_base: Pose) -> Pose:
    """The part's pose in the base frame: the camera's mounting pose composed with the marker
    pose the camera reports (what tf2's lookup does in the seed's vision node)."""
    return Pose.from_matrix(camera_in_base.to_matrix() @ marker_in_camera.to_matrix())
