"""Trajectory execution: MoveIt's TrajectoryExecutionManager without ROS.

What move_group does between "execute this trajectory" and "SUCCESS", as plain Python so it can be
unit-tested with a simulated controller and a simulated clock:

* **Controllers** come from a ros2_control controllers file (or MoveIt's moveit_controllers.yaml):
  each joint trajectory controller owns a set of joints.
* **Preparation**: a trajectory is checked (known joints, finite values, limits, increasing time),
  mimic joints are dropped (their controller drives the source joint), and it is split per
  controller by joint mapping. A controller whose joints are only partly in the trajectory gets
  the missing ones held at their current values, so every controller receives a complete command.
* **Start tolerance** (``trajectory_execution.allowed_start_tolerance``): the first point must be
  within this distance of the current joint state, or execution is refused before anything moves.
* **Monitoring**: after sending, the controllers' states are watched. Success needs every
  controller to report success *and* the joint states to reach the last point within the goal
  tolerance. Execution that takes longer than
  ``duration * allowed_execution_duration_scaling + allowed_goal_duration_margin`` is cancelled
  and reported TIMED_OUT; a controller that aborts makes it CONTROL_FAILED; a stop request
  makes it PREEMPTED. In every non-success case the controllers still running are stopped.
* **Task solutions** (MTC's execute_task_solution): a list of sub-trajectories with planning-scene
  diffs applied before and/or after each one. The whole solution is validated (trajectories,
  controllers, continuity, and a dry run of every scene diff on a copy of the scene) before the
  first motion, and each "after" diff is applied only once its trajectory succeeded, so a failure
  never leaves a half-applied attach/detach behind.

The ROS side (publishing commands, receiving controller states and /joint_states) hides behind
the small :class:`ControllerBus` interface, which the planning server implements with rclpy.
"""
from __future__ import annotations

import math
import threading
import time
import uuid
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Protocol, Sequence

import numpy as np

from interfaces_py.msgs import (
    JointTrajectory,
    JointTrajectoryPoint,
    MessageError,
    MoveItErrorCode,
    PlanningScene as PlanningSceneMsg,
    RobotState as RobotStateMsg,
    RobotTrajectory,
)

from .controllers_config import load_controllers_config, read_controllers_source
from .errors import PlanningError, SceneError
from .planning_scene import PlanningScene
from .robot_model import RobotModel
from .robot_trajectory import joint_trajectory_to_timed, timed_to_joint_trajectory
from .trajectory_limits import DEFAULT_LIMIT_TOLERANCE, motion_limit_problem

__all__ = [
    "ControllerBus",
    "ControllerInfo",
    "ControllerState",
    "ExecutionError",
    "ExecutionMonitor",
    "ExecutionResult",
    "ExecutionSettings",
    "SolutionResult",
    "SolutionStep",
    "TrajectoryExecutionManager",
    "allowed_duration",
    "check_start_state",
    "joint_trajectory_to_timed",
    "load_controllers",
    "parse_task_solution",
    "parse_trajectory",
    "prepare_trajectory",
    "split_trajectory",
    "timed_to_joint_trajectory",
]

# Controller status values (the mock controllers' /<name>/state "status").
TERMINAL_SUCCESS = "succeeded"
TERMINAL_FAILURE = ("aborted", "failed")
TERMINAL_INTERRUPTED = ("preempted", "stopped")
SOURCE = "trajectory_execution"
#: MoveIt's controller handle types (moveit_controllers.yaml ``type``)
FOLLOW_JOINT_TRAJECTORY = "FollowJointTrajectory"
GRIPPER_COMMAND = "GripperCommand"
ACTION_NAMESPACES = {FOLLOW_JOINT_TRAJECTORY: "follow_joint_trajectory", GRIPPER_COMMAND: "gripper_cmd"}


class ExecutionError(PlanningError, ValueError):
    """Execution refused or failed before motion, with the MoveIt error code to report."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.message = message

    def error_code(self) -> MoveItErrorCode:
        return MoveItErrorCode(self.code, self.message, SOURCE)


# ---------------------------------------------------------------------------- settings
@dataclass(frozen=True)
class ExecutionSettings:
    """MoveIt's trajectory_execution parameters (same names and defaults) plus our goal check."""

    allowed_execution_duration_scaling: float = 1.2
    allowed_goal_duration_margin: float = 0.5
    allowed_start_tolerance: float = 0.01  # rad (m); 0 disables the check
    execution_duration_monitoring: bool = True
    goal_tolerance: float = 0.02  # rad (m) between the last point and /joint_states; 0 disables
    joint_state_timeout: float = 1.0  # s: older joint states are stale
    #: relative slack on the joint velocity/acceleration limits a sent trajectory must keep
    limit_tolerance: float = DEFAULT_LIMIT_TOLERANCE

    def __post_init__(self) -> None:
        for name in ("allowed_execution_duration_scaling", "allowed_goal_duration_margin",
                     "allowed_start_tolerance", "goal_tolerance", "joint_state_timeout", "limit_tolerance"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        if self.allowed_execution_duration_scaling < 1.0:
            raise ValueError("allowed_execution_duration_scaling must be >= 1.0 "
                             f"(got {self.allowed_execution_duration_scaling}): a trajectory needs its own duration")
        if self.joint_state_timeout <= 0:
            raise ValueError("joint_state_timeout must be > 0")

    def allowed_duration(self, duration: float) -> float:
        return allowed_duration(duration, self.allowed_execution_duration_scaling, self.allowed_goal_duration_margin)


def allowed_duration(duration: float, scaling: float, margin: float) -> float:
    """MoveIt's limit on how long executing a trajectory of ``duration`` seconds may take."""
    return float(duration) * float(scaling) + float(margin)


# ---------------------------------------------------------------------------- controllers
@dataclass(frozen=True)
class ControllerInfo:
    """A controller as MoveIt's simple controller manager knows it: its name, the joints it
    drives and its action (``FollowJointTrajectory`` on ``/<name>/<action_ns>``, or
    ``GripperCommand``, which gets the last point of the gripper's trajectory)."""

    name: str
    joints: tuple[str, ...]
    action_type: str = FOLLOW_JOINT_TRAJECTORY
    action_ns: str = "follow_joint_trajectory"

    @property
    def action_name(self) -> str:
        return f"/{self.name}/{self.action_ns}"

    @property
    def command_topic(self) -> str:
        return f"/{self.name}/joint_trajectory"

    @property
    def state_topic(self) -> str:
        return f"/{self.name}/state"

    @property
    def stop_service(self) -> str:
        return f"/{self.name}/stop"


def _controller_joints(name: str, entry: Any, where: str) -> tuple[str, ...]:
    if isinstance(entry, Mapping) and "ros__parameters" in entry:
        entry = entry["ros__parameters"]
    joints = entry.get("joints") if isinstance(entry, Mapping) else None
    if not isinstance(joints, list) or not joints or not all(isinstance(j, str) and j for j in joints):
        raise ValueError(f"{where}: controller '{name}' needs a non-empty 'joints' list of joint names")
    if len(set(joints)) != len(joints):
        raise ValueError(f"{where}: controller '{name}' lists a joint twice")
    return tuple(joints)


def load_controllers(source: str | Path | Mapping | None) -> list[ControllerInfo]:
    """Controllers from a controllers file or its parsed content (None: config/moveit_controllers.yaml).

    Layouts understood:

    * ros2_control (what the mock controllers read): ``controller_manager.ros__parameters.<name>.type``
      names each controller; joint trajectory controllers list their joints in
      ``<name>.ros__parameters.joints``. Broadcasters and other non-trajectory types are skipped.
    * MoveIt's moveit_controllers.yaml: ``moveit_simple_controller_manager.controller_names`` plus
      ``moveit_simple_controller_manager.<name>.joints``.
    * Plain: ``controllers: {<name>: {joints: [...]}}``.
    """
    if source is None:
        from ..paths import config_file

        source = config_file("moveit_controllers.yaml")
    data, where = read_controllers_source(source, "controllers")
    controllers: list[ControllerInfo] = []
    if "controller_manager" in data:
        # ros2_control's own file: its one parser, other controller types (broadcasters,
        # forward command controllers, ...) skipped
        config = load_controllers_config(data, skip_other_types=True)
        for c in config.controllers:
            kind = GRIPPER_COMMAND if "GripperActionController" in c.type else FOLLOW_JOINT_TRAJECTORY
            controllers.append(ControllerInfo(c.name, c.joints, kind, ACTION_NAMESPACES[kind]))
    elif "moveit_simple_controller_manager" in data:
        manager = data["moveit_simple_controller_manager"]
        if not isinstance(manager, Mapping):
            raise ValueError(f"{where}: moveit_simple_controller_manager must be a mapping")
        names = manager.get("controller_names", [])
        if not isinstance(names, list):
            raise ValueError(f"{where}: controller_names must be a list")
        for name in names:
            entry = manager.get(name)
            kind = entry.get("type", FOLLOW_JOINT_TRAJECTORY) if isinstance(entry, Mapping) else FOLLOW_JOINT_TRAJECTORY
            if kind not in ACTION_NAMESPACES:
                raise ValueError(f"{where}: controller '{name}' has type {kind!r}; supported: "
                                 f"{', '.join(ACTION_NAMESPACES)}")
            action_ns = entry.get("action_ns", ACTION_NAMESPACES[kind]) if isinstance(entry, Mapping) else None
            if not isinstance(action_ns, str) or not action_ns.strip("/"):
                raise ValueError(f"{where}: controller '{name}' needs an action_ns string")
            controllers.append(ControllerInfo(str(name), _controller_joints(str(name), entry, where), kind,
                                              action_ns.strip("/")))
    elif "controllers" in data:
        entries = data["controllers"]
        if not isinstance(entries, Mapping):
            raise ValueError(f"{where}: 'controllers' must map controller names to {{joints: [...]}}")
        for name, entry in entries.items():
            controllers.append(ControllerInfo(str(name), _controller_joints(str(name), entry, where)))
    else:
        raise ValueError(f"{where}: no controllers found (expected controller_manager, "
                         "moveit_simple_controller_manager or controllers)")
    if not controllers:
        raise ValueError(f"{where}: defines no joint trajectory controller")
    return controllers


def check_controllers(model: RobotModel, controllers: Sequence[ControllerInfo]) -> None:
    """Every controller joint must be an active joint of the robot (mimic joints are not driven)."""
    names = [c.name for c in controllers]
    if len(set(names)) != len(names):
        raise ValueError(f"controller names must be unique, got {names}")
    for controller in controllers:
        unknown = [j for j in controller.joints if j not in model.variable_names]
        if unknown:
            raise ValueError(
                f"controller '{controller.name}' drives {unknown}, which are not active joints of robot "
                f"'{model.name}' (active joints: {model.variable_names})"
            )


def parse_trajectory(value: Any, what: str = "trajectory") -> tuple[JointTrajectory, str]:
    """(JointTrajectory, group name) from a RobotTrajectory or JointTrajectory message / dict / JSON.

    Raises ExecutionError(INVALID_MOTION_PLAN) naming the problem.
    """
    try:
        if isinstance(value, RobotTrajectory):
            return value.joint_trajectory, value.group_name
        if isinstance(value, JointTrajectory):
            return value, ""
        if isinstance(value, (str, bytes, bytearray)):
            import json

            try:
                value = json.loads(value)
            except ValueError as exc:
                raise ExecutionError(MoveItErrorCode.INVALID_MOTION_PLAN, f"{what}: malformed JSON: {exc}") from None
        if not isinstance(value, Mapping):
            raise ExecutionError(MoveItErrorCode.INVALID_MOTION_PLAN,
                                 f"{what} must be a RobotTrajectory or JointTrajectory object, got {type(value).__name__}")
        if "joint_trajectory" in value:
            robot_trajectory = RobotTrajectory.from_dict(value)
            return robot_trajectory.joint_trajectory, robot_trajectory.group_name
        return JointTrajectory.from_dict(value), ""
    except MessageError as exc:
        raise ExecutionError(MoveItErrorCode.INVALID_MOTION_PLAN, f"invalid {what}: {exc}") from None


def prepare_trajectory(model: RobotModel, trajectory: JointTrajectory, position_tolerance: float = 1e-4,
                       limit_tolerance: float = DEFAULT_LIMIT_TOLERANCE) -> JointTrajectory:
    """The trajectory as controllers get it: active joints only, checked.

    Mimic joints are dropped when their source joint is in the trajectory (the controller drives
    the source); a mimic joint alone is refused. Refuses (ExecutionError INVALID_MOTION_PLAN): no
    points, unknown joints, non-finite values (also caught by the message class), positions outside
    the joint limits, times not strictly increasing, velocities or accelerations beyond the joint
    limits by more than ``limit_tolerance`` (relative; see trajectory_limits.py).
    """
    bad = MoveItErrorCode.INVALID_MOTION_PLAN
    if not trajectory.joint_names:
        raise ExecutionError(bad, "trajectory names no joints")
    if not trajectory.points:
        raise ExecutionError(bad, "trajectory has no points")
    mimic = set(model.mimic_joint_names)
    names = list(trajectory.joint_names)
    unknown = [n for n in names if n not in model.variable_names and n not in mimic]
    if unknown:
        raise ExecutionError(
            bad, f"trajectory names joints {unknown} that robot '{model.name}' does not have; "
            f"its joints are {model.variable_names}"
        )
    keep = [i for i, n in enumerate(names) if n not in mimic]
    dropped = [n for n in names if n in mimic]
    if dropped:
        sources = {model.joint(n).mimic.joint for n in dropped if model.joint(n).mimic is not None}
        missing = sorted(s for s in sources if s not in names)
        if missing:
            raise ExecutionError(bad, f"trajectory moves mimic joints {dropped} without their source joints {missing}; "
                                      "command the source joint instead")
    indices = np.array([model.variable_index(names[i]) for i in keep], dtype=int)
    low, high = model.lower_limits[indices], model.upper_limits[indices]
    previous = -math.inf
    for k, point in enumerate(trajectory.points):
        values = np.array([point.positions[i] for i in keep], dtype=float)
        if not np.all(np.isfinite(values)):
            raise ExecutionError(bad, f"trajectory point {k} contains NaN or infinite positions")
        outside = [
            f"{names[keep[j]]}={values[j]:.4f} outside [{low[j]:.4f}, {high[j]:.4f}]"
            for j in range(len(keep))
            if values[j] < low[j] - position_tolerance or values[j] > high[j] + position_tolerance
        ]
        if outside:
            raise ExecutionError(bad, f"trajectory point {k} is outside the joint limits: " + "; ".join(outside))
        t = point.time_from_start
        if not math.isfinite(t) or t < 0:
            raise ExecutionError(bad, f"trajectory point {k} has an invalid time_from_start {t}")
        if t <= previous:
            raise ExecutionError(bad, f"trajectory point {k}: time_from_start {t} is not after the previous point's {previous}")
        previous = t
    problem = motion_limit_problem(
        [names[i] for i in keep],
        np.array([p.time_from_start for p in trajectory.points], dtype=float),
        np.array([[p.positions[i] for i in keep] for p in trajectory.points], dtype=float),
        _given(trajectory, "velocities", keep), _given(trajectory, "accelerations", keep),
        model.velocity_limits[indices], model.acceleration_limits[indices], limit_tolerance)
    if problem is not None:
        raise ExecutionError(bad, problem)
    if not dropped:
        return trajectory
    return JointTrajectory(
        joint_names=[names[i] for i in keep],
        points=[_select_point(p, keep) for p in trajectory.points],
        frame_id=trajectory.frame_id,
    )


def _given(trajectory: JointTrajectory, field: str, keep: Sequence[int]) -> np.ndarray | None:
    """The points' velocities or accelerations of the kept joints, or None unless every point has them."""
    rows = [getattr(p, field) for p in trajectory.points]
    if not all(len(r) == len(trajectory.joint_names) for r in rows):
        return None
    return np.array([[r[i] for i in keep] for r in rows], dtype=float)


def _select_point(point: JointTrajectoryPoint, keep: Sequence[int]) -> JointTrajectoryPoint:
    return JointTrajectoryPoint(
        positions=[point.positions[i] for i in keep],
        velocities=[point.velocities[i] for i in keep] if point.velocities else [],
        accelerations=[point.accelerations[i] for i in keep] if point.accelerations else [],
        time_from_start=point.time_from_start,
    )


def trajectory_duration(trajectory: JointTrajectory) -> float:
    return trajectory.points[-1].time_from_start if trajectory.points else 0.0


def select_controllers(
    joints: Sequence[str], controllers: Sequence[ControllerInfo], allowed: Sequence[str] | None = None
) -> list[ControllerInfo]:
    """The controllers that together drive ``joints`` (MoveIt picks the fewest that cover them).

    Greedy: the controller covering most of the still uncovered joints first (file order breaks
    ties). ``allowed`` restricts the choice (a task step's controller_names).
    """
    candidates = list(controllers)
    if allowed:
        names = {c.name for c in controllers}
        unknown = [a for a in allowed if a not in names]
        if unknown:
            raise ExecutionError(
                MoveItErrorCode.CONTROL_FAILED,
                f"unknown controllers {unknown}; configured controllers: {sorted(names)}",
            )
        candidates = [c for c in controllers if c.name in allowed]
    uncovered = list(joints)
    chosen: list[ControllerInfo] = []
    while uncovered:
        best = max(candidates, key=lambda c: sum(j in c.joints for j in uncovered), default=None)
        if best is None or not any(j in best.joints for j in uncovered):
            listing = "; ".join(f"{c.name}: {list(c.joints)}" for c in candidates) or "none"
            raise ExecutionError(
                MoveItErrorCode.CONTROL_FAILED,
                f"no controller drives joints {uncovered} (controllers: {listing})",
            )
        chosen.append(best)
        candidates.remove(best)
        uncovered = [j for j in uncovered if j not in best.joints]
    return chosen


def split_trajectory(
    trajectory: JointTrajectory,
    controllers: Sequence[ControllerInfo],
    current: Mapping[str, float] | None = None,
    allowed: Sequence[str] | None = None,
    goal_id: str = "",
) -> list[tuple[ControllerInfo, JointTrajectory]]:
    """One command per controller, each over all of that controller's joints.

    Joints of a chosen controller that the trajectory does not move are held at their ``current``
    values (positions constant, velocities zero), so controllers never receive partial goals.
    With ``goal_id`` each command's frame_id (the message's header.frame_id) is set to
    ``<goal_id>/<controller>``: the controllers report on a goal under that id, so the monitor
    can tell reports about this execution from reports about earlier goals.
    """
    chosen = select_controllers(trajectory.joint_names, controllers, allowed)
    index = {name: i for i, name in enumerate(trajectory.joint_names)}
    commands = []
    for controller in chosen:
        held = [j for j in controller.joints if j not in index]
        if held and current is None:
            raise ExecutionError(MoveItErrorCode.CONTROL_FAILED,
                                 f"controller '{controller.name}' also drives {held}, whose current values are unknown")
        missing = [j for j in held if j not in (current or {})]
        if missing:
            raise ExecutionError(MoveItErrorCode.ROBOT_STATE_STALE,
                                 f"no joint state for {missing}, which controller '{controller.name}' must hold")
        points = []
        for p in trajectory.points:
            positions, velocities, accelerations = [], [], []
            for j in controller.joints:
                if j in index:
                    i = index[j]
                    positions.append(p.positions[i])
                    velocities.append(p.velocities[i] if p.velocities else 0.0)
                    accelerations.append(p.accelerations[i] if p.accelerations else 0.0)
                else:
                    positions.append(float(current[j]))
                    velocities.append(0.0)
                    accelerations.append(0.0)
            points.append(JointTrajectoryPoint(
                positions=positions,
                velocities=velocities if p.velocities or held else [],
                accelerations=accelerations if p.accelerations else [],
                time_from_start=p.time_from_start,
            ))
        frame_id = f"{goal_id}/{controller.name}" if goal_id else trajectory.frame_id
        commands.append((controller, JointTrajectory(joint_names=list(controller.joints), points=points,
                                                     frame_id=frame_id)))
    return commands


def check_start_state(trajectory: JointTrajectory, current: Mapping[str, float], tolerance: float) -> None:
    """Refuse a trajectory whose first point is farther than ``tolerance`` from the robot.

    MoveIt's allowed_start_tolerance: a controller would otherwise jump to the first point.
    Raises ExecutionError(START_STATE_INVALID) naming the joint; tolerance 0 disables the check.
    """
    if tolerance <= 0 or not trajectory.points:
        return
    first = trajectory.points[0].positions
    worst_name, worst = "", 0.0
    for name, value in zip(trajectory.joint_names, first):
        if name not in current:
            raise ExecutionError(MoveItErrorCode.ROBOT_STATE_STALE, f"no current joint state for '{name}'")
        deviation = abs(float(value) - float(current[name]))
        if deviation > worst:
            worst_name, worst = name, deviation
    if worst > tolerance:
        raise ExecutionError(
            MoveItErrorCode.START_STATE_INVALID,
            f"execution refused: the trajectory starts {worst:.4f} away from the current state at joint "
            f"'{worst_name}' (trajectory {dict(zip(trajectory.joint_names, first))[worst_name]:.4f}, "
            f"robot {current[worst_name]:.4f}); allowed_start_tolerance is {tolerance}",
        )


# ---------------------------------------------------------------------------- controller feedback
@dataclass(frozen=True)
class ControllerState:
    """One /<controller>/state message (JSON) as the monitor needs it."""

    status: str
    active: bool = False
    message: str = ""
    goal_id: str = ""
    joint_names: tuple[str, ...] = ()
    received: float = 0.0  # monotonic receive time, set by the bus

    @classmethod
    def from_dict(cls, data: Any, received: float = 0.0) -> "ControllerState":
        if not isinstance(data, Mapping):
            raise ValueError(f"controller state must be a JSON object, got {type(data).__name__}")
        status = data.get("status")
        if not isinstance(status, str) or not status:
            raise ValueError("controller state lacks a 'status' string")
        goal_id = data.get("goal_id", "")
        names = data.get("joint_names", [])
        return cls(
            status=status,
            active=bool(data.get("active", False)),
            message=str(data.get("message", "") or ""),
            goal_id="" if goal_id is None else str(goal_id),
            joint_names=tuple(str(n) for n in names) if isinstance(names, list) else (),
            received=float(received),
        )


class ControllerBus(Protocol):
    """What execution needs from the outside world (the planning server implements it in ROS)."""

    def is_available(self, controller: str) -> bool:
        """True when the controller listens to its command topic."""

    def send(self, controller: str, trajectory: JointTrajectory) -> None:
        """Send a command (raises on transport failure)."""

    def stop(self, controller: str) -> None:
        """Ask the controller to stop (hold position)."""

    def controller_state(self, controller: str, goal_id: str | None = None) -> ControllerState | None:
        """The latest state the controller reported (about goal ``goal_id`` when given), or None.

        Per-goal lookup matters: a controller reports a rejected goal once and then goes on
        reporting its current goal, so "the latest state" alone could hide the rejection."""


@dataclass
class ExecutionResult:
    """The outcome of one trajectory execution."""

    error_code: MoveItErrorCode
    controllers: list[str] = field(default_factory=list)
    duration: float = 0.0  # measured, s
    expected_duration: float = 0.0
    allowed_duration: float | None = None

    @property
    def success(self) -> bool:
        return bool(self.error_code)

    @property
    def message(self) -> str:
        return self.error_code.message

    def __bool__(self) -> bool:
        return self.success

    def to_dict(self) -> dict[str, Any]:
        return {
            "error_code": self.error_code.to_dict(),
            "controllers": list(self.controllers),
            "duration": self.duration,
            "expected_duration": self.expected_duration,
            "allowed_duration": self.allowed_duration,
        }


def _code(val: int, message: str) -> MoveItErrorCode:
    return MoveItErrorCode(val, message, SOURCE)


class ExecutionMonitor:
    """Decides the outcome of a running execution from controller states, joint states and time.

    Pure bookkeeping, no threads and no clock of its own: the caller feeds it and asks ``poll``.
    A controller state counts for this execution only if it names the goal id sent with the
    command (the command's frame_id); for commands sent without an id, only if its goal_id differs
    from the one the controller reported before sending. Either way a stale "succeeded" from the
    previous goal is never mistaken for this one's.
    """

    def __init__(
        self,
        commands: Sequence[tuple[ControllerInfo, JointTrajectory]],
        settings: ExecutionSettings,
        started: float,
        baseline: Mapping[str, ControllerState | None],
    ) -> None:
        self.commands = list(commands)
        self.settings = settings
        self.started = started
        self.duration = max((trajectory_duration(t) for _, t in commands), default=0.0)
        self.deadline = (
            started + settings.allowed_duration(self.duration) if settings.execution_duration_monitoring else math.inf
        )
        self._baseline = {name: (state.goal_id if state is not None else None) for name, state in baseline.items()}
        self._baseline_received = {name: (state.received if state is not None else -math.inf)
                                   for name, state in baseline.items()}
        self._expected = {c.name: t.frame_id for c, t in commands}
        self._latest: dict[str, ControllerState] = {}
        self._heard: dict[str, float] = {}  # when each controller last reported anything
        self._succeeded: set[str] = set()
        self._stop_requested = False
        self._goal: dict[str, float] = {}
        for _, trajectory in commands:
            self._goal.update(zip(trajectory.joint_names, trajectory.points[-1].positions))

    @property
    def controller_names(self) -> list[str]:
        return [c.name for c, _ in self.commands]

    def expected_goal(self, controller: str) -> str | None:
        """The goal id the command to ``controller`` carries (None if sent without one)."""
        return self._expected.get(controller) or None

    def belongs_to_us(self, controller: str, state: ControllerState) -> bool:
        """Whether a state reports on the goal this execution sent."""
        expected = self._expected.get(controller)
        if expected:
            return state.goal_id == expected
        baseline = self._baseline.get(controller)
        if state.received < self._baseline_received.get(controller, -math.inf):
            return False
        if state.received <= self.started:
            return False
        if baseline is None:
            return True
        return state.goal_id != baseline

    def update(self, controller: str, state: ControllerState | None) -> None:
        if state is None or not self.belongs_to_us(controller, state):
            return
        self._latest[controller] = state
        if state.status == TERMINAL_SUCCESS:
            self._succeeded.add(controller)

    def heard(self, controller: str, received: float) -> None:
        """The controller reported (any state, any goal) at ``received``: it is alive."""
        self._heard[controller] = max(received, self._heard.get(controller, -math.inf))

    def request_stop(self) -> None:
        self._stop_requested = True

    def _lost(self, now: float, positions: Mapping[str, float] | None) -> MoveItErrorCode | None:
        """CONTROL_FAILED for a controller that stopped reporting while its goal runs: it is
        declared lost after ``joint_state_timeout`` of silence, not at the duration deadline."""
        timeout = self.settings.joint_state_timeout
        for name in self.controller_names:
            if name in self._succeeded:
                continue
            silence = now - max(self._heard.get(name, -math.inf), self.started)
            if silence > timeout:
                joints = ("and /joint_states stopped too" if positions is None
                          else "while /joint_states still arrive")
                return _code(MoveItErrorCode.CONTROL_FAILED,
                             f"controller '{name}' stopped reporting: no state for {silence:.2f} s (state timeout "
                             f"{timeout:g} s, the joint_state_timeout) {joints}; is its process still running?")
        return None

    def goal_deviation(self, positions: Mapping[str, float]) -> tuple[str, float] | None:
        """(joint, deviation) of the joint farthest from the last point; None if a joint is unknown."""
        worst = ("", 0.0)
        for name, target in self._goal.items():
            if name not in positions:
                return None
            deviation = abs(float(positions[name]) - target)
            if deviation > worst[1]:
                worst = (name, deviation)
        return worst

    def poll(self, now: float, positions: Mapping[str, float] | None) -> MoveItErrorCode | None:
        """The outcome once it is decided, else None. ``positions``: current joint states (None if stale)."""
        if self._stop_requested:
            return _code(MoveItErrorCode.PREEMPTED, "execution stopped on request")
        for name in self.controller_names:
            state = self._latest.get(name)
            if state is None:
                continue
            if state.status in TERMINAL_FAILURE:
                detail = f": {state.message}" if state.message else ""
                return _code(MoveItErrorCode.CONTROL_FAILED, f"controller '{name}' {state.status} the trajectory{detail}")
            if state.status in TERMINAL_INTERRUPTED:
                detail = f": {state.message}" if state.message else ""
                return _code(MoveItErrorCode.CONTROL_FAILED,
                             f"controller '{name}' was {state.status} by something else than this execution{detail}")
        lost = self._lost(now, positions)
        if lost is not None:
            return lost
        all_done = len(self._succeeded) == len(self.commands)
        if all_done:
            tolerance = self.settings.goal_tolerance
            if tolerance <= 0:
                return _code(MoveItErrorCode.SUCCESS, self._success_message(now))
            deviation = self.goal_deviation(positions) if positions is not None else None
            if deviation is not None and deviation[1] <= tolerance:
                return _code(MoveItErrorCode.SUCCESS, self._success_message(now))
        if now > self.deadline:
            return self._timeout(now, positions, all_done)
        return None

    def _success_message(self, now: float) -> str:
        return (f"trajectory of {self.duration:.3f} s executed in {now - self.started:.3f} s by "
                f"{', '.join(self.controller_names)}")

    def _timeout(self, now: float, positions: Mapping[str, float] | None, all_done: bool) -> MoveItErrorCode:
        s = self.settings
        limit = (f"{self.deadline - self.started:.3f} s (duration {self.duration:.3f} s x "
                 f"{s.allowed_execution_duration_scaling} + {s.allowed_goal_duration_margin} s)")
        if all_done:
            if positions is None:
                return _code(MoveItErrorCode.CONTROL_FAILED,
                             f"controllers reported success but no current joint states arrived within {limit}")
            name, deviation = self.goal_deviation(positions) or ("?", math.nan)
            return _code(MoveItErrorCode.CONTROL_FAILED,
                         f"controllers reported success but joint '{name}' is still {deviation:.4f} from the goal "
                         f"(goal_tolerance {s.goal_tolerance}) after {limit}")
        pending = []
        for name in self.controller_names:
            if name in self._succeeded:
                continue
            state = self._latest.get(name)
            if state is None:
                pending.append(f"'{name}' never reported this goal")
            else:
                detail = f" ({state.message})" if state.message else ""
                pending.append(f"'{name}' is {state.status}{detail}")
        return _code(MoveItErrorCode.TIMED_OUT, f"execution exceeded the allowed {limit}: " + "; ".join(pending))


# ---------------------------------------------------------------------------- task solutions
@dataclass
class SolutionStep:
    """One sub-trajectory of a task solution with the scene changes around it."""

    name: str
    group: str = ""
    trajectory: JointTrajectory | None = None  # None (or no points): a scene-change-only step
    controllers: tuple[str, ...] | None = None
    scene_diff_before: PlanningSceneMsg | None = None
    scene_diff_after: PlanningSceneMsg | None = None

    @property
    def moves(self) -> bool:
        return self.trajectory is not None and len(self.trajectory.points) > 0


_STEP_KEYS = {"name", "group", "trajectory", "controller", "controller_names", "controllers",
              "scene_diff_before", "scene_diff_after", "scene_diff", "execution_info"}
_IGNORED_STEP_KEYS = {"info", "id", "cost", "comment", "stage_id", "stage"}


def as_scene_diff(value: Any, what: str) -> PlanningSceneMsg:
    """A planning-scene diff for applying during execution.

    Always applied as a diff (is_diff forced, so an omitted flag can never wipe the world), and the
    robot_state's joint positions are dropped: during execution the robot's real state comes from
    /joint_states, a planned state in a diff would only fight it. Attached objects are kept.
    """
    try:
        msg = value if isinstance(value, PlanningSceneMsg) else (
            PlanningSceneMsg.from_json(value) if isinstance(value, (str, bytes, bytearray)) else PlanningSceneMsg.from_dict(value)
        )
    except MessageError as exc:
        raise ExecutionError(MoveItErrorCode.INVALID_MOTION_PLAN, f"{what}: {exc}") from None
    state = RobotStateMsg(attached_collision_objects=list(msg.robot_state.attached_collision_objects), is_diff=True)
    return replace(msg, robot_state=state, is_diff=True)


def parse_task_solution(data: Any) -> list[SolutionStep]:
    """Solution steps from ``{"steps": [...]}``, ``{"sub_trajectory": [...]}`` (MTC) or a list.

    Each step: ``trajectory`` (RobotTrajectory or JointTrajectory; optional), ``group``, ``name``,
    ``controller`` / ``controller_names`` (or MTC's ``execution_info.controller_names``),
    ``scene_diff_before`` and ``scene_diff_after`` (``scene_diff`` is MTC's name for the latter).
    Everything is validated here; ExecutionError(INVALID_MOTION_PLAN) names the step and field.
    """
    bad = MoveItErrorCode.INVALID_MOTION_PLAN
    if isinstance(data, Mapping):
        raw = data.get("steps", data.get("sub_trajectory"))
        if raw is None:
            raise ExecutionError(bad, "task solution needs a 'steps' list")
    else:
        raw = data
    if not isinstance(raw, list) or not raw:
        raise ExecutionError(bad, "task solution 'steps' must be a non-empty list")
    steps = []
    for k, entry in enumerate(raw):
        where = f"step {k}"
        if not isinstance(entry, Mapping):
            raise ExecutionError(bad, f"{where} must be an object, got {type(entry).__name__}")
        unknown = sorted(set(entry) - _STEP_KEYS - _IGNORED_STEP_KEYS)
        if unknown:
            raise ExecutionError(bad, f"{where}: unknown keys {unknown}; known: {sorted(_STEP_KEYS)}")
        name = entry.get("name", "")
        if not name and isinstance(entry.get("info"), Mapping):
            name = entry["info"].get("stage_name", "")  # MTC-style sub_trajectory: the stage's name
        if not isinstance(name, str):
            raise ExecutionError(bad, f"{where}: 'name' must be a string")
        where = f"step {k}" + (f" ('{name}')" if name else "")
        trajectory, group = None, entry.get("group", "")
        if not isinstance(group, str):
            raise ExecutionError(bad, f"{where}: 'group' must be a string")
        if entry.get("trajectory") is not None:
            trajectory, traj_group = parse_trajectory(entry["trajectory"], f"{where} trajectory")
            group = group or traj_group
        controllers = _step_controllers(entry, where)
        before = entry.get("scene_diff_before")
        after = entry.get("scene_diff_after")
        if entry.get("scene_diff") is not None:
            if after is not None:
                raise ExecutionError(bad, f"{where}: give scene_diff or scene_diff_after, not both")
            after = entry["scene_diff"]
        steps.append(SolutionStep(
            name=name or f"step {k}",
            group=group,
            trajectory=trajectory,
            controllers=controllers,
            scene_diff_before=as_scene_diff(before, f"{where} scene_diff_before") if before is not None else None,
            scene_diff_after=as_scene_diff(after, f"{where} scene_diff_after") if after is not None else None,
        ))
    return steps


def _step_controllers(entry: Mapping, where: str) -> tuple[str, ...] | None:
    bad = MoveItErrorCode.INVALID_MOTION_PLAN
    value = entry.get("controller_names", entry.get("controllers", entry.get("controller")))
    info = entry.get("execution_info")
    if value is None and isinstance(info, Mapping):
        value = info.get("controller_names")
    if value is None or value == "" or value == []:
        return None
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        raise ExecutionError(bad, f"{where}: controller names must be a string or a list of strings")
    return tuple(value)


@dataclass
class SolutionResult:
    """The outcome of a task solution: which steps ran and which scene changes were applied."""

    error_code: MoveItErrorCode
    steps_completed: int = 0
    failed_step: int | None = None
    applied: list[str] = field(default_factory=list)
    step_results: list[dict[str, Any]] = field(default_factory=list)

    @property
    def success(self) -> bool:
        return bool(self.error_code)

    def __bool__(self) -> bool:
        return self.success

    def to_dict(self) -> dict[str, Any]:
        return {
            "error_code": self.error_code.to_dict(),
            "steps_completed": self.steps_completed,
            "failed_step": self.failed_step,
            "applied_scene_diffs": list(self.applied),
            "steps": list(self.step_results),
        }


# ---------------------------------------------------------------------------- the manager
class TrajectoryExecutionManager:
    """Executes trajectories and task solutions, one at a time, through a ControllerBus.

    ``current_positions()`` returns the current joint positions by name (mimic joints may be
    included) and their age in seconds, or (None, None) when no joint state arrived yet.
    ``clock`` and ``wait`` are injectable so tests can run on simulated time; by default ``wait``
    sleeps until ``notify()`` is called (a controller state or joint state arrived) or the poll
    period passes.
    """

    def __init__(
        self,
        model: RobotModel,
        controllers: Sequence[ControllerInfo],
        bus: ControllerBus,
        current_positions: Callable[[], tuple[Mapping[str, float] | None, float | None]],
        settings: ExecutionSettings | None = None,
        clock: Callable[[], float] = time.monotonic,
        wait: Callable[[float], None] | None = None,
        poll_period: float = 0.01,
        log: Callable[[str, str], None] | None = None,
    ) -> None:
        check_controllers(model, controllers)
        self.model = model
        self.controllers = list(controllers)
        self.bus = bus
        self.settings = settings or ExecutionSettings()
        self._current_positions = current_positions
        self._clock = clock
        self._wake = threading.Event()
        self._wait = wait or self._default_wait
        self._poll_period = poll_period
        self._log = log or (lambda level, text: None)
        self._busy = threading.Lock()
        self._state_lock = threading.Lock()
        self._monitor: ExecutionMonitor | None = None
        self._stop_requested = False
        self._started_at: float | None = None
        self._description = ""
        self.last_result: dict[str, Any] | None = None
        # Goal ids "<prefix><n>/<controller>": unique per manager, readable in controller logs.
        self.goal_prefix = f"exec-{uuid.uuid4().hex[:6]}-"
        self._goal_counter = 0

    # ------------------------------------------------------------------ status
    @property
    def executing(self) -> bool:
        return self._busy.locked()

    def status(self) -> dict[str, Any]:
        with self._state_lock:
            running = self._started_at is not None
            return {
                "executing": running,
                "description": self._description if running else "",
                "elapsed": (self._clock() - self._started_at) if running else 0.0,
                "last_result": self.last_result,
            }

    def notify(self) -> None:
        """New feedback arrived: wake the monitoring loop."""
        self._wake.set()

    def _default_wait(self, timeout: float) -> None:
        self._wake.wait(timeout)
        self._wake.clear()

    def stop(self) -> bool:
        """Stop the running execution (reported PREEMPTED). False when nothing was executing."""
        with self._state_lock:
            if self._started_at is None:
                return False
            self._stop_requested = True
            if self._monitor is not None:
                self._monitor.request_stop()
        self._wake.set()
        return True

    def _fresh_positions(self) -> Mapping[str, float] | None:
        positions, age = self._current_positions()
        if positions is None or age is None or age > self.settings.joint_state_timeout:
            return None
        return positions

    def _require_positions(self, joints: Iterable[str]) -> Mapping[str, float]:
        positions, age = self._current_positions()
        if positions is None:
            raise ExecutionError(MoveItErrorCode.ROBOT_STATE_STALE,
                                 "no joint state received on /joint_states yet: are the controllers running?")
        if age is None or age > self.settings.joint_state_timeout:
            raise ExecutionError(
                MoveItErrorCode.ROBOT_STATE_STALE,
                f"the last joint state is {age:.2f} s old (joint_state_timeout {self.settings.joint_state_timeout} s): "
                "is the joint state broadcaster running?",
            )
        missing = [j for j in joints if j not in positions]
        if missing:
            raise ExecutionError(MoveItErrorCode.ROBOT_STATE_STALE, f"/joint_states lacks joints {missing}")
        return positions

    # ------------------------------------------------------------------ single trajectories
    def _begin(self, description: str) -> MoveItErrorCode | None:
        if not self._busy.acquire(blocking=False):
            with self._state_lock:
                what, since = self._description, (self._clock() - self._started_at) if self._started_at else 0.0
            return _code(MoveItErrorCode.FAILURE,
                         f"refused: another execution ({what}) is in progress for {since:.2f} s; "
                         "stop it first or wait for it to finish")
        with self._state_lock:
            self._started_at = self._clock()
            self._description = description
            self._stop_requested = False
            self._monitor = None
        return None

    def _end(self, result: dict[str, Any]) -> None:
        with self._state_lock:
            self._started_at = None
            self._monitor = None
            self.last_result = result
        self._busy.release()

    def execute(self, trajectory: JointTrajectory, controllers: Sequence[str] | None = None,
                description: str = "trajectory") -> ExecutionResult:
        """Execute one trajectory (blocking). Never raises for bad input: the result says why."""
        refused = self._begin(description)
        if refused is not None:
            return ExecutionResult(refused)
        result = ExecutionResult(_code(MoveItErrorCode.FAILURE, "not executed"))
        try:
            result = self._execute(trajectory, controllers, description)
        except ExecutionError as exc:
            self._log("warning", f"execution of {description} refused: {exc.message}")
            result = ExecutionResult(exc.error_code())
        except Exception as exc:  # a bug or transport failure must still end the execution cleanly
            result = ExecutionResult(_code(MoveItErrorCode.FAILURE, f"execution failed: {type(exc).__name__}: {exc}"))
        finally:
            self._end(result.to_dict())
        return result

    def _execute(self, trajectory: JointTrajectory, controllers: Sequence[str] | None, description: str) -> ExecutionResult:
        with self._state_lock:
            if self._stop_requested:
                return ExecutionResult(_code(MoveItErrorCode.PREEMPTED, "execution stopped on request before it started"))
        prepared = prepare_trajectory(self.model, trajectory, limit_tolerance=self.settings.limit_tolerance)
        chosen = select_controllers(prepared.joint_names, self.controllers, controllers)
        needed = sorted({j for c in chosen for j in c.joints} | set(prepared.joint_names))
        current = self._require_positions(needed)
        check_start_state(prepared, current, self.settings.allowed_start_tolerance)
        if self._already_there(prepared, current):
            return ExecutionResult(_code(MoveItErrorCode.SUCCESS, "nothing to execute: the robot is already at the "
                                         "trajectory's only point"), [c.name for c in chosen])
        self._goal_counter += 1
        goal_id = f"{self.goal_prefix}{self._goal_counter}"
        commands = split_trajectory(prepared, self.controllers, current, controllers, goal_id)
        for controller, _ in commands:
            if not self.bus.is_available(controller.name):
                raise ExecutionError(
                    MoveItErrorCode.CONTROL_FAILED,
                    f"controller '{controller.name}' is not running (no action server on {controller.action_name})",
                )
        baseline = {c.name: self.bus.controller_state(c.name) for c, _ in commands}
        started = self._clock()
        monitor = ExecutionMonitor(commands, self.settings, started, baseline)
        with self._state_lock:
            if self._stop_requested:
                return ExecutionResult(_code(MoveItErrorCode.PREEMPTED, "execution stopped on request before it started"))
            self._monitor = monitor
        self._log("info", f"executing {description}: {monitor.duration:.3f} s on {', '.join(monitor.controller_names)}")
        try:
            for controller, command in commands:
                self.bus.send(controller.name, command)
        except Exception as exc:
            self._stop_all(commands)
            raise ExecutionError(MoveItErrorCode.CONTROL_FAILED, f"sending the trajectory failed: {exc}") from None
        while True:
            for controller, _ in commands:
                latest = self.bus.controller_state(controller.name)
                if latest is not None:
                    monitor.heard(controller.name, latest.received)
                monitor.update(controller.name,
                               self.bus.controller_state(controller.name, monitor.expected_goal(controller.name)))
            now = self._clock()
            outcome = monitor.poll(now, self._fresh_positions())
            if outcome is not None:
                break
            self._wait(self._poll_period)
        if not outcome:
            self._stop_all(commands)
        elapsed = self._clock() - started
        limit = monitor.deadline - started if math.isfinite(monitor.deadline) else None
        level = "info" if outcome else ("warning" if outcome.val == MoveItErrorCode.PREEMPTED else "error")
        self._log(level, f"execution of {description}: {outcome}")
        return ExecutionResult(outcome, monitor.controller_names, elapsed, monitor.duration, limit)

    def _already_there(self, trajectory: JointTrajectory, current: Mapping[str, float]) -> bool:
        """A zero-duration trajectory whose point is where the robot is (a plan from a state to
        itself) needs no controller: sending it would only risk a spurious timeout."""
        if trajectory_duration(trajectory) > 0.0 or any(
            p.positions != trajectory.points[0].positions for p in trajectory.points
        ):
            return False
        tolerance = self.settings.goal_tolerance or 1e-6
        return all(abs(v - current[n]) <= tolerance for n, v in zip(trajectory.joint_names, trajectory.points[0].positions))

    def _stop_all(self, commands: Sequence[tuple[ControllerInfo, JointTrajectory]]) -> None:
        for controller, _ in commands:
            try:
                self.bus.stop(controller.name)
            except Exception as exc:  # keep stopping the others
                self._log("error", f"stopping controller '{controller.name}' failed: {exc}")

    # ------------------------------------------------------------------ task solutions
    def check_solution(self, steps: Sequence[SolutionStep], scene: PlanningScene,
                       current: Mapping[str, float] | None = None) -> None:
        """Validate a whole solution before the first motion (ExecutionError naming the step).

        Trajectories and controllers are checked, consecutive steps must join within the start
        tolerance, and every scene diff is applied on a copy of ``scene`` with the robot placed
        where the previous steps leave it: a diff that would fail at run time fails here instead.
        """
        staged = scene.copy()
        tolerance = self.settings.allowed_start_tolerance
        expected: dict[str, float] = dict(current or {})
        for k, step in enumerate(steps):
            where = f"step {k} ('{step.name}')"
            if step.scene_diff_before is not None:
                try:
                    staged.apply_planning_scene_msg(step.scene_diff_before)
                except (SceneError, MessageError) as exc:
                    raise ExecutionError(MoveItErrorCode.INVALID_MOTION_PLAN,
                                         f"{where}: scene_diff_before cannot be applied: {exc}") from None
            if step.moves:
                try:
                    prepared = prepare_trajectory(self.model, step.trajectory,
                                                  limit_tolerance=self.settings.limit_tolerance)
                    select_controllers(prepared.joint_names, self.controllers, step.controllers)
                except ExecutionError as exc:
                    raise ExecutionError(exc.code, f"{where}: {exc.message}") from None
                if k > 0 and tolerance > 0:
                    for name, value in zip(prepared.joint_names, prepared.points[0].positions):
                        if name in expected and abs(value - expected[name]) > tolerance:
                            raise ExecutionError(
                                MoveItErrorCode.INVALID_MOTION_PLAN,
                                f"{where} starts at {name}={value:.4f} but the previous steps end at "
                                f"{expected[name]:.4f} (allowed_start_tolerance {tolerance})",
                            )
                end = dict(zip(prepared.joint_names, prepared.points[-1].positions))
                expected.update(end)
                try:
                    staged.set_current_state(end)
                except (ValueError, PlanningError) as exc:
                    raise ExecutionError(MoveItErrorCode.INVALID_MOTION_PLAN, f"{where}: end state: {exc}") from None
            if step.scene_diff_after is not None:
                try:
                    staged.apply_planning_scene_msg(step.scene_diff_after)
                except (SceneError, MessageError) as exc:
                    raise ExecutionError(MoveItErrorCode.INVALID_MOTION_PLAN,
                                         f"{where}: scene_diff_after cannot be applied: {exc}") from None

    def execute_solution(
        self,
        steps: Sequence[SolutionStep],
        apply_diff: Callable[[PlanningSceneMsg], None],
        scene: PlanningScene | None = None,
    ) -> SolutionResult:
        """Execute a task solution step by step (blocking), applying scene diffs as it goes.

        ``apply_diff`` applies a diff to the live scene (raising SceneError leaves it unchanged).
        ``scene`` (a snapshot of the live scene) enables the dry run of :meth:`check_solution`.
        """
        refused = self._begin(f"task solution of {len(steps)} steps")
        if refused is not None:
            return SolutionResult(refused)
        result = SolutionResult(_code(MoveItErrorCode.FAILURE, "not executed"))
        try:
            result = self._execute_solution(steps, apply_diff, scene)
        except ExecutionError as exc:
            result = SolutionResult(exc.error_code(), failed_step=None)
        except Exception as exc:
            result = SolutionResult(_code(MoveItErrorCode.FAILURE, f"execution failed: {type(exc).__name__}: {exc}"))
        finally:
            self._end(result.to_dict())
        return result

    def _execute_solution(self, steps: Sequence[SolutionStep], apply_diff: Callable[[PlanningSceneMsg], None],
                          scene: PlanningScene | None) -> SolutionResult:
        if scene is not None:
            positions, _ = self._current_positions()
            self.check_solution(steps, scene, positions)
        result = SolutionResult(_code(MoveItErrorCode.SUCCESS, ""))
        for k, step in enumerate(steps):
            where = f"step {k} ('{step.name}')"
            with self._state_lock:
                stopped = self._stop_requested
            if stopped:
                return self._fail(result, k, _code(MoveItErrorCode.PREEMPTED, f"execution stopped on request before {where}"))
            if step.scene_diff_before is not None:
                try:
                    apply_diff(step.scene_diff_before)
                except (SceneError, MessageError, ValueError) as exc:
                    return self._fail(result, k, _code(MoveItErrorCode.FAILURE,
                                                       f"{where}: scene_diff_before could not be applied: {exc}"))
                result.applied.append(f"{where}: scene_diff_before")
            step_record: dict[str, Any] = {"name": step.name, "group": step.group}
            if step.moves:
                try:
                    outcome = self._execute(step.trajectory, step.controllers, where)
                except ExecutionError as exc:
                    self._log("warning", f"execution of {where} refused: {exc.message}")
                    outcome = ExecutionResult(exc.error_code())
                step_record.update(outcome.to_dict())
                result.step_results.append(step_record)
                if not outcome:
                    code = outcome.error_code
                    tail = (" Its scene_diff_after was not applied." if step.scene_diff_after is not None else "")
                    return self._fail(result, k, _code(code.val, f"{where} failed: {code.message.rstrip('.')}.{tail}"))
            else:
                result.step_results.append(step_record)
            if step.scene_diff_after is not None:
                try:
                    apply_diff(step.scene_diff_after)
                except (SceneError, MessageError, ValueError) as exc:
                    return self._fail(result, k, _code(MoveItErrorCode.FAILURE,
                                                       f"{where}: scene_diff_after could not be applied: {exc}"))
                result.applied.append(f"{where}: scene_diff_after")
            result.steps_completed = k + 1
        result.error_code = _code(MoveItErrorCode.SUCCESS, f"{len(steps)} steps executed")
        return result

    def _fail(self, result: SolutionResult, step: int, code: MoveItErrorCode) -> SolutionResult:
        applied = ("Applied scene diffs: " + ", ".join(result.applied) + "." if result.applied
                   else "No scene diff was applied.")
        text = code.message.rstrip()
        result.error_code = _code(code.val, f"{text}{'' if text.endswith('.') else '.'} {applied}")
        result.failed_step = step
        self._log("warning" if code.val == MoveItErrorCode.PREEMPTED else "error",
                  f"task solution stopped at step {step}: {result.error_code.message}")
        return result
