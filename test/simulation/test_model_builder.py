"""The MuJoCo model built from the URDF + SRDF and the scene file: what is in it, and the clear
errors for what MuJoCo cannot build (naming the link, mesh or object)."""
from __future__ import annotations

import re

import numpy as np
import pytest

from mycobot_planning.simulation import (MujocoSimulator, SceneObject, SimScene, SimulationModelError,
                                         SimulationSettings, build_model, load_scene, load_settings)
import mujoco  # noqa: E402  (after the simulation package: it sets MUJOCO_GL)

from mycobot_planning.core import RobotModel
from mycobot_planning.paths import config_file

URDF_LINK = """
  <link name="{name}">
    <inertial><mass value="{mass}"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry>{geometry}</geometry></collision>
  </link>"""
TWO_LINK_SRDF = """<robot name="r">
  <group name="arm"><joint name="j1"/></group>
  <group name="gripper"><joint name="g"/></group>
</robot>"""


def two_link_robot(tmp_path, geometry: str = '<box size="0.05 0.05 0.05"/>', mass: float = 0.2) -> RobotModel:
    """A base, an arm link on j1 (with ``geometry`` and ``mass``) and a finger on g."""
    urdf = f"""<robot name="r">
  <link name="world"/>
  {URDF_LINK.format(name="base", mass=1.0, geometry='<box size="0.1 0.1 0.02"/>')}
  {URDF_LINK.format(name="arm_link", mass=mass, geometry=geometry)}
  {URDF_LINK.format(name="finger", mass=0.01, geometry='<box size="0.01 0.01 0.02"/>')}
  <joint name="fix" type="fixed"><parent link="world"/><child link="base"/></joint>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm_link"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="g" type="prismatic"><parent link="arm_link"/><child link="finger"/><origin xyz="0 0 0.05"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="0.02" effort="5" velocity="0.1"/></joint>
</robot>"""
    return RobotModel.from_strings(urdf, TWO_LINK_SRDF, package_dirs=[str(tmp_path)])


def test_the_mycobot_model_has_every_link_joint_servo_and_mimic_constraint(mycobot):
    built = build_model(mycobot, load_scene(config_file("mujoco_scene.yaml")), load_settings(config_file("mujoco_sim.yaml")))
    model = built.model
    bodies = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(model.nbody)}
    assert set(mycobot.links_with_collision_geometry()) <= bodies  # static links kept as bodies
    actuators = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a) for a in range(model.nu)]
    assert actuators == list(mycobot.group("arm").joint_names) + ["gripper_controller"]
    # the five mimic joints are joint equalities on gripper_controller with the URDF multipliers
    equalities = {}
    for e in range(model.neq):
        assert model.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT  # nothing welded: no attach in the simulator
        joint = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, model.eq_obj1id[e])
        source = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, model.eq_obj2id[e])
        equalities[joint] = (source, float(model.eq_data[e][1]))
    assert equalities == {name: ("gripper_controller", mycobot.joint(name).mimic.multiplier)
                          for name in mycobot.mimic_joint_names}
    # limits from the URDF, options and finger pads from config/mujoco_sim.yaml
    j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "link2_to_link3")
    assert model.jnt_range[j] == pytest.approx([-2.879793, 2.879793])
    assert model.opt.timestep == 0.001 and model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
    assert model.opt.impratio == 10.0
    pads = built.index.fingertip_geoms
    assert len(pads) == 2 and all(model.geom_condim[g] == 4 and model.geom_priority[g] == 1 for g in pads)


def test_the_srdf_disabled_pairs_are_contact_excludes(mycobot):
    built = build_model(mycobot, SimScene())
    excluded = {frozenset((mujoco.mj_id2name(built.model, mujoco.mjtObj.mjOBJ_BODY, b1),
                           mujoco.mj_id2name(built.model, mujoco.mjtObj.mjOBJ_BODY, b2)))
                for b1, b2 in zip(*np.divmod(built.model.exclude_signature, 1 << 16))}
    for a, b, _ in mycobot.srdf.disabled_collisions:
        assert frozenset((a, b)) in excluded, (a, b)


def test_the_scene_objects_have_their_mass_and_the_cylinder_is_free(mycobot):
    built = build_model(mycobot, load_scene(config_file("mujoco_scene.yaml")))
    model, index = built.model, built.index
    cylinder = index.object_bodies["object"]
    assert model.body_mass[cylinder] == pytest.approx(0.07)
    assert model.jnt_type[model.body_jntadr[cylinder]] == mujoco.mjtJoint.mjJNT_FREE
    assert model.body_jntnum[index.object_bodies["table"]] == 0  # fixed
    geom = index.object_geoms["object"]
    assert model.geom_size[geom][:2] == pytest.approx([0.0125, 0.175])


def test_the_mimic_joints_follow_the_gripper_joint(sim, mycobot):
    sim.command_gripper(-0.34)
    sim.advance(0.5)
    state = sim.joint_states().as_dict()
    for name in mycobot.mimic_joint_names:
        info = mycobot.joint(name).mimic
        assert state[name] == pytest.approx(info.multiplier * state[info.joint], abs=0.01), name
    assert state["gripper_controller"] == pytest.approx(-0.34, abs=0.01)


def test_a_robot_with_meshes_builds_and_holds_its_pose(panda):
    """The Panda's STL collision meshes load (its COLLADA visual meshes are not needed)."""
    settings = SimulationSettings(arm_group="arm", gripper_group="hand")
    start = {"panda_joint2": -0.5, "panda_joint4": -2.0, "panda_joint6": 1.5}
    with MujocoSimulator(panda, SimScene(), settings, camera=False, initial_positions=start) as simulator:
        assert simulator.model.nmesh >= 8
        simulator.advance(1.0)
        positions = dict(zip(simulator.arm_joints, simulator.arm_positions()))
        for name, value in start.items():
            assert positions[name] == pytest.approx(value, abs=0.005)


TETRAHEDRON = [(0, 0, 0), (0.05, 0, 0), (0, 0.05, 0), (0, 0, 0.05)]
FACES = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def ascii_stl() -> str:
    facets = "".join("facet normal 0 0 0\nouter loop\n" + "".join(
        "vertex {} {} {}\n".format(*TETRAHEDRON[i]) for i in face) + "endloop\nendfacet\n" for face in FACES)
    return f"solid part\n{facets}endsolid part\n"


def ascii_ply() -> str:
    header = ("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
              "element face 4\nproperty list uchar int vertex_indices\nend_header\n")
    return header + "".join("{} {} {}\n".format(*v) for v in TETRAHEDRON) + "".join(
        "3 {} {} {}\n".format(*f) for f in FACES)


@pytest.mark.parametrize("name,content,problem", [
    # PLY loads in the RobotModel (Coal reads it through assimp); MuJoCo has no PLY decoder
    ("part.ply", ascii_ply(), r"link 'arm_link': collision mesh 'part.ply' is a .ply file; MuJoCo reads STL, "
                              r"OBJ, MSH meshes only"),
    # an ASCII STL: the planning side reads it, MuJoCo decodes binary STL only
    ("part.stl", ascii_stl(), r"link 'arm_link': MuJoCo cannot read collision mesh 'part.stl'.*ASCII file"),
])
def test_a_mesh_mujoco_cannot_read_is_named(tmp_path, name, content, problem):
    (tmp_path / name).write_text(content)
    robot = two_link_robot(tmp_path, f'<mesh filename="{name}"/>')
    with pytest.raises(SimulationModelError, match=problem):
        build_model(robot, SimScene())


def test_a_mesh_gone_since_the_robot_model_loaded_is_named(tmp_path):
    (tmp_path / "part.obj").write_text("".join("v {} {} {}\n".format(*v) for v in TETRAHEDRON)
                                       + "".join("f {} {} {}\n".format(*(i + 1 for i in f)) for f in FACES))
    robot = two_link_robot(tmp_path, '<mesh filename="part.obj"/>')
    build_model(robot, SimScene())  # an OBJ mesh builds
    (tmp_path / "part.obj").unlink()
    with pytest.raises(SimulationModelError, match=r"link 'arm_link': collision mesh 'part.obj' not found at"):
        build_model(robot, SimScene())


def test_a_free_object_without_mass_is_refused_by_name():
    with pytest.raises(SimulationModelError, match=r"object 'cup' is a free body with mass 0"):
        SceneObject("cup", "cylinder", (0.1, 0.03), [0.2, 0.0, 0.05, 0, 0, 0], mass=0.0)
    SceneObject("shelf", "box", (0.1, 0.1, 0.1), [0.2, 0.0, 0.05, 0, 0, 0], fixed=True)  # fixed: no mass needed


def test_a_scene_file_with_a_massless_object_is_refused_naming_file_and_object(tmp_path):
    path = tmp_path / "scene.yaml"
    path.write_text("objects:\n  - {id: cup, shape: box, size: [0.05, 0.05, 0.05], pose: [0.2, 0, 0.025, 0, 0, 0]}\n")
    with pytest.raises(SimulationModelError, match=re.escape(f"{path}: object 'cup' is a free body with mass 0.0")):
        load_scene(path)


def test_a_moving_link_without_mass_is_named(tmp_path):
    robot = two_link_robot(tmp_path, '<box size="0.05 0.05 0.05"/>', mass=0.0)
    with pytest.raises(SimulationModelError, match=r"link 'arm_link' moves but has no mass"):
        build_model(robot, SimScene())


@pytest.mark.parametrize("text,problem", [
    ("objects:\n  - {id: a, shape: cone, radius: 1, pose: [0, 0, 0, 0, 0, 0]}\n", "shape must be one of"),
    ("objects:\n  - {id: a, shape: box, size: [0.1, 0.1], pose: [0, 0, 0, 0, 0, 0], fixed: true}\n", "needs 3 sizes"),
    ("objects:\n  - {id: a, shape: box, size: [0.1, 0.1, 0.1], fixed: true}\n", "no pose"),
    ("objects:\n  - {id: a, shape: sphere, radius: 0.1, pose: [0, 0, 1, 0, 0, 0], mass: 1, colour: red}\n",
     "unknown keys ['colour']"),
    ("table: {}\n", "unknown scene keys ['table']"),
    ("floor: {z: .nan}\n", "floor.z must be a finite number"),
    ("objects:\n  - {id: a, shape: sphere, radius: 0.1, pose: [0, 0, 1, 0, 0, 0], mass: 1}\n"
     "  - {id: a, shape: sphere, radius: 0.1, pose: [0, 0, 2, 0, 0, 0], mass: 1}\n", "two objects are named 'a'"),
])
def test_bad_scene_files_are_refused_with_the_reason(tmp_path, text, problem):
    path = tmp_path / "scene.yaml"
    path.write_text(text)
    with pytest.raises(SimulationModelError, match=re.escape(problem)):
        load_scene(path)


def test_an_object_named_like_a_link_is_refused(mycobot):
    scene = SimScene(objects=(SceneObject("link3", "sphere", (0.02,), [0.3, 0.3, 0.1, 0, 0, 0], mass=0.1),))
    with pytest.raises(SimulationModelError, match="object 'link3' has the name of a robot link"):
        build_model(mycobot, scene)


def test_settings_errors_name_the_key(tmp_path):
    path = tmp_path / "sim.yaml"
    path.write_text("mujoco_sim:\n  ros__parameters:\n    arm_servo: {bandwith_hz: 5}\n")
    with pytest.raises(SimulationModelError, match=r"mujoco_sim.arm_servo: unknown keys \['bandwith_hz'\]"):
        MujocoSimulator(RobotModel.mycobot(), SimScene(), path, camera=False)
    with pytest.raises(SimulationModelError, match="timestep must be >= 0.0002 and <= 0.002"):
        SimulationSettings(timestep=0.01)
    with pytest.raises(SimulationModelError, match="gripper_group: the robot has no group 'hand'"):
        build_model(RobotModel.mycobot(), SimScene(), SimulationSettings(gripper_group="hand"))
