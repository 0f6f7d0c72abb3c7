"""``moveit.task_constructor.stages``: the stages of mycobot_planning.task.stages, with FixedState
also taking moveit_py's PlanningScene (``moveit.core.planning_scene``), as MTC's does."""
from __future__ import annotations

from typing import Any

from mycobot_planning.task import stages as _stages
from mycobot_planning.task.stages import *  # noqa: F401,F403 - MTC's namespace, re-exported as a whole
from mycobot_planning.task.stages import __all__  # noqa: F401

from ..core.planning_scene import core_scene


class FixedState(_stages.FixedState):
    __doc__ = _stages.FixedState.__doc__

    def setState(self, scene: Any) -> None:
        super().setState(core_scene(scene))
