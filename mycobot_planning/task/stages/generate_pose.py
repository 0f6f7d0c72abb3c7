"""Pose generators fed by a monitored stage: GeneratePose, GenerateGraspPose, GeneratePlacePose.

They spawn states carrying a ``target_pose`` property (a PoseStamped); a ComputeIK wrapping
them turns each into arm configurations (``configureInitFrom(Stage.INTERFACE, ["target_pose"])``).

* GeneratePose: one state with the ``pose`` property as target, per monitored solution.
* GenerateGraspPose: grasp candidates around ``object``: its frame rotated about
  ``rotation_axis`` (object z by default) in steps of ``angle_delta`` over a full turn, with the
  end effector in its ``pregrasp`` posture (a named state of the eef group, e.g. 'open', or a
  joint map). Fed by a stage whose solutions see the object, e.g. "current state".
* GeneratePlacePose: placements of the *attached* ``object`` at ``pose``: for a cylinder or a
  sphere ten rotations about the world z axis through the target, for a box the symmetric
  ones, otherwise the pose itself; the object frame is the ``ik_frame``. Fed by the stage that
  attached the object.
"""
from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np
import pinocchio as pin

from interfaces_py.msgs import SolidPrimitive

from ...core.planning_scene import PlanningScene
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

    def setEndEffector(self, eef: str) -> None:
        self._properties.set("eef", eef)

    def setObject(self, name: str) -> None:
        self._properties.set("object", name)

    def setAngleDelta(self, delta: float) -> None:
        self._properties.set("angle_delta", delta)

    def setRotationAxis(self, axis) -> None:
        self._properties.set("rotation_axis", axis)

    def setPreGraspPose(self, posture: Any) -> None:
        self._properties.set("pregrasp", posture)

    def setGraspPose(self, posture: Any) -> None:
        self._properties.set("grasp", posture)

    def init(self, robot_model) -> None:
        errors = InitStageException()
        try:
            super().init(robot_model)
        except InitStageException as exc:
            errors.append(exc)
        p = self._properties
        if p["angle_delta"] == 0.0:
            errors.push_back(self, "property 'angle_delta' must be non-zero")
        self._require_property("object", errors)
        eef = self._require_property("eef", errors)
        if eef is not None:
            if eef not in robot_model.end_effectors:
                errors.push_back(self, f"property 'eef': unknown end effector '{eef}'; known: "
                                       f"{', '.join(robot_model.end_effectors) or 'none'}")
            else:
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
        scene = solution.end.scene  # type: ignore[union-attr]
        name = self._properties["object"]
        if not scene.has_object(name):
            self.spawn(InterfaceState(scene), SubTrajectory.failure(f"object '{name}' not in scene"))
            return
        self._upstream.append(solution)

    def compute(self) -> None:
        solution = self._upstream.popleft()
        scene = solution.end.scene.diff()  # type: ignore[union-attr]
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


class GeneratePlacePose(GeneratePose):
    def __init__(self, name: str = "generate place pose", monitored=None) -> None:
        super().__init__(name, monitored)
        p = self._properties
        p.declare("object", type=str, description="attached object to place")
        p.declare("allow_z_flip", False, "allow placing objects upside down", type=bool)

    def setObject(self, name: str) -> None:
        self._properties.set("object", name)

    def init(self, robot_model) -> None:
        errors = InitStageException()
        try:
            super().init(robot_model)
        except InitStageException as exc:
            errors.append(exc)
        self._require_property("object", errors)
        if errors:
            raise errors

    def onNewSolution(self, solution: SolutionBase) -> None:
        scene = solution.end.scene  # type: ignore[union-attr]
        name = self._properties["object"]
        if not scene.has_object(name):
            self.spawn(InterfaceState(scene), SubTrajectory.failure(f"frame '{name}' is not known"))
            return
        if not scene.is_attached(name):
            self.spawn(InterfaceState(scene), SubTrajectory.failure(f"frame '{name}' is not attached to the robot"))
            return
        self._upstream.append(solution)

    def compute(self) -> None:
        solution = self._upstream.popleft()
        scene = solution.end.scene.diff()  # type: ignore[union-attr]
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
