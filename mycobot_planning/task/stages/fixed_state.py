"""FixedState: a task starts from a scene given in advance: a PlanningScene, or a planning-scene
message (interfaces_py or its dict/JSON form) turned into one for the task's robot at init."""
from __future__ import annotations

from typing import Any, Mapping

from interfaces_py.msgs import PlanningScene as PlanningSceneMsg

from ...core.errors import PlanningError
from ...core.planning_scene.planning_scene import PlanningScene
from ..cost_terms import Constant
from ..errors import InitStageException, TaskError
from ..properties import PropertySetter
from ..stage import Generator
from ..storage import InterfaceState, SubTrajectory


class FixedState(Generator):
    def __init__(self, name: str = "initial state", scene: Any = None) -> None:
        super().__init__(name)
        self._properties.declare("ignore_collisions", False, "spawn the state even if it collides", type=bool)
        self.setCostTerm(Constant(0.0))
        self._scene: PlanningScene | None = None
        self._scene_msg: Any = None
        self._ran = False
        if scene is not None:
            self.setState(scene)

    def setState(self, scene: Any) -> None:
        """A PlanningScene, or a planning-scene message (PlanningScene message, dict or JSON)."""
        if isinstance(scene, PlanningScene):
            self._scene, self._scene_msg = scene, None
        elif isinstance(scene, (PlanningSceneMsg, Mapping, str)):
            self._scene, self._scene_msg = None, scene
        else:
            raise TaskError(f"stage '{self._name}': expected a PlanningScene or a planning-scene message, "
                            f"got {type(scene).__name__}")

    setIgnoreCollisions = PropertySetter("ignore_collisions", bool)

    def reset(self) -> None:
        super().reset()
        self._ran = False

    def init(self, robot_model) -> None:
        errors = InitStageException().collect(super().init, robot_model)
        if self._scene_msg is not None:
            try:
                self._scene = PlanningScene.from_msg(robot_model, self._scene_msg)
            except (PlanningError, ValueError) as exc:
                errors.push_back(self, f"the planning-scene message cannot be applied: {exc}")
        if self._scene is None:
            if self._scene_msg is None:
                errors.push_back(self, "no state given (call setState with a PlanningScene)")
        elif self._scene.robot_model is not robot_model:
            errors.push_back(self, f"the scene is for robot '{self._scene.robot_model.name}', the task's robot is "
                                   f"'{robot_model.name}'")
        if errors:
            raise errors
        self._ran = False

    def canCompute(self) -> bool:
        return not self._ran and self._scene is not None

    def compute(self) -> None:
        self._ran = True
        scene = self._scene.copy()  # type: ignore[union-attr]
        solution = SubTrajectory()
        if not self._properties["ignore_collisions"] and scene.is_state_colliding():
            report = scene.check_collision(max_contacts=1)
            solution.markAsFailure("in collision: " + "; ".join(str(c) for c in report.contacts))
        self.spawn(InterfaceState(scene), solution)

