"""Pick and Place: a grasp (or ungrasp) stage between two straight-line motions of the end
effector (MTC's stages::PickPlaceBase, Pick, Place).

* Pick: ``approach object`` (MoveRelative, planned backward from the grasp) → the grasp stage
  (e.g. SimpleGrasp) → ``lift object`` (MoveRelative, forward).
* Place: ``place object`` (backward from the place pose) → the ungrasp stage (e.g.
  SimpleUnGrasp) → ``retract`` (forward).

Why a container: the two motions must use the arm the end effector hangs on and the same
frame, and the grasp stage needs the end effector and the object. Setting ``eef``, ``object``
and ``eef_frame`` once on the Pick / Place configures all of them: at init the container derives
``eef_group`` and ``eef_parent_group`` from ``eef``; the motions plan ``eef_parent_group`` for
the ``eef_frame`` (default: the group's tip), the grasp stage inherits ``eef`` and ``object``.
Both motions share one CartesianPath solver, ``cartesian_solver``, to configure (scaling, step
size) in one place.
"""
from __future__ import annotations

from typing import Any, Mapping

from ...core.robot_model.robot_model import RobotModel
from ..errors import InitStageException, PropertyError, TaskError
from ..geometry import PoseStamped
from ..properties import PropertyMap, PropertySetter
from ..containers import SerialContainer
from ..solvers import CartesianPath
from ..stage import Stage
from .move_relative import MoveRelative
from .simple_grasp import read_property

__all__ = ["Pick", "PickPlaceBase", "Place"]


def _ik_frame_from_eef_frame(source: PropertyMap | Mapping[str, Any]) -> PoseStamped | None:
    """The motions' ik_frame: the parent's ``eef_frame`` (identity pose in it), or undefined so
    that MoveRelative moves the group's tip."""
    try:
        frame = read_property(source, "eef_frame")
    except LookupError:
        return None
    return PoseStamped(frame) if isinstance(frame, str) else None


class PickPlaceBase(SerialContainer):
    """The common part of Pick (forward) and Place (the same steps in reverse order)."""

    #: the public names of the two motions' setters (for error messages)
    _motion_setters = ("setApproachRetract", "setLiftPlace")

    def __init__(self, grasp_stage: Stage, name: str, forward: bool) -> None:
        super().__init__(name)
        if not isinstance(grasp_stage, Stage):
            what = "grasp" if forward else "ungrasp"
            raise TaskError(f"{type(self).__name__} '{name}': needs the {what} stage (e.g. stages.Simple"
                            f"{'Grasp' if forward else 'UnGrasp'}), got {type(grasp_stage).__name__}")
        if grasp_stage.parent is not None:
            raise TaskError(f"stage '{grasp_stage.name}' already belongs to container '{grasp_stage.parent.name}'")
        p = self._properties
        p.declare("object", type=str, description="name of object to grasp")
        p.declare("eef", type=str, description="end effector name")
        p.declare("eef_frame", type=str, description="name of end effector frame")
        # derived from eef at init
        p.declare("eef_group", type=str, description="JMG of eef")
        p.declare("eef_parent_group", type=str, description="JMG of eef's parent")
        self._cartesian_solver = CartesianPath()
        forwarded = grasp_stage.properties.get("forwarded_properties", frozenset())

        def motion(stage_name: str, marker_ns: str) -> MoveRelative:
            stage = MoveRelative(stage_name, self._cartesian_solver)
            stage.setForwardedProperties(forwarded)
            props = stage.properties
            props.property("group").configureInitFrom(Stage.PARENT, "eef_parent_group")
            props.property("ik_frame").configureInitFrom(Stage.PARENT, _ik_frame_from_eef_frame)
            stage.setMarkerNS(marker_ns)
            return stage

        try:
            grasp_stage.properties.configureInitFrom(Stage.PARENT, ["eef", "object"])
        except PropertyError as exc:
            raise TaskError(f"{type(self).__name__} '{name}': cannot pass eef / object to '{grasp_stage.name}': "
                            f"{exc}") from None
        # The first motion: approach (pick) or retract (place); the second: lift or place.
        self._approach = motion("approach object", "approach") if forward else motion("retract", "retract")
        self._grasp = grasp_stage
        self._lift = motion("lift object", "lift") if forward else motion("place object", "place")
        ordered = [self._approach, grasp_stage, self._lift]
        for stage in ordered if forward else reversed(ordered):
            self.insert(stage)

    # ------------------------------------------------------------------ configuration (MTC's API)
    @property
    def cartesian_solver(self) -> CartesianPath:
        """The CartesianPath both motions plan with (set its properties to tune them)."""
        return self._cartesian_solver

    def cartesianSolver(self) -> CartesianPath:
        return self._cartesian_solver

    setEndEffector = PropertySetter("eef", str)
    setObject = PropertySetter("object", str)

    def _set_motion(self, which: int, motion: Any, min_distance: float | None, max_distance: float | None) -> None:
        """Configure the first (0) or second (1) motion; errors name the setter the user called."""
        stage, setter = (self._approach, self._lift)[which], self._motion_setters[which]
        if isinstance(motion, Mapping):
            if min_distance is not None or max_distance is not None:
                raise TaskError(f"stage '{self._name}': {setter}(joints) takes joint offsets only, no distances")
            stage.setDirection(motion)
            return
        if min_distance is None or max_distance is None:
            raise TaskError(f"stage '{self._name}': {setter}(motion, min_distance, max_distance) needs both distances")
        for value, what in ((min_distance, "min_distance"), (max_distance, "max_distance")):
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise TaskError(f"stage '{self._name}': {setter}: {what} must be a number, got {value!r}")
        stage.setDirection(motion)  # PropertyTypeError naming the problem for a bad motion
        stage.setMinMaxDistance(min_distance, max_distance)

    def setApproachRetract(self, motion: Any, min_distance: float, max_distance: float) -> None:
        self._set_motion(0, motion, min_distance, max_distance)

    def setLiftPlace(self, motion: Any, min_distance: float | None = None, max_distance: float | None = None) -> None:
        self._set_motion(1, motion, min_distance, max_distance)

    # ------------------------------------------------------------------ life cycle
    def init(self, robot_model: RobotModel) -> None:
        errors = InitStageException().collect(Stage.init, self, robot_model)
        p = self._properties
        eef = p["eef"]
        eef_reported = True
        if eef is None:
            errors.push_back(self, "property 'eef' is undefined: set the end effector (e.g. pick.eef = 'hand')")
        elif eef not in robot_model.end_effectors:
            errors.push_back(self, f"unknown end effector: '{eef}'; known: {', '.join(robot_model.end_effectors) or 'none'}")
        else:
            eef_reported = False
            end_effector = robot_model.end_effectors[eef]
            p.setCurrent("eef_group", end_effector.group)
            p.setCurrent("eef_parent_group", end_effector.parent_group)
        missing_motion = {}
        for stage, setter in ((self._approach, self._motion_setters[0]), (self._lift, self._motion_setters[1])):
            direction = stage.properties.property("direction")
            if direction.value() is None and not direction.initsFrom(Stage.INTERFACE):
                missing_motion[stage.name] = setter
                errors.push_back(self, f"no motion for '{stage.name}': call {setter}(motion, min_distance, max_distance)")
        for child in self._children:
            try:
                child.init(robot_model)
            except InitStageException as exc:
                for stage_name, message in exc:
                    # already reported above, with the setter to call
                    if stage_name in missing_motion and message.startswith("property 'direction' is undefined"):
                        continue
                    # the motions' group is eef_parent_group: a bad eef is reported above
                    if eef_reported and stage_name in (self._approach.name, self._lift.name) \
                            and message.startswith("property 'group' is undefined"):
                        continue
                    errors.push_back(stage_name, message)
        if errors:
            raise errors


class Pick(PickPlaceBase):
    """Approach the object, grasp it with the grasp stage, lift it."""

    _motion_setters = ("setApproachMotion", "setLiftMotion")

    def __init__(self, grasp_generator: Stage, name: str = "pick") -> None:
        # (MTC's binding calls the grasp stage "grasp_generator")
        super().__init__(grasp_generator, name, True)

    def setApproachMotion(self, motion: Any, min_distance: float, max_distance: float) -> None:
        """Straight motion onto the grasp: a TwistStamped (or Vector3Stamped) and its distances."""
        self.setApproachRetract(motion, min_distance, max_distance)

    def setLiftMotion(self, motion: Any, min_distance: float | None = None, max_distance: float | None = None) -> None:
        """Straight motion away from the grasp (TwistStamped or Vector3Stamped with distances), or
        a joint map of offsets ``{joint: delta}``."""
        self.setLiftPlace(motion, min_distance, max_distance)


class Place(PickPlaceBase):
    """Lower the object onto the place pose, release it with the ungrasp stage, retract."""

    _motion_setters = ("setRetractMotion", "setPlaceMotion")

    def __init__(self, place_generator: Stage, name: str = "place") -> None:
        # (MTC's binding calls the ungrasp stage "place_generator")
        super().__init__(place_generator, name, False)

    def setRetractMotion(self, motion: Any, min_distance: float, max_distance: float) -> None:
        """Straight motion away from the released object: a TwistStamped (or Vector3Stamped)."""
        self.setApproachRetract(motion, min_distance, max_distance)

    def setPlaceMotion(self, motion: Any, min_distance: float | None = None, max_distance: float | None = None) -> None:
        """Straight motion onto the place pose (TwistStamped or Vector3Stamped with distances), or
        a joint map of offsets ``{joint: delta}``."""
        self.setLiftPlace(motion, min_distance, max_distance)
