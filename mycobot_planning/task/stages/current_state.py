"""CurrentState: a task starts from the scene the robot is in.

In a plain script that is the scene given to the Task (or the stage's ``setScene``); in a node
the Task's scene provider fetches it from the planning_server, waiting the stage's ``timeout``
(3 s by default, as in MTC).
"""
from __future__ import annotations

from ...core.errors import PlanningError
from ...core.planning_scene.planning_scene import PlanningScene
from ..errors import InitStageException, TaskError
from ..stage import Generator
from ..storage import InterfaceState, SubTrajectory


class CurrentState(Generator):
    def __init__(self, name: str = "current state", scene: PlanningScene | None = None) -> None:
        super().__init__(name)
        self._properties.property("timeout").setValue(3.0)
        self._properties.property("timeout").setDescription("max time to wait for the current scene (s)")
        self._scene = None
        self._ran = False
        if scene is not None:
            self.setScene(scene)

    def setScene(self, scene: PlanningScene | None) -> None:
        """Use this scene instead of the task's current scene."""
        if scene is not None and not isinstance(scene, PlanningScene):
            raise TaskError(f"stage '{self._name}': expected a PlanningScene, got {type(scene).__name__}")
        self._scene = scene

    def reset(self) -> None:
        super().reset()
        self._ran = False

    def init(self, robot_model) -> None:
        super().init(robot_model)
        if self._scene is not None and self._scene.robot_model is not robot_model:
            raise InitStageException(self, f"the given scene is for robot '{self._scene.robot_model.name}', "
                                           f"the task's robot is '{robot_model.name}'")
        self._ran = False

    def canCompute(self) -> bool:
        return not self._ran

    def compute(self) -> None:
        self._ran = True
        try:
            if self._scene is not None:
                scene = self._scene.copy()
            else:
                scene = self._context.current_scene(self.timeout_or(3.0))  # type: ignore[union-attr]
        except (PlanningError, ValueError, TimeoutError, OSError) as exc:
            failed = PlanningScene(self._context.robot_model)  # type: ignore[union-attr]
            self.spawn(InterfaceState(failed), SubTrajectory.failure(f"failed to acquire current PlanningScene: {exc}"))
            return
        self.spawn(InterfaceState(scene), SubTrajectory(cost=0.0))

