"""MoveIt's planning_interface::PlanningContext: one motion plan request, the scene it is planned
on and the planner that solves it, made per request and dropped after it.

Why this shape: every plan shares the one RobotModel (immutable, no scratch data on it), and the
buffers a plan writes belong to the plan (its IK solvers, Cartesian step solvers and constraint
projections own their Pinocchio data) or to its thread (a compiled scene's collision data, a
RobotState's forward kinematics). So plans of several clients run at once on the same model and
the same pipeline; a context costs a few objects, not a model. ``terminate()`` from any thread
ends a running sampling planner early (PREEMPTED), as MoveIt's PlanningContext::terminate.
"""
from __future__ import annotations

import dataclasses
import threading
from typing import Any, Protocol

from .planning_interface import MotionPlanRequest, MotionPlanResponse
from ..planning_scene.planning_scene import PlanningScene

__all__ = ["PlanningContext", "Planner"]


class Planner(Protocol):
    """What a context solves with: a planning pipeline or any one planner."""

    def plan(self, scene: PlanningScene, request: MotionPlanRequest) -> MotionPlanResponse: ...


class _EitherSet:
    """Set when the context was terminated or the request's own cancel was set."""

    __slots__ = ("_own", "_theirs")

    def __init__(self, own: threading.Event, theirs: Any) -> None:
        self._own, self._theirs = own, theirs

    def is_set(self) -> bool:
        return self._own.is_set() or bool(self._theirs.is_set())


class PlanningContext:
    """One request on one scene with one planner (MoveIt's PlanningContext: solve, terminate, clear).

    The scene is used as given: callers pass their own copy (the planning server copies its
    monitored scene per request); copies share the compiled collision geometry, and each thread
    checks with buffers of its own.
    """

    def __init__(self, planner: Planner, scene: PlanningScene, request: MotionPlanRequest, name: str = "") -> None:
        if request.start_state is not None and request.start_state.model is not scene.robot_model:
            raise ValueError("the request's start state belongs to another robot model than the scene")
        self.name = name or request.pipeline_id
        self.planner = planner
        self.scene: PlanningScene | None = scene
        self._terminated = threading.Event()
        cancel = self._terminated if request.cancel is None else _EitherSet(self._terminated, request.cancel)
        self.request: MotionPlanRequest | None = dataclasses.replace(request, cancel=cancel)

    def solve(self) -> MotionPlanResponse:
        """Plan the request on the scene (once; a cleared context cannot solve)."""
        if self.scene is None or self.request is None:
            raise RuntimeError(f"planning context '{self.name}' was cleared")
        return self.planner.plan(self.scene, self.request)

    def terminate(self) -> bool:
        """Ask a running solve to stop (a sampling planner answers PREEMPTED); any thread."""
        self._terminated.set()
        return True

    def clear(self) -> None:
        """Drop the scene and the request (and with them whatever the plan kept alive)."""
        self.scene = None
        self.request = None
