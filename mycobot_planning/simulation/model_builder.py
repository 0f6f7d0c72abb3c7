"""The MuJoCo model of the robot and its world, built with MuJoCo's own tools.

The robot comes in through MuJoCo's URDF importer (``mujoco.MjSpec.from_string``): it reads the
links' inertias, the joints with their limits, damping, friction and effort limits, the
collision geometry (primitives and STL/OBJ meshes) and turns every ``<mimic>`` joint into a joint
equality constraint. We prepare the URDF for it (absolute mesh paths resolved as our RobotModel
resolved them, visual elements dropped, static links kept as bodies so every link has a pose)
and then edit the resulting MjSpec: solver options, servos, the SRDF's disabled collision pairs
as contact excludes, finger-pad contact, the scene's floor and objects, and the camera. Why this
path and not a hand-written MJCF: docs/simulation.md, section "The model".
"""
from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from ..core.robot_model import RobotModel
from ..perception.depth_camera import DepthCameraConfig
from .errors import SimulationModelError
from .scene import SceneObject, SimScene
from .settings import SimulationSettings

#: Mesh formats MuJoCo decodes (its URDF importer and asset loader).
MESH_FORMATS = (".stl", ".obj", ".msh")
CAMERA_NAME = "depth_camera"
FLOOR_NAME = "floor"
#: Geom group of the scene's objects and of the robot (the camera renders both).
ROBOT_GROUP, WORLD_GROUP = 0, 1


@dataclass
class ModelIndex:
    """Where the robot's and the world's parts are in a compiled model (ids by name)."""

    arm_joints: list[str]
    gripper_joint: str
    mimic_joints: dict[str, tuple[str, float, float]]  # joint -> (source, multiplier, offset)
    fingertip_links: list[str]
    arm_qpos: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    arm_dof: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    arm_actuators: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    gripper_qpos: int = -1
    gripper_dof: int = -1
    gripper_actuator: int = -1
    joint_qpos: dict[str, int] = field(default_factory=dict)
    joint_dof: dict[str, int] = field(default_factory=dict)
    fingertip_geoms: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    robot_geoms: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    object_bodies: dict[str, int] = field(default_factory=dict)
    object_qpos: dict[str, int] = field(default_factory=dict)  # free joint qpos address (-1: fixed)
    object_dof: dict[str, int] = field(default_factory=dict)
    object_geoms: dict[str, int] = field(default_factory=dict)
    link_bodies: dict[str, int] = field(default_factory=dict)
    #: position actuator gains (kp, kv) per actuated joint, as built
    gains: dict[str, tuple[float, float]] = field(default_factory=dict)

    def fill(self, model: mujoco.MjModel, scene: SimScene) -> None:
        """Look every id up in ``model`` (after each compile)."""
        names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(model.njnt)]
        self.joint_qpos = {n: int(model.jnt_qposadr[j]) for j, n in enumerate(names) if n}
        self.joint_dof = {n: int(model.jnt_dofadr[j]) for j, n in enumerate(names) if n}
        self.arm_qpos = np.array([self.joint_qpos[n] for n in self.arm_joints], dtype=int)
        self.arm_dof = np.array([self.joint_dof[n] for n in self.arm_joints], dtype=int)
        self.arm_actuators = np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, n)
                                       for n in self.arm_joints], dtype=int)
        self.gripper_qpos = self.joint_qpos[self.gripper_joint]
        self.gripper_dof = self.joint_dof[self.gripper_joint]
        self.gripper_actuator = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, self.gripper_joint)
        self.link_bodies = {}
        robot_bodies = set()
        for b in range(1, model.nbody):
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)
            if name and name not in scene.object_ids:
                self.link_bodies[name] = b
                robot_bodies.add(b)
        tips = {self.link_bodies[n] for n in self.fingertip_links}
        self.fingertip_geoms = np.array([g for g in range(model.ngeom) if model.geom_bodyid[g] in tips], dtype=int)
        self.robot_geoms = np.array([g for g in range(model.ngeom) if model.geom_bodyid[g] in robot_bodies], dtype=int)
        self.object_bodies, self.object_qpos, self.object_dof, self.object_geoms = {}, {}, {}, {}
        for obj in scene.objects:
            b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, obj.id)
            self.object_bodies[obj.id] = b
            j = model.body_jntadr[b]
            self.object_qpos[obj.id] = int(model.jnt_qposadr[j]) if j >= 0 else -1
            self.object_dof[obj.id] = int(model.jnt_dofadr[j]) if j >= 0 else -1
            self.object_geoms[obj.id] = int(model.body_geomadr[b])


# --------------------------------------------------------------------------------- the robot


def _resolved_meshes(robot: RobotModel) -> dict[str, list[str]]:
    """Per link, the resolved paths of its collision meshes in URDF order, as Pinocchio found
    them for the RobotModel (so package:// and relative paths resolve exactly alike)."""
    out: dict[str, list[str]] = {}
    frames = robot.pin_model.frames
    for geom in robot.pin_collision_model.geometryObjects:
        path = getattr(geom, "meshPath", "") or ""
        if path and path.upper() not in ("BOX", "CYLINDER", "SPHERE", "CAPSULE", "CONE"):
            out.setdefault(frames[geom.parentFrame].name, []).append(path)
    return out


def prepared_urdf(robot: RobotModel) -> tuple[str, dict[str, tuple[str, str]]]:
    """The robot's URDF ready for MuJoCo's importer, and mesh name -> (link, file) for errors.

    Visual elements go (the simulation and its camera use the collision geometry, and visual
    meshes are often COLLADA, which MuJoCo cannot read); collision meshes get absolute paths and
    are checked to exist and be of a format MuJoCo decodes, naming the link if not.
    """
    try:
        root = ET.fromstring(robot.urdf_xml)
    except ET.ParseError as exc:
        raise SimulationModelError(f"the robot's URDF is not valid XML: {exc}") from None
    resolved = _resolved_meshes(robot)
    meshes: dict[str, tuple[str, str]] = {}
    for link in root.findall("link"):
        name = link.get("name", "")
        for visual in link.findall("visual"):
            link.remove(visual)
        paths = iter(resolved.get(name, []))
        for collision in link.findall("collision"):
            mesh = collision.find("geometry/mesh")
            if mesh is None:
                continue
            given = mesh.get("filename", "")
            path = next(paths, None)
            if path is None:
                raise SimulationModelError(f"link '{name}': collision mesh '{given}' was not resolved by the robot model")
            suffix = Path(path).suffix.lower()
            if suffix not in MESH_FORMATS:
                raise SimulationModelError(
                    f"link '{name}': collision mesh '{given}' is a {suffix or 'extension-less'} file; MuJoCo reads "
                    f"{', '.join(f.upper().lstrip('.') for f in MESH_FORMATS)} meshes only (convert it, e.g. to STL)")
            if not Path(path).is_file():
                raise SimulationModelError(f"link '{name}': collision mesh '{given}' not found at {path}")
            mesh.set("filename", str(Path(path).resolve()))
            meshes.setdefault(Path(path).stem, (name, given))
    for old in root.findall("mujoco"):
        root.remove(old)
    extension = ET.Element("mujoco")
    # fusestatic off: a link on a fixed joint stays a body, so every link has a pose to read and
    # the SRDF's pairs name bodies that exist.
    ET.SubElement(extension, "compiler", {"fusestatic": "false", "discardvisual": "true", "strippath": "false",
                                          "balanceinertia": "true"})
    root.insert(0, extension)
    return ET.tostring(root, encoding="unicode"), meshes


_ELEMENT = re.compile(r"Element name '([^']*)'")


def _explain(exc: Exception, meshes: dict[str, tuple[str, str]], scene: SimScene | None) -> SimulationModelError:
    """A MuJoCo compile error turned into one naming the link, mesh or object."""
    text = " ".join(str(exc).split())
    found = _ELEMENT.search(text)
    element = found.group(1) if found else ""
    if "mass and inertia of moving bodies" in text:
        if scene is not None and element in scene.object_ids:
            return SimulationModelError(f"object '{element}' is a free body without mass: give it a mass > 0 (kg)")
        return SimulationModelError(
            f"link '{element}' moves but has no mass (or no inertia): MuJoCo cannot simulate it; give the link an "
            f"<inertial> with mass > 0 in the URDF ({text})")
    if element in meshes and ("mesh" in text.lower() or "decoder" in text.lower() or "stl" in text.lower()):
        link, given = meshes[element]
        return SimulationModelError(f"link '{link}': MuJoCo cannot read collision mesh '{given}': {text}")
    return SimulationModelError(f"MuJoCo cannot build the model: {text}")


def robot_index(robot: RobotModel, settings: SimulationSettings) -> ModelIndex:
    """The joints the servos drive and the finger pads, from the SRDF groups and the settings."""
    for key in ("arm_group", "gripper_group"):
        group = getattr(settings, key)
        if not robot.has_group(group):
            raise SimulationModelError(f"{key}: the robot has no group '{group}' (groups: {', '.join(robot.group_names)})")
    arm = [j for j in robot.group(settings.arm_group).joint_names if robot.joint(j).mimic is None]
    gripper = [j for j in robot.group(settings.gripper_group).joint_names if robot.joint(j).mimic is None]
    if len(gripper) != 1:
        raise SimulationModelError(f"gripper_group '{settings.gripper_group}' must have exactly one actuated joint "
                                   f"(the others mimic it), it has {gripper}")
    mimics = {}
    for name in robot.mimic_joint_names:
        info = robot.joint(name).mimic
        mimics[name] = (info.joint, float(info.multiplier), float(info.offset))
    limp = [j for j in robot.joint_names if robot.joint(j).type != "fixed" and j not in arm and j not in gripper
            and j not in mimics]
    if limp:
        raise SimulationModelError(
            f"joints {limp} are in neither arm_group '{settings.arm_group}' nor gripper_group "
            f"'{settings.gripper_group}' and mimic no joint: nothing would drive them in the simulation")
    tips = list(settings.fingertip_links)
    if not tips:
        links = robot.group(settings.gripper_group).link_names
        with_geometry = set(robot.links_with_collision_geometry())
        parents = {robot.joint(j).parent_link for j in robot.joint_names}
        tips = [link for link in links if link not in parents and link in with_geometry]
    for link in tips:
        if not robot.has_link(link):
            raise SimulationModelError(f"fingertip_links: the robot has no link '{link}'")
        if link not in robot.links_with_collision_geometry():
            raise SimulationModelError(f"fingertip_links: link '{link}' has no collision geometry to grip with")
    return ModelIndex(arm, gripper[0], mimics, tips)


def _joint_inertia(model: mujoco.MjModel, dofs: list[int]) -> np.ndarray:
    """Diagonal of the joint-space inertia at the model's reference pose (qpos0)."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    full = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, full)
    return np.array([full[d, d] for d in dofs])


def _servo_gains(inertia: float, bandwidth_hz: float, damping_ratio: float) -> tuple[float, float]:
    omega = 2.0 * math.pi * bandwidth_hz
    kp = inertia * omega * omega
    return kp, 2.0 * damping_ratio * math.sqrt(kp * inertia)


def _robot_spec(robot: RobotModel, settings: SimulationSettings, index: ModelIndex) -> tuple[mujoco.MjSpec, dict]:
    urdf, meshes = prepared_urdf(robot)
    try:
        spec = mujoco.MjSpec.from_string(urdf)
    except ValueError as exc:
        raise SimulationModelError(f"MuJoCo cannot read the robot's URDF: {' '.join(str(exc).split())}") from None
    joints = {j.name: j for j in spec.joints}
    for name in index.arm_joints + [index.gripper_joint] + list(index.mimic_joints):
        if name not in joints:
            raise SimulationModelError(f"joint '{name}' is missing from MuJoCo's import of the URDF")
    # Mimic joints: MuJoCo's importer makes joint equalities of them; add any it did not.
    coupled = {(e.name1, e.name2) for e in spec.equalities if e.type == mujoco.mjtEq.mjEQ_JOINT}
    for name, (source, multiplier, offset) in index.mimic_joints.items():
        if (name, source) not in coupled:
            eq = spec.add_equality()
            eq.type = mujoco.mjtEq.mjEQ_JOINT
            eq.name1, eq.name2 = name, source
            eq.data[:5] = [offset, multiplier, 0.0, 0.0, 0.0]
    # As stiff as the time step allows (MuJoCo's minimum time constant is two steps): the mimic
    # joints stand for a rigid linkage, which the default (20 ms) lets twist under a grip.
    for eq in spec.equalities:
        if eq.type == mujoco.mjtEq.mjEQ_JOINT and eq.name1 in index.mimic_joints:
            eq.solref = [2.0 * settings.timestep, 1.0]
    servo, grip = settings.arm_servo, settings.gripper
    for name in index.arm_joints:
        joints[name].armature = servo.armature
        if servo.effort_limit > 0:
            joints[name].actfrclimited = mujoco.mjtLimited.mjLIMITED_TRUE
            joints[name].actfrcrange = [-servo.effort_limit, servo.effort_limit]
    for name in [index.gripper_joint] + list(index.mimic_joints):
        joints[name].armature = grip.armature
    if servo.gravity_compensation:
        for body in spec.bodies[1:]:
            body.gravcomp = 1.0
        for joint in spec.joints:
            joint.actgravcomp = True
    return spec, meshes


def _add_servos(spec: mujoco.MjSpec, robot_model: mujoco.MjModel, settings: SimulationSettings,
                index: ModelIndex) -> None:
    """Position actuators: one per arm joint, one on the gripper joint (the mimic joints follow
    through their equality constraints). Gains from each joint's inertia (see ArmServoSettings)."""
    dof = {mujoco.mj_id2name(robot_model, mujoco.mjtObj.mjOBJ_JOINT, j): int(robot_model.jnt_dofadr[j])
           for j in range(robot_model.njnt)}
    inertia = dict(zip(dof, _joint_inertia(robot_model, list(dof.values()))))
    for name in index.arm_joints:
        kp, kv = _servo_gains(inertia[name], settings.arm_servo.bandwidth_hz, settings.arm_servo.damping_ratio)
        _position_actuator(spec, name, kp, kv)
        index.gains[name] = (kp, kv)
    # The gripper joint drags its mimic joints: the inertia it moves is theirs too, scaled by the
    # square of their multipliers (the chain of constraints acts as a gearbox).
    grip = inertia[index.gripper_joint] + sum(
        mult * mult * inertia[name] for name, (source, mult, _) in index.mimic_joints.items()
        if source == index.gripper_joint)
    kp, kv = _servo_gains(grip, settings.gripper.bandwidth_hz, settings.gripper.damping_ratio)
    _position_actuator(spec, index.gripper_joint, kp, kv)
    index.gains[index.gripper_joint] = (kp, kv)


def _position_actuator(spec: mujoco.MjSpec, joint: str, kp: float, kv: float) -> None:
    actuator = spec.add_actuator()
    actuator.name = joint
    actuator.target = joint
    actuator.trntype = mujoco.mjtTrn.mjTRN_JOINT
    actuator.set_to_position(kp=kp, kv=kv)
    actuator.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
    actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_FALSE


def _add_excludes(spec: mujoco.MjSpec, robot: RobotModel) -> None:
    """The SRDF's disabled collision pairs are not simulated as contacts either: links that touch
    by design (the finger linkage, adjacent links) would otherwise push each other apart."""
    bodies = {b.name for b in spec.bodies}
    for a, b, _reason in robot.srdf.disabled_collisions:
        if a in bodies and b in bodies and a != b:
            exclude = spec.add_exclude()
            exclude.bodyname1, exclude.bodyname2 = a, b


def _configure(spec: mujoco.MjSpec, settings: SimulationSettings, index: ModelIndex) -> None:
    option = spec.option
    option.timestep = settings.timestep
    option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{settings.integrator.upper()}")
    option.cone = getattr(mujoco.mjtCone, f"mjCONE_{settings.contact.cone.upper()}")
    option.impratio = settings.contact.impratio
    option.noslip_iterations = settings.contact.noslip_iterations
    tip = settings.contact.fingertip
    tips = set(index.fingertip_links)
    for body in spec.bodies:
        if body.name not in tips:
            continue
        for geom in body.geoms:
            geom.condim = tip.condim
            geom.friction = list(tip.friction)
            geom.margin = tip.margin
            geom.solref = list(tip.solref)
            geom.priority = 1  # the pad's own contact parameters win over the object's
    for geom in spec.geoms:
        geom.group = ROBOT_GROUP


# --------------------------------------------------------------------------------- the world


def _quat_wxyz(rotation: np.ndarray) -> list[float]:
    x, y, z, w = Rotation.from_matrix(rotation).as_quat()
    return [float(w), float(x), float(y), float(z)]


def add_object(spec: mujoco.MjSpec, obj: SceneObject) -> None:
    """One scene object as a body of the world: welded when fixed, else on a free joint with its
    mass (inertia of a uniform solid, from the geom)."""
    body = spec.worldbody.add_body()
    body.name = obj.id
    body.pos = obj.pose[:3, 3].tolist()
    body.quat = _quat_wxyz(obj.pose[:3, :3])
    if not obj.fixed:
        joint = body.add_freejoint()
        joint.name = f"{obj.id}_free"
    geom = body.add_geom()
    geom.name = obj.id
    if obj.shape == "box":
        geom.type = mujoco.mjtGeom.mjGEOM_BOX
        geom.size = (np.asarray(obj.size) / 2.0).tolist()
    elif obj.shape == "cylinder":
        geom.type = mujoco.mjtGeom.mjGEOM_CYLINDER
        geom.size = [obj.size[1], obj.size[0] / 2.0, 0.0]
    else:
        geom.type = mujoco.mjtGeom.mjGEOM_SPHERE
        geom.size = [obj.size[0], 0.0, 0.0]
    geom.friction = list(obj.friction)
    geom.rgba = list(obj.color)
    geom.group = WORLD_GROUP
    if not obj.fixed:
        geom.mass = obj.mass


def _add_world(spec: mujoco.MjSpec, scene: SimScene, link_names: set[str]) -> None:
    for obj in scene.objects:
        if obj.id in link_names:
            raise SimulationModelError(f"object '{obj.id}' has the name of a robot link; rename it")
        add_object(spec, obj)
    if scene.floor is not None:
        floor = spec.worldbody.add_geom()
        floor.name = FLOOR_NAME
        floor.type = mujoco.mjtGeom.mjGEOM_PLANE
        floor.size = [0.0, 0.0, 0.05]
        floor.pos = [0.0, 0.0, scene.floor.z]
        floor.friction = list(scene.floor.friction)
        floor.rgba = [0.45, 0.45, 0.45, 1.0]
        floor.group = WORLD_GROUP
    light = spec.worldbody.add_light()
    light.pos = [0.0, 0.0, 2.0]
    light.dir = [0.0, 0.0, -1.0]


def add_camera(spec: mujoco.MjSpec, camera: DepthCameraConfig) -> None:
    """The depth camera at the configured optical-frame pose with exact pinhole intrinsics.

    MuJoCo cameras look along their -z with +y up; the optical frame looks along +z with +y
    down: the same frame turned half a turn about x. The intrinsics go in as MuJoCo's sensor
    model (resolution, focal length and principal point offset in pixels)."""
    intr = camera.intrinsics
    cam = spec.worldbody.add_camera()
    cam.name = CAMERA_NAME
    cam.pos = camera.pose[:3, 3].tolist()
    cam.quat = _quat_wxyz(camera.pose[:3, :3] @ np.diag([1.0, -1.0, -1.0]))
    cam.resolution = [intr.width, intr.height]
    cam.sensor_size = [float(intr.width), float(intr.height)]  # one length unit per pixel
    cam.focal_length = [intr.fx, intr.fy]
    # MuJoCo's principal point offset is from the image centre, with y up; ours (cx, cy) is in
    # pixel-centre coordinates with y down.
    cam.principal_length = [intr.cx - (intr.width - 1) / 2.0, -(intr.cy - (intr.height - 1) / 2.0)]
    spec.visual.global_.offwidth = max(spec.visual.global_.offwidth, intr.width)
    spec.visual.global_.offheight = max(spec.visual.global_.offheight, intr.height)


# --------------------------------------------------------------------------------- together


def _check_frame(robot_model: mujoco.MjModel, scene: SimScene) -> None:
    """Scene poses are in MuJoCo's world frame: ``frame_id`` must be "world" or a link welded to
    the world at its origin (the myCobot's base_link), else the poses would be misread."""
    if scene.frame_id == "world":
        return
    body = mujoco.mj_name2id(robot_model, mujoco.mjtObj.mjOBJ_BODY, scene.frame_id)
    if body < 0:
        raise SimulationModelError(f"scene frame_id '{scene.frame_id}' is not 'world' nor a link of the robot")
    data = mujoco.MjData(robot_model)
    mujoco.mj_kinematics(robot_model, data)
    at_origin = np.allclose(data.xpos[body], 0.0, atol=1e-9) and np.allclose(data.xmat[body], np.eye(3).ravel(), atol=1e-9)
    if robot_model.body_weldid[body] != 0 or not at_origin:
        raise SimulationModelError(f"scene frame_id '{scene.frame_id}' must be 'world' or a link fixed at the world "
                                   "origin; give the poses in the world frame")



@dataclass
class BuiltModel:
    """A compiled model with its spec (kept for spawning and removing objects) and index."""

    spec: mujoco.MjSpec
    model: mujoco.MjModel
    index: ModelIndex
    scene: SimScene
    settings: SimulationSettings
    meshes: dict[str, tuple[str, str]]

    def compile(self) -> mujoco.MjModel:
        try:
            self.model = self.spec.compile()
        except ValueError as exc:
            raise _explain(exc, self.meshes, self.scene) from None
        self.index.fill(self.model, self.scene)
        return self.model


def build_model(robot: RobotModel, scene: SimScene, settings: SimulationSettings | None = None) -> BuiltModel:
    """The robot of ``robot`` (URDF + SRDF) in the world of ``scene``, simulated as ``settings``
    say. Raises SimulationModelError naming the link, mesh or object that cannot be built."""
    settings = settings or SimulationSettings()
    index = robot_index(robot, settings)
    spec, meshes = _robot_spec(robot, settings, index)
    try:
        robot_only = spec.compile()
    except ValueError as exc:
        raise _explain(exc, meshes, None) from None
    _check_frame(robot_only, scene)
    _add_servos(spec, robot_only, settings, index)
    _add_excludes(spec, robot)
    _configure(spec, settings, index)
    _add_world(spec, scene, {b.name for b in spec.bodies})
    if scene.camera is not None:
        add_camera(spec, scene.camera)
    built = BuiltModel(spec, robot_only, index, scene, settings, meshes)
    built.compile()
    return built
