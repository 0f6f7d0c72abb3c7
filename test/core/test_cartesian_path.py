"""Cartesian paths (computeCartesianPath) and relative motions (MTC MoveRelative)."""
from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from interfaces_py.msgs import CollisionObject, MoveItErrorCode
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.planners.cartesian.cartesian_path import (
    STOP_COLLISION,
    STOP_COMPLETE,
    STOP_JOINT_JUMP,
    STOP_NO_IK,
    CartesianPathResult,
    compute_cartesian_path,
    nearest_rotation,
    slerp_rotations,
)
from mycobot_planning.core.planners.cartesian.relative_motion import plan_relative_motion, relative_target_poses
from mycobot_planning.core.planning_interface.planning_interface import PlanningFailure
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory
from mycobot_planning.core.transforms import make_pose

FLANGE = "link6_flange"


# ---------------------------------------------------------------------------- helpers
@pytest.fixture()
def ready(mycobot: RobotModel) -> RobotState:
    state = RobotState(mycobot)
    state.set_named("ready")
    return state


@pytest.fixture()
def scene(mycobot: RobotModel, ready: RobotState) -> PlanningScene:
    return PlanningScene(mycobot, ready)


def poses_along(result: CartesianPathResult, link: str, offset: np.ndarray | None = None) -> list[np.ndarray]:
    out = []
    for state in result.states():
        pose = state.frame_pose(link)
        out.append(pose if offset is None else pose @ offset)
    return out


def distance_to_line(point: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance from point to the segment a-b."""
    ab = b - a
    t = float(np.clip((point - a) @ ab / (ab @ ab), 0.0, 1.0))
    return float(np.linalg.norm(point - (a + t * ab)))


def rotation_angle(r1: np.ndarray, r2: np.ndarray) -> float:
    return float(np.linalg.norm(pin.log3(r1.T @ r2)))


def full_positions(start: RobotState, group_values: np.ndarray) -> np.ndarray:
    full = start.positions.copy()
    full[start.model.group("arm").variable_indices] = group_values
    return full


def translated(pose: np.ndarray, delta) -> np.ndarray:
    out = pose.copy()
    out[:3, 3] += np.asarray(delta, dtype=float)
    return out


# ---------------------------------------------------------------------------- straight line
def test_step_rotations_are_scipys_slerp():
    """slerp_rotations/nearest_rotation (Rodrigues in NumPy) against SciPy's Rotation, which the
    steps were computed with before: r0 * exp(t log(r0^-1 r1)) on 3,000 random pairs, a quarter
    each of any angle, 1e-12 to 1e-2 rad, within 1e-3 rad of pi, and none."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(11)
    fractions = np.arange(1, 12) / 11
    worst = 0.0
    for k in range(3000):
        r0 = Rotation.random(random_state=int(rng.integers(2**31))).as_matrix()
        kind = k % 4
        if kind == 0:
            rotvec = Rotation.random(random_state=int(rng.integers(2**31))).as_rotvec()
        elif kind == 3:
            rotvec = np.zeros(3)
        else:
            rotvec = rng.normal(size=3)
            size = 10 ** rng.uniform(-12, -2) if kind == 1 else math.pi - 10 ** rng.uniform(-9, -3)
            rotvec *= size / np.linalg.norm(rotvec)
        r1 = r0 @ Rotation.from_rotvec(rotvec).as_matrix()
        start = Rotation.from_matrix(r0)
        reference = (start * Rotation.from_rotvec(
            fractions[:, None] * (start.inv() * Rotation.from_matrix(r1)).as_rotvec()[None, :])).as_matrix()
        a, b = nearest_rotation(r0), nearest_rotation(r1)
        ours = slerp_rotations(a, pin.log3(a.T @ b), fractions)
        worst = max(worst, float(np.abs(ours - reference).max()))
    assert worst < 1e-9, worst
    # a rotation orthonormal only to 1e-7 (check_pose accepts 1e-6) is projected onto the nearest one
    skewed = r0 + 1e-7 * rng.normal(size=(3, 3))
    projected = nearest_rotation(skewed)
    assert np.allclose(projected @ projected.T, np.eye(3), atol=1e-14) and np.linalg.det(projected) > 0
    assert np.abs(projected - skewed).max() < 1e-6


def test_straight_line_on_mycobot_is_complete_on_the_line_and_valid(scene, ready):
    start_pose = ready.frame_pose(FLANGE)
    goal = translated(start_pose, (-0.1, 0.0, 0.0))
    result = compute_cartesian_path(scene, "arm", ready, [goal], eef_step=0.005)

    assert result.error_code.val == MoveItErrorCode.SUCCESS
    assert result.fraction == 1.0
    assert result.stop_reason == STOP_COMPLETE
    # MoveIt: the waypoints exclude the start, the path includes it.
    np.testing.assert_allclose(result.path[0], ready.group_positions("arm"))
    assert len(result.path) == 21  # 0.1 m / 0.005 m steps + the start
    poses = poses_along(result, FLANGE)
    for pose in poses:
        assert distance_to_line(pose[:3, 3], start_pose[:3, 3], goal[:3, 3]) < 1e-4
        assert rotation_angle(pose[:3, :3], start_pose[:3, :3]) < 1e-4
    np.testing.assert_allclose(poses[-1][:3, 3], goal[:3, 3], atol=1e-5)
    steps = np.linalg.norm(np.diff([p[:3, 3] for p in poses], axis=0), axis=1)
    assert np.all(steps <= 0.005 + 1e-5)
    # Progress is monotonic along the line (no back-and-forth).
    progress = [float((p[:3, 3] - start_pose[:3, 3]) @ np.array([-1.0, 0, 0])) for p in poses]
    assert np.all(np.diff(progress) > 0)

    report = validate_trajectory(scene, result.trajectory, "arm", ready)
    assert report.valid, report.problems
    np.testing.assert_allclose(result.trajectory.positions[-1], result.path[-1], atol=1e-9)
    assert result.trajectory.joint_names == list(scene.robot_model.group("arm").joint_names)


def test_default_start_state_is_the_scenes_and_link_defaults_to_the_tip(scene, ready):
    goal = translated(ready.frame_pose(FLANGE), (-0.02, 0.0, 0.0))
    result = compute_cartesian_path(scene, "arm", None, [goal])
    assert result.fraction == 1.0
    assert result.link == FLANGE
    np.testing.assert_allclose(result.states()[-1].frame_pose(FLANGE)[:3, 3], goal[:3, 3], atol=1e-5)


def test_orientation_is_slerped_and_rotation_steps_are_bounded(scene, ready):
    start_pose = ready.frame_pose(FLANGE)
    goal = translated(start_pose, (-0.02, 0.0, 0.0))
    axis = np.array([0.0, 0.0, 1.0])
    goal[:3, :3] = pin.exp3(0.3 * axis) @ start_pose[:3, :3]
    result = compute_cartesian_path(scene, "arm", ready, [goal], eef_step=0.01, max_rotation_step=0.02)
    assert result.fraction == 1.0
    # The rotation (0.3 rad at <= 0.02 rad per step) sets the number of steps, not the 2 cm.
    assert len(result.path) - 1 == 15
    poses = poses_along(result, FLANGE)
    for i, pose in enumerate(poses):
        t = i / 15
        expected = pin.exp3(t * 0.3 * axis) @ start_pose[:3, :3]
        assert rotation_angle(pose[:3, :3], expected) < 1e-4
        np.testing.assert_allclose(pose[:3, 3], start_pose[:3, 3] + t * (goal[:3, 3] - start_pose[:3, 3]), atol=1e-5)


def test_velocity_scaling_slows_the_trajectory_and_stays_valid(scene, ready):
    goal = translated(ready.frame_pose(FLANGE), (-0.05, 0.0, 0.0))
    fast = compute_cartesian_path(scene, "arm", ready, [goal], eef_step=0.01)
    slow = compute_cartesian_path(scene, "arm", ready, [goal], eef_step=0.01, velocity_scaling=0.2,
                                  acceleration_scaling=0.2)
    np.testing.assert_allclose(slow.path, fast.path)
    assert slow.trajectory.duration > 2.0 * fast.trajectory.duration
    report = validate_trajectory(scene, slow.trajectory, "arm", ready, velocity_scaling=0.2, acceleration_scaling=0.2)
    assert report.valid, report.problems


def test_waypoints_in_a_link_frame(scene, ready):
    """frame='link6_flange': a waypoint 2 cm along the flange's z axis (its approach axis)."""
    start_pose = ready.frame_pose(FLANGE)
    result = compute_cartesian_path(scene, "arm", ready, [make_pose((0.0, 0.0, 0.02))], frame=FLANGE)
    assert result.fraction == 1.0
    reached = result.states()[-1].frame_pose(FLANGE)
    np.testing.assert_allclose(reached[:3, 3], start_pose[:3, 3] + start_pose[:3, :3] @ [0, 0, 0.02], atol=1e-5)


def test_multiple_waypoints_fraction_counts_segments(scene, ready):
    """Two segments: the first completes, the second is cut by an obstacle; the fraction is
    MoveIt's 1/W per segment plus the achieved share of the cut segment."""
    p0 = ready.frame_pose(FLANGE)
    w1 = translated(p0, (-0.02, 0.0, 0.0))
    w2 = translated(w1, (0.0, 0.0, -0.1))  # downwards: the arm runs into itself on the way
    result = compute_cartesian_path(scene, "arm", ready, [w1, w2], eef_step=0.005)
    assert 0.5 < result.fraction < 1.0
    steps_second = 20  # 0.1 m / 0.005
    achieved_second = len(result.path) - 1 - 4  # 4 steps in the first segment
    assert result.fraction == pytest.approx(0.5 + 0.5 * achieved_second / steps_second)
    assert result.stop_reason in (STOP_COLLISION, STOP_NO_IK)
    assert result.error_code.val == MoveItErrorCode.SUCCESS  # the caller decides, as in MoveIt
    assert f"{100 * result.fraction:.2f}%" in result.message
    assert validate_trajectory(scene, result.trajectory, "arm", ready).valid


# ---------------------------------------------------------------------------- collisions
def test_line_through_a_box_returns_exactly_the_collision_free_prefix(mycobot, ready):
    scene = PlanningScene(mycobot, ready)
    # The gripper hangs along -y at the 'ready' state; the box sits in its way along -x.
    scene.add_object(CollisionObject.box("box", (0.01, 0.04, 0.04), make_pose((-0.03, -0.20, 0.168))))
    goal = translated(ready.frame_pose(FLANGE), (-0.1, 0.0, 0.0))
    result = compute_cartesian_path(scene, "arm", ready, [goal], eef_step=0.002)
    assert 0.0 < result.fraction < 1.0
    assert result.stop_reason == STOP_COLLISION
    assert "'box' (Object)" in result.message
    # The same path without collision checking: ours must be exactly its prefix...
    free = compute_cartesian_path(scene, "arm", ready, [goal], eef_step=0.002, avoid_collisions=False)
    assert free.fraction == 1.0
    k = len(result.path) - 1
    np.testing.assert_allclose(result.path, free.path[: k + 1], atol=1e-12)
    assert result.fraction == pytest.approx(k / 50)
    # ...every state of it valid, and the next step collides (at the state or on the way to it).
    assert all(scene.is_valid_positions(full_positions(ready, q)) for q in result.path)
    a, b = free.path[k], free.path[k + 1]
    between = [a + t * (b - a) for t in np.linspace(0.0, 1.0, 21)[1:]]
    assert not all(scene.is_valid_positions(full_positions(ready, q)) for q in between)
    report = validate_trajectory(scene, result.trajectory, "arm", ready)
    assert report.valid, report.problems
    # Without the box, the free path itself is collision-free too.
    scene.remove_object("box")
    assert validate_trajectory(scene, free.trajectory, "arm", ready).valid


def test_motion_between_coarse_steps_is_collision_checked(mycobot, ready):
    """One 6 cm step down through a 4 mm plate: both ends are free, the motion between is not."""
    scene = PlanningScene(mycobot, ready)
    scene.add_object(CollisionObject.box("plate", (0.2, 0.01, 0.004), make_pose((0.06, -0.18, 0.13))))
    goal = translated(ready.frame_pose(FLANGE), (0.0, 0.0, -0.06))
    free = compute_cartesian_path(scene, "arm", ready, [goal], eef_step=0.1, avoid_collisions=False)
    assert free.fraction == 1.0 and len(free.path) == 2
    assert all(scene.is_valid_positions(full_positions(ready, q)) for q in free.path)

    result = compute_cartesian_path(scene, "arm", ready, [goal], eef_step=0.1)
    assert result.fraction == 0.0
    assert result.stop_reason == STOP_COLLISION
    assert "motion to the state of step 1" in result.message and "plate" in result.message
    # Fine steps meet the plate at a state instead, at the same place.
    fine = compute_cartesian_path(scene, "arm", ready, [goal], eef_step=0.002)
    assert 0.0 < fine.fraction < 1.0 and fine.stop_reason == STOP_COLLISION
    assert validate_trajectory(scene, fine.trajectory, "arm", ready).valid


def test_start_state_in_collision_is_reported(mycobot, ready):
    scene = PlanningScene(mycobot, ready)
    scene.add_object(CollisionObject.box("block", (0.05, 0.05, 0.05), ready.frame_pose(FLANGE)))
    goal = translated(ready.frame_pose(FLANGE), (-0.02, 0.0, 0.0))
    result = compute_cartesian_path(scene, "arm", ready, [goal])
    assert result.error_code.val == MoveItErrorCode.START_STATE_IN_COLLISION
    assert "block" in result.message
    assert result.trajectory is None and result.fraction == 0.0
    # Without collision avoidance the same request plans (only bounds are enforced).
    free = compute_cartesian_path(scene, "arm", ready, [goal], avoid_collisions=False)
    assert free.fraction == 1.0


def test_nothing_achievable_gives_fraction_zero_with_the_start_only(scene, ready):
    unreachable = translated(ready.frame_pose(FLANGE), (1.0, 0.0, 0.0))  # a metre: beyond reach
    result = compute_cartesian_path(scene, "arm", ready, [unreachable], eef_step=1.0)
    assert result.error_code.val == MoveItErrorCode.SUCCESS
    assert result.fraction == 0.0
    assert result.stop_reason == STOP_NO_IK
    assert "no IK solution" in result.message
    assert result.path.shape == (1, 6)
    assert len(result.trajectory) == 1
    np.testing.assert_allclose(result.trajectory.positions[0], ready.group_positions("arm"))


def test_unreachable_end_returns_reachable_prefix(scene, ready):
    goal = translated(ready.frame_pose(FLANGE), (0.0, 0.0, 0.4))  # straight up, beyond reach
    result = compute_cartesian_path(scene, "arm", ready, [goal], eef_step=0.01)
    assert 0.0 < result.fraction < 1.0
    assert result.stop_reason in (STOP_NO_IK, STOP_COLLISION)
    assert result.fraction == pytest.approx((len(result.path) - 1) / 40)
    assert validate_trajectory(scene, result.trajectory, "arm", ready).valid


# ---------------------------------------------------------------------------- joint-space jumps
def wrist_singularity_case(model: RobotModel):
    """A straight 8 cm line through a pose 0.01 rad from the myCobot's wrist singularity (joint 5
    at pi/2): tiny Cartesian steps there need the wrist to swing round by radians, the classic
    joint-space jump computeCartesianPath's jump_threshold exists for."""
    near = RobotState(model)
    near.set_named("ready")
    q = near.positions.copy()
    q[3], q[4] = 0.8, math.pi / 2 - 0.01
    near.set_positions(q)
    scene = PlanningScene(model, near)
    middle = near.frame_pose(FLANGE)
    # Start 4 cm before the near-singular pose (reached by a Cartesian move away from it).
    back = compute_cartesian_path(scene, "arm", near, [translated(middle, (-0.04, 0.0, 0.0))], eef_step=0.002)
    assert back.fraction == 1.0
    start = back.states()[-1]
    return scene, start, [translated(middle, (0.04, 0.0, 0.0))]


def test_jump_threshold_cuts_the_path_before_a_wrist_swing(mycobot):
    scene, start, waypoints = wrist_singularity_case(mycobot)
    unchecked = compute_cartesian_path(scene, "arm", start, waypoints, eef_step=0.002)
    distances = np.abs(np.diff(unchecked.path, axis=0)).sum(axis=1)
    assert distances.max() > 10 * np.median(distances), "the scenario must contain a joint-space jump"
    # Every state of it is still on the line: the jump is joint-space only.
    a, b = start.frame_pose(FLANGE)[:3, 3], waypoints[0][:3, 3]
    assert all(distance_to_line(p[:3, 3], a, b) < 1e-4 for p in poses_along(unchecked, FLANGE))

    checked = compute_cartesian_path(scene, "arm", start, waypoints, eef_step=0.002, jump_threshold=4.0)
    assert checked.stop_reason == STOP_JOINT_JUMP
    assert "jump" in checked.message
    # MoveIt's test: cut before the first step longer than 4 x the mean step of the computed path.
    cut = int(np.flatnonzero(distances > 4.0 * distances.mean())[0])
    np.testing.assert_allclose(checked.path, unchecked.path[: cut + 1], atol=1e-12)
    assert len(checked.path) < len(unchecked.path)
    assert checked.fraction == pytest.approx(cut / 40) and checked.fraction < unchecked.fraction
    assert validate_trajectory(scene, checked.trajectory, "arm", start).valid

    # MoveIt 2's absolute per-joint test: no joint may move more than 0.2 rad in one step.
    absolute = compute_cartesian_path(scene, "arm", start, waypoints, eef_step=0.002, revolute_jump_threshold=0.2)
    assert absolute.stop_reason == STOP_JOINT_JUMP
    assert "revolute_jump_threshold" in absolute.message
    per_joint = np.abs(np.diff(unchecked.path, axis=0)).max(axis=1)
    first = int(np.flatnonzero(per_joint > 0.2)[0])
    np.testing.assert_allclose(absolute.path, unchecked.path[: first + 1], atol=1e-12)


def test_jump_threshold_enforces_min_steps_per_segment(scene, ready):
    goal = translated(ready.frame_pose(FLANGE), (-0.02, 0.0, 0.0))
    coarse = compute_cartesian_path(scene, "arm", ready, [goal], eef_step=0.01)
    assert len(coarse.path) - 1 == 2
    checked = compute_cartesian_path(scene, "arm", ready, [goal], eef_step=0.01, jump_threshold=2.0)
    assert len(checked.path) - 1 == 10  # MoveIt's MIN_STEPS_FOR_JUMP_THRESH
    assert checked.fraction == 1.0


# ---------------------------------------------------------------------------- ik frame offset
def test_tcp_offset_moves_the_tcp_on_the_line(scene, ready):
    tcp = make_pose((0.0, 0.0, 0.1))  # 10 cm beyond the flange, along its z axis
    start_tcp = ready.frame_pose(FLANGE) @ tcp
    goal = translated(start_tcp, (-0.03, 0.0, 0.0))
    goal[:3, :3] = pin.exp3(np.array([0.0, 0.0, 0.3])) @ start_tcp[:3, :3]
    result = compute_cartesian_path(scene, "arm", ready, [goal], ik_frame_offset=tcp, eef_step=0.005)
    assert result.fraction == 1.0
    tcp_poses = poses_along(result, FLANGE, tcp)
    for pose in tcp_poses:
        assert distance_to_line(pose[:3, 3], start_tcp[:3, 3], goal[:3, 3]) < 1e-4
    np.testing.assert_allclose(tcp_poses[-1], goal, atol=1e-5)
    # The flange itself swings on an arc (the rotation is about the TCP), so it is off its chord.
    flange = [p[:3, 3] for p in poses_along(result, FLANGE)]
    assert max(distance_to_line(p, flange[0], flange[-1]) for p in flange) > 1e-3
    assert validate_trajectory(scene, result.trajectory, "arm", ready).valid


# ---------------------------------------------------------------------------- Panda
def test_panda_line(panda):
    start = RobotState(panda)
    start.set_group_positions("arm", [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
    scene = PlanningScene(panda, start)
    tip = panda.group("arm").tip_link
    start_pose = start.frame_pose(tip)
    goal = translated(start_pose, (0.0, 0.1, -0.1))
    result = compute_cartesian_path(scene, "arm", start, [goal], eef_step=0.005)
    assert result.fraction == 1.0
    assert result.path.shape[1] == 7
    for pose in poses_along(result, tip):
        assert distance_to_line(pose[:3, 3], start_pose[:3, 3], goal[:3, 3]) < 1e-4
        assert rotation_angle(pose[:3, :3], start_pose[:3, :3]) < 1e-4
    report = validate_trajectory(scene, result.trajectory, "arm", start)
    assert report.valid, report.problems
    # The hand's finger (outside the group) keeps the start value.
    finger = panda.variable_index("panda_finger_joint1")
    assert all(s.positions[finger] == start.positions[finger] for s in result.states())


# ---------------------------------------------------------------------------- relative motion
def test_relative_motion_along_world_minus_z(scene, ready):
    start_pose = ready.frame_pose(FLANGE)
    result = plan_relative_motion(scene, "arm", ready, direction=(0.0, 0.0, -1.0), max_distance=0.03, eef_step=0.005)
    assert result.success, result.message
    assert result.achieved_distance == pytest.approx(0.03, abs=1e-5)
    reached = result.cartesian.states()[-1].frame_pose(FLANGE)
    np.testing.assert_allclose(reached[:3, 3], start_pose[:3, 3] + [0, 0, -0.03], atol=1e-5)
    assert rotation_angle(reached[:3, :3], start_pose[:3, :3]) < 1e-4
    assert validate_trajectory(scene, result.trajectory, "arm", ready).valid


def test_relative_direction_length_is_the_distance_without_max_distance(scene, ready):
    """MTC: with max_distance 0 the vector's own length is how far to go."""
    target = relative_target_poses(scene, ready, FLANGE, direction=(0.0, 0.0, -0.025))
    assert target.distance == pytest.approx(0.025)
    np.testing.assert_allclose(target.pose[:3, 3], ready.frame_pose(FLANGE)[:3, 3] + [0, 0, -0.025])
    scaled = relative_target_poses(scene, ready, FLANGE, direction=(0.0, 0.0, -0.025), distance=0.05)
    np.testing.assert_allclose(scaled.pose[:3, 3], ready.frame_pose(FLANGE)[:3, 3] + [0, 0, -0.05])


def test_relative_motion_along_a_link_axis(scene, ready):
    """Approach along the flange's own z axis, as MTC's 'approach object' stage does."""
    start_pose = ready.frame_pose(FLANGE)
    result = plan_relative_motion(scene, "arm", ready, direction=(0.0, 0.0, 1.0), frame=FLANGE, max_distance=0.02,
                                  eef_step=0.005)
    assert result.success, result.message
    expected = start_pose[:3, 3] + start_pose[:3, :3] @ np.array([0.0, 0.0, 0.02])
    reached = result.cartesian.states()[-1].frame_pose(FLANGE)
    np.testing.assert_allclose(reached[:3, 3], expected, atol=1e-5)
    # At 'ready' the flange's z axis points along world -y.
    np.testing.assert_allclose(expected - start_pose[:3, 3], [0.0, -0.02, 0.0], atol=1e-3)


def test_relative_direction_in_an_object_frame(mycobot, ready):
    scene = PlanningScene(mycobot, ready)
    # An object turned 90 degrees about z: its x axis is the world's y axis.
    turned = make_pose((0.3, 0.3, 0.0), rpy=(0, 0, math.pi / 2))
    scene.add_object(CollisionObject.box("marker", (0.01, 0.01, 0.01), turned))
    target = relative_target_poses(scene, ready, FLANGE, direction=(1.0, 0.0, 0.0), frame="marker", distance=0.02)
    np.testing.assert_allclose(target.linear, [0.0, 0.02, 0.0], atol=1e-12)


def test_twist_rotates_about_the_ik_frame_origin(scene, ready):
    start_pose = ready.frame_pose(FLANGE)
    # MTC's "rz -18 deg" stage: pure rotation about world z.
    result = plan_relative_motion(scene, "arm", ready, twist=(0, 0, 0, 0, 0, -math.pi / 10), eef_step=0.005)
    assert result.success, result.message
    assert result.target.measure == "rotation"
    assert result.achieved_distance == pytest.approx(math.pi / 10, abs=1e-4)
    for pose in poses_along(result.cartesian, FLANGE):
        np.testing.assert_allclose(pose[:3, 3], start_pose[:3, 3], atol=1e-5)  # the origin stays put
    reached = result.cartesian.states()[-1].frame_pose(FLANGE)
    expected = pin.exp3(np.array([0.0, 0.0, -math.pi / 10])) @ start_pose[:3, :3]
    assert rotation_angle(reached[:3, :3], expected) < 1e-4
    assert validate_trajectory(scene, result.trajectory, "arm", ready).valid


def test_twist_with_tcp_offset_rotates_about_the_tcp_and_max_distance_scales_it(scene, ready):
    tcp = make_pose((0.0, 0.0, 0.05))
    start_tcp = ready.frame_pose(FLANGE) @ tcp
    target = relative_target_poses(scene, ready, FLANGE, tcp, twist=(0, 0, 0, 0, 0, 1.0), distance=0.2)
    assert target.distance == pytest.approx(0.2)  # pure rotation: max_distance is the angle
    np.testing.assert_allclose(target.pose[:3, 3], start_tcp[:3, 3], atol=1e-12)
    # Twist with a linear part: max_distance sets the translation, the rotation scales along.
    mixed = relative_target_poses(scene, ready, FLANGE, tcp, twist=(0.01, 0, 0, 0, 0, 0.1), distance=0.02)
    assert mixed.measure == "translation"
    np.testing.assert_allclose(mixed.linear, [0.02, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(mixed.angular, [0.0, 0.0, 0.2], atol=1e-12)
    result = plan_relative_motion(scene, "arm", ready, ik_frame_offset=tcp, twist=(0, 0, 0, 0, 0, 1.0),
                                  max_distance=0.2, eef_step=0.005)
    assert result.success, result.message
    for pose in poses_along(result.cartesian, FLANGE, tcp):
        np.testing.assert_allclose(pose[:3, 3], start_tcp[:3, 3], atol=1e-5)


@pytest.fixture()
def blocked_scene(mycobot, ready) -> PlanningScene:
    """Moving the flange along world -x from 'ready' hits this box after about 4.4 cm."""
    scene = PlanningScene(mycobot, ready)
    scene.add_object(CollisionObject.box("box", (0.01, 0.04, 0.04), make_pose((-0.03, -0.20, 0.168))))
    return scene


def test_min_distance_minus_one_requires_the_full_motion(blocked_scene, ready):
    result = plan_relative_motion(blocked_scene, "arm", ready, direction=(-1, 0, 0), max_distance=0.1, eef_step=0.002)
    assert not result.success
    assert result.error_code.val == MoveItErrorCode.PLANNING_FAILED
    assert "failed to move full distance" in result.message
    assert 0.02 < result.achieved_distance < 0.1
    assert result.trajectory is not None  # kept for inspection, as MTC keeps failed solutions
    assert result.stop_reason == STOP_COLLISION


def test_min_distance_positive_succeeds_when_reached(blocked_scene, ready):
    ok = plan_relative_motion(blocked_scene, "arm", ready, direction=(-1, 0, 0), min_distance=0.02, max_distance=0.1,
                              eef_step=0.002)
    assert ok.success, ok.message
    assert 0.02 <= ok.achieved_distance < 0.1
    reached = ok.cartesian.states()[-1].frame_pose(FLANGE)
    assert ok.achieved_distance == pytest.approx(np.linalg.norm(reached[:3, 3] - ready.frame_pose(FLANGE)[:3, 3]))
    assert validate_trajectory(blocked_scene, ok.trajectory, "arm", ready).valid

    short = plan_relative_motion(blocked_scene, "arm", ready, direction=(-1, 0, 0), min_distance=0.08,
                                 max_distance=0.1, eef_step=0.002)
    assert not short.success
    assert "min_distance not reached" in short.message
    assert short.achieved_distance == pytest.approx(ok.achieved_distance)


def test_min_distance_zero_accepts_any_distance(blocked_scene, ready):
    result = plan_relative_motion(blocked_scene, "arm", ready, direction=(-1, 0, 0), min_distance=0.0,
                                  max_distance=0.1, eef_step=0.002)
    assert result.success
    assert result.fraction < 1.0


def test_relative_motion_bad_inputs(scene, ready):
    both = plan_relative_motion(scene, "arm", ready, direction=(0, 0, 1), twist=(0, 0, 0, 0, 0, 1))
    assert both.error_code.val == MoveItErrorCode.INVALID_GOAL_CONSTRAINTS and "exactly one" in both.message
    zero = plan_relative_motion(scene, "arm", ready, direction=(0, 0, 0))
    assert zero.error_code.val == MoveItErrorCode.INVALID_GOAL_CONSTRAINTS and "zero" in zero.message
    short = plan_relative_motion(scene, "arm", ready, direction=(0, 0, 1, 2))
    assert short.error_code.val == MoveItErrorCode.INVALID_GOAL_CONSTRAINTS
    frame = plan_relative_motion(scene, "arm", ready, direction=(0, 0, 1), frame="nowhere")
    assert frame.error_code.val == MoveItErrorCode.FRAME_TRANSFORM_FAILURE and "nowhere" in frame.message
    crossed = plan_relative_motion(scene, "arm", ready, direction=(0, 0, 1), min_distance=0.2, max_distance=0.1)
    assert crossed.error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN and "min_distance" in crossed.message
    group = plan_relative_motion(scene, "legs", ready, direction=(0, 0, 1))
    assert group.error_code.val == MoveItErrorCode.INVALID_GROUP_NAME
    with pytest.raises(PlanningFailure, match="exactly one"):
        relative_target_poses(scene, ready, FLANGE)


# ---------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "kwargs, code, words",
    [
        (dict(eef_step=0.0), MoveItErrorCode.INVALID_MOTION_PLAN, "eef_step"),
        (dict(eef_step=-0.01), MoveItErrorCode.INVALID_MOTION_PLAN, "eef_step"),
        (dict(eef_step=float("nan")), MoveItErrorCode.INVALID_MOTION_PLAN, "eef_step"),
        (dict(eef_step=1e-9), MoveItErrorCode.INVALID_MOTION_PLAN, "too small"),
        (dict(jump_threshold=-1.0), MoveItErrorCode.INVALID_MOTION_PLAN, "jump_threshold"),
        (dict(revolute_jump_threshold=float("inf")), MoveItErrorCode.INVALID_MOTION_PLAN, "revolute_jump_threshold"),
        (dict(velocity_scaling=1.5), MoveItErrorCode.INVALID_MOTION_PLAN, "velocity_scaling"),
        (dict(acceleration_scaling=0.0), MoveItErrorCode.INVALID_MOTION_PLAN, "acceleration_scaling"),
        (dict(link="no_such_link"), MoveItErrorCode.INVALID_LINK_NAME, "no_such_link"),
        (dict(link="base_link"), MoveItErrorCode.INVALID_LINK_NAME, "not moved by group"),
        (dict(group="legs"), MoveItErrorCode.INVALID_GROUP_NAME, "legs"),
        (dict(waypoints=[]), MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "empty"),
        (dict(waypoints=None), MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "waypoints"),
        (dict(waypoints=[np.full((4, 4), np.nan)]), MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "NaN"),
        (dict(waypoints=[np.eye(3)]), MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "4x4"),
        (dict(ik_frame_offset=np.ones((4, 4))), MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "ik_frame_offset"),
        (dict(frame="nowhere"), MoveItErrorCode.FRAME_TRANSFORM_FAILURE, "nowhere"),
    ],
)
def test_bad_input_gives_error_codes_not_exceptions(scene, ready, kwargs, code, words):
    request = dict(group="arm", waypoints=[translated(ready.frame_pose(FLANGE), (-0.02, 0.0, 0.0))])
    request.update(kwargs)
    group, waypoints = request.pop("group"), request.pop("waypoints")
    result = compute_cartesian_path(scene, group, ready, waypoints, **request)
    assert result.error_code.val == code, result.message
    assert words in result.message
    assert not result
    assert result.trajectory is None and result.fraction == 0.0


def test_start_state_of_another_robot_or_outside_limits(scene, ready, panda):
    goal = [translated(ready.frame_pose(FLANGE), (-0.02, 0.0, 0.0))]
    other = compute_cartesian_path(scene, "arm", RobotState(panda), goal)
    assert other.error_code.val == MoveItErrorCode.INVALID_ROBOT_STATE
    outside = ready.copy()
    q = outside.positions.copy()
    q[0] = 3.5
    outside.set_positions(q)
    result = compute_cartesian_path(scene, "arm", outside, goal)
    assert result.error_code.val == MoveItErrorCode.START_STATE_INVALID
    assert "link1_to_link2" in result.message


def test_result_converts_to_a_motion_plan_response(scene, ready):
    goal = translated(ready.frame_pose(FLANGE), (-0.02, 0.0, 0.0))
    result = compute_cartesian_path(scene, "arm", ready, [goal])
    response = result.to_motion_plan_response()
    assert response.success and response.trajectory is result.trajectory
    assert response.group_name == "arm" and response.planner_id == "cartesian"
