"""What MoveTo and MoveRelative share: a propagating stage that plans one group's motion with a
planner (MTC's solvers), with the group, ik_frame and path_constraints properties, their
setters, and the checks of the planner at init. MTC's two stages repeat this; one base here."""
from __future__ import annotations

from typing import Any

from ...core.planning_scene.planning_scene import PlanningScene

from ..cost_terms import PathLength
from ..errors import InitStageException
from ..geometry import PoseStamped, as_pose_stamped
from ..path_constraints import check_path_constraints, declare_path_constraints
from ..properties import PropertySetter
from ..solvers import PlannerInterface
from ..stage import PropagatingEitherWay
from ..storage import BACKWARD, InterfaceState, SubTrajectory
from ..trajectories import reverse_trajectory


class PlanningStage(PropagatingEitherWay):
    """``ik_frame_description`` says what the ik frame is moved to (the property's description)."""

    #: The property that says where to move ("goal", "direction").
    _motion = ""

    def __init__(self, name: str, planner: PlannerInterface | None, ik_frame_description: str) -> None:
        super().__init__(name)
        self._planner = planner
        self.setCostTerm(PathLength())
        p = self._properties
        p.property("timeout").setDefaultValue(1.0)
        p.declare("group", type=str, description="name of planning group")
        p.declare("ik_frame", type=PoseStamped, coerce=as_pose_stamped, description=ik_frame_description)

    def _declare_path_constraints(self) -> None:
        """Declared last by the subclasses, after their own properties (MTC's order)."""
        declare_path_constraints(self._properties)

    @property
    def planner(self) -> PlannerInterface | None:
        return self._planner

    setGroup = PropertySetter("group", str)

    def setIKFrame(self, pose_or_link: Any, link: str | None = None) -> None:
        self._properties.set("ik_frame", pose_or_link if link is None else PoseStamped(link, pose_or_link))

    setPathConstraints = PropertySetter("path_constraints", Any)

    def init(self, robot_model: Any) -> None:
        errors = self._init_planner(robot_model)
        group = self._require_property("group", errors)
        motion = self._require_property(self._motion, errors)
        self._check_motion(robot_model, group, motion, errors)
        check_path_constraints(self, robot_model, errors)
        if errors:
            raise errors

    def _check_motion(self, robot_model: Any, group: Any, motion: Any, errors: InitStageException) -> None:
        """The subclass's checks of the group and the motion at init, reported in ``errors``."""

    def _init_planner(self, robot_model: Any) -> InitStageException:
        """The base stage's init and the planner's, their errors collected (not raised)."""
        errors = InitStageException().collect(super().init, robot_model)
        if not isinstance(self._planner, PlannerInterface):
            errors.push_back(self, f"needs a planner (a PlannerInterface), got {type(self._planner).__name__}")
        else:
            try:
                self._planner.init(robot_model)
            except (ValueError, TypeError) as exc:
                errors.push_back(self, f"planner {type(self._planner).__name__}: {exc}")
        return errors

    def _start_propagation(self, state: InterfaceState) -> tuple[PlanningScene, SubTrajectory | None]:
        """The scene to plan in (a diff of the state's), and the failure to report when the group
        or the motion is not usable (else None)."""
        scene = state.scene.diff()
        group = self._properties["group"]
        if group is None or not scene.robot_model.has_group(group):
            return scene, SubTrajectory.failure(f"invalid joint model group: {group}")
        if self._properties[self._motion] is None:
            return scene, SubTrajectory.failure(f"undefined {self._motion}")
        return scene, None

    def _planning_extras(self) -> dict[str, Any]:
        """The keyword arguments of the planner's questions: the path constraints, when there are any."""
        constraints = self._properties["path_constraints"]
        return {"path_constraints": constraints} if constraints else {}

    def _finish_propagation(self, state: InterfaceState, scene: PlanningScene, solution: SubTrajectory,
                            trajectory: Any, direction: int, success: bool, empty_comment: str,
                            failure_comment: str) -> tuple[bool, PlanningScene, SubTrajectory]:
        """The propagation's answer from the planned group ``trajectory``: ``scene`` moved to its
        end and the solution carrying it (reversed when planning backward), failed with
        ``empty_comment`` when there is no trajectory, with ``failure_comment`` when not ``success``."""
        if trajectory is None or len(trajectory) == 0:
            solution.comment = empty_comment
            return False, scene, solution
        positions = state.scene.current_state.positions.copy()
        positions[scene.robot_model.group(solution.group).variable_indices] = trajectory.positions[-1]
        scene.set_current_state(positions)
        solution.trajectory = reverse_trajectory(trajectory) if direction == BACKWARD else trajectory
        if not success:
            solution.comment = failure_comment
            return False, scene, solution
        return True, scene, solution
