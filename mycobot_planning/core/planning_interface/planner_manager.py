"""MoveIt's planning_interface::PlannerManager: what every planner plugin offers the pipeline,
and the registry the pipeline, move_group's planner queries and the parameter checks read.

A planner is one class that satisfies ``PlannerManager`` plus one registration: built-in ones
call ``register_planner`` (core.planners.registry); third-party ones name a factory in the
setuptools entry-point group ``mycobot_planning.planners`` (docs/core.md, "Adding a planner").
The factory receives the ``PlannerSettings`` (the configuration files of the robot) and returns
the manager; the pipeline builds each manager once.
"""
from __future__ import annotations

import threading
from dataclasses import dataclass
from importlib.metadata import entry_points
from pathlib import Path
from typing import Callable, Mapping, Protocol, Sequence, runtime_checkable

from .planning_interface import MotionPlanRequest, MotionPlanResponse
from ..planning_scene.planning_scene import PlanningScene

__all__ = ["ENTRY_POINT_GROUP", "PlannerFactory", "PlannerManager", "PlannerSettings", "PlannerRegistryError",
           "planner_factories", "register_planner", "unregister_planner"]

#: setuptools entry-point group third-party planners register in: ``name = module:factory``.
ENTRY_POINT_GROUP = "mycobot_planning.planners"


@dataclass(frozen=True)
class PlannerSettings:
    """The robot's planner configuration files (None: the package's defaults)."""

    ompl_config: str | Path | Mapping | None = None
    cartesian_limits: str | Path | Mapping | None = None


@runtime_checkable
class PlannerManager(Protocol):
    """One planning pipeline (MoveIt: a planner plugin behind a pipeline id)."""

    #: the request's pipeline_id that selects this planner ("ompl", "pilz_industrial_motion_planner")
    pipeline_id: str
    #: human-readable name (query_planner_interface's ``name``)
    description: str
    #: True when the planner keeps to path constraints while it searches; False: the pipeline
    #: checks its path afterwards and refuses it if it leaves them
    enforces_path_constraints: bool

    # Optional: ``independent_attempts = True`` says that the request's attempts do not depend on
    # each other (MotionPlanRequest.first_attempt numbers them; the shortest path is the answer,
    # ties to the earlier attempt), so PlanningWorkers may plan them in several processes.

    def planner_ids(self, group: str = "") -> list[str]:
        """The planner ids a request may name (for ``group``; "": for any group)."""

    def planner_id_problem(self, planner_id: str, groups: Sequence[str] = ()) -> str | None:
        """None when ``planner_id`` ("" meaning the default) names a planner of this pipeline for
        one of ``groups`` (any group when empty); else why not."""

    def can_service_request(self, request: MotionPlanRequest) -> bool:
        """Whether this planner can plan ``request`` (its group, planner id and goal kind)."""

    def plan(self, scene: PlanningScene, request: MotionPlanRequest) -> MotionPlanResponse:
        """Plan; never raises for bad input (the response's error code says what was wrong)."""

    def planner_params(self, planner_id: str, group: str = "") -> dict[str, str]:
        """The parameters of one planner configuration as strings ({} when there is none)."""

    def set_planner_params(self, planner_id: str, params: Mapping[str, str], replace: bool = False) -> str | None:
        """Change one planner configuration; None when applied, else why not (nothing changed)."""


PlannerFactory = Callable[[PlannerSettings], PlannerManager]


class PlannerRegistryError(ValueError):
    """A planner registration is unusable (a duplicate id, an entry point that does not load)."""


_FACTORIES: dict[str, PlannerFactory] = {}
_LOCK = threading.Lock()
_ENTRY_POINTS_LOADED = False


def register_planner(pipeline_id: str, factory: PlannerFactory, replace: bool = False) -> None:
    """Make ``pipeline_id`` available to every PlanningPipeline built afterwards."""
    with _LOCK:
        if pipeline_id in _FACTORIES and not replace and _FACTORIES[pipeline_id] is not factory:
            raise PlannerRegistryError(f"planning pipeline '{pipeline_id}' is registered already")
        _FACTORIES[pipeline_id] = factory


def unregister_planner(pipeline_id: str) -> None:
    """Forget ``pipeline_id`` (pipelines built already keep their planner)."""
    with _LOCK:
        _FACTORIES.pop(pipeline_id, None)


def planner_factories() -> dict[str, PlannerFactory]:
    """Every registered pipeline id with its factory: the built-ins first, then the entry points
    of ``ENTRY_POINT_GROUP`` (read once per process)."""
    global _ENTRY_POINTS_LOADED
    with _LOCK:
        load = not _ENTRY_POINTS_LOADED
        _ENTRY_POINTS_LOADED = True
    if load:
        for point in entry_points(group=ENTRY_POINT_GROUP):
            try:
                factory = point.load()
            except Exception as exc:  # a broken plugin must not take the built-in planners down
                raise PlannerRegistryError(f"planner entry point '{point.name} = {point.value}' of group "
                                           f"{ENTRY_POINT_GROUP} does not load: {type(exc).__name__}: {exc}") from exc
            register_planner(point.name, factory)
    with _LOCK:
        return dict(_FACTORIES)
