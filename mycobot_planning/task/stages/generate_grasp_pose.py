"""GenerateGraspPose: grasp candidates around ``object``, its frame turned about ``rotation_axis``
in steps of ``angle_delta``, the end effector in its ``pregrasp`` posture."""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import pinocchio as pin


from ...core.planning_scene.planning_scene import PlanningScene
from ..errors import InitStageException
from ..geometry import PoseStamped
from ..properties import PropertySetter
from ..storage import InterfaceState, SolutionBase, SubTrajectory
from .generate_pose import GeneratePose


def _as_axis(value: Any) -> np.ndarray:
    axis = np.array(value, dtype=float).reshape(-1)
    if axis.size != 3 or not np.all(np.isfinite(axis)) or np.linalg.norm(axis) < 1e-12:
        raise ValueError("rotation_axis must be a non-zero 3-vector")
    return axis / np.linalg.norm(axis)


def _apply_posture(scene, eef_group: str, posture: Any) -> None:
    """Put the end effector in a named posture or a joint map (ValueError naming the problem)."""
    model = scene.robot_model
    state = scene.current_state.copy()
    if isinstance(posture, str):
        values = model.named_state(posture, eef_group)
    elif isinstance(posture, dict):
        joints = model.group(eef_group).joint_names
        unknown = [name for name in posture if name not in joints]
        if unknown:
            raise ValueError(f"joints {unknown} are not part of group '{eef_group}'")
        values = posture
    else:
        raise ValueError("expected a named state or a joint map")
    state.set_joint_positions({k: float(v) for k, v in values.items() if k in model.variable_names})
    scene.set_current_state(state)


class GenerateGraspPose(GeneratePose):
    _needs_pose = False

    def __init__(self, name: str = "generate grasp pose", monitored=None) -> None:
        super().__init__(name, monitored)
        p = self._properties
        p.declare("eef", type=str, description="name of end-effector")
        p.declare("object", type=str, description="object to grasp")
        p.declare("angle_delta", 0.1, "angular steps (rad)", type=float)
        p.declare("rotation_axis", np.array([0.0, 0.0, 1.0]), "rotate the object pose about this axis",
                  type=np.ndarray, coerce=_as_axis)
        p.declare("pregrasp", description="pregrasp posture (named state or joint map)")
        p.declare("grasp", description="grasp posture (named state or joint map)")

    setEndEffector = PropertySetter("eef", str)
    setObject = PropertySetter("object", str)
    setAngleDelta = PropertySetter("angle_delta", float)
    setRotationAxis = PropertySetter("rotation_axis", Any)
    setPreGraspPose = PropertySetter("pregrasp", Any)
    setGraspPose = PropertySetter("grasp", Any)

    def init(self, robot_model) -> None:
        errors = InitStageException().collect(super().init, robot_model)
        p = self._properties
        if p["angle_delta"] == 0.0:
            errors.push_back(self, "property 'angle_delta' must be non-zero")
        self._require_property("object", errors)
        eef = self._require_property("eef", errors)
        if self._check_eef(eef, robot_model, errors):
            posture = p["pregrasp"]
            if posture is None:
                errors.push_back(self, self._describe_undefined("pregrasp"))
            else:
                try:
                    _apply_posture(PlanningScene(robot_model), robot_model.end_effectors[eef].group, posture)
                except ValueError as exc:
                    errors.push_back(self, f"property 'pregrasp': invalid pregrasp: {exc}")
        if errors:
            raise errors

    def onNewSolution(self, solution: SolutionBase) -> None:
        name = self._properties["object"]
        present = solution.end.scene.has_object(name)  # type: ignore[union-attr]
        self._queue(solution, None if present else f"object '{name}' not in scene")

    def compute(self) -> None:
        solution, scene = self._next()
        p = self._properties
        model = scene.robot_model
        eef = model.end_effectors[p["eef"]]
        try:
            _apply_posture(scene, eef.group, p["pregrasp"])
        except ValueError as exc:
            self.spawn(InterfaceState(scene), SubTrajectory.failure(f"invalid pregrasp: {exc}"))
            return
        delta = float(p["angle_delta"])
        axis = p["rotation_axis"]
        angle = 0.0
        while -2.0 * math.pi < angle < 2.0 * math.pi:
            pose = np.eye(4)
            pose[:3, :3] = pin.exp3(axis * angle)
            angle += delta
            state = InterfaceState(scene, lineage_depth=solution.end.schedule_depth)  # type: ignore[union-attr]
            state.properties["target_pose"] = PoseStamped(p["object"], pose)
            for name in ("pregrasp", "grasp"):
                if p[name] is not None:
                    state.properties[name] = p[name]
            self.spawn(state, SubTrajectory(cost=0.0, comment=f"{angle:.6f}"))

