"""The controllers MoveIt may send trajectories to (moveit_simple_controller_manager's role):
which controller owns which joints, how a trajectory is split among them, and the small
interface (ControllerBus) behind which the nodes talk to real controllers."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Protocol, Sequence


from interfaces_py.msgs import JointTrajectory, JointTrajectoryPoint, MoveItErrorCode

from ...paths import config_file
from .controllers_config import load_controllers_config, read_controllers_source
from ..robot_model.robot_model import RobotModel
from .settings import ExecutionError

# Controller status values (the mock controllers' /<name>/state "status").
TERMINAL_SUCCESS = "succeeded"
TERMINAL_FAILURE = ("aborted", "failed")
TERMINAL_INTERRUPTED = ("preempted", "stopped")
#: MoveIt's controller handle types (moveit_controllers.yaml ``type``)
FOLLOW_JOINT_TRAJECTORY = "FollowJointTrajectory"
GRIPPER_COMMAND = "GripperCommand"
ACTION_NAMESPACES = {FOLLOW_JOINT_TRAJECTORY: "follow_joint_trajectory", GRIPPER_COMMAND: "gripper_cmd"}


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

