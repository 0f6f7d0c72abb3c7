"""What MoveTo and MoveRelative share: a propagating stage that plans one group's motion with a
planner (MTC's solvers), with the group, ik_frame and path_constraints properties, their
setters, and the checks of the planner at init. MTC's two stages repeat this; one base here."""
from __future__ import annotations

from typing import Any

from ..cost_terms import PathLength
from ..errors import InitStageException
from ..geometry import PoseStamped, as_pose_stamped
from ..path_constraints import declare_path_constraints
from ..solvers import PlannerInterface
from ..stage import PropagatingEitherWay


class PlanningStage(PropagatingEitherWay):
    """``ik_frame_description`` says what the ik frame is moved to (the property's description)."""

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

    def setGroup(self, group: str) -> None:
        self._properties.set("group", group)

    def setIKFrame(self, pose_or_link: Any, link: str | None = None) -> None:
        self._properties.set("ik_frame", pose_or_link if link is None else PoseStamped(link, pose_or_link))

    def setPathConstraints(self, path_constraints: Any) -> None:
        self._properties.set("path_constraints", path_constraints)

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
