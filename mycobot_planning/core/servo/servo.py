"""The servo step: one command and the last commanded state in, the next joint positions out.

MoveIt Servo's loop (moveit_servo/src/servo.cpp, utils/common.cpp) made ROS-free:

1. the command becomes a joint delta for one ``publish_period``: a joint jog directly; a twist or
   a pose error (capped to scale.linear / scale.rotational per second) through the pseudo-inverse
   of the group's Jacobian at its tip link;
2. the delta is scaled so that no joint exceeds its velocity limit (all joints by one factor, the
   direction is kept), then by the singularity factor (Jacobian condition number, moving toward or
   away) and by the collision factor the caller measured (collision_velocity_scale);
3. the velocity is smoothed by the Butterworth filter (butterworth_filter_coeff);
4. a joint moving toward a limit inside its margin is halted (all joints when
   halt_all_joints_in_*_mode), JOINT_BOUND;
5. the next positions are checked for collision (if a checker is given): a step into collision
   is refused and the arm holds where it is (HALT_FOR_COLLISION), so the arm stops short of
   contact.

No command (none yet, a stale stream, a reached pose target) lets the smoothing bring the motion
to rest. One Servo per servo loop: it keeps its own Pinocchio data and filter state.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
import pinocchio as pin

from ..errors import RobotModelError
from ..robot_model.robot_model import RobotModel
from .parameters import STATUS_MESSAGES, CommandType, ServoParameters, StatusCode
from .smoothing import ButterworthFilter

__all__ = ["CommandError", "JointJogCommand", "PoseCommand", "Servo", "ServoStep", "TwistCommand",
           "collision_velocity_scale"]

#: exp(-ln(1000) / threshold * (threshold - d)): 1 at the threshold, 1/1000 at contact (MoveIt's)
_LN_1000 = math.log(1000.0)
#: share of the remaining pose error corrected per period once inside one period's reach
_POSE_GAIN = 0.3


class CommandError(ValueError):
    """A command the servo refuses (status INVALID); the message says why."""


@dataclass(frozen=True)
class TwistCommand:
    """geometry_msgs/TwistStamped: linear (m/s or unitless) and angular (rad/s or unitless)
    velocity, axes of ``frame_id``."""

    frame_id: str
    linear: tuple[float, float, float]
    angular: tuple[float, float, float]


@dataclass(frozen=True)
class JointJogCommand:
    """control_msgs/JointJog: velocities of some of the group's joints (the others stay)."""

    joint_names: tuple[str, ...]
    velocities: tuple[float, ...]


@dataclass(frozen=True)
class PoseCommand:
    """geometry_msgs/PoseStamped: where the group's tip link should be (``pose``, 4x4, in
    ``frame_id``)."""

    frame_id: str
    pose: np.ndarray


@dataclass
class ServoStep:
    """What one step commands: the group's next positions, velocities and accelerations, the
    status, and whether anything moves (False once at rest)."""

    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray
    status: int
    moving: bool
    reached: bool = False  # pose tracking: inside both tolerances

    @property
    def message(self) -> str:
        return STATUS_MESSAGES[self.status]


def collision_velocity_scale(self_distance: float, scene_distance: float, self_threshold: float,
                             scene_threshold: float) -> tuple[float, int]:
    """MoveIt's collision monitor: 0 and HALT_FOR_COLLISION on contact (a distance <= 0), else
    the smaller of exp(-ln(1000)/threshold * (threshold - d)) for the self and scene distances
    inside their thresholds; DECELERATE_FOR_COLLISION when below 1."""
    if self_distance <= 0.0 or scene_distance <= 0.0:
        return 0.0, StatusCode.HALT_FOR_COLLISION
    scale = 1.0
    for distance, threshold in ((self_distance, self_threshold), (scene_distance, scene_threshold)):
        if distance < threshold:
            scale = min(scale, math.exp(-_LN_1000 / threshold * (threshold - distance)))
    return scale, (StatusCode.DECELERATE_FOR_COLLISION if scale < 1.0 else StatusCode.NO_WARNING)


def _finite(values: Sequence[float], what: str) -> np.ndarray:
    array = np.asarray(values, dtype=float).reshape(-1)
    if not np.all(np.isfinite(array)):
        raise CommandError(f"{what} {[float(v) for v in array]} has a NaN or infinite value")
    return array


def _pinv_times(u: np.ndarray, s: np.ndarray, vt: np.ndarray, x: np.ndarray) -> np.ndarray:
    """pinv(J) @ x from J's SVD (singular values below 1e-10 of the largest cut off)."""
    keep = s > 1e-10 * s[0]
    return vt[keep].T @ ((u[:, keep].T @ x) / s[keep])


def _rotation_vector(rotation: np.ndarray) -> np.ndarray:
    return np.asarray(pin.log3(rotation), dtype=float)


class Servo:
    """See the module docstring. ``model`` is shared (read-only); ``params`` may be replaced
    with set_parameters between steps."""

    def __init__(self, model: RobotModel, params: ServoParameters | None = None) -> None:
        self.model = model
        params = params or ServoParameters()
        if not model.has_group(params.move_group_name):
            raise ValueError(f"move_group_name '{params.move_group_name}' is not a group of robot "
                             f"'{model.name}' (groups: {model.group_names})")
        self.group = model.group(params.move_group_name)
        if not self.group.tip_link:
            raise ValueError(f"group '{self.group.name}' has no tip link: Cartesian commands need a chain")
        self.joint_names = list(self.group.joint_names)
        self.indices = np.asarray(self.group.variable_indices, dtype=int)
        self.tip = self.group.tip_link
        self.planning_frame = model.root_link
        self._tip_id = model.frame_id(self.tip)
        self._jmap = model.jacobian_map(self.indices)
        self._data = model.pin_model.createData()
        self.lower = np.asarray(model.lower_limits, dtype=float)[self.indices]
        self.upper = np.asarray(model.upper_limits, dtype=float)[self.indices]
        self.vmax = np.array([model.joint(j).max_velocity for j in self.joint_names], dtype=float)
        self.vmax[~np.isfinite(self.vmax) | (self.vmax <= 0)] = np.inf
        self.params = params
        problems = params.problems(len(self.joint_names))
        if problems:
            raise ValueError("invalid servo parameters: " + "; ".join(problems))
        self._filter = ButterworthFilter(len(self.joint_names), params.butterworth_filter_coeff)
        self._full = model.default_positions().astype(float)
        self._velocity = np.zeros(len(self.joint_names))
        self._reach = model.cached(("servo_reach", self.group.name), self._measure_reach)

    # ------------------------------------------------------------------ state
    def set_parameters(self, params: ServoParameters) -> None:
        problems = params.problems(len(self.joint_names))
        if problems:
            raise ValueError("invalid servo parameters: " + "; ".join(problems))
        if params.move_group_name != self.group.name:
            raise ValueError("move_group_name cannot change while the servo runs")
        if params.butterworth_filter_coeff != self.params.butterworth_filter_coeff:
            self._filter = ButterworthFilter(len(self.joint_names), params.butterworth_filter_coeff)
            self._filter.reset(self._velocity)
        self.params = params

    def reset(self, full_positions: Sequence[float]) -> None:
        """Take ``full_positions`` (every variable of the model) as the commanded state, at rest."""
        full = np.asarray(full_positions, dtype=float).reshape(-1)
        if full.shape[0] != len(self.model.variable_names) or not np.all(np.isfinite(full)):
            raise ValueError(f"reset needs {len(self.model.variable_names)} finite positions")
        self._full = full.copy()
        self._velocity[:] = 0.0
        self._filter.reset(0.0)

    @property
    def full_positions(self) -> np.ndarray:
        return self._full.copy()

    @property
    def positions(self) -> np.ndarray:
        """The group's commanded positions."""
        return self._full[self.indices].copy()

    @property
    def velocities(self) -> np.ndarray:
        return self._velocity.copy()

    # ------------------------------------------------------------------ kinematics
    def _kinematics(self, group_positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(tip pose 4x4 in the planning frame, 6 x n Jacobian: linear; angular, world axes at the tip)."""
        full = self._full.copy()
        full[self.indices] = group_positions
        q = self.model.to_q(full)
        jac = pin.computeFrameJacobian(self.model.pin_model, self._data, q, self._tip_id,
                                       pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        pose = self._data.oMf[self._tip_id].homogeneous.copy()
        return pose, jac @ self._jmap

    def frame_pose(self, frame: str) -> np.ndarray:
        """Pose of a link/frame of the model at the commanded state (CommandError if unknown)."""
        try:
            fid = self.model.frame_id(frame)
        except RobotModelError:
            raise CommandError(f"unknown frame '{frame}': not a link or frame of robot '{self.model.name}'") from None
        q = self.model.to_q(self._full)
        pin.forwardKinematics(self.model.pin_model, self._data, q)
        return pin.updateFramePlacement(self.model.pin_model, self._data, fid).homogeneous.copy()

    def _check_frame(self, frame: str) -> None:
        try:
            self.model.frame_id(frame)
        except RobotModelError:
            raise CommandError(f"unknown frame '{frame}': not a link or frame of robot '{self.model.name}'") from None

    def tip_pose(self) -> np.ndarray:
        return self._kinematics(self.positions)[0]

    def _measure_reach(self) -> float:
        """The farthest the tip gets from the group's base link origin (sampled, +5 %)."""
        rng = np.random.default_rng(0)
        data = self.model.pin_model.createData()
        base_id = self.model.frame_id(self.group.base_link)
        best = 0.0
        low = np.where(np.isfinite(self.lower), self.lower, -math.pi)
        high = np.where(np.isfinite(self.upper), self.upper, math.pi)
        for _ in range(2000):
            full = self.model.default_positions().astype(float)
            full[self.indices] = rng.uniform(low, high)
            pin.framesForwardKinematics(self.model.pin_model, data, self.model.to_q(full))
            best = max(best, float(np.linalg.norm(data.oMf[self._tip_id].translation - data.oMf[base_id].translation)))
        return best * 1.05

    # ------------------------------------------------------------------ commands
    def check_command(self, command: TwistCommand | JointJogCommand | PoseCommand) -> None:
        """Raise CommandError when the servo must refuse ``command`` (status INVALID)."""
        if isinstance(command, TwistCommand):
            if not command.frame_id:
                raise CommandError("twist command has an empty header.frame_id: say which frame its axes are in")
            self._check_frame(command.frame_id)
            values = np.concatenate([_finite(command.linear, "twist linear"), _finite(command.angular, "twist angular")])
            if self.params.command_in_type == "unitless" and np.any(np.abs(values) > 1.0):
                raise CommandError(f"unitless twist component above 1 ({[float(v) for v in values]}): "
                                   "unitless commands are within [-1, 1] (command_in_type)")
        elif isinstance(command, JointJogCommand):
            names = list(command.joint_names)
            if len(names) != len(command.velocities):
                raise CommandError(f"joint jog has {len(names)} joint_names and {len(command.velocities)} velocities")
            if not names:
                raise CommandError("joint jog names no joints")
            if len(set(names)) != len(names):
                raise CommandError(f"joint jog names a joint twice: {names}")
            unknown = [n for n in names if n not in self.joint_names]
            if unknown:
                raise CommandError(f"joint jog names {unknown}, not joints of group '{self.group.name}' "
                                   f"({self.joint_names})")
            values = _finite(command.velocities, "joint jog velocities")
            if self.params.command_in_type == "unitless" and np.any(np.abs(values) > 1.0):
                raise CommandError(f"unitless joint jog velocity above 1 ({[float(v) for v in values]})")
        elif isinstance(command, PoseCommand):
            if not command.frame_id:
                raise CommandError("pose command has an empty header.frame_id")
            frame = self.frame_pose(command.frame_id)
            pose = np.asarray(command.pose, dtype=float)
            if pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
                raise CommandError("pose command has a NaN or infinite value")
            target = frame @ pose
            base = self.frame_pose(self.group.base_link)
            distance = float(np.linalg.norm(target[:3, 3] - base[:3, 3]))
            if distance > self._reach:
                raise CommandError(f"pose target is unreachable: {distance:.3f} m from {self.group.base_link}, "
                                   f"the group reaches {self._reach:.3f} m")
        else:
            raise CommandError(f"unknown command {type(command).__name__}")

    def _cartesian_delta(self, command: TwistCommand | PoseCommand, tip: np.ndarray) -> tuple[np.ndarray, bool]:
        """The tip's motion for one period (6: linear; angular, planning frame axes, at the tip),
        and whether a pose target is reached."""
        p = self.params
        dt = p.publish_period
        if isinstance(command, TwistCommand):
            lin = np.asarray(command.linear, dtype=float)
            ang = np.asarray(command.angular, dtype=float)
            if p.command_in_type == "unitless":
                lin, ang = lin * p.scale_linear, ang * p.scale_rotational
            else:
                n = float(np.linalg.norm(lin))
                if n > p.scale_linear:
                    lin = lin * (p.scale_linear / n)
                n = float(np.linalg.norm(ang))
                if n > p.scale_rotational:
                    ang = ang * (p.scale_rotational / n)
            frame = self.frame_pose(command.frame_id)
            rot = frame[:3, :3]
            lin_w, ang_w = rot @ lin, rot @ ang
            if not p.apply_twist_commands_about_ee_frame:
                lin_w = lin_w + np.cross(ang_w, tip[:3, 3] - frame[:3, 3])
            return np.concatenate([lin_w, ang_w]) * dt, False
        target = self.frame_pose(command.frame_id) @ np.asarray(command.pose, dtype=float)
        lin_err = target[:3, 3] - tip[:3, 3]
        ang_err = _rotation_vector(target[:3, :3] @ tip[:3, :3].T)
        lin_n, ang_n = float(np.linalg.norm(lin_err)), float(np.linalg.norm(ang_err))
        if lin_n <= p.pose_tracking_linear_tolerance and ang_n <= p.pose_tracking_angular_tolerance:
            return np.zeros(6), True
        lin_cap, ang_cap = p.scale_linear * dt, p.scale_rotational * dt
        lin = lin_err * min(1.0, lin_cap / lin_n) if lin_n > 0 else lin_err
        ang = ang_err * min(1.0, ang_cap / ang_n) if ang_n > 0 else ang_err
        # the last stretch: close a share of the error each period (no overshoot with the smoothing lag)
        if lin_n <= lin_cap / _POSE_GAIN:
            lin = lin_err * _POSE_GAIN
        if ang_n <= ang_cap / _POSE_GAIN:
            ang = ang_err * _POSE_GAIN
        return np.concatenate([lin, ang]), False

    def singularity_scale(self, jac: np.ndarray, delta_x: np.ndarray, q: np.ndarray,
                          svd: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> tuple[float, int]:
        """MoveIt's velocityScalingFactorForSingularity: the condition number of the Jacobian,
        and whether ``delta_x`` moves toward the singularity (a probe step along the last
        left-singular vector tells which way that is). ``svd``: np.linalg.svd(jac) if known."""
        p = self.params
        u, s, vt = svd if svd is not None else np.linalg.svd(jac)
        if s[-1] <= 1e-12:
            return 0.0, StatusCode.HALT_FOR_SINGULARITY
        condition = float(s[0] / s[-1])
        toward = u[:, -1].copy()
        # MoveIt probes with pinv(J) @ toward * step_scale, a step of step_scale / sigma_min rad
        # that jumps across the singularity when sigma_min is small (1.7 rad on the myCobot at
        # condition 300): the probe here is step_scale rad along the matching joint direction
        probe = vt[-1] * p.singularity_step_scale
        _, jac_new = self._kinematics(q + probe)
        s_new = np.linalg.svd(jac_new, compute_uv=False)
        condition_new = float(s_new[0] / s_new[-1]) if s_new[-1] > 1e-12 else math.inf
        if condition_new < condition:
            toward = -toward
        lower, hard = p.lower_singularity_threshold, p.hard_stop_singularity_threshold
        if float(toward @ delta_x) > 0:
            upper, warn = hard, StatusCode.DECELERATE_FOR_APPROACHING_SINGULARITY
        else:
            upper = lower + (hard - lower) * p.leaving_singularity_threshold_multiplier
            warn = StatusCode.DECELERATE_FOR_LEAVING_SINGULARITY
        if condition >= upper:
            return 0.0, StatusCode.HALT_FOR_SINGULARITY
        if condition > lower:
            return 1.0 - (condition - lower) / (upper - lower), warn
        return 1.0, StatusCode.NO_WARNING

    # ------------------------------------------------------------------ the step
    def step(self, command: TwistCommand | JointJogCommand | PoseCommand | None,
             collision_scale: float = 1.0, collision_status: int = StatusCode.NO_WARNING,
             collides: Callable[[np.ndarray], bool] | None = None) -> ServoStep:
        """One period. ``command`` None: no (fresh) command, come to rest. ``collision_scale`` /
        ``collision_status``: what collision_velocity_scale gave for the current state;
        ``collides(full_positions)``: the exact check of the next state (None: not checked).
        Commands must have passed check_command."""
        p = self.params
        dt = p.publish_period
        q = self._full[self.indices].copy()
        status = StatusCode.NO_WARNING
        reached = False
        cartesian = not isinstance(command, JointJogCommand)
        velocity = np.zeros(len(self.joint_names))
        if isinstance(command, JointJogCommand):
            for name, value in zip(command.joint_names, command.velocities):
                velocity[self.joint_names.index(name)] = value
            if p.command_in_type == "unitless":
                velocity *= p.scale_joint
        elif command is not None:
            tip, jac = self._kinematics(q)
            delta_x, reached = self._cartesian_delta(command, tip)
            if not reached:
                u, sv, vt = svd = np.linalg.svd(jac, full_matrices=False)
                step_q = _pinv_times(u, sv, vt, delta_x)
                # second order: the Jacobian halfway along the step (MoveIt's first-order step
                # drifts off a straight line by 1-2 degrees over 10 cm on the myCobot)
                _, jac_mid = self._kinematics(q + 0.5 * step_q)
                velocity = _pinv_times(*np.linalg.svd(jac_mid, full_matrices=False), delta_x) / dt
                scale, status = self.singularity_scale(jac, delta_x, q, svd)
                velocity *= scale
        if command is not None:
            ratio = float(np.max(np.abs(velocity) / self.vmax)) if velocity.size else 0.0
            if p.override_velocity_scaling_factor >= 0.01:
                velocity *= p.override_velocity_scaling_factor
                ratio *= p.override_velocity_scaling_factor
            if ratio > 1.0:
                velocity /= ratio
        if p.check_collisions and collision_scale < 1.0:
            velocity *= max(0.0, collision_scale)
            status = collision_status if collision_scale > 0 else StatusCode.HALT_FOR_COLLISION
        if status == StatusCode.HALT_FOR_SINGULARITY or status == StatusCode.HALT_FOR_COLLISION:
            velocity[:] = 0.0
            smoothed = velocity
            self._filter.reset(0.0)
        elif p.use_smoothing:
            smoothed = self._filter.filter(velocity)
        else:
            smoothed = velocity
        margins = np.broadcast_to(np.asarray(p.joint_limit_margins, dtype=float), q.shape)
        toward = ((smoothed < 0) & (q < self.lower + margins)) | ((smoothed > 0) & (q > self.upper - margins))
        if np.any(toward):
            halt_all = p.halt_all_joints_in_cartesian_mode if cartesian else p.halt_all_joints_in_joint_mode
            if halt_all:
                smoothed = np.zeros_like(smoothed)
            else:
                smoothed = np.where(toward, 0.0, smoothed)
            self._filter.reset(smoothed)
            status = StatusCode.JOINT_BOUND
        smoothed[np.abs(smoothed) < 1e-4] = 0.0  # at rest: below 1e-4 rad/s
        nxt = np.minimum(np.maximum(q + smoothed * dt, self.lower), self.upper)
        if collides is not None and p.check_collisions and np.any(nxt != q):
            full = self._full.copy()
            full[self.indices] = nxt
            if collides(full):
                nxt = q
                self._filter.reset(0.0)
                status = StatusCode.HALT_FOR_COLLISION
        velocity_out = (nxt - q) / dt
        acceleration = (velocity_out - self._velocity) / dt
        self._velocity = velocity_out
        self._full[self.indices] = nxt
        return ServoStep(nxt.copy(), velocity_out, acceleration, status, bool(np.any(nxt != q)), reached)

    @staticmethod
    def command_type_of(command: TwistCommand | JointJogCommand | PoseCommand) -> int:
        if isinstance(command, JointJogCommand):
            return CommandType.JOINT_JOG
        return CommandType.TWIST if isinstance(command, TwistCommand) else CommandType.POSE
