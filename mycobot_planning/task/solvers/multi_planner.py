"""MTC's MultiPlanner: the first of several solvers that succeeds."""
from __future__ import annotations

import time
from typing import TYPE_CHECKING, Callable


from ..errors import TaskError
from .planner_interface import PlannerInterface, PlanResult

if TYPE_CHECKING:  # pragma: no cover
    from ...core.robot_model.robot_model import RobotModel


class MultiPlanner(PlannerInterface):
    """Tries its planners in order and answers with the first success (MTC's MultiPlanner), each
    getting the time the ones before it left; a failure says why every planner failed."""

    def __init__(self, *planners: PlannerInterface) -> None:
        super().__init__()
        object.__setattr__(self, "_planners", [])
        self.add(*planners)

    def add(self, *planners: PlannerInterface) -> None:
        for planner in planners:
            if not isinstance(planner, PlannerInterface):
                raise TaskError(f"MultiPlanner.add expects planners, got {type(planner).__name__}")
            self._planners.append(planner)

    def clear(self) -> None:
        self._planners.clear()

    def __len__(self) -> int:
        return len(self._planners)

    def __getitem__(self, index: int) -> PlannerInterface:
        return self._planners[index]

    def __iter__(self):
        return iter(self._planners)

    def init(self, robot_model: "RobotModel") -> None:
        super().init(robot_model)
        if not self._planners:
            raise ValueError("MultiPlanner has no planners: add() at least one")
        for planner in self._planners:
            planner.init(robot_model)

    def _first_success(self, timeout: float, attempt: Callable[[PlannerInterface, float], PlanResult]) -> PlanResult:
        deadline = time.monotonic() + self._timeout(timeout)
        failures: list[str] = []
        last: PlanResult | None = None
        for planner in self._planners:
            remaining = deadline - time.monotonic()
            if remaining <= 0.0:
                failures.append(f"{planner.planner_id}: no time left")
                break
            last = attempt(planner, remaining)
            if last:
                return last
            failures.append(f"{planner.planner_id}: {last.message}")
        return PlanResult(False, last.trajectory if last else None, "; ".join(failures), self.planner_id)

    def plan(self, from_scene, to_scene, group, timeout, context=None, path_constraints=None):
        extra = {"path_constraints": path_constraints} if path_constraints is not None else {}
        return self._first_success(timeout, lambda p, t: p.plan(from_scene, to_scene, group, t, context, **extra))

    def plan_pose(self, from_scene, link, offset, target, group, timeout, context=None, path_constraints=None):
        extra = {"path_constraints": path_constraints} if path_constraints is not None else {}
        return self._first_success(timeout, lambda p, t: p.plan_pose(from_scene, link, offset, target, group, t,
                                                                      context, **extra))
