"""The batch sphere test (collision_detection/batch_check.py) never calls a colliding state free.

Judged by the plain exact check (CompiledScene.collides_all_pairs) on random states of the
myCobot, the Panda (its arm and, with the prismatic fingers, arm_and_hand), the UR5 and the
xArm7 (mesh links) among boxes, cylinders, spheres and a mesh; with an attached object; and on
the peers bench's plan problems, whose every path must pass the exact trajectory validator.
"""
from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import pytest

from interfaces_py.msgs import CollisionObject, Mesh, Pose
from mycobot_planning.bench.peers.parts import OursParts
from mycobot_planning.bench.peers.problems import panda_parts_problems
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.collision_detection.batch_check import joint_tables, numba_available
from mycobot_planning.core.collision_detection.sphere_cover import enclosing_spheres
from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest
from mycobot_planning.core.planners.ompl.solve import _bisection_order, _edge_fractions, _edge_valid
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory
from mycobot_planning.core.transforms import make_pose
from mycobot_planning.paths import example_robot_data_dir

pytestmark = pytest.mark.skipif(not numba_available(), reason="numba is not installed (scripts/requirements.txt)")


def _erd(description: str, urdf: str, srdf: str) -> RobotModel:
    root = example_robot_data_dir() / description
    return RobotModel.from_files(root / "urdf" / urdf, root / "srdf" / srdf)


def _obstacles(scene: PlanningScene, reach: float, height: float = 0.0) -> None:
    """A box, a cylinder, a sphere and a small mesh (a tetrahedron) around the robot."""
    scene.add_object(CollisionObject.box("box", [0.3 * reach, 0.3 * reach, 0.3 * reach],
                                         make_pose([0.55 * reach, 0.1 * reach, height + 0.3 * reach])))
    scene.add_object(CollisionObject.cylinder("cylinder", 0.6 * reach, 0.08 * reach,
                                              make_pose([-0.4 * reach, 0.4 * reach, height + 0.3 * reach])))
    scene.add_object(CollisionObject.sphere("sphere", 0.12 * reach, make_pose([0.0, -0.5 * reach, height + 0.6 * reach])))
    s = 0.2 * reach
    mesh = Mesh(vertices=[[0, 0, 0], [s, 0, 0], [0, s, 0], [0, 0, s]], triangles=[[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]])
    scene.add_object(CollisionObject("mesh", pose=Pose.from_matrix(make_pose([-0.5 * reach, -0.3 * reach, height + 0.5 * reach])),
                                     meshes=[mesh], mesh_poses=[Pose()]))


def _agreement(scene: PlanningScene, group: str | np.ndarray, count: int, seed: int = 1) -> tuple[int, int]:
    """(states called free by the batch test, of those the exact check finds colliding)."""
    model = scene.robot_model
    start = scene.current_state
    free_of = scene.batch_free_checker(group, start)
    assert free_of is not None
    indices = model.group(group).variable_indices if isinstance(group, str) else np.asarray(group)
    low = np.where(np.isfinite(model.lower_limits[indices]), model.lower_limits[indices], -np.pi)
    high = np.where(np.isfinite(model.upper_limits[indices]), model.upper_limits[indices], np.pi)
    values = np.random.default_rng(seed).uniform(low, high, (count, len(indices)))
    free = free_of(values)
    exact = scene.colliding_rows(group, start, values[free], all_pairs=True)
    return int(free.sum()), int(exact.sum())


@pytest.mark.parametrize("robot, group, reach", [
    ("mycobot", "arm", 0.3),
    ("panda", "arm", 0.8),
    ("panda", "arm_and_hand", 0.8),  # prismatic finger joints
    ("ur5", None, 0.9),  # with its gripper; its SRDF has no groups: every variable
    ("xarm7", None, 0.7),
])
def test_no_state_the_exact_check_finds_colliding_is_called_free(robot, group, reach, mycobot, panda):
    model = {"mycobot": mycobot, "panda": panda}.get(robot)
    if robot == "ur5":
        model = _erd("ur_description", "ur5_gripper.urdf", "ur5_gripper.srdf")
    elif robot == "xarm7":
        model = _erd("xarm_description", "xarm7.urdf", "xarm7.srdf")
    group = group or (model.group_names[0] if model.group_names else np.arange(len(model.variable_names)))
    scene = PlanningScene(model)
    _obstacles(scene, reach)
    count = 10_000 if robot in ("mycobot", "panda") and isinstance(group, str) and group == "arm" else 3_000
    free, wrong = _agreement(scene, group, count)
    assert wrong == 0, f"{wrong} of {free} states called free collide"
    assert free > 0.05 * count  # the test decides something: not a test that only says "undecided"


@pytest.mark.parametrize("robot, reach", [("mycobot", 0.3), ("panda", 0.8)])
def test_one_state_answers_are_the_batch_answers(robot, reach, mycobot, panda):
    """The one-state call (what validity_checker runs before the exact check) reads the same
    tables as the batch call: the same verdict on every state, both kinds represented. The batch
    call folds the joints no slot drives (the myCobot's gripper, the Panda's fingers) into their
    parents (batch_check._held_joints, from HOLD_MIN_STATES states a call), the one-state call does not:
    the two kinematics give the same verdicts."""
    model = {"mycobot": mycobot, "panda": panda}[robot]
    scene = PlanningScene(model)
    _obstacles(scene, reach)
    start = scene.current_state
    indices = model.group("arm").variable_indices
    low, high = model.lower_limits[indices], model.upper_limits[indices]
    values = np.random.default_rng(5).uniform(low, high, (3_000, len(indices)))
    batch = scene.batch_free_checker("arm", start)(values)
    one = scene.batch_free_checker("arm", start, one_state=True)
    assert [one(row) for row in values] == batch.tolist()
    assert 0 < batch.sum() < len(batch)


def test_an_attached_object_is_covered(panda):
    scene = PlanningScene(panda)
    _obstacles(scene, 0.8)
    hand = "panda_hand"
    scene.add_object(CollisionObject.box("held", [0.06, 0.3, 0.06], make_pose([0.0, 0.0, 0.1])))
    scene.attach_object("held", hand, touch_links=["panda_hand", "panda_leftfinger", "panda_rightfinger"])
    free, wrong = _agreement(scene, "arm", 5_000, seed=3)
    assert wrong == 0 and free > 0


def test_spheres_contain_the_shapes():
    rng = np.random.default_rng(0)
    for geometry in (coal.Box(0.4, 0.1, 0.05), coal.Cylinder(0.05, 0.6), coal.Capsule(0.03, 0.4),
                     coal.Cone(0.1, 0.3), coal.Sphere(0.2)):
        centres, radii = enclosing_spheres(geometry)
        geometry.computeLocalAABB()  # the box the random points are drawn from
        low, high = np.asarray(geometry.aabb_local.min_), np.asarray(geometry.aabb_local.max_)
        points = rng.uniform(low, high, (4000, 3))
        inside = np.array([_inside(geometry, p) for p in points[:4000]])
        covered = np.min(np.linalg.norm(points[:4000, None] - centres[None], axis=2) - radii[None], axis=1) <= 1e-12
        assert np.all(covered[inside]), type(geometry).__name__


def test_mesh_spheres_hold_every_point_of_every_triangle(panda):
    rng = np.random.default_rng(1)
    for geom in panda.pin_collision_model.geometryObjects:
        if not isinstance(geom.geometry, coal.BVHModelBase):
            continue
        mesh = geom.geometry
        vertices = np.asarray(mesh.vertices())
        triangles = np.array([[t[0], t[1], t[2]] for t in (mesh.tri_indices(i) for i in range(mesh.num_tris))])
        weights = rng.dirichlet(np.ones(3), (len(triangles), 8))  # 8 random points per triangle
        points = np.einsum("tkc,tcx->tkx", weights, vertices[triangles]).reshape(-1, 3)
        points = np.vstack([points, vertices])
        centres, radii = enclosing_spheres(mesh)
        gap = np.min(np.linalg.norm(points[:, None] - centres[None], axis=2) - radii[None], axis=1)
        assert gap.max() <= 1e-12, geom.name


def _inside(geometry: coal.CollisionGeometry, point: np.ndarray) -> bool:
    probe = coal.Sphere(1e-9)
    request, result = coal.CollisionRequest(), coal.CollisionResult()
    return coal.collide(geometry, coal.Transform3s(), probe, coal.Transform3s(np.eye(3), point), request, result) > 0


def test_unsupported_joints_have_no_batch_path():
    model = pin.Model()
    model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "base")
    assert joint_tables(model) is None


def test_edge_answers_are_the_validity_functions():
    """With or without the batch test an edge gets the same answer and the same first invalid
    state: the batch test only spares calls."""
    asked: list[float] = []

    def valid(q: np.ndarray) -> bool:
        asked.append(float(q[0]))
        return not 0.62 < float(q[0]) < 0.8

    a, b = np.zeros(1), np.array([0.6])
    fractions = _edge_fractions(16)
    assert np.array_equal(fractions[1:], _bisection_order(16))
    plain = _edge_valid(a, b, fractions, valid, None)
    asked_plain = list(asked)
    asked.clear()
    batched = _edge_valid(a, b, fractions, valid, lambda states: states[:, 0] < 0.3)
    assert plain == batched == 2
    assert len(asked) < len(asked_plain)
    asked.clear()
    b = np.array([0.7])
    assert _edge_valid(a, b, fractions, valid, lambda states: states[:, 0] < 0.3) == 0  # the end is invalid
    asked.clear()
    b = np.array([0.9])
    plain = _edge_valid(a, b, fractions, valid, None)
    asked_plain = list(asked)
    asked.clear()
    batched = _edge_valid(a, b, fractions, valid, lambda states: states[:, 0] < 0.3)
    assert plain == batched == 1
    assert [x for x in asked_plain if x >= 0.3] == asked and len(asked) < len(asked_plain)



def test_staged_edges_answer_as_one_batch_and_spare_the_rest():
    """_edge_valid's stages (a few states first, then more): on 2,000 random edges of 1 to 300
    states, each with random blocked intervals and a batch test that calls a random part of the
    free states free, the answer and the states asked of the validity function are those of the
    states in order (free by the batch test or valid, up to the first invalid one), and an edge
    whose first invalid state comes early has the batch test run on fewer than all its states."""
    from mycobot_planning.core.planners.ompl.solve import EDGE_FIRST_STAGE

    rng = np.random.default_rng(21)
    spared = 0
    for _ in range(2000):
        blocked = np.sort(rng.uniform(0.0, 1.0, (int(rng.integers(0, 3)), 2)), axis=1)
        salt = rng.integers(1 << 30)

        def exact(x: float) -> bool:
            return not any(lo < x < hi for lo, hi in blocked)

        def sure(x: float) -> bool:  # a batch test: free only if valid, and not always then
            return exact(x) and (hash((round(x, 12), int(salt))) % 3 != 0)

        asked: list[float] = []
        tested: list[int] = []

        def valid(q: np.ndarray) -> bool:
            asked.append(float(q[0]))
            return exact(float(q[0]))

        def batch(states: np.ndarray) -> np.ndarray:
            tested.append(len(states))
            return np.array([sure(float(x)) for x in states[:, 0]], dtype=bool)

        segments = int(rng.integers(1, 300))
        a, b = np.array([rng.uniform(0.0, 0.5)]), np.array([rng.uniform(0.5, 1.0)])
        end_known = bool(rng.random() < 0.3) and exact(float(b[0]))
        fractions = _edge_fractions(segments)
        answer = _edge_valid(a, b, fractions, valid, batch, end_known)
        xs = (a + fractions[:, None] * (b - a))[:, 0]
        xs[0] = b[0]
        expected, expected_asked = 2, []
        for k in range(1 if end_known else 0, len(xs)):
            if not sure(float(xs[k])):
                expected_asked.append(float(xs[k]))
                if not exact(float(xs[k])):
                    expected = 1 if k else 0
                    break
        assert answer == expected
        assert asked == expected_asked
        if expected != 2 and len(xs) > 4 * EDGE_FIRST_STAGE and len(expected_asked) and \
                np.flatnonzero(xs == expected_asked[-1])[0] < EDGE_FIRST_STAGE:
            assert sum(tested) == EDGE_FIRST_STAGE
            spared += 1
    assert spared > 50

def test_every_peers_plan_passes_the_exact_validator():
    parts = panda_parts_problems(0, ik_count=1, check_count=1)
    ours = OursParts(parts)
    assert ours.scene.batch_free_checker(ours.group, ours.start) is not None
    solved = 0
    for k, problem in enumerate(parts["plan"]):
        start = ours.start.copy()
        start.set_group_positions(ours.group, np.asarray(problem["start"], dtype=float))
        request = MotionPlanRequest(ours.group, JointGoal(np.asarray(problem["goal"], dtype=float)),
                                    start_state=start, allowed_planning_time=1.0, seed=k + 1)
        response = ours.planner.plan(ours.scene, request)
        if not response.success:
            continue
        solved += 1
        report = validate_trajectory(ours.scene, response.trajectory, ours.group, start, all_pairs=True)
        assert report.valid, f"problem {k}: {report}"
    assert solved >= len(parts["plan"]) - 1


def test_a_scene_change_is_followed(panda):
    scene = PlanningScene(panda)
    free_of = scene.batch_free_checker("arm", RobotState(panda))
    values = np.array([[0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]])  # the SRDF's "ready"
    one = scene.batch_free_checker("arm", RobotState(panda), one_state=True)
    valid = scene.validity_checker("arm", RobotState(panda), check_bounds=False)  # sphere test, then exact
    assert free_of(values)[0] and one(values[0]) and valid(values[0])
    scene.add_object(CollisionObject.box("everywhere", [4.0, 4.0, 4.0], make_pose([0.0, 0.0, 0.0])))
    assert not free_of(values)[0] and not one(values[0]) and not valid(values[0])


def test_nan_and_malformed_states_are_never_free(panda):
    scene = PlanningScene(panda)
    free_of = scene.batch_free_checker("arm", RobotState(panda))
    ready = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
    states = np.array([ready, ready])
    states[1, 2] = np.nan
    assert free_of(states).tolist() == [True, False]
    one = scene.batch_free_checker("arm", RobotState(panda), one_state=True)
    assert one(ready) and not one(states[1]) and not one(ready[:5]) and not one([0.0] * 7)
    with pytest.raises(ValueError):
        free_of(np.zeros((2, 5)))
    check = scene.validity_checker("arm", RobotState(panda), check_bounds=False)
    assert check(ready)
    with pytest.raises(ValueError):
        check(ready[:5])


def _axes_urdf() -> str:
    """A chain whose joints turn about +-X, +-Y, +-Z, a tilted axis, slide, and turn without
    limits (continuous), with rotated joint frames."""
    joints = [("revolute", "1 0 0"), ("revolute", "0 -1 0"), ("revolute", "0 0 1"), ("revolute", "-1 0 0"),
              ("revolute", "0 1 0"), ("revolute", "0 0 -1"), ("revolute", "0.6 0 0.8"), ("prismatic", "0 1 0"),
              ("continuous", "0 0 1"), ("continuous", "1 0 0")]
    links = "".join(f'<link name="l{k}"/>' for k in range(len(joints) + 1))
    chain = "".join(
        f'<joint name="j{k}" type="{kind}"><parent link="l{k}"/><child link="l{k + 1}"/>'
        f'<origin xyz="0.1 {0.02 * k} 0.05" rpy="{0.3 * k} {0.7 - 0.1 * k} {0.2 * k}"/><axis xyz="{axis}"/>'
        + ('' if kind == "continuous" else '<limit lower="-3" upper="3" effort="1" velocity="1"/>') + '</joint>'
        for k, (kind, axis) in enumerate(joints))
    return f'<robot name="axes">{links}{chain}</robot>'


def test_joint_kinematics_are_pinocchios_for_every_axis():
    """The compiled forward kinematics (its shortcuts for joints about one coordinate axis, either
    sign, and the general formula) give Pinocchio's joint placements on 200 random states."""
    from mycobot_planning.core.collision_detection.batch_check import joint_kinematics

    model = pin.buildModelFromXML(_axes_urdf())
    data = model.createData()
    parents, kinds, index, axes, placements = joint_tables(model)
    assert {int(k) for k in kinds[1:]} == {1, 2, 3}  # revolute, prismatic, unbounded
    nj = model.njoints
    rot, trans = np.zeros((nj, 3, 3)), np.zeros((nj, 3))
    rot[0] = np.eye(3)
    rot0, trans0 = np.ascontiguousarray(placements[:, :3, :3]), np.ascontiguousarray(placements[:, :3, 3])
    pin.seed(3)
    for _ in range(200):
        q = pin.randomConfiguration(model, -3.0 * np.ones(model.nq), 3.0 * np.ones(model.nq))
        pin.forwardKinematics(model, data, q)
        joint_kinematics(q, parents, kinds, index, axes, rot0, trans0, rot, trans, np.empty((3, 3)), np.empty((3, 3)))
        for j in range(1, nj):
            assert np.allclose(rot[j], data.oMi[j].rotation, atol=1e-12), model.names[j]
            assert np.allclose(trans[j], data.oMi[j].translation, atol=1e-12), model.names[j]


def test_outer_spheres_hold_each_bodys_spheres_as_the_per_body_computation():
    """_pack's bounding sphere per body, in one reduction over all bodies: the same values as the
    per-body computation it replaced (bit for bit), and every sphere of a body inside its own."""
    from mycobot_planning.core.collision_detection.batch_check import _outer_spheres

    rng = np.random.default_rng(3)
    for _ in range(500):
        bodies = [(rng.normal(size=(m, 3)), rng.uniform(1e-3, 0.2, m)) for m in rng.integers(1, 12, rng.integers(1, 20))]
        centres = np.vstack([c for c, _ in bodies])
        radii = np.concatenate([r for _, r in bodies])
        outer = _outer_spheres(centres, radii, np.array([len(r) for _, r in bodies]))
        for (c, r), sphere in zip(bodies, outer):
            middle = 0.5 * (np.min(c - r[:, None], axis=0) + np.max(c + r[:, None], axis=0))
            radius = float(np.max(np.linalg.norm(c - middle, axis=1) + r)) * (1.0 + 1e-12)
            assert np.array_equal(sphere, np.append(middle, radius))
            assert np.all(np.linalg.norm(c - sphere[:3], axis=1) + r <= sphere[3])
    assert _outer_spheres(np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=np.int64)).shape == (0, 4)
    with pytest.raises(ValueError, match="at least one sphere"):
        _outer_spheres(np.zeros((1, 3)), np.ones(1), np.array([1, 0]))
