"""``moveit.core.robot_state``: moveit_py's RobotState over the core RobotState.

A RobotState made from a robot model owns its state; the one a planning scene hands out
(``scene.current_state``) is that scene's own state, so changing it changes the scene, as in
moveit_py. Forward kinematics is computed on demand, so ``update()`` has nothing to do and
``dirty`` is always False. Velocities, accelerations and efforts are kept per variable (the core
state holds positions only).
"""
from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np
from geometry_msgs.msg import Pose as PoseMsg
from moveit_msgs.msg import RobotState as RobotStateMsg

from interfaces_py.msgs import Pose
from interfaces_py.pose_conversion import PoseError, pose_matrix
from interfaces_py.ros_conversions import pose_to_msg
from mycobot_planning.core.errors import PlanningError
from mycobot_planning.core.kinematics.ik_solver import IKSolver
from mycobot_planning.core.robot_state.robot_state import RobotState as CoreRobotState

from .robot_model import JointModelGroup, RobotModel, core_model, robot_model, unwrap

__all__ = ["RobotState", "core_state", "random_generator", "robotStateToRobotStateMsg", "seed"]

_UPDATE_KINDS = ("all", "links_only", "collisions_only")


def _group_name(group: Any) -> str:
    return group.name if isinstance(group, JointModelGroup) else str(group)


def _per_variable(attribute: str, what: str) -> property:
    """The property ``what``: the per-variable array ``attribute`` of a RobotState (velocities,
    accelerations, efforts) read and written as a dict by variable name."""

    def get(self: RobotState) -> dict[str, float]:
        return self._named(getattr(self, attribute))

    def set_(self: RobotState, values: Mapping[str, float]) -> None:
        self._set_named(getattr(self, attribute), values, what)

    return property(get, set_, doc=f"{what} by variable name")


class RobotState:
    """moveit_py's RobotState: ``RobotState(robot_model)``."""

    def __init__(self, robot_model: Any) -> None:
        self._state = CoreRobotState(core_model(robot_model))
        self._init_derivatives()

    def _init_derivatives(self) -> None:
        n = len(self._state.model.variable_names)
        self._velocities = np.zeros(n)
        self._accelerations = np.zeros(n)
        self._efforts = np.zeros(n)

    @classmethod
    def _wrap(cls, state: CoreRobotState) -> "RobotState":
        """A view of ``state`` itself (a scene's current state)."""
        wrapper = cls.__new__(cls)
        wrapper._state = state
        wrapper._init_derivatives()
        return wrapper

    # ------------------------------------------------------------------ model and copies
    @property
    def robot_model(self) -> RobotModel:
        return robot_model(self._state.model)

    @property
    def dirty(self) -> bool:
        return False

    def __copy__(self) -> "RobotState":
        clone = RobotState._wrap(self._state.copy())
        clone._velocities, clone._accelerations, clone._efforts = (
            self._velocities.copy(), self._accelerations.copy(), self._efforts.copy())
        return clone

    def __deepcopy__(self, memo: dict) -> "RobotState":
        return self.__copy__()

    def update(self, force: bool = False, type: str = "all") -> None:  # noqa: A002 - moveit_py's keyword
        """Nothing to do: transforms are computed when asked for."""
        if type not in _UPDATE_KINDS:
            raise ValueError(f"Invalid category '{type}'; expected one of {list(_UPDATE_KINDS)}")

    # ------------------------------------------------------------------ variables by name
    def _named(self, values: np.ndarray) -> dict[str, float]:
        return {n: float(v) for n, v in zip(self._state.model.variable_names, values)}

    def _set_named(self, target: np.ndarray, values: Mapping[str, float], what: str) -> None:
        model = self._state.model
        for name, value in values.items():
            if name not in model.variable_names:
                raise KeyError(f"{what}: '{name}' is not a variable of robot '{model.name}'")
            target[model.variable_index(name)] = float(value)

    @property
    def joint_positions(self) -> dict[str, float]:
        return self._named(self._state.positions)

    @joint_positions.setter
    def joint_positions(self, values: Mapping[str, float]) -> None:
        model = self._state.model
        unknown = [n for n in values if n not in model.variable_names]
        if unknown:
            raise KeyError(f"joint_positions: {unknown} are not variables of robot '{model.name}'")
        self._state.set_joint_positions(dict(values))

    joint_velocities = _per_variable("_velocities", "joint_velocities")
    joint_accelerations = _per_variable("_accelerations", "joint_accelerations")
    joint_efforts = _per_variable("_efforts", "joint_efforts")

    # ------------------------------------------------------------------ groups
    def get_joint_group_positions(self, joint_model_group_name: str) -> np.ndarray:
        return self._state.group_positions(joint_model_group_name)

    def set_joint_group_positions(self, joint_model_group_name: str, position_values: Sequence[float]) -> None:
        self._state.set_group_positions(joint_model_group_name, np.asarray(position_values, dtype=float))

    set_joint_group_active_positions = set_joint_group_positions

    def _group_values(self, array: np.ndarray, group: str) -> np.ndarray:
        return array[self._state.model.group(group).variable_indices].copy()

    def _set_group_values(self, array: np.ndarray, group: str, values: Sequence[float]) -> None:
        jmg = self._state.model.group(group)
        v = np.asarray(values, dtype=float).reshape(-1)
        if v.shape[0] != jmg.variable_count:
            raise ValueError(f"group '{group}' has {jmg.variable_count} variables, got {v.shape[0]} values")
        array[jmg.variable_indices] = v

    def get_joint_group_velocities(self, joint_model_group_name: str) -> np.ndarray:
        return self._group_values(self._velocities, joint_model_group_name)

    def set_joint_group_velocities(self, joint_model_group_name: str, velocity_values: Sequence[float]) -> None:
        self._set_group_values(self._velocities, joint_model_group_name, velocity_values)

    def get_joint_group_accelerations(self, joint_model_group_name: str) -> np.ndarray:
        return self._group_values(self._accelerations, joint_model_group_name)

    def set_joint_group_accelerations(self, joint_model_group_name: str, acceleration_values: Sequence[float]) -> None:
        self._set_group_values(self._accelerations, joint_model_group_name, acceleration_values)

    # ------------------------------------------------------------------ default and random values
    def set_to_default_values(self, joint_model_group: Any = None, name: str | None = None) -> bool:
        """All joints to 0 (clipped into the limits); with a group and a name, the SRDF state."""
        if joint_model_group is None:
            self._state.set_positions(self._state.model.default_positions())
            return True
        group = _group_name(joint_model_group)
        model = self._state.model
        if name is None or name not in model.named_state_names(group):
            return False
        self._state.set_named(name, group)
        return True

    def set_to_random_positions(self, joint_model_group: Any = None) -> None:
        """Every variable (or the group's) uniformly within its limits (continuous joints: ±pi)."""
        model = self._state.model
        indices = (np.arange(len(model.variable_names)) if joint_model_group is None
                   else model.group(_group_name(joint_model_group)).variable_indices)
        low = np.maximum(model.lower_limits[indices], -np.pi)
        high = np.minimum(model.upper_limits[indices], np.pi)
        positions = np.array(self._state.positions, dtype=float)
        positions[indices] = random_generator().uniform(low, high)
        self._state.set_positions(positions)

    # ------------------------------------------------------------------ kinematics
    def get_global_link_transform(self, link_name: str) -> np.ndarray:
        return self._state.frame_pose(link_name)

    def get_frame_transform(self, frame_id: str) -> np.ndarray:
        """The frame's pose in the model frame (identity for a frame the robot does not have)."""
        try:
            return self._state.frame_pose(frame_id)
        except PlanningError:
            return np.eye(4)

    def get_pose(self, link_name: str) -> PoseMsg:
        return pose_to_msg(Pose.from_matrix(self._state.frame_pose(link_name)))

    def get_jacobian(self, joint_model_group_name: str, *args: Any, **kwargs: Any) -> np.ndarray:
        """``(group, reference_point_position)`` at the group's tip link, or ``(group, link_name,
        reference_point_position, use_quaternion_representation=False)``: 6 x n, linear rows
        first, at the reference point (given in the link's frame), in model-frame axes."""
        if args and isinstance(args[0], str):
            link, rest = args[0], args[1:]
        elif "link_name" in kwargs:
            link, rest = kwargs.pop("link_name"), args
        else:
            link, rest = self._state.model.group(joint_model_group_name).tip_link, args
        point = np.asarray(rest[0] if rest else kwargs.get("reference_point_position", np.zeros(3)),
                           dtype=float).reshape(3)
        if kwargs.get("use_quaternion_representation") or (len(rest) > 1 and rest[1]):
            raise ValueError("use_quaternion_representation is not supported: the Jacobian is given with angular "
                             "velocity rows")
        jacobian = self._state.jacobian(link, joint_model_group_name)
        offset = self._state.frame_pose(link)[:3, :3] @ point
        # a point fixed on the link moves with v + w x r
        jacobian[:3] -= np.cross(offset, jacobian[3:].T).T
        return jacobian

    def set_from_ik(self, joint_model_group_name: str, geometry_pose: Any, tip_name: str,
                    timeout: float = 0.0) -> bool:
        """Solve IK for ``tip_name`` at ``geometry_pose`` (model frame), seeded from this state;
        True and the state changed when a solution was found (0 timeout: kinematics.yaml's)."""
        try:
            target = pose_matrix(geometry_pose, "geometry_pose")
        except PoseError as exc:
            raise ValueError(str(exc)) from None
        solver = IKSolver(self._state.model, joint_model_group_name, tip_name)
        solutions = solver.solve(target, seed=self._state, timeout=timeout if timeout > 0 else None,
                                 rng=random_generator())
        if not solutions:
            return False
        self._state.set_positions(solutions[0].positions)
        return True

    def clear_attached_bodies(self) -> None:
        """Nothing to clear: attached objects belong to the planning scene here."""

    # ------------------------------------------------------------------ text
    @property
    def state_tree(self) -> str:
        return "\n".join(f"{n}: {v:.6f}" for n, v in self.joint_positions.items())

    @property
    def state_info(self) -> str:
        return f"Robot State @{id(self):#x}\n  * Position: " + " ".join(f"{v:g}" for v in self._state.positions)

    def __repr__(self) -> str:
        return f"RobotState({self.joint_positions})"


_RNG: np.random.Generator | None = None


def random_generator() -> np.random.Generator:
    """The generator set_to_random_positions and IK restarts draw from (one per process, seeded
    from the OS as MoveIt's is; :func:`seed` makes a run repeatable)."""
    global _RNG
    if _RNG is None:
        _RNG = np.random.default_rng()
    return _RNG


def seed(value: int | None) -> None:
    """Restart the random generator from ``value`` (None: fresh OS entropy)."""
    global _RNG
    _RNG = np.random.default_rng(value)


def core_state(state: Any) -> CoreRobotState:
    """The core RobotState of a moveit_py RobotState (or of a core one: itself)."""
    return unwrap(state, RobotState, CoreRobotState, "_state")


def robotStateToRobotStateMsg(state: Any, copy_attached_bodies: bool = True) -> RobotStateMsg:  # noqa: N802
    """A moveit_msgs/RobotState with every variable's position (attached bodies: none here)."""
    core = core_state(state)
    msg = RobotStateMsg()
    msg.joint_state.name = list(core.model.variable_names)
    msg.joint_state.position = [float(v) for v in core.positions]
    if isinstance(state, RobotState):
        msg.joint_state.velocity = [float(v) for v in state._velocities]
    return msg

