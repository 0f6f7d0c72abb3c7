"""The simulator: steps MuJoCo in real time, takes joint commands, reports joint states, object
poses, the gripper's GripperCommand state and depth frames.

Its API is what a ros2_control plant needs (docs/simulation.md, section "API"): write
``set_arm_command`` (or hand it a whole trajectory with ``follow_trajectory``) and
``command_gripper``, read ``joint_states`` and ``gripper_state``; the world is read with
``object_poses`` and reset, paused, stepped, extended with ``spawn_object`` and shrunk with
``remove_object``. Every public method takes the simulator's lock, so a ROS node may call them
from its callbacks while ``start()``'s thread steps the physics.
"""
from __future__ import annotations

import logging
import math
import threading
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from interfaces_py.pose_conversion import PoseError, pose_matrix

from ..core.robot_model import RobotModel
from ..core.robot_trajectory import TimedTrajectory
from ..paths import config_file
from .camera import CameraWorker, DepthFrame
from .errors import CommandError, SimulationError, SpawnError
from .gripper import GripperCommand, GripperGoalTracker, GripperState
from .model_builder import BuiltModel, add_object, build_model
from .scene import SceneObject, SimScene, load_scene
from .settings import SimulationSettings, load_settings

_LOG = logging.getLogger(__name__)

#: s: a velocity command is extrapolated at most this long after it arrived, then held (a
#: controller that stopped sending must not drag the joints on).
COMMAND_HOLD = 0.05
#: s: how long after it arrived a command's own reference (set_arm_command's ``ahead``) is followed
#: before the servos hold its last point: the controller loop may be starved that long on a loaded
#: machine while the physics goes on
REFERENCE_HOLD = 0.5
#: s: behind real time by more than this is reported (log and status)
BEHIND_THRESHOLD = 0.05
#: s: behind by more than this, the real-time clock gives up catching up (the debt is dropped)
MAX_LAG = 0.5
#: m: a spawned object overlapping another by more than this is refused
OVERLAP_TOLERANCE = 1e-4
#: s: window of the real-time factor in the status
RTF_WINDOW = 1.0


@dataclass(frozen=True)
class JointStates:
    """sensor_msgs/JointState's content: every simulated robot joint (arm, gripper, mimic), with
    position, velocity and the effort its actuator exerts; ``stamp`` is the simulation time."""

    names: tuple[str, ...]
    positions: np.ndarray
    velocities: np.ndarray
    efforts: np.ndarray
    stamp: float

    def as_dict(self) -> dict[str, float]:
        return dict(zip(self.names, self.positions.tolist()))


@dataclass(frozen=True)
class SimulatorStatus:
    """How the simulation runs. ``real_time_factor``: simulated seconds per wall second over the
    last second of running (0 when not running); ``behind_real_time``: the real-time loop is
    more than BEHIND_THRESHOLD behind the wall clock (x speed factor); ``lag`` by how much."""

    time: float
    steps: int
    paused: bool
    running: bool
    speed_factor: float
    real_time_factor: float
    behind_real_time: bool
    lag: float
    camera_frames: int
    camera_frame_time: float  # s: median time to render a frame (last 50)
    message: str


@dataclass
class _ArmCommand:
    positions: np.ndarray
    velocities: np.ndarray
    stamp: float
    #: the commanded motion ahead: simulation time -> arm-order (positions, velocities)
    ahead: Callable[[float], tuple[np.ndarray, np.ndarray] | None] | None = None


class MujocoSimulator:
    """A MuJoCo world with the robot in it (see the module docstring and docs/simulation.md).

    ``scene``: a SimScene or a scene YAML (default ``config/mujoco_scene.yaml``); ``settings``: a
    SimulationSettings or a parameter file (default ``config/mujoco_sim.yaml``);
    ``initial_positions``: joint values to start (and reset) at (default all 0); ``camera``:
    render the scene's depth camera at ``settings.camera_rate`` while stepping, its points in
    ``camera_frame`` ("world": the scene's frame, as perception_server expects them; "camera":
    the optical frame), with the camera config's noise model unless ``camera_noise`` is False.
    """

    def __init__(self, robot: RobotModel, scene: SimScene | str | Path | None = None,
                 settings: SimulationSettings | str | Path | None = None, *,
                 initial_positions: Mapping[str, float] | None = None, camera: bool = True,
                 camera_frame: str = "world", camera_noise: bool = True) -> None:
        self.robot = robot
        if scene is None:
            scene = config_file("mujoco_scene.yaml")
        self.scene = scene if isinstance(scene, SimScene) else load_scene(scene)
        if settings is None:
            settings = config_file("mujoco_sim.yaml")
        self.settings = settings if isinstance(settings, SimulationSettings) else load_settings(settings)
        self._lock = threading.RLock()
        self._built: BuiltModel = build_model(robot, self.scene, self.settings)
        self.model = self._built.model
        self.data = mujoco.MjData(self.model)
        index = self._built.index
        self.arm_joints: tuple[str, ...] = tuple(index.arm_joints)
        self.gripper_joint: str = index.gripper_joint
        self.joint_names: tuple[str, ...] = tuple(
            n for n in robot.joint_names if n in index.joint_qpos and robot.joint(n).type != "fixed")
        self._initial = self._checked_initial(initial_positions or {})
        gj = robot.joint(self.gripper_joint)
        effort = float(self.model.jnt_actfrcrange[mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT,
                                                                     self.gripper_joint)][1])
        self._gripper = GripperGoalTracker(self.gripper_joint, gj.lower, gj.upper, gj.max_velocity,
                                           effort if effort > 0 else math.inf, self.settings.gripper)
        self._arm_limits = np.array([[robot.joint(n).lower, robot.joint(n).upper] for n in self.arm_joints])
        # velocity feed-forward: the target moves kv/kp x the commanded velocity ahead (settings.py)
        gains = np.array([index.gains[n] for n in self.arm_joints])
        self._feedforward = gains[:, 1] / gains[:, 0] if self.settings.arm_servo.velocity_feedforward else None
        self._trajectory: TimedTrajectory | None = None
        self._trajectory_start = 0.0
        self._trajectory_columns: np.ndarray | None = None
        self._command = _ArmCommand(np.zeros(len(self.arm_joints)), np.zeros(len(self.arm_joints)), 0.0)
        self._paused = False
        self._resync = False  # set by reset(): the real-time loop takes its time reference anew
        self._steps = 0
        self._camera: CameraWorker | None = None
        self._camera_enabled = camera and self.scene.camera is not None
        self._camera_frame = camera_frame
        self._camera_noise = camera_noise
        self._next_frame = 0.0
        self._frame_listeners: list[Callable[[DepthFrame], None]] = []
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._speed = self.settings.speed_factor
        self._rtf = 0.0
        self._lag = 0.0
        self._behind = False
        self._running = False
        self._message = "ready"
        self._reset_state()

    # ------------------------------------------------------------------ set-up helpers
    def _checked_initial(self, values: Mapping[str, float]) -> dict[str, float]:
        out = {}
        driven = self.arm_joints + (self.gripper_joint,)
        for name, value in values.items():
            if name not in driven:
                mimic = self._built.index.mimic_joints.get(name)
                hint = f" (it mimics '{mimic[0]}': give that one)" if mimic else ""
                raise CommandError(f"initial_positions: '{name}' is not an arm or gripper joint{hint}; joints: "
                                   f"{', '.join(driven)}")
            joint = self.robot.joint(name)
            if not (isinstance(value, (int, float)) and math.isfinite(value)
                    and joint.lower - 1e-9 <= value <= joint.upper + 1e-9):
                raise CommandError(f"initial_positions: {name} = {value!r} must be a number within "
                                   f"[{joint.lower:g}, {joint.upper:g}]")
            out[name] = float(value)
        return out

    def _reset_state(self) -> None:
        """Everything back to the start: robot at its initial positions and holding them, the
        objects where the scene puts them, time 0."""
        mujoco.mj_resetData(self.model, self.data)
        index = self._built.index
        # default: every joint at 0, or at its nearest limit when 0 is outside (as the mock controllers)
        values = {n: self._initial.get(n, min(max(0.0, self.robot.joint(n).lower), self.robot.joint(n).upper))
                  for n in self.arm_joints + (self.gripper_joint,)}
        for name, (source, multiplier, offset) in index.mimic_joints.items():
            values[name] = multiplier * values.get(source, self._initial.get(source, 0.0)) + offset
        for name, value in values.items():
            self.data.qpos[index.joint_qpos[name]] = value
        arm = np.array([values[n] for n in self.arm_joints])
        self._command = _ArmCommand(arm, np.zeros_like(arm), 0.0)
        self._trajectory = None
        self._gripper.hold(values[self.gripper_joint])
        self._apply_controls()
        mujoco.mj_forward(self.model, self.data)
        self._steps = 0
        self._next_frame = 0.0

    # ------------------------------------------------------------------ properties
    @property
    def time(self) -> float:
        """Simulation time (s)."""
        return float(self.data.time)

    @property
    def timestep(self) -> float:
        return float(self.model.opt.timestep)

    @property
    def index(self):
        """Ids of joints, actuators, objects in the current model (model_builder.ModelIndex)."""
        return self._built.index

    @property
    def paused(self) -> bool:
        return self._paused

    @property
    def speed_factor(self) -> float:
        return self._speed

    # ------------------------------------------------------------------ commands
    def set_arm_command(self, positions: Mapping[str, float] | Sequence[float],
                        velocities: Mapping[str, float] | Sequence[float] | None = None,
                        ahead: Callable[[float], tuple[np.ndarray, np.ndarray] | None] | None = None) -> None:
        """Position targets for the arm joints (ros2_control's position command interface), with
        optional velocities (its velocity interface): the servos track ``positions`` extrapolated
        by ``velocities`` until the next command (for at most COMMAND_HOLD, then they hold), with
        the velocity as feed-forward. ``ahead`` (simulation time -> arm-order positions and
        velocities, None when there is no motion ahead): the motion the controller commands next,
        followed every physics step until the next command (for at most REFERENCE_HOLD, then the
        servos hold), so a controller loop that runs late leaves the arm on its trajectory.
        Cancels a trajectory being followed. Refuses unknown joints, NaN and positions outside
        the limits (CommandError), changing nothing."""
        q = self._arm_vector(positions, "positions")
        qd = np.zeros_like(q) if velocities is None else self._arm_vector(velocities, "velocities", limits=False)
        with self._lock:
            self._trajectory = None
            self._command = _ArmCommand(q, qd, self.time, ahead)

    def follow_trajectory(self, trajectory: TimedTrajectory) -> None:
        """Follow a timed trajectory of the arm joints from now on, sampled every physics step
        exactly as a JointTrajectoryController interpolates it (time 0 = now). Joints it does not
        name hold their command; gripper joints in it are ignored (the gripper takes
        GripperCommands). Refused (CommandError) if it names unknown joints, leaves the limits,
        or starts more than 0.05 rad from where the arm is."""
        names = list(trajectory.joint_names)
        unknown = [n for n in names if n not in self.arm_joints and n != self.gripper_joint]
        if unknown:
            raise CommandError(f"trajectory names joints the arm does not have: {unknown} (arm: {list(self.arm_joints)})")
        columns = np.array([names.index(n) if n in names else -1 for n in self.arm_joints], dtype=int)
        if np.all(columns < 0):
            raise CommandError("the trajectory moves none of the arm joints")
        used = columns >= 0
        pos = trajectory.positions[:, columns[used]]
        low, high = self._arm_limits[used, 0], self._arm_limits[used, 1]
        bad = np.argwhere((pos < low - 1e-6) | (pos > high + 1e-6))
        if bad.size:
            i, j = bad[0]
            name = np.asarray(self.arm_joints)[used][j]
            raise CommandError(f"trajectory point {i} puts {name} at {pos[i, j]:.4f}, outside its limits "
                               f"[{low[j]:g}, {high[j]:g}]")
        with self._lock:
            current = self.data.qpos[self._built.index.arm_qpos][used]
            deviation = np.abs(trajectory.positions[0, columns[used]] - current)
            if deviation.size and deviation.max() > 0.05:
                j = int(np.argmax(deviation))
                name = np.asarray(self.arm_joints)[used][j]
                raise CommandError(f"the trajectory starts {deviation[j]:.4f} rad from where {name} is; it must "
                                   "start at the current state")
            self._trajectory = trajectory
            self._trajectory_columns = columns
            self._trajectory_start = self.time - float(trajectory.times[0])

    @property
    def trajectory_active(self) -> bool:
        """A trajectory given to follow_trajectory has not reached its end time yet."""
        with self._lock:
            return self._trajectory is not None and \
                self.time - self._trajectory_start < float(self._trajectory.times[-1]) - 1e-12

    def stop_arm(self) -> None:
        """Stop following: hold the arm where it is now."""
        with self._lock:
            q = self.data.qpos[self._built.index.arm_qpos].copy()
            self._trajectory = None
            self._command = _ArmCommand(q, np.zeros_like(q), self.time)

    def command_gripper(self, position: float, max_effort: float = 0.0) -> None:
        """A GripperCommand: move the gripper joint to ``position``, pushing with at most
        ``max_effort`` (0: its effort limit). Replaces any command in progress; refuses NaN and
        positions outside the joint limits (CommandError)."""
        with self._lock:
            self._gripper.start(GripperCommand(position, max_effort), self.data.qpos[self._built.index.gripper_qpos],
                                self.time)

    def gripper_state(self) -> GripperState:
        with self._lock:
            index = self._built.index
            return GripperState(
                float(self.data.qpos[index.gripper_qpos]), float(self.data.qvel[index.gripper_dof]),
                float(self.data.actuator_force[index.gripper_actuator]), self._gripper.stalled,
                self._gripper.reached, self._gripper.active, self._gripper.command, tuple(self._pad_contacts()))

    def _arm_vector(self, values: Mapping[str, float] | Sequence[float], what: str, limits: bool = True) -> np.ndarray:
        if isinstance(values, Mapping):
            unknown = sorted(set(values) - set(self.arm_joints))
            missing = [n for n in self.arm_joints if n not in values]
            if unknown or missing:
                raise CommandError(f"arm command {what}: " + "; ".join(
                    ([f"unknown joints {unknown}"] if unknown else []) + ([f"missing joints {missing}"] if missing else [])))
            values = [values[n] for n in self.arm_joints]
        try:
            arr = np.asarray(values, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise CommandError(f"arm command {what} must be numbers, got {values!r}") from None
        if arr.shape != (len(self.arm_joints),):
            raise CommandError(f"arm command {what}: {len(self.arm_joints)} values needed for {list(self.arm_joints)}, "
                               f"got {arr.size}")
        if not np.all(np.isfinite(arr)):
            j = int(np.flatnonzero(~np.isfinite(arr))[0])
            raise CommandError(f"arm command {what}: {self.arm_joints[j]} is {arr[j]}; values must be finite")
        if limits:
            bad = np.flatnonzero((arr < self._arm_limits[:, 0] - 1e-9) | (arr > self._arm_limits[:, 1] + 1e-9))
            if bad.size:
                j = int(bad[0])
                raise CommandError(f"arm command: {self.arm_joints[j]} = {arr[j]:g} is outside its limits "
                                   f"[{self._arm_limits[j, 0]:g}, {self._arm_limits[j, 1]:g}]")
        return arr

    # ------------------------------------------------------------------ state
    def joint_states(self) -> JointStates:
        """Every robot joint's position, velocity and actuator effort now."""
        with self._lock:
            index = self._built.index
            q = np.array([self.data.qpos[index.joint_qpos[n]] for n in self.joint_names])
            qd = np.array([self.data.qvel[index.joint_dof[n]] for n in self.joint_names])
            tau = np.array([self.data.qfrc_actuator[index.joint_dof[n]] for n in self.joint_names])
            return JointStates(self.joint_names, q, qd, tau, self.time)

    def arm_positions(self) -> np.ndarray:
        with self._lock:
            return self.data.qpos[self._built.index.arm_qpos].copy()

    def arm_target(self) -> np.ndarray:
        """Where the arm servos are told to be now (the desired state a controller reports)."""
        with self._lock:
            return self._arm_reference()[0]

    def world_objects(self) -> tuple[SceneObject, ...]:
        """The objects of the world as it is now (the scene file's, spawned ones, not removed ones),
        each with the pose it was built at; object_poses() gives where they are."""
        with self._lock:
            return tuple(self._built.scene.objects)

    def object_poses(self) -> dict[str, np.ndarray]:
        """Every scene object's true pose (4x4, world frame) now."""
        with self._lock:
            return {name: self._body_pose(body) for name, body in self._built.index.object_bodies.items()}

    def object_pose(self, name: str) -> np.ndarray:
        return self._named_body_pose(
            lambda index: index.object_bodies, name,
            lambda: f"no object '{name}' in the simulation (objects: {', '.join(self.scene.object_ids)})")

    def set_object_state(self, name: str, pose: np.ndarray | Sequence[float] | None = None,
                         linear_velocity: Sequence[float] | None = None,
                         angular_velocity: Sequence[float] | None = None) -> None:
        """Teleport a free object (``pose``: 4x4 or a pose vector, world frame) and/or set its
        velocity (m/s, rad/s, world frame); what is not given stays. A push is a velocity."""
        with self._lock:
            index = self._built.index
            if name not in index.object_bodies:
                raise KeyError(f"no object '{name}' in the simulation (objects: {', '.join(index.object_bodies)})")
            qpos, dof = index.object_qpos[name], index.object_dof[name]
            if qpos < 0:
                raise CommandError(f"object '{name}' is fixed: it cannot be moved")
            if pose is not None:
                try:
                    matrix = pose_matrix(pose, f"pose of '{name}'")
                except PoseError as exc:
                    raise CommandError(str(exc)) from None
                self.data.qpos[qpos:qpos + 3] = matrix[:3, 3]
                x, y, z, w = Rotation.from_matrix(matrix[:3, :3]).as_quat()
                self.data.qpos[qpos + 3:qpos + 7] = [w, x, y, z]
                mujoco.mj_kinematics(self.model, self.data)
            for offset, value, what in ((0, linear_velocity, "linear_velocity"), (3, angular_velocity, "angular_velocity")):
                if value is None:
                    continue
                arr = np.asarray(value, dtype=float).reshape(-1)
                if arr.shape != (3,) or not np.all(np.isfinite(arr)):
                    raise CommandError(f"{what} of '{name}' must be 3 finite numbers, got {value!r}")
                if offset == 3:  # the free joint's angular velocity is in the body frame
                    rot = self.data.xmat[index.object_bodies[name]].reshape(3, 3)
                    arr = rot.T @ arr
                self.data.qvel[dof + offset:dof + offset + 3] = arr
            mujoco.mj_forward(self.model, self.data)

    def link_pose(self, link: str) -> np.ndarray:
        """A robot link's true pose (4x4, world frame) now."""
        return self._named_body_pose(lambda index: index.link_bodies, link,
                                     lambda: f"no link '{link}' in the simulation")

    def _named_body_pose(self, bodies: Callable[[Any], Mapping[str, int]], name: str,
                         missing: Callable[[], str]) -> np.ndarray:
        """The pose now of the body named ``name`` in the ``bodies`` of the model's index; a
        KeyError saying ``missing()`` when there is none."""
        with self._lock:
            body = bodies(self._built.index).get(name)
            if body is None:
                raise KeyError(missing())
            return self._body_pose(body)

    def _body_pose(self, body: int) -> np.ndarray:
        pose = np.eye(4)
        pose[:3, :3] = self.data.xmat[body].reshape(3, 3)
        pose[:3, 3] = self.data.xpos[body]
        return pose

    def _pad_contacts(self) -> list[str]:
        index = self._built.index
        pads = set(index.fingertip_geoms.tolist())
        owners = {g: name for name, g in index.object_geoms.items()}
        found = []
        for k in range(self.data.ncon):
            contact = self.data.contact[k]
            g1, g2 = int(contact.geom1), int(contact.geom2)
            if contact.exclude:  # within the margin but not pushing (MuJoCo's gap)
                continue
            for pad, other in ((g1, g2), (g2, g1)):
                if pad in pads and other in owners and owners[other] not in found:
                    found.append(owners[other])
        return found

    def objects_between_pads(self, max_distance: float = 0.01) -> list[str]:
        """The free objects within ``max_distance`` (m) of every finger pad now, nearest first:
        what a gripper closing now would close on (touching or not)."""
        with self._lock:
            index = self._built.index
            free = {o.id for o in self._built.scene.objects if not o.fixed}
            pads: dict[int, list[int]] = {}
            for g in index.fingertip_geoms.tolist():
                pads.setdefault(int(self.model.geom_bodyid[g]), []).append(g)
            found = []
            for name, geom in index.object_geoms.items():
                if name not in free:
                    continue
                worst = max(min(mujoco.mj_geomDistance(self.model, self.data, g, geom, max_distance, None)
                                for g in geoms) for geoms in pads.values())
                if worst <= max_distance:
                    found.append((worst, name))
            return [name for _, name in sorted(found)]

    def contacts_of(self, name: str) -> list[str]:
        """What object or robot link ``name`` (an object) touches now."""
        with self._lock:
            index = self._built.index
            geom = index.object_geoms.get(name)
            if geom is None:
                raise KeyError(f"no object '{name}'")
            out = []
            for k in range(self.data.ncon):
                contact = self.data.contact[k]
                if contact.exclude or geom not in (contact.geom1, contact.geom2):
                    continue
                other = contact.geom2 if contact.geom1 == geom else contact.geom1
                out.append(self._geom_owner(int(other)))
            return sorted(set(out))

    def _geom_owner(self, geom: int) -> str:
        name = mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_GEOM, geom)
        body = int(self.model.geom_bodyid[geom])
        if body == 0:
            return name or f"geom {geom}"
        return mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_BODY, body) or f"body {body}"

    # ------------------------------------------------------------------ stepping
    def _arm_reference(self) -> tuple[np.ndarray, np.ndarray]:
        """Where the arm servos should be now, and how fast they should move."""
        now = self.time
        if self._trajectory is not None:
            q, qd, _ = self._trajectory.sample(now - self._trajectory_start)
            ref_q, ref_qd = self._command.positions.copy(), np.zeros(len(self.arm_joints))
            used = self._trajectory_columns >= 0
            ref_q[used] = q[self._trajectory_columns[used]]
            ref_qd[used] = qd[self._trajectory_columns[used]]
            return ref_q, ref_qd
        cmd = self._command
        elapsed = now - cmd.stamp
        if cmd.ahead is not None:
            held = elapsed >= REFERENCE_HOLD
            reference = cmd.ahead(cmd.stamp + REFERENCE_HOLD if held else now)
            if reference is not None:
                low, high = self._arm_limits[:, 0], self._arm_limits[:, 1]
                q = np.minimum(np.maximum(reference[0], low), high)
                return q, np.zeros_like(q) if held else reference[1]
            return cmd.positions, np.zeros_like(cmd.velocities)
        if elapsed >= COMMAND_HOLD:
            return cmd.positions + cmd.velocities * COMMAND_HOLD, np.zeros_like(cmd.velocities)
        return cmd.positions + cmd.velocities * max(elapsed, 0.0), cmd.velocities

    def _finish_trajectory(self) -> None:
        """Past its end a trajectory becomes a hold command at its last point (JTC holds there)."""
        traj = self._trajectory
        if traj is not None and self.time - self._trajectory_start >= float(traj.times[-1]):
            q, _ = self._arm_reference()
            self._command = _ArmCommand(q, np.zeros_like(q), self.time)
            self._trajectory = None

    def _apply_controls(self) -> None:
        index = self._built.index
        q, qd = self._arm_reference()
        self.data.ctrl[index.arm_actuators] = q + self._feedforward * qd if self._feedforward is not None else q
        self.data.ctrl[index.gripper_actuator] = self._gripper.advance(self.timestep)
        bound = self._gripper.effort_bound()
        limited = math.isfinite(bound)
        self.model.actuator_forcelimited[index.gripper_actuator] = int(limited)
        if limited:
            self.model.actuator_forcerange[index.gripper_actuator] = (-bound, bound)

    def _step_once(self) -> None:
        if self._camera_enabled and self.settings.camera_rate > 0 and self.time + 1e-9 >= self._next_frame:
            # the frame of this instant, rendered in the camera's thread while the physics goes on
            self._next_frame = self.time + 1.0 / self.settings.camera_rate
            self._capture_locked()
        self._apply_controls()
        mujoco.mj_step(self.model, self.data)
        self._steps += 1
        self._finish_trajectory()
        index = self._built.index
        self._gripper.update(float(self.data.qpos[index.gripper_qpos]), float(self.data.qvel[index.gripper_dof]),
                             self.time)

    def step(self, steps: int = 1) -> None:
        """Advance ``steps`` physics steps now, as fast as the CPU allows. While start()'s thread
        runs the simulation, pause it first (as mujoco_ros2_control's step_simulation asks)."""
        if isinstance(steps, bool) or not isinstance(steps, int) or steps < 0:
            raise SimulationError(f"steps must be an integer >= 0, got {steps!r}")
        with self._lock:
            if self._running_in_background() and not self._paused:
                raise SimulationError("the simulation is running in real time: pause() it before stepping by hand")
            for _ in range(steps):
                self._step_once()

    def advance(self, duration: float) -> None:
        """Advance ``duration`` simulated seconds as fast as the CPU allows (tests, benchmarks)."""
        self.step(int(round(max(duration, 0.0) / self.timestep)))

    def run_until(self, done: Callable[["MujocoSimulator"], bool], timeout: float) -> bool:
        """Step (as fast as possible) until ``done(sim)`` or ``timeout`` simulated seconds passed;
        returns whether ``done`` held. Checked every millisecond of simulated time."""
        end = self.time + timeout
        check_every = max(1, int(round(0.001 / self.timestep)))
        while self.time < end - 1e-12:
            if done(self):
                return True
            self.step(check_every)
        return bool(done(self))

    # ------------------------------------------------------------------ real time
    def _speed_or_default(self, speed_factor: float | None) -> float:
        speed = self.settings.speed_factor if speed_factor is None else speed_factor
        if isinstance(speed, bool) or not isinstance(speed, (int, float)) or not (math.isfinite(speed)
                                                                                  and 0 < speed <= 100):
            raise SimulationError(f"speed_factor must be within (0, 100], got {speed_factor!r}")
        return float(speed)

    def _running_in_background(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def run_realtime(self, duration: float, speed_factor: float | None = None) -> SimulatorStatus:
        """Step ``duration`` simulated seconds paced to the wall clock x ``speed_factor``
        (default the settings' speed_factor), in this thread; returns the status afterwards."""
        speed = self._speed_or_default(speed_factor)
        if not (isinstance(duration, (int, float)) and math.isfinite(duration) and duration >= 0):
            raise SimulationError(f"duration must be a number of seconds >= 0, got {duration!r}")
        if self._running_in_background():
            raise SimulationError("the simulation already runs in real time (start()); stop() it first")
        self._stop.clear()
        self._loop(self.time + duration, speed)
        return self.status()

    def start(self, speed_factor: float | None = None) -> None:
        """Run in real time in a background thread until stop() (pause() holds it). Errors that
        stop the thread are logged and left in the status message."""
        speed = self._speed_or_default(speed_factor)
        with self._lock:
            if self._running_in_background():
                return
            self._stop.clear()
            self._thread = threading.Thread(target=self._guarded_loop, args=(math.inf, speed),
                                            name="mujoco_sim", daemon=True)
            self._thread.start()

    def _guarded_loop(self, end_time: float, speed: float) -> None:
        try:
            self._loop(end_time, speed)
        except Exception as exc:  # noqa: BLE001 - a background thread has no caller to raise to
            self._message = f"stopped: {exc}"
            _LOG.error("the simulation stopped: %s", exc)

    def stop(self) -> None:
        self._stop.set()
        thread = self._thread
        if thread is not None:
            thread.join(timeout=5.0)
        self._thread = None

    def set_speed_factor(self, speed_factor: float) -> None:
        """Change the real-time pace (simulated seconds per wall second, (0, 100]); the real-time
        loop takes its time reference anew from here."""
        speed = self._speed_or_default(speed_factor)
        with self._lock:
            self._speed = speed
            self.settings = replace(self.settings, speed_factor=speed)
            self._lag = 0.0
            self._resync = True

    def pause(self) -> None:
        with self._lock:
            self._paused = True
            self._message = "paused"

    def resume(self) -> None:
        with self._lock:
            self._paused = False
            self._message = "running"

    def _loop(self, end_time: float, speed: float) -> None:
        """Step so that simulated time follows the wall clock x speed factor. Behind means more
        than BEHIND_THRESHOLD late, or (over a full RTF_WINDOW) slower than 95 % of the speed
        factor; it is logged once when it starts and once when it ends, and is in the status."""
        self._speed = speed
        self._behind = False
        self._running = True
        self._message = "running"
        wall0, sim0 = time.perf_counter(), self.time
        window: list[tuple[float, float]] = [(wall0, sim0)]
        try:
            while not self._stop.is_set() and self.time < end_time - 1e-12:
                if self._paused or self._resync:
                    if self._paused:
                        time.sleep(0.005)
                    self._resync = False
                    wall0, sim0 = time.perf_counter(), self.time
                    window = [(wall0, sim0)]
                    continue
                now = time.perf_counter()
                target = min(sim0 + (now - wall0) * self._speed, end_time)
                lag = (target - self.time) / self._speed
                if lag > MAX_LAG:  # too far behind to catch up: drop the debt, go on from here
                    wall0, sim0 = now, self.time
                    target = self.time
                with self._lock:
                    steps = 0
                    while self.time < target - 1e-12 and steps < 50:
                        self._step_once()
                        steps += 1
                    window.append((time.perf_counter(), self.time))
                    while len(window) > 2 and window[-1][0] - window[1][0] > RTF_WINDOW:
                        window.pop(0)
                    span = window[-1][0] - window[0][0]
                    self._rtf = (window[-1][1] - window[0][1]) / span if span > 0 else 0.0
                    self._lag = max(0.0, lag)
                    slow = span >= 0.9 * RTF_WINDOW and self._rtf < 0.95 * self._speed
                    self._update_behind(lag > BEHIND_THRESHOLD or slow)
                ahead = (self.time - sim0) / self._speed - (time.perf_counter() - wall0)
                if ahead > 0:
                    time.sleep(min(ahead, 0.002))
        finally:
            self._running = False

    def _update_behind(self, behind: bool) -> None:
        if behind and not self._behind:
            self._message = (f"falling behind real time: {self._lag:.3f} s late, running at {self._rtf:.2f} x real "
                             f"time for a speed factor of {self._speed:g}")
            _LOG.warning(self._message)
        elif not behind and self._behind and self._lag < BEHIND_THRESHOLD / 2:
            self._message = f"caught up with real time (speed factor {self._speed:g})"
            _LOG.info(self._message)
        else:
            return
        self._behind = behind

    def status(self) -> SimulatorStatus:
        with self._lock:
            frames = self._camera.frames if self._camera is not None else 0
            frame_time = self._camera.frame_seconds if self._camera is not None else 0.0
            return SimulatorStatus(self.time, self._steps, self._paused, self._running, self._speed, self._rtf,
                                   self._behind, self._lag, frames, frame_time, self._message)

    # ------------------------------------------------------------------ camera
    def _camera_worker(self) -> CameraWorker:
        if self._camera is None:
            if self.scene.camera is None:
                raise SimulationError("the scene has no camera (give camera or camera_file in the scene file)")
            self._camera = CameraWorker(self.model, self.scene.camera, self._camera_frame, self.scene.frame_id,
                                        self._camera_noise, on_frame=self._dispatch_frame)
        return self._camera

    def _dispatch_frame(self, frame: DepthFrame) -> None:
        for listener in list(self._frame_listeners):
            try:
                listener(frame)
            except Exception:  # noqa: BLE001 - a listener's bug must not stop the camera
                _LOG.exception("a depth frame listener failed")

    def _capture_locked(self) -> None:
        """Hand the state to the camera thread (rendered while the physics steps on)."""
        self._camera_worker().submit(self.model, self.data, self.time)

    def capture(self) -> DepthFrame:
        """Render a depth frame of the world as it is now (blocks until it is rendered)."""
        with self._lock:
            worker = self._camera_worker()
            worker.submit(self.model, self.data, self.time)
        return worker.wait()

    @property
    def latest_frame(self) -> DepthFrame | None:
        """The last frame the camera rendered (at camera_rate while stepping), if any; call
        wait_for_frame() first to have the one of the last camera tick."""
        return self._camera.latest if self._camera is not None else None

    def wait_for_frame(self) -> DepthFrame | None:
        """Wait until the frame in progress is rendered; returns the latest frame."""
        return self._camera.wait() if self._camera is not None else None

    def on_frame(self, listener: Callable[[DepthFrame], None]) -> None:
        """Call ``listener(frame)`` for every frame rendered (in the camera's thread)."""
        self._frame_listeners.append(listener)

    def set_camera_rate(self, rate: float) -> None:
        """Frames per simulated second (0: none while stepping; capture() still works)."""
        if not (isinstance(rate, (int, float)) and math.isfinite(rate) and 0 <= rate <= 60):
            raise SimulationError(f"camera rate must be within [0, 60] Hz, got {rate!r}")
        with self._lock:
            self.settings = replace(self.settings, camera_rate=float(rate))
            self._next_frame = self.time

    # ------------------------------------------------------------------ world
    def reset(self) -> None:
        """Objects back to the scene file (spawned ones removed, removed ones back), the robot
        back to its initial positions, time 0; commands in progress are dropped."""
        with self._lock:
            if self._built.scene is not self.scene:
                self._rebuild(self.scene)
            self._reset_state()
            self._message = "reset"
            self._lag = 0.0
            self._resync = True  # the real-time loop measures time from here, not from before the reset

    def spawn_object(self, obj: SceneObject) -> None:
        """Add ``obj`` to the running world. Refused (SpawnError, nothing changed) when its name
        is taken or it would overlap something, naming what it overlaps and by how much."""
        with self._lock:
            if obj.id in self._built.index.object_bodies or obj.id in self._built.index.link_bodies:
                raise SpawnError(f"cannot spawn '{obj.id}': an object or link of that name exists")
            # Check on a copy first: a refused object leaves the running model untouched.
            trial = self._built.spec.copy()
            add_object(trial, obj)
            try:
                trial_model = trial.compile()
            except ValueError as exc:
                raise SpawnError(f"cannot spawn '{obj.id}': {' '.join(str(exc).split())}") from None
            trial_data = mujoco.MjData(trial_model)
            trial_data.qpos[:self.model.nq] = self.data.qpos
            mujoco.mj_kinematics(trial_model, trial_data)
            overlaps = _overlaps(trial_model, trial_data, obj.id)
            if overlaps:
                raise SpawnError(f"cannot spawn '{obj.id}': it overlaps " + ", ".join(
                    f"'{other}' by {depth * 1000:.1f} mm" for other, depth in overlaps))
            spec = self._built.spec
            add_object(spec, obj)
            model, data = spec.recompile(self.model, self.data)
            self._adopt(model, data, self._built.scene.with_object(obj))

    def remove_object(self, name: str) -> None:
        """Take object ``name`` out of the running world (KeyError if there is none)."""
        with self._lock:
            if name not in self._built.index.object_bodies:
                raise KeyError(f"no object '{name}' in the simulation (objects: "
                               f"{', '.join(self._built.scene.object_ids) or 'none'})")
            spec = self._built.spec
            spec.delete(spec.body(name))
            model, data = spec.recompile(self.model, self.data)
            scene = replace(self._built.scene, objects=tuple(o for o in self._built.scene.objects if o.id != name))
            self._adopt(model, data, scene)

    def _adopt(self, model: mujoco.MjModel, data: mujoco.MjData, scene: SimScene) -> None:
        self._built.scene = scene
        self._built.model = model
        self._built.index.fill(model, scene)
        self.model, self.data = model, data
        mujoco.mj_forward(self.model, self.data)

    def _rebuild(self, scene: SimScene) -> None:
        self._built = build_model(self.robot, scene, self.settings)
        self.model = self._built.model
        self.data = mujoco.MjData(self.model)

    def close(self) -> None:
        self.stop()
        if self._camera is not None:
            self._camera.close()
            self._camera = None

    def __enter__(self) -> "MujocoSimulator":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _overlaps(model: mujoco.MjModel, data: mujoco.MjData, body_name: str) -> list[tuple[str, float]]:
    """What the body's geoms penetrate (name of the other body or geom, depth), deepest first.
    Every other geom is checked, welded ones and excluded pairs included (the contact list
    skips those)."""
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body_name)
    mine = [g for g in range(model.ngeom) if model.geom_bodyid[g] == body]
    found: dict[str, float] = {}
    fromto = np.zeros(6)
    for g in mine:
        for other in range(model.ngeom):
            if model.geom_bodyid[other] == body:
                continue
            dist = mujoco.mj_geomDistance(model, data, g, other, 0.01, fromto)
            if dist >= -OVERLAP_TOLERANCE:
                continue
            other_body = int(model.geom_bodyid[other])
            name = (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, other_body) if other_body
                    else mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, other)) or "the world"
            found[name] = max(found.get(name, 0.0), -float(dist))
    return sorted(found.items(), key=lambda item: -item[1])
