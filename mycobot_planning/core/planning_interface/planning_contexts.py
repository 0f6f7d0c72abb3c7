"""Planning contexts: a robot model and a pipeline for each plan that runs at the same time.

Why this exists: one RobotModel's Pinocchio data, its compiled collision data and its IK solvers'
buffers are shared by everything that plans on it, so two plans on one model in two threads would
corrupt each other's forward kinematics. move_group answers one client while another client's
long plan runs; so do we, by giving each concurrent plan a context of its own. The first context
is the server's own model and pipeline (no copying: the common case of one plan at a time costs
nothing); further ones are built on demand by a factory, kept for reuse, up to a bound, and get
the request's scene re-created on their model from its PlanningScene message.
"""
from __future__ import annotations

import dataclasses
import threading
from contextlib import contextmanager
from typing import Any, Callable, Iterator

from .planning_interface import MotionPlanRequest
from ..planning_scene.planning_scene import PlanningScene
from ..robot_model.robot_model import RobotModel

__all__ = ["PlanningContext", "PlanningContextPool", "MAX_CONCURRENT_PLANS"]

#: Plans that run at once; more wait for a free context. Each extra context holds one more robot
#: model (a few MB for the myCobot); on a 2-core machine more than three gain nothing.
MAX_CONCURRENT_PLANS = 3

ContextFactory = Callable[[], tuple[RobotModel, Any]]


@dataclasses.dataclass
class PlanningContext:
    """One model + pipeline, used by one plan at a time."""

    model: RobotModel
    pipeline: Any
    primary: bool = False

    def scene_for(self, scene: PlanningScene) -> PlanningScene:
        """``scene`` on this context's model (itself for the primary context)."""
        if self.primary:
            return scene
        rebuilt = PlanningScene(self.model)
        rebuilt.apply_planning_scene_msg(scene.get_planning_scene_msg())
        return rebuilt

    def request_for(self, request: MotionPlanRequest, scene: PlanningScene) -> MotionPlanRequest:
        """``request`` with its start state on this context's model (taken from ``scene``)."""
        if self.primary or request.start_state is None:
            return request
        return dataclasses.replace(request, start_state=scene.current_state.copy())


class PlanningContextPool:
    """Hands out free contexts; builds another one (up to ``max_contexts``) when all are busy.

    Without a factory there is only the primary context and plans run one after the other.
    """

    def __init__(self, model: RobotModel, pipeline: Any, factory: ContextFactory | None = None,
                 max_contexts: int = MAX_CONCURRENT_PLANS) -> None:
        self._factory = factory
        self._max = max(1, int(max_contexts)) if factory is not None else 1
        self._contexts = [PlanningContext(model, pipeline, primary=True)]
        self._free = [self._contexts[0]]
        self._building = 0
        self._cond = threading.Condition()

    @property
    def size(self) -> int:
        with self._cond:
            return len(self._contexts)

    def prepare(self) -> None:
        """Build one spare context now (from a background thread at start-up), so the first
        concurrent plan does not wait for a model to load."""
        with self._cond:
            if self._factory is None or len(self._contexts) + self._building >= self._max or len(self._free) > 1:
                return
            self._building += 1
        self._add(self._build())

    def _build(self) -> PlanningContext | None:
        try:
            model, pipeline = self._factory()  # type: ignore[misc]
            return PlanningContext(model, pipeline)
        except Exception:  # the primary context still works; the caller then waits for it
            return None

    def _add(self, context: PlanningContext | None) -> None:
        with self._cond:
            self._building -= 1
            if context is not None:
                primary = self._contexts[0].pipeline
                if hasattr(primary, "ompl") and hasattr(context.pipeline, "ompl"):
                    context.pipeline.ompl.config = primary.ompl.config  # planner parameters set since start-up
                self._contexts.append(context)
                self._free.append(context)
            else:
                self._max = len(self._contexts)  # the factory fails: stop trying
            self._cond.notify_all()

    def pipelines(self) -> list[Any]:
        """Every context's pipeline (to change a setting in all of them)."""
        with self._cond:
            return [c.pipeline for c in self._contexts]

    @contextmanager
    def acquire(self) -> Iterator[PlanningContext]:
        """A context for the duration of one plan (waits while all are busy and no more may be built)."""
        context = None
        while context is None:
            build = False
            with self._cond:
                if self._free:
                    context = self._free.pop(0)
                elif self._factory is not None and len(self._contexts) + self._building < self._max:
                    self._building += 1
                    build = True
                else:
                    self._cond.wait()
            if build:
                self._add(self._build())
        try:
            yield context
        finally:
            with self._cond:
                self._free.append(context)
                self._free.sort(key=lambda c: not c.primary)  # the primary first: no scene copy needed
                self._cond.notify_all()
