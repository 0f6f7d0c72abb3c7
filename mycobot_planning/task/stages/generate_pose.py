"""GeneratePose: one state with the ``pose`` property as ``target_pose`` per monitored solution.

A ComputeIK wrapping it turns each into arm configurations
(``configureInitFrom(Stage.INTERFACE, ["target_pose"])``); the grasp and place generators
build on it.
"""
from __future__ import annotations

from collections import deque
from typing import Any, Iterator



from ...core.planning_scene.planning_scene import PlanningScene
from ..cost_terms import Constant
from ..errors import InitStageException
from ..geometry import PoseStamped, as_pose_stamped, frame_transform
from ..properties import PropertySetter
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

    setPose = PropertySetter("pose", Any)

    def reset(self) -> None:
        super().reset()
        self._upstream.clear()

    def init(self, robot_model) -> None:
        errors = InitStageException().collect(super().init, robot_model)
        if self._needs_pose:
            self._require_property("pose", errors)
        if errors:
            raise errors

    def onNewSolution(self, solution: SolutionBase) -> None:
        self._queue(solution)

    def _queue(self, solution: SolutionBase, problem: str | None = None) -> None:
        """Keep ``solution`` for compute, or answer it at once with a failure saying ``problem``."""
        if problem is None:
            self._upstream.append(solution)
        else:
            self.spawn(InterfaceState(solution.end.scene), SubTrajectory.failure(problem))  # type: ignore[union-attr]

    def _next(self) -> tuple[SolutionBase, PlanningScene]:
        """The oldest kept solution and a scene diff of its end to build targets in."""
        solution = self._upstream.popleft()
        return solution, solution.end.scene.diff()  # type: ignore[union-attr]

    def canCompute(self) -> bool:
        return bool(self._upstream)

    def _schedule_key(self) -> tuple | None:
        # Work derived from a monitored solution is as urgent as that solution's end state.
        if not self._upstream:
            return None
        return min(solution.end.schedule_key() for solution in self._upstream)  # type: ignore[union-attr]

    def compute(self) -> None:
        solution, scene = self._next()
        target = self._properties["pose"]
        if target is None:
            self.spawn(InterfaceState(scene), SubTrajectory.failure("property 'pose' is undefined"))
            return
        try:
            frame_transform(scene, target.frame_id)
        except ValueError as exc:
            self.spawn(InterfaceState(scene), SubTrajectory.failure(f"unknown frame '{target.frame_id}': {exc}"))
            return
        for pose in self._targets(target):
            state = InterfaceState(scene, lineage_depth=solution.end.schedule_depth)  # type: ignore[union-attr]
            self.forwardProperties(solution.end, state)  # type: ignore[arg-type]
            state.properties["target_pose"] = pose
            self.spawn(state, SubTrajectory(cost=0.0))

    def _targets(self, seed: PoseStamped) -> Iterator[PoseStamped]:
        """The target poses spawned for one monitored solution: the ``pose`` property itself."""
        yield seed

