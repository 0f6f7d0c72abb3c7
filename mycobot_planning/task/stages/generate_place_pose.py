"""GeneratePlacePose: placements of the attached ``object`` at ``pose`` (its symmetric turns for a
cylinder, sphere or box), the object frame as the ``ik_frame``."""
from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from interfaces_py.msgs import SolidPrimitive

from ..errors import InitStageException
from ..geometry import PoseStamped, frame_transform
from ..properties import PropertySetter
from ..storage import InterfaceState, SolutionBase, SubTrajectory
from .generate_pose import GeneratePose


class GeneratePlacePose(GeneratePose):
    def __init__(self, name: str = "generate place pose", monitored=None) -> None:
        super().__init__(name, monitored)
        p = self._properties
        p.declare("object", type=str, description="attached object to place")
        p.declare("allow_z_flip", False, "allow placing objects upside down", type=bool)

    setObject = PropertySetter("object", str)

    def init(self, robot_model) -> None:
        errors = InitStageException().collect(super().init, robot_model)
        self._require_property("object", errors)
        if errors:
            raise errors

    def onNewSolution(self, solution: SolutionBase) -> None:
        scene = solution.end.scene  # type: ignore[union-attr]
        name = self._properties["object"]
        problem = (f"frame '{name}' is not known" if not scene.has_object(name)
                   else f"frame '{name}' is not attached to the robot" if not scene.is_attached(name) else None)
        self._queue(solution, problem)

    def compute(self) -> None:
        solution, scene = self._next()
        p = self._properties
        name = p["object"]
        target = p["pose"]
        try:
            nominal = frame_transform(scene, target.frame_id) @ target.pose
        except ValueError as exc:
            self.spawn(InterfaceState(scene), SubTrajectory.failure(str(exc)))
            return
        flips = 1 if p["allow_z_flip"] else 0
        primitives = scene.get_attached_object(name).object.primitives
        kind = primitives[0].type if len(primitives) == 1 and not scene.get_attached_object(name).object.meshes else None
        if kind in (SolidPrimitive.CYLINDER, SolidPrimitive.SPHERE):
            rotations = 10
        elif kind == SolidPrimitive.BOX:
            dims = primitives[0].dimensions
            rotations = 4 if abs(dims[0] - dims[1]) < 1e-5 else 2
        else:
            flips, rotations = 0, 1
        ik_frame = PoseStamped(name, np.eye(4))
        for flip in range(flips + 1):
            flipped = nominal.copy()
            if flip:
                flipped[:3, :3] = flipped[:3, :3] @ pin.exp3(np.array([math.pi, 0.0, 0.0]))
            for i in range(rotations):
                rotation = pin.exp3(np.array([0.0, 0.0, i * 2.0 * math.pi / rotations]))
                pose = flipped.copy()
                pose[:3, :3] = rotation @ flipped[:3, :3]
                state = InterfaceState(scene, lineage_depth=solution.end.schedule_depth)  # type: ignore[union-attr]
                self.forwardProperties(solution.end, state)  # type: ignore[arg-type]
                state.properties["target_pose"] = PoseStamped("world", pose)
                state.properties["ik_frame"] = ik_frame
                self.spawn(state, SubTrajectory(cost=0.0))

