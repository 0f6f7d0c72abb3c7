"""GeneratePose: one state with the ``pose`` property as ``target_pose`` per monitored solution.

A ComputeIK wrapping it turns each into arm configurations
(``configureInitFrom(Stage.INTERFACE, ["target_pose"])``); the grasp and place generators
build on it.
"""
from __future__ import annotations

from collections import deque
from typing import Any



from ..cost_terms import Constant
from ..errors import InitStageException
from ..geometry import PoseStamped, as_pose_stamped, frame_transform
from ..stage import MonitoringGenerator
from ..storage import InterfaceState, SolutionBase, SubTrajectory


class GeneratePose(MonitoringGenerator):
    _needs_pose = True  # GenerateGraspPose derives its targets from the object instead

    def __init__(self, name: str = "generate pose", monitored=None) -> None:
        super().__init__(name, monitored)
        self.setCostTerm(Constant(0.0))
        self._properties.declare("pose", type=PoseStamped, coerce=as_pose_stamped,
                                 description="target pose to pass on in spawned states")
        self._upstream: deque[SolutionBase] = deque()

    def setPose(self, pose: Any) -> None:
        self._properties.set("pose", pose)

    def reset(self) -> None:
        super().reset()
        self._upstream.clear()

    def init(self, robot_model) -> None:
        errors = InitStageException()
        try:
            super().init(robot_model)
        except InitStageException as exc:
            errors.append(exc)
        if self._needs_pose:
            self._require_property("pose", errors)
        if errors:
            raise errors

    def onNewSolution(self, solution: SolutionBase) -> None:
        self._upstream.append(solution)

    def canCompute(self) -> bool:
        return bool(self._upstream)

    def _schedule_key(self) -> tuple | None:
        # Work derived from a monitored solution is as urgent as that solution's end state.
        if not self._upstream:
            return None
        return min(solution.end.schedule_key() for solution in self._upstream)  # type: ignore[union-attr]

    def compute(self) -> None:
        solution = self._upstream.popleft()
        scene = solution.end.scene.diff()  # type: ignore[union-attr]
        target = self._properties["pose"]
        if target is None:
            self.spawn(InterfaceState(scene), SubTrajectory.failure("property 'pose' is undefined"))
            return
        try:
            frame_transform(scene, target.frame_id)
        except ValueError as exc:
            self.spawn(InterfaceState(scene), SubTrajectory.failure(f"unknown frame '{target.frame_id}': {exc}"))
            return
        state = InterfaceState(scene, lineage_depth=solution.end.schedule_depth)  # type: ignore[union-attr]
        self.forwardProperties(solution.end, state)  # type: ignore[arg-type]
        state.properties["target_pose"] = target
        self.spawn(state, SubTrajectory(cost=0.0))

