"""Tests for interfaces_py.msgs: exact JSON round trips, validation errors, pose maths, no ROS."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from interfaces_py.msgs import (
    AllowedCollisionMatrix,
    AttachedCollisionObject,
    CollisionObject,
    JointTrajectory,
    JointTrajectoryPoint,
    Mesh,
    MessageError,
    MoveItErrorCode,
    PlanningScene,
    PlanningSceneWorld,
    Pose,
    RobotState,
    RobotTrajectory,
    SolidPrimitive,
)
from task_helpers import float_bits

AWKWARD = [0.1, 1e-300, -0.0, 1 / 3, 5e-324, 1.7976931348623157e308, -2.5e-17, 123456789.123456789]


def _bits(value) -> list[str]:
    return float_bits(value)


def _awkward_pose() -> Pose:
    return Pose(position=[0.1, 1e-300, -0.0], orientation=[0.1, -0.0, 1e-300, 1 / 3])


def _scene() -> PlanningScene:
    box = CollisionObject.box("box", [0.1, 1e-300, 1 / 3], Pose.from_xyz_rpy([0.3, -0.0, 0.1], [0.1, 0.2, 0.3]))
    mixed = CollisionObject(
        id="mixed",
        frame_id="base",
        pose=_awkward_pose(),
        primitives=[SolidPrimitive.cylinder(0.2, 0.05), SolidPrimitive.cone(0.1, 5e-324)],
        primitive_poses=[Pose(), _awkward_pose()],
        meshes=[
            Mesh.from_file("package://mycobot_description/meshes/part.dae", [0.001, 0.001, 0.001]),
            Mesh.from_triangles([[0, 0, 0], [0.1, 0, 0], [0, 0.1, -0.0]], [[0, 1, 2]]),
        ],
        mesh_poses=[Pose(), Pose.from_xyz_rpy([1, 2, 3], [0, 0, 1])],
        operation=CollisionObject.APPEND,
    )
    held = AttachedCollisionObject(
        "link6_flange", CollisionObject.sphere("ball", 0.02), touch_links=["gripper_left", "gripper_right"], weight=0.1
    )
    acm = AllowedCollisionMatrix(
        entry_names=["a", "b"], entry_values=[[False, True], [True, False]],
        default_entry_names=["octomap"], default_entry_values=[True],
    )
    state = RobotState(
        joint_names=["j1", "j2", "j3"], positions=[0.1, -0.0, 1e-300], velocities=[0.0, 1 / 3, -2.5e-17],
        attached_collision_objects=[held],
    )
    return PlanningScene(
        name="kitchen", robot_model_name="mycobot_280", robot_state=state,
        world=PlanningSceneWorld([box, mixed]), allowed_collision_matrix=acm, is_diff=True,
    )


def _trajectory() -> JointTrajectory:
    return JointTrajectory(
        joint_names=["j1", "j2"],
        points=[
            JointTrajectoryPoint([0.0, -0.0]),
            JointTrajectoryPoint([0.1, 1e-300], [1 / 3, 0.0], [0.0, 5e-324], time_from_start=0.1),
            JointTrajectoryPoint([0.2, 0.3], time_from_start=0.1),  # equal times are allowed
            JointTrajectoryPoint([0.3, 0.4], time_from_start=123456.789012345),
        ],
        frame_id="world",
    )


SAMPLES = [
    Pose(),
    _awkward_pose(),
    Pose(position=AWKWARD[:3], orientation=[1e-5, 2e-5, 3e-5, 4e-5]),
    SolidPrimitive.box(0.1, 1e-300, 99.99999999999999),  # awkward but within MAX_OBJECT_EXTENT
    SolidPrimitive.sphere(5e-324),
    SolidPrimitive.cylinder(1 / 3, 0.1),
    SolidPrimitive.cone(0.1, 0.2),
    Mesh(resource="/tmp/part.stl"),
    Mesh.from_triangles([[0.1, -0.0, 1e-300], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2], [0, 2, 3]], [2, 2, 2]),
    CollisionObject.box("box", [0.1, 0.2, 0.3]),
    CollisionObject(id="gone", operation=CollisionObject.REMOVE),
    CollisionObject(id="moved", pose=_awkward_pose(), operation=CollisionObject.MOVE),
    _scene().world.collision_objects[1],
    _scene().robot_state.attached_collision_objects[0],
    _scene().allowed_collision_matrix,
    AllowedCollisionMatrix(),
    _scene().robot_state,
    RobotState(),
    PlanningSceneWorld(),
    _scene(),
    PlanningScene(),
    JointTrajectoryPoint(AWKWARD, time_from_start=1e-300),
    _trajectory(),
    JointTrajectory([], []),
    RobotTrajectory(_trajectory(), group_name="arm_group"),
    MoveItErrorCode(),
    MoveItErrorCode(MoveItErrorCode.NO_IK_SOLUTION, "no solution for 'link6_flange'", "ik"),
]


# ---- round trips ---------------------------------------------------------------------


@pytest.mark.parametrize("msg", SAMPLES, ids=lambda m: type(m).__name__)
def test_json_round_trip_is_exact(msg):
    text = msg.to_json()
    back = type(msg).from_json(text)
    assert back == msg
    assert _bits(back.to_dict()) == _bits(msg.to_dict())  # bit-identical floats, -0.0 included
    assert back.to_json() == text
    assert type(msg).from_dict(msg.to_dict()) == msg
    assert json.loads(text) == msg.to_dict()


def test_every_message_class_has_a_round_trip_sample():
    import interfaces_py.msgs as msgs

    classes = {getattr(msgs, n) for n in msgs.__all__ if n != "MessageError"}
    assert classes == {type(m) for m in SAMPLES}


def test_negative_zero_and_tiny_values_survive():
    p = Pose.from_json(Pose(position=[-0.0, 1e-300, 5e-324]).to_json())
    assert math.copysign(1.0, p.position[0]) == -1.0
    assert p.position[1] == 1e-300 and p.position[2] == 5e-324


def test_nested_round_trip_keeps_structure():
    scene = PlanningScene.from_json(_scene().to_json())
    obj = scene.world.collision_objects[1]
    assert isinstance(obj.pose, Pose) and isinstance(obj.meshes[1], Mesh)
    assert obj.meshes[1].triangles == [[0, 1, 2]]
    assert scene.robot_state.attached_collision_objects[0].object.primitives[0].dimensions == [0.02]
    assert scene.allowed_collision_matrix.is_allowed("a", "b")


def test_from_dict_fills_defaults_and_accepts_json_ints():
    obj = CollisionObject.from_dict({"id": "b", "primitives": [{"type": 1, "dimensions": [1, 2, 3]}],
                                     "primitive_poses": [{}]})
    assert obj.frame_id == "world" and obj.operation == CollisionObject.ADD and obj.pose == Pose()
    assert obj.primitives[0].dimensions == [1.0, 2.0, 3.0]
    assert all(type(d) is float for d in obj.primitives[0].dimensions)


def test_numpy_inputs_become_plain_python_values():
    p = Pose(position=np.array([1.0, 2.0, 3.0]), orientation=np.array([0, 0, 0, 1], dtype=np.float32))
    assert p.position == [1.0, 2.0, 3.0] and all(type(v) is float for v in p.position + p.orientation)
    import array

    assert RobotState(joint_names=("a",), positions=array.array("d", [0.5])).positions == [0.5]
    with pytest.raises(MessageError, match="expected a list"):
        Pose(position=np.float64(1.0))
    tri = Mesh.from_triangles(np.eye(3), np.array([[0, 1, 2]]))
    assert type(tri.triangles[0][0]) is int
    json.loads(tri.to_json())


def test_constructor_copies_caller_lists():
    xyz = [1.0, 2.0, 3.0]
    p = Pose(position=xyz)
    xyz[0] = 99.0
    assert p.position[0] == 1.0


# ---- generic validation --------------------------------------------------------------


@pytest.mark.parametrize(
    "cls, data, field, words",
    [
        (CollisionObject, {"frame_id": "world"}, "CollisionObject.id", "missing"),
        (JointTrajectory, {"joint_names": ["a"]}, "JointTrajectory.points", "missing"),
        (AttachedCollisionObject, {"link_name": "l"}, "AttachedCollisionObject.object", "missing"),
        (Pose, {"position": [0, 0, 0], "orientaton": [0, 0, 0, 1]}, "Pose.orientaton", "unknown field"),
        (Pose, {"position": [0, "1", 0]}, "Pose.position[1]", "expected a number"),
        (Pose, {"position": 5}, "Pose.position", "expected a list"),
        (Pose, {"position": [0, True, 0]}, "Pose.position[1]", "expected a number"),
        (Pose, {"position": [0, float("nan"), 0]}, "Pose.position[1]", "finite"),
        (Pose, {"position": [0, 0, float("inf")]}, "Pose.position[2]", "finite"),
        (Pose, {"position": [0, 0]}, "Pose.position", "expected 3"),
        (Pose, {"orientation": [0, 0, 1]}, "Pose.orientation", "expected 4"),
        (Pose, {"orientation": [0, 0, 0, 0]}, "Pose.orientation", "norm"),
        (Pose, {"orientation": [1e-10, 0, 0, 0]}, "Pose.orientation", "norm"),
        (SolidPrimitive, {"type": 1.0, "dimensions": [1, 1, 1]}, "SolidPrimitive.type", "integer"),
        (SolidPrimitive, {"type": 5, "dimensions": [1, 1, 1]}, "SolidPrimitive.type", "unknown primitive type 5"),
        (SolidPrimitive, {"type": 1, "dimensions": [1, 1]}, "SolidPrimitive.dimensions", "expected 3"),
        (SolidPrimitive, {"type": 2, "dimensions": [1, 1]}, "SolidPrimitive.dimensions", "expected 1"),
        (SolidPrimitive, {"type": 3, "dimensions": [1]}, "SolidPrimitive.dimensions", "expected 2"),
        (SolidPrimitive, {"type": 1, "dimensions": [1, 0, 1]}, "SolidPrimitive.dimensions[1]", "> 0"),
        (SolidPrimitive, {"type": 4, "dimensions": [1, -1]}, "SolidPrimitive.dimensions[1]", "> 0"),
        (Mesh, {}, "Mesh.triangles", "empty"),
        (Mesh, {"resource": "a.stl", "vertices": [[0, 0, 0]], "triangles": [[0, 0, 0]]}, "Mesh", "not both"),
        (Mesh, {"resource": "   "}, "Mesh.resource", "blank"),
        (Mesh, {"resource": "a.stl", "scale": [1, 0, 1]}, "Mesh.scale[1]", "> 0"),
        (Mesh, {"resource": "a.stl", "scale": [1, 1]}, "Mesh.scale", "expected 3"),
        (Mesh, {"vertices": [[0, 0, 0], [1, 0, 0]], "triangles": [[0, 1, 2]]}, "Mesh.triangles[0]", "out of range"),
        (Mesh, {"vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "triangles": [[0, -1, 2]]}, "Mesh.triangles[0]",
         "out of range"),
        (Mesh, {"vertices": [[0, 0], [1, 0, 0], [0, 1, 0]], "triangles": [[0, 1, 2]]}, "Mesh.vertices[0]",
         "expected 3"),
        (Mesh, {"vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "triangles": [[0, 1]]}, "Mesh.triangles[0]",
         "expected 3"),
        (CollisionObject, {"id": "", "operation": 1}, "CollisionObject.id", "non-empty"),
        (CollisionObject, {"id": "a", "frame_id": "", "operation": 1}, "CollisionObject.frame_id", "non-empty"),
        (CollisionObject, {"id": "a", "operation": 4}, "CollisionObject.operation", "unknown operation 4"),
        (CollisionObject, {"id": "a"}, "CollisionObject.primitives", "ADD needs at least one"),
        (CollisionObject, {"id": "a", "operation": 2}, "CollisionObject.primitives", "APPEND needs at least one"),
        (CollisionObject, {"id": "a", "primitives": [{"type": 2, "dimensions": [1]}]},
         "CollisionObject.primitive_poses", "0 poses for 1 primitives"),
        (CollisionObject, {"id": "a", "meshes": [{"resource": "x.stl"}], "mesh_poses": [{}, {}]},
         "CollisionObject.mesh_poses", "2 poses for 1 meshes"),
        (CollisionObject, {"id": "a", "primitives": [{"type": 2, "dimensions": [0]}], "primitive_poses": [{}]},
         "CollisionObject.primitives[0].dimensions[0]", "> 0"),
        (CollisionObject, {"id": "a", "pose": [0, 0, 0]}, "CollisionObject.pose", "expected Pose or a dict"),
        (AttachedCollisionObject, {"link_name": "", "object": {"id": "a", "operation": 1}},
         "AttachedCollisionObject.link_name", "non-empty"),
        (AttachedCollisionObject, {"link_name": "l", "object": {"id": "a", "operation": 1}, "weight": -1},
         "AttachedCollisionObject.weight", ">= 0"),
        (AttachedCollisionObject, {"link_name": "l", "object": {"id": "a", "operation": 1}, "touch_links": [1]},
         "AttachedCollisionObject.touch_links[0]", "expected a string"),
        (AllowedCollisionMatrix, {"entry_names": ["a", "b"], "entry_values": [[True, False]]},
         "AllowedCollisionMatrix.entry_values", "expected 2 rows"),
        (AllowedCollisionMatrix, {"entry_names": ["a", "b"], "entry_values": [[True, False], [False]]},
         "AllowedCollisionMatrix.entry_values[1]", "expected 2 columns"),
        (AllowedCollisionMatrix, {"entry_names": ["a", "b"], "entry_values": [[True, True], [False, True]]},
         "AllowedCollisionMatrix.entry_values", "not symmetric for ('a', 'b')"),
        (AllowedCollisionMatrix, {"entry_names": ["a", "a"], "entry_values": [[True, True], [True, True]]},
         "AllowedCollisionMatrix.entry_names", "duplicate"),
        (AllowedCollisionMatrix, {"entry_names": ["a"], "entry_values": [[1]]},
         "AllowedCollisionMatrix.entry_values[0][0]", "true/false"),
        (AllowedCollisionMatrix, {"default_entry_names": ["a"], "default_entry_values": []},
         "AllowedCollisionMatrix.default_entry_values", "expected 1"),
        (RobotState, {"joint_names": ["a", "b"], "positions": [0.0]}, "RobotState.positions", "expected 2"),
        (RobotState, {"joint_names": ["a"], "positions": [0.0], "velocities": [0, 0]}, "RobotState.velocities",
         "expected 1"),
        (RobotState, {"joint_names": ["a", "a"], "positions": [0, 0]}, "RobotState.joint_names", "duplicate"),
        (RobotState, {"joint_names": [""], "positions": [0]}, "RobotState.joint_names[0]", "non-empty"),
        (RobotState, {"is_diff": 1}, "RobotState.is_diff", "true/false"),
        (PlanningScene, {"robot_state": {"joint_names": ["a"], "positions": [float("nan")]}},
         "PlanningScene.robot_state.positions[0]", "finite"),
        (PlanningScene, {"world": {"collision_objects": [{"id": "x", "pose": {"orientation": [0, 0, 0, 0]},
                                                          "operation": 3}]}},
         "PlanningScene.world.collision_objects[0].pose.orientation", "norm"),
        (JointTrajectoryPoint, {"positions": [0, 0], "velocities": [0]}, "JointTrajectoryPoint.velocities",
         "expected 2"),
        (JointTrajectoryPoint, {"positions": [0], "accelerations": [0, 0]}, "JointTrajectoryPoint.accelerations",
         "expected 1"),
        (JointTrajectoryPoint, {"positions": [0], "time_from_start": -0.1}, "JointTrajectoryPoint.time_from_start",
         ">= 0"),
        (JointTrajectory, {"joint_names": ["a", "b"], "points": [{"positions": [0]}]},
         "JointTrajectory.points[0].positions", "expected 2"),
        (JointTrajectory, {"joint_names": ["a"], "points": [{"positions": [0], "time_from_start": 1.0},
                                                             {"positions": [0], "time_from_start": 0.5}]},
         "JointTrajectory.points[1].time_from_start", "earlier"),
        (JointTrajectory, {"joint_names": ["a"], "points": [{"positions": [float("inf")]}]},
         "JointTrajectory.points[0].positions[0]", "finite"),
        (RobotTrajectory, {"joint_trajectory": {"joint_names": ["a"], "points": []}, "group_name": 3},
         "RobotTrajectory.group_name", "expected a string"),
        (MoveItErrorCode, {"val": 42}, "MoveItErrorCode.val", "unknown MoveIt error code 42"),
    ],
)
def test_validation_names_field_and_problem(cls, data, field, words):
    with pytest.raises(MessageError) as info:
        cls.from_dict(data)
    assert info.value.field == field
    assert words in info.value.problem
    assert str(info.value).startswith(field + ":")
    assert isinstance(info.value, ValueError)


def test_direct_construction_is_validated_too():
    with pytest.raises(MessageError, match=r"^SolidPrimitive\.dimensions\[0\]: BOX x must be > 0"):
        SolidPrimitive.box(-1, 1, 1)
    with pytest.raises(MessageError, match=r"^Pose\.position\[0\]: must be finite, got nan"):
        Pose(position=[math.nan, 0, 0])
    with pytest.raises(MessageError, match=r"^JointTrajectoryPoint\.positions: expected a list"):
        JointTrajectoryPoint(positions="abc")


@pytest.mark.parametrize(
    "text, words",
    [
        ("{", "malformed JSON"),
        ("", "malformed JSON"),
        ('{"position": [0, 0, 0],}', "malformed JSON"),
        (b"\xff\xfe\x00", "malformed JSON"),
        ("[1, 2, 3]", "expected a JSON object"),
        ("null", "expected a JSON object"),
    ],
)
def test_malformed_json(text, words):
    with pytest.raises(MessageError, match=words) as info:
        Pose.from_json(text)
    assert info.value.field == "Pose"


def test_json_nan_literal_and_non_text_rejected():
    with pytest.raises(MessageError, match=r"Pose\.position\[0\]: must be finite"):
        Pose.from_json('{"position": [NaN, 0, 0]}')
    with pytest.raises(MessageError, match="expected JSON text"):
        Pose.from_json({"position": [0, 0, 0]})


def test_to_json_is_compact_and_ordered_like_the_fields():
    assert Pose().to_json() == '{"position":[0.0,0.0,0.0],"orientation":[0.0,0.0,0.0,1.0]}'
    names = [f.name for f in dataclasses.fields(CollisionObject)]
    assert list(json.loads(CollisionObject.box("b", [1, 1, 1]).to_json())) == names


# ---- Pose ----------------------------------------------------------------------------


def _rot(axis: str, a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return {
        "x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
        "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
        "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]),
    }[axis]


def test_pose_normalises_quaternion_and_normalisation_is_idempotent():
    p = Pose(orientation=[0, 0, 2, 2])
    assert p.orientation == pytest.approx([0, 0, math.sqrt(0.5), math.sqrt(0.5)], abs=1e-15)
    rng = np.random.default_rng(7)
    for _ in range(500):
        q = Pose(orientation=rng.normal(size=4) * 10 ** rng.uniform(-8, 8))
        assert Pose(orientation=q.orientation).orientation == q.orientation
        assert math.hypot(*q.orientation) == pytest.approx(1.0, abs=1e-15)


def test_pose_identity_and_matrix():
    assert Pose.identity() == Pose() and np.array_equal(Pose.identity().to_matrix(), np.eye(4))
    T = Pose(position=[1, 2, 3], orientation=[0, 0, math.sin(0.25), math.cos(0.25)]).to_matrix()
    expected = np.eye(4)
    expected[:3, :3] = _rot("z", 0.5)
    expected[:3, 3] = [1, 2, 3]
    np.testing.assert_allclose(T, expected, atol=1e-15)


def test_from_xyz_rpy_is_fixed_axis_like_urdf():
    r, p, y = 0.3, -1.1, 2.5
    pose = Pose.from_xyz_rpy([0.1, 0.2, 0.3], [r, p, y])
    np.testing.assert_allclose(pose.to_matrix()[:3, :3], _rot("z", y) @ _rot("y", p) @ _rot("x", r), atol=1e-14)
    np.testing.assert_array_equal(pose.to_matrix()[:3, 3], [0.1, 0.2, 0.3])
    with pytest.raises(MessageError, match=r"rpy.*expected 3"):
        Pose.from_xyz_rpy([0, 0, 0], [0, 0])


@pytest.mark.parametrize("seed", range(20))
def test_from_matrix_inverts_to_matrix(seed):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=4)
    if seed < 4:  # exercise every branch of Shepperd's method (each axis dominant, 180° turns)
        q = np.eye(4)[seed] + 1e-3 * rng.normal(size=4)
    pose = Pose(position=rng.normal(size=3), orientation=q)
    T = pose.to_matrix()
    back = Pose.from_matrix(T)
    np.testing.assert_allclose(back.to_matrix(), T, atol=1e-13)
    assert abs(np.dot(back.orientation, pose.orientation)) == pytest.approx(1.0, abs=1e-13)


def test_from_matrix_rejects_non_rigid_input():
    with pytest.raises(MessageError, match=r"Pose\.from_matrix\(T\): expected shape \(4, 4\)"):
        Pose.from_matrix(np.eye(3))
    bad = np.eye(4)
    bad[0, 0] = 2.0
    with pytest.raises(MessageError, match="not a proper rotation"):
        Pose.from_matrix(bad)
    mirror = np.diag([1.0, 1.0, -1.0, 1.0])
    with pytest.raises(MessageError, match="not a proper rotation"):
        Pose.from_matrix(mirror)
    nan = np.eye(4)
    nan[0, 3] = np.nan
    with pytest.raises(MessageError, match="finite"):
        Pose.from_matrix(nan)
    skew = np.eye(4)
    skew[3, 0] = 1.0
    with pytest.raises(MessageError, match="bottom row"):
        Pose.from_matrix(skew)


def test_compose_matches_matrix_product():
    a = Pose.from_xyz_rpy([1, 2, 3], [0.3, -0.2, 1.0])
    b = Pose.from_xyz_rpy([0.1, 0, -0.2], [0, 0.5, -0.7])
    np.testing.assert_allclose(a.compose(b).to_matrix(), a.to_matrix() @ b.to_matrix(), atol=1e-14)


# ---- class specifics ------------------------------------------------------------------


def test_solid_primitive_constants_and_constructors():
    assert (SolidPrimitive.BOX, SolidPrimitive.SPHERE, SolidPrimitive.CYLINDER, SolidPrimitive.CONE) == (1, 2, 3, 4)
    assert (SolidPrimitive.BOX_X, SolidPrimitive.BOX_Y, SolidPrimitive.BOX_Z, SolidPrimitive.SPHERE_RADIUS) == (
        0, 1, 2, 0)
    assert (SolidPrimitive.CYLINDER_HEIGHT, SolidPrimitive.CYLINDER_RADIUS) == (0, 1)
    assert (SolidPrimitive.CONE_HEIGHT, SolidPrimitive.CONE_RADIUS) == (0, 1)
    cyl = SolidPrimitive.cylinder(height=0.4, radius=0.05)
    assert cyl == SolidPrimitive(3, [0.4, 0.05]) and cyl.type_name == "CYLINDER"
    assert cyl.dimensions[SolidPrimitive.CYLINDER_RADIUS] == 0.05
    assert SolidPrimitive.cone(0.3, 0.1).dimensions[SolidPrimitive.CONE_HEIGHT] == 0.3
    assert SolidPrimitive.box(1, 2, 3).dimensions[SolidPrimitive.BOX_Z] == 3.0
    assert SolidPrimitive.sphere(0.5) == SolidPrimitive(SolidPrimitive.SPHERE, [0.5])
    assert {f.name for f in dataclasses.fields(SolidPrimitive)} == {"type", "dimensions"}


def test_collision_object_convenience_constructors():
    T = Pose.from_xyz_rpy([0.2, 0.0, 0.1], [0, 0, 0.5]).to_matrix()
    box = CollisionObject.box("b", (0.1, 0.2, 0.3), T, frame_id="base")
    assert box.frame_id == "base" and box.operation == CollisionObject.ADD
    np.testing.assert_allclose(box.pose.to_matrix(), T, atol=1e-15)
    assert box.primitives == [SolidPrimitive.box(0.1, 0.2, 0.3)] and box.primitive_poses == [Pose()]
    cyl = CollisionObject.cylinder("c", 0.5, 0.02)
    assert cyl.primitives[0].dimensions == [0.5, 0.02] and cyl.pose == Pose() and cyl.frame_id == "world"
    assert CollisionObject.sphere("s", 0.1, Pose(position=[1, 0, 0])).pose.position == [1.0, 0.0, 0.0]
    mesh = CollisionObject.mesh("m", "package://pkg/m.stl", scale=(2, 2, 2))
    assert mesh.meshes[0].resource == "package://pkg/m.stl" and mesh.mesh_poses == [Pose()]
    assert (CollisionObject.ADD, CollisionObject.REMOVE, CollisionObject.APPEND, CollisionObject.MOVE) == (
        0, 1, 2, 3)
    assert CollisionObject(id="x", operation=CollisionObject.MOVE).operation_name == "MOVE"
    with pytest.raises(MessageError, match=r"CollisionObject\.pose: .*proper rotation"):
        CollisionObject.box("b", (1, 1, 1), np.diag([2.0, 2.0, 2.0, 1.0]))
    with pytest.raises(MessageError, match=r"CollisionObject\.box\(size\): expected 3"):
        CollisionObject.box("b", (1, 1))


def test_acm_lookup_and_set_allowed():
    acm = AllowedCollisionMatrix(default_entry_names=["octomap"], default_entry_values=[True])
    assert not acm.is_allowed("a", "b")
    assert acm.is_allowed("a", "octomap")  # default entry: octomap may touch anything
    acm.set_allowed("a", "b")
    acm.set_allowed("c", "a")
    acm.set_allowed("c", "a", False)
    assert acm.is_allowed("b", "a") and not acm.is_allowed("a", "c")
    assert acm.entry_names == ["a", "b", "c"]
    assert AllowedCollisionMatrix.from_json(acm.to_json()) == acm  # still square and symmetric


def test_robot_state_helpers():
    s = RobotState.from_joint_positions({"j1": 0.5, "j2": -1})
    assert s.joint_positions() == {"j1": 0.5, "j2": -1.0} and s.velocities == []
    with pytest.raises(MessageError, match="duplicate object id"):
        ball = AttachedCollisionObject("l", CollisionObject.sphere("ball", 0.1))
        RobotState(attached_collision_objects=[ball, ball])


def test_trajectory_duration():
    assert _trajectory().duration == 123456.789012345
    assert JointTrajectory(["a"], []).duration == 0.0


def test_moveit_error_code():
    expected = {
        "SUCCESS": 1, "UNDEFINED": 0, "FAILURE": 99999, "PLANNING_FAILED": -1, "INVALID_MOTION_PLAN": -2,
        "MOTION_PLAN_INVALIDATED_BY_ENVIRONMENT_CHANGE": -3, "CONTROL_FAILED": -4,
        "UNABLE_TO_AQUIRE_SENSOR_DATA": -5, "TIMED_OUT": -6, "PREEMPTED": -7, "START_STATE_IN_COLLISION": -10,
        "START_STATE_VIOLATES_PATH_CONSTRAINTS": -11, "GOAL_IN_COLLISION": -12,
        "GOAL_VIOLATES_PATH_CONSTRAINTS": -13, "GOAL_CONSTRAINTS_VIOLATED": -14, "INVALID_GROUP_NAME": -15,
        "INVALID_GOAL_CONSTRAINTS": -16, "INVALID_ROBOT_STATE": -17, "INVALID_LINK_NAME": -18,
        "INVALID_OBJECT_NAME": -19, "FRAME_TRANSFORM_FAILURE": -21, "COLLISION_CHECKING_UNAVAILABLE": -22,
        "ROBOT_STATE_STALE": -23, "SENSOR_INFO_STALE": -24, "COMMUNICATION_FAILURE": -25,
        "START_STATE_INVALID": -26, "GOAL_STATE_INVALID": -27, "UNRECOGNIZED_GOAL_TYPE": -28, "CRASH": -29,
        "ABORT": -30, "NO_IK_SOLUTION": -31,
    }
    for name, val in expected.items():
        assert getattr(MoveItErrorCode, name) == val
        code = MoveItErrorCode(val)
        assert code.name == name and MoveItErrorCode.from_name(name) == code
        assert bool(code) == (name == "SUCCESS")
    assert MoveItErrorCode().name == "SUCCESS" and MoveItErrorCode()
    err = MoveItErrorCode.from_name("NO_IK_SOLUTION", "target out of reach", source="ik")
    assert str(err) == "NO_IK_SOLUTION: target out of reach" and not err and err.source == "ik"
    assert str(MoveItErrorCode.from_name("TIMED_OUT")) == "TIMED_OUT"
    for bad in ("NOT_A_CODE", "name", "_NAMES", "SUCCESS ", 5):
        with pytest.raises(MessageError, match="unknown MoveIt error code name"):
            MoveItErrorCode.from_name(bad)
    with pytest.raises(MessageError, match=r"MoveItErrorCode\.val: unknown MoveIt error code -8"):
        MoveItErrorCode(-8)


# ---- no ROS ----------------------------------------------------------------------------


def test_import_pulls_no_ros():
    root = Path(__file__).resolve().parents[2]
    code = (
        "import sys, interfaces_py, interfaces_py.msgs\n"
        "bad = sorted(m for m in sys.modules if m.split('.')[0] in "
        "('rclpy', 'geometry_msgs', 'std_msgs', 'shape_msgs', 'sensor_msgs', 'trajectory_msgs',"
        " 'visualization_msgs', 'builtin_interfaces', 'interfaces_py.ros_conversions'))\n"
        "assert 'interfaces_py.ros_conversions' not in sys.modules\n"
        "print(bad)\n"
    )
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")]))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_package_exports_msgs_names():
    import interfaces_py
    import interfaces_py.msgs as msgs

    assert set(interfaces_py.__all__) == set(msgs.__all__)
    for name in interfaces_py.__all__:
        assert getattr(interfaces_py, name) is getattr(msgs, name)


# ---------------------------------------------------------------------------- trajectories from arrays
def test_joint_trajectory_from_arrays_equals_the_point_by_point_message():
    rng = np.random.default_rng(4)
    times, positions, velocities = np.linspace(0.0, 1.0, 7), rng.normal(size=(7, 3)), rng.normal(size=(7, 3))
    names = ["a", "b", "c"]
    fast = JointTrajectory.from_arrays(names, times, positions, velocities)
    slow = JointTrajectory(joint_names=names, points=[
        JointTrajectoryPoint(positions=list(p), velocities=list(v), time_from_start=float(t))
        for t, p, v in zip(times, positions, velocities)])
    assert fast == slow and fast.to_dict() == slow.to_dict()
    with_acc = JointTrajectory.from_arrays(names, times, positions, velocities, positions * 2)
    assert with_acc.points[2].accelerations == list(positions[2] * 2)


@pytest.mark.parametrize("change, words", [
    (lambda a: a.update(positions=a["positions"][:, :2]), "positions: expected shape"),
    (lambda a: a["velocities"].__setitem__((1, 1), np.nan), "velocities: must be finite"),
    (lambda a: a["times"].__setitem__(3, 0.0), "non-decreasing"),
    (lambda a: a["times"].__setitem__(0, -1.0), ">= 0"),
])
def test_joint_trajectory_from_arrays_refuses_what_the_constructor_refuses(change, words):
    arrays = {"times": np.linspace(0.0, 1.0, 5), "positions": np.zeros((5, 3)), "velocities": np.zeros((5, 3))}
    change(arrays)
    with pytest.raises(MessageError, match=words):
        JointTrajectory.from_arrays(["a", "b", "c"], arrays["times"], arrays["positions"], arrays["velocities"])
    with pytest.raises(MessageError, match="duplicate name"):
        JointTrajectory.from_arrays(["a", "a", "c"], arrays["times"], np.zeros((5, 3)), np.zeros((5, 3)))


def test_pose_checks_keep_np_allclose_tolerances():
    """Pose.from_matrix and core.transforms.is_pose test each entry against np.allclose's
    tolerances without calling it (it cost ~20 us a call): on 20,000 poses with entries nudged by
    1e-9 to 1e-3 they accept exactly the matrices the np.allclose definitions accept."""
    import numpy as np
    from scipy.spatial.transform import Rotation

    from interfaces_py.msgs import Pose
    from mycobot_planning.core.transforms import is_pose, make_pose

    rng = np.random.default_rng(1)
    accepted = 0
    for k in range(20000):
        T = make_pose(rng.normal(size=3), quat_xyzw=Rotation.random(random_state=k).as_quat())
        T = T + rng.choice([0.0, 1e-9, 1e-7, 3e-6, 1e-5, 1e-3], size=(4, 4)) * (rng.random((4, 4)) < 0.15)
        rot = T[:3, :3]
        proper = np.linalg.det(rot) > 0
        assert is_pose(T) == bool(np.allclose(rot @ rot.T, np.eye(3), atol=1e-6) and proper
                                  and np.allclose(T[3], [0.0, 0.0, 0.0, 1.0]))
        expected = bool(np.allclose(T[3], [0, 0, 0, 1], atol=1e-9) and np.allclose(rot.T @ rot, np.eye(3), atol=1e-6)
                        and proper)
        try:
            Pose.from_matrix(T)
            converted = True
        except ValueError:
            converted = False
        assert converted == expected
        accepted += expected
    assert 1000 < accepted < 19000
