"""Industrial (Pilz-style) PTP / LIN / CIRC on the myCobot and the Panda.

What is asserted is the behaviour MoveIt's pilz_industrial_motion_planner promises: PTP moves all
joints on one synchronised trapezoid within the scaled joint limits; LIN/CIRC keep the tool on a
line / circle with the orientation slerped and the translational speed within the scaled
Cartesian limit; colliding motions are refused with MoveIt's "Invalid states at index locations"
message; bad requests get MoveIt's error codes. Every successful trajectory is also checked by the
independent trajectory validator.
"""
from __future__ import annotations

import math
import re

import numpy as np
import pinocchio as pin
import pytest

from interfaces_py.msgs import CollisionObject, MoveItErrorCode
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.planners.pilz import (
    CartesianLimits,
    CartesianLimitsError,
    IndustrialMotionPlanner,
    TrapezoidProfile,
    load_cartesian_limits,
    plan_industrial,
    sample_times,
)
from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest, NamedGoal, PoseGoal
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory
from mycobot_planning.core.transforms import make_pose, rpy_to_matrix

from file_checks import assert_file_refused
from test_ompl_planner_manager import fallback_scene, ready_with

TAU = 2 * math.pi
INVALID_STATES = re.compile(
    r"Invalid states at index locations: \[ ((?:\d+ )+)\] out of (\d+); "
    r"contact between '(\w+)' \((\w+)\) and '(\w+)' \(([\w ]+)\)"
)


# ---------------------------------------------------------------------------- helpers
def fallback_target(model: RobotModel) -> dict[str, float]:
    return dict(model.named_state("ready", "arm"), link1_to_link2=TAU / 8)


def workspace_state(model: RobotModel) -> RobotState:
    """A myCobot state away from singularities, with room to move the flange a few cm."""
    return ready_with(model, link1_to_link2=0.4, link2_to_link3=-0.5, link4_to_link5=0.3)


def assert_valid(scene: PlanningScene, response, group: str, start: RobotState,
                 velocity_scaling: float = 1.0, acceleration_scaling: float = 1.0) -> None:
    assert response.success, response.error_code
    report = validate_trajectory(scene, response.trajectory, group, start,
                                 velocity_scaling=velocity_scaling, acceleration_scaling=acceleration_scaling)
    assert report.valid, report.problems


def flange_positions(model: RobotModel, start: RobotState, group: str, link: str, rows: np.ndarray) -> np.ndarray:
    state = start.copy()
    out = []
    for row in rows:
        state.set_group_positions(group, row)
        out.append(state.frame_pose(link)[:3, 3])
    return np.array(out)


def request(group: str, goal, start: RobotState, planner_id: str, **kw) -> MotionPlanRequest:
    return MotionPlanRequest(group, goal, start_state=start, pipeline_id="pilz_industrial_motion_planner",
                             planner_id=planner_id, **kw)


@pytest.fixture(scope="module")
def free_mycobot(mycobot: RobotModel) -> PlanningScene:
    return PlanningScene(mycobot)


@pytest.fixture(scope="module")
def free_panda(panda: RobotModel) -> PlanningScene:
    return PlanningScene(panda)


# ---------------------------------------------------------------------------- Cartesian limits
def test_default_cartesian_limits_file():
    limits = load_cartesian_limits()
    assert limits == CartesianLimits(max_trans_vel=1.0, max_trans_acc=2.25, max_trans_dec=-5.0, max_rot_vel=1.57)
    assert limits.equivalent_radius == pytest.approx(1.0 / 1.57)


def test_cartesian_limits_from_mappings_and_files(tmp_path):
    inner = {"max_trans_vel": 0.5, "max_trans_acc": 1, "max_trans_dec": -2, "max_rot_vel": 0.8}
    assert load_cartesian_limits(inner) == load_cartesian_limits({"cartesian_limits": inner})
    path = tmp_path / "limits.yaml"
    path.write_text("cartesian_limits:\n  max_trans_vel: 0.5\n  max_trans_acc: 1\n  max_trans_dec: -2\n  max_rot_vel: 0.8\n")
    assert load_cartesian_limits(path) == CartesianLimits(0.5, 1.0, -2.0, 0.8)
    assert load_cartesian_limits(str(path)).max_trans_dec == -2.0


@pytest.mark.parametrize(
    "data, words",
    [
        ({"max_trans_vel": 1, "max_trans_acc": 1, "max_trans_dec": -1}, "missing ['max_rot_vel']"),
        ({"max_trans_vel": 1, "max_trans_acc": 1, "max_trans_dec": 1, "max_rot_vel": 1}, "max_trans_dec must be negative"),
        ({"max_trans_vel": 0, "max_trans_acc": 1, "max_trans_dec": -1, "max_rot_vel": 1}, "max_trans_vel must be > 0"),
        ({"max_trans_vel": 1, "max_trans_acc": float("nan"), "max_trans_dec": -1, "max_rot_vel": 1}, "max_trans_acc must be a finite"),
        ({"max_trans_vel": "fast", "max_trans_acc": 1, "max_trans_dec": -1, "max_rot_vel": 1}, "max_trans_vel must be a finite"),
        ({"max_trans_vel": 1, "max_trans_acc": 1, "max_trans_dec": -1, "max_rot_vel": 1, "max_rot_acc": 1}, "unknown keys ['max_rot_acc']"),
        ({"cartesian_limits": [1, 2]}, "must be a mapping"),
        ([1, 2, 3], "expected a mapping"),
    ],
)
def test_cartesian_limits_rejected(data, words):
    with pytest.raises(CartesianLimitsError, match=re.escape(words)):
        load_cartesian_limits(data)


@pytest.mark.parametrize("name, text, match", [
    ("missing.yaml", None, "cannot read"),
    ("bad.yaml", "cartesian_limits: [unclosed\n", "not valid YAML"),
])
def test_cartesian_limits_bad_files(tmp_path, name, text, match):
    assert_file_refused(load_cartesian_limits, CartesianLimitsError, tmp_path / name, text, match)


# ---------------------------------------------------------------------------- profile
@pytest.mark.parametrize("distance", [2.0, 0.3])  # trapezoid (reaches v) and triangle
def test_trapezoid_profile_reaches_distance_within_limits(distance):
    profile = TrapezoidProfile(distance, 1.0, 2.0, 4.0)
    t = np.linspace(0.0, profile.duration, 20001)
    s, sd, sdd = profile.evaluate(t)
    assert s[0] == 0.0 and s[-1] == distance
    assert sd[0] == 0.0 and sd[-1] == 0.0
    assert np.all(np.diff(s) >= 0.0)
    assert sd.max() <= 1.0 + 1e-12
    assert sdd.max() <= 2.0 and sdd.min() >= -4.0
    # Position is the integral of velocity (the phases join up).
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (sd[1:] + sd[:-1]) * np.diff(t))])
    assert np.allclose(integral, s, atol=1e-6)
    if distance == 2.0:
        assert profile.peak_velocity == 1.0 and profile.t_cruise > 0
        assert profile.t_acc == pytest.approx(0.5) and profile.t_dec == pytest.approx(0.25)
    else:
        assert profile.t_cruise == 0.0 and profile.peak_velocity < 1.0
        assert len(profile.breakpoints) == 1


def test_profile_acceleration_is_right_continuous():
    profile = TrapezoidProfile(2.0, 1.0, 2.0, 4.0)
    _, _, sdd = profile.evaluate(np.array([0.0, profile.t_acc, profile.t_acc + profile.t_cruise, profile.duration]))
    assert sdd.tolist() == [2.0, 0.0, -4.0, 0.0]


def test_sample_times_grid_plus_breakpoints():
    times = sample_times(1.0, (0.3333, 0.5005), 0.1)
    assert times[0] == 0.0 and times[-1] == 1.0
    assert 0.3333 in times and 0.5005 in times
    assert 0.5 not in times  # within 1 % of dt of the 0.5005 boundary: dropped
    # Dropping a grid sample lengthens its interval by at most the 1 % margin.
    assert np.all(np.diff(times) > 0) and np.max(np.diff(times)) <= 0.101 + 1e-12
    assert sample_times(0.0, (), 0.1).tolist() == [0.0]
    # A cruise phase of ~0 s gives two boundaries 1e-12 apart: merged into one point.
    merged = sample_times(1.0, (0.55, 0.55 + 1e-12), 0.1)
    assert np.all(np.diff(merged) > 1e-9) and merged[-1] == 1.0
    assert np.sum(np.abs(merged - 0.55) < 1e-9) == 1


# ---------------------------------------------------------------------------- PTP
def check_synchronised(trajectory, velocity_limits, acceleration_limits, vel_scale, acc_scale) -> None:
    """Each joint's velocity/acceleration is the leading joint's scaled by the ratio of their
    displacements; all rest at both ends; limits times scaling hold and one of them is reached."""
    q, v, a = trajectory.positions, trajectory.velocities, trajectory.accelerations
    delta = q[-1] - q[0]
    lead = int(np.argmax(np.abs(delta)))
    for j in range(q.shape[1]):
        ratio = delta[j] / delta[lead]
        assert np.allclose(v[:, j], ratio * v[:, lead], atol=1e-12)
        assert np.allclose(a[:, j], ratio * a[:, lead], atol=1e-12)
    assert np.all(v[0] == 0.0) and np.all(v[-1] == 0.0) and np.all(a[-1] == 0.0)
    # Every moving joint is in motion at every interior sample: they start and stop together.
    moving = np.abs(delta) > 0
    assert np.all(np.abs(v[1:-1][:, moving]) > 0)
    vel_ratio = np.max(np.abs(v) / (velocity_limits * vel_scale))
    acc_ratio = np.max(np.abs(a) / (acceleration_limits * acc_scale))
    assert vel_ratio <= 1 + 1e-9 and acc_ratio <= 1 + 1e-9
    assert max(vel_ratio, acc_ratio) == pytest.approx(1.0)  # time-optimal under the binding limit


@pytest.mark.parametrize("scaling", [(1.0, 1.0), (0.5, 0.3)])
def test_ptp_named_goal_mycobot(mycobot, free_mycobot, scaling):
    start = RobotState(mycobot)
    start.set_named("ready")
    vs, acs = scaling
    response = plan_industrial(free_mycobot, request("arm", NamedGoal("home"), start, "PTP",
                                                     max_velocity_scaling_factor=vs, max_acceleration_scaling_factor=acs))
    assert_valid(free_mycobot, response, "arm", start, vs, acs)
    traj = response.trajectory
    idx = mycobot.group("arm").variable_indices
    assert traj.joint_names == list(mycobot.group("arm").joint_names)
    assert np.array_equal(traj.positions[-1], np.zeros(6))
    assert np.array_equal(traj.positions[0], start.positions[idx])
    assert traj.interpolation == "cubic"
    check_synchronised(traj, mycobot.velocity_limits[idx], mycobot.acceleration_limits[idx], vs, acs)
    assert np.max(np.diff(traj.times)) <= 0.01 + 1e-12
    assert response.planner_id == "PTP" and "leading axis" in response.message


def test_ptp_interpolation_is_exact(mycobot, free_mycobot):
    """Between samples, the cubic interpolation reproduces the trapezoid exactly (the phase
    boundaries are samples), so a controller executes exactly the planned profile."""
    start = RobotState(mycobot)
    start.set_named("ready")
    traj = plan_industrial(free_mycobot, request("arm", NamedGoal("home"), start, "PTP"), sample_time=0.1).trajectory
    q0, q1 = traj.positions[0], traj.positions[-1]
    delta = q1 - q0
    dist = np.abs(delta[np.abs(delta) > 0])
    idx = mycobot.group("arm").variable_indices
    vmax = np.min(mycobot.velocity_limits[idx][np.abs(delta) > 0] / dist)
    amax = np.min(mycobot.acceleration_limits[idx][np.abs(delta) > 0] / dist)
    profile = TrapezoidProfile(1.0, vmax, amax)
    assert traj.duration == pytest.approx(profile.duration, abs=1e-12)
    t = np.linspace(0.0, traj.duration, 997)
    q, qd, _ = traj.sample(t)
    s, sd, _ = profile.evaluate(t)
    assert np.allclose(q, q0 + s[:, None] * delta, atol=1e-12)
    assert np.allclose(qd, sd[:, None] * delta, atol=1e-12)


def test_ptp_joint_goal_panda_unequal_limits(panda, free_panda):
    start = RobotState(panda)
    start.set_named("default", "arm_and_hand")
    goal = start.group_positions("arm") + np.array([0.5, -0.3, 0.2, 0.4, -0.6, 0.3, 1.0])
    vs, acs = 0.7, 0.5
    response = plan_industrial(free_panda, request("arm", JointGoal(goal), start, "PTP",
                                                   max_velocity_scaling_factor=vs, max_acceleration_scaling_factor=acs))
    assert_valid(free_panda, response, "arm", start, vs, acs)
    idx = panda.group("arm").variable_indices
    assert np.allclose(response.trajectory.positions[-1], goal, atol=1e-12)
    check_synchronised(response.trajectory, panda.velocity_limits[idx], panda.acceleration_limits[idx], vs, acs)
    # Joint 7 moves furthest (1.0 rad) but joints 1-4 have lower limits: the leading axis is the
    # one whose own fastest profile takes longest.
    assert "leading axis panda_joint7" in response.message


def test_ptp_named_goal_panda_other_group(panda, free_panda):
    start = RobotState(panda)
    start.set_joint_positions({"panda_joint2": -0.3, "panda_joint4": -2.0, "panda_joint6": 1.8})
    response = plan_industrial(free_panda, request("arm_and_hand", NamedGoal("default"), start, "PTP"))
    assert_valid(free_panda, response, "arm_and_hand", start)
    expected = panda.named_state("default", "arm_and_hand")
    assert np.allclose(response.trajectory.positions[-1], [expected[j] for j in panda.group("arm_and_hand").joint_names])


@pytest.mark.parametrize("robot", ["mycobot", "panda"])
def test_ptp_pose_goal_takes_nearest_solution(robot, request_fixture_models, robot_scenes):
    model = request_fixture_models[robot]
    scene = robot_scenes[robot]
    group = "arm"
    jmg = model.group(group)
    if robot == "mycobot":
        start = workspace_state(model)
    else:
        start = RobotState(model)
        start.set_named("default", "arm_and_hand")
    offset = np.linspace(0.15, -0.15, jmg.variable_count)
    near = start.copy()
    near.set_group_positions(group, start.group_positions(group) + offset)
    pose = near.frame_pose(jmg.tip_link)
    response = plan_industrial(scene, request(group, PoseGoal(pose), start, "PTP", seed=1))
    assert_valid(scene, response, group, start)
    end = start.copy()
    end.set_group_positions(group, response.trajectory.positions[-1])
    reached = end.frame_pose(jmg.tip_link)
    assert np.allclose(reached[:3, 3], pose[:3, 3], atol=1e-4)
    assert np.allclose(reached[:3, :3], pose[:3, :3], atol=1e-3)
    if robot == "mycobot":  # 6 joints: the IK solution nearest the start is the one we perturbed
        assert np.allclose(response.trajectory.positions[-1], near.group_positions(group), atol=1e-3)


@pytest.fixture(scope="module")
def request_fixture_models(mycobot, panda):
    return {"mycobot": mycobot, "panda": panda}


@pytest.fixture(scope="module")
def robot_scenes(free_mycobot, free_panda):
    return {"mycobot": free_mycobot, "panda": free_panda}


def test_ptp_goal_already_reached(mycobot, free_mycobot):
    start = RobotState(mycobot)
    start.set_named("ready")
    response = plan_industrial(free_mycobot, request("arm", NamedGoal("ready"), start, "PTP"))
    assert response.success
    assert len(response.trajectory) == 1 and "already reached" in response.message


def test_planner_object(mycobot, free_mycobot):
    planner = IndustrialMotionPlanner(sample_time=0.05)
    start = RobotState(mycobot)
    start.set_named("ready")
    response = planner.plan(free_mycobot, request("arm", NamedGoal("home"), start, "PTP"))
    assert response.success and np.max(np.diff(response.trajectory.times)) <= 0.05 + 1e-12


# ---------------------------------------------------------------------------- fallbacks_move_to
def test_fallback_case_a_succeeds(mycobot):
    """90 degree offset from the target, no obstacle: PTP swings link1_to_link2 from -45 to +45."""
    scene = fallback_scene(mycobot, with_box=False)
    start = ready_with(mycobot, link1_to_link2=-TAU / 8)
    response = plan_industrial(scene, request("arm", JointGoal(fallback_target(mycobot)), start, "PTP"))
    assert_valid(scene, response, "arm", start)
    target = fallback_target(mycobot)
    assert np.allclose(response.trajectory.positions[-1], [target[j] for j in mycobot.group("arm").joint_names])


@pytest.mark.parametrize("with_box", [False, True])
def test_fallback_case_b_succeeds(mycobot, with_box):
    """Start already at +45 degrees with link3_to_link4 = 0: only link3_to_link4 moves (0 to
    pi/2). In the seeds this start has no box; even with the box the straight joint path stays
    on the +y side of the base, away from the wall at y = -0.2, so PTP succeeds either way."""
    scene = fallback_scene(mycobot, with_box=with_box)
    start = ready_with(mycobot, link1_to_link2=TAU / 8, link3_to_link4=0.0)
    response = plan_industrial(scene, request("arm", JointGoal(fallback_target(mycobot)), start, "PTP"))
    assert_valid(scene, response, "arm", start)
    moving = np.flatnonzero(np.ptp(response.trajectory.positions, axis=0) > 0)
    assert [mycobot.group("arm").joint_names[j] for j in moving] == ["link3_to_link4"]


@pytest.mark.parametrize("sample_time", [0.01, 0.1])
def test_fallback_case_c_fails_with_moveit_message(mycobot, sample_time):
    """The box blocks the swing: MoveIt logs "Invalid states at index locations: [ 4 5 ] out of
    13" with a contact between 'box' and 'link6_flange' at Pilz's 0.1 s sampling."""
    scene = fallback_scene(mycobot, with_box=True)
    start = ready_with(mycobot, link1_to_link2=-TAU / 8)
    response = plan_industrial(scene, request("arm", JointGoal(fallback_target(mycobot)), start, "PTP"),
                               sample_time=sample_time)
    assert response.error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN
    assert response.trajectory is None
    match = INVALID_STATES.search(response.message)
    assert match, response.message
    indices = [int(i) for i in match.group(1).split()]
    total = int(match.group(2))
    assert match.group(3, 4, 6) == ("box", "Object", "Robot link")
    assert match.group(5) in ("link5", "link6", "link6_flange", "gripper_base")
    assert indices == sorted(indices) and 0 < indices[0] and indices[-1] < total - 1
    # The reported states really collide, the others do not: replay the same (free-space) plan.
    free = plan_industrial(fallback_scene(mycobot, with_box=False),
                           request("arm", JointGoal(fallback_target(mycobot)), start, "PTP"), sample_time=sample_time)
    assert len(free.trajectory) == total
    full = start.copy()
    colliding = []
    for i, row in enumerate(free.trajectory.positions):
        full.set_group_positions("arm", row)
        if scene.check_collision(full):
            colliding.append(i)
    assert colliding == indices
    if sample_time == 0.1:
        times = free.trajectory.times[indices]
        assert {0.4, 0.5} <= {round(t, 6) for t in times}  # MoveIt's [ 4 5 ] (t = 0.4 s, 0.5 s)


def test_collision_between_samples_is_caught(mycobot):
    """A 5 mm cube where the flange passes between two 0.25 s samples: MoveIt's sample-only
    check misses it (collision_check_resolution=None reproduces that); ours does not."""
    start = ready_with(mycobot, link1_to_link2=-TAU / 8)
    goal = JointGoal(fallback_target(mycobot))
    free = plan_industrial(PlanningScene(mycobot), request("arm", goal, start, "PTP"), sample_time=0.25)
    traj = free.trajectory
    scene = None
    for t in np.linspace(traj.times[1], traj.times[2], 12)[1:-1]:
        state = start.copy()
        state.set_group_positions("arm", traj.sample(t)[0])
        candidate = PlanningScene(mycobot)
        candidate.add_object(CollisionObject.box("post", [0.005] * 3, make_pose(state.frame_pose("link6_flange")[:3, 3]),
                                                 frame_id="base_link"))
        sample_states = [start.copy() for _ in traj.positions]
        for s, row in zip(sample_states, traj.positions):
            s.set_group_positions("arm", row)
        if all(candidate.is_state_valid(s) for s in sample_states):
            scene = candidate
            break
    assert scene is not None, "no spot between samples 1 and 2 that every sample misses"
    caught = plan_industrial(scene, request("arm", goal, start, "PTP"), sample_time=0.25)
    assert caught.error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN
    assert "motion between index locations 1 and 2" in caught.message
    assert "'post' (Object)" in caught.message
    sample_only = plan_industrial(scene, request("arm", goal, start, "PTP"), sample_time=0.25,
                                  collision_check_resolution=None)
    assert sample_only.success
    assert not validate_trajectory(scene, sample_only.trajectory, "arm", start).valid


# ---------------------------------------------------------------------------- LIN
def rotation_progress(r0: np.ndarray, rotations: list[np.ndarray], axis_angle: np.ndarray) -> np.ndarray:
    """Fraction of the start-to-goal rotation done at each sample; asserts a fixed axis."""
    out = []
    angle = np.linalg.norm(axis_angle)
    for r in rotations:
        rel = pin.log3(r0.T @ r)
        along = float(np.dot(rel, axis_angle)) / angle
        assert np.linalg.norm(rel - along * axis_angle / angle) < 1e-6  # same axis
        out.append(along / angle)
    return np.array(out)


def test_lin_straight_line_with_slerp(mycobot, free_mycobot):
    start = workspace_state(mycobot)
    link = "link6_flange"
    t0 = start.frame_pose(link)
    goal = t0.copy()
    goal[:3, 3] += [0.03, -0.04, 0.03]
    goal[:3, :3] = rpy_to_matrix([0.05, -0.04, 0.03]) @ t0[:3, :3]
    vs, acs = 0.05, 0.03
    response = plan_industrial(free_mycobot, request("arm", PoseGoal(goal), start, "LIN",
                                                     max_velocity_scaling_factor=vs, max_acceleration_scaling_factor=acs))
    assert_valid(free_mycobot, response, "arm", start)
    traj = response.trajectory
    assert traj.interpolation == "quintic"
    state = start.copy()
    positions, rotations, speeds = [], [], []
    for row, qd in zip(traj.positions, traj.velocities):
        state.set_group_positions("arm", row)
        pose = state.frame_pose(link)
        positions.append(pose[:3, 3])
        rotations.append(pose[:3, :3])
        speeds.append(np.linalg.norm(state.jacobian(link, "arm")[:3] @ qd))
    positions = np.array(positions)
    d = goal[:3, 3] - t0[:3, 3]
    along = (positions - t0[:3, 3]) @ d / (d @ d)
    off_line = positions - t0[:3, 3] - along[:, None] * d
    assert np.max(np.linalg.norm(off_line, axis=1)) < 1e-4
    assert np.all(np.diff(along) > 0) and along[0] == pytest.approx(0, abs=1e-9) and along[-1] == pytest.approx(1, abs=1e-7)
    # Orientation: slerp about one axis, in step with the translation.
    progress = rotation_progress(t0[:3, :3], rotations, pin.log3(t0[:3, :3].T @ goal[:3, :3]))
    assert np.allclose(progress, along, atol=1e-4)
    assert np.allclose(rotations[-1], goal[:3, :3], atol=1e-6)
    # Translational speed within max_trans_vel * scaling, reached in the cruise phase.
    limits = load_cartesian_limits()
    assert max(speeds) <= limits.max_trans_vel * vs * (1 + 1e-6)
    assert max(speeds) == pytest.approx(limits.max_trans_vel * vs, rel=1e-3)
    # Interpolated (quintic) states stay on the line too.
    mid = 0.5 * (traj.times[:-1] + traj.times[1:])
    between = flange_positions(mycobot, start, "arm", link, traj.sample(mid)[0])
    t_between = (between - t0[:3, 3]) @ d / (d @ d)
    assert np.max(np.linalg.norm(between - t0[:3, 3] - t_between[:, None] * d, axis=1)) < 1e-4


def test_lin_rotation_limits_slow_mostly_rotating_moves(mycobot, free_mycobot):
    """A 5 mm move with a 0.3 rad turn: the rotational limit (max_rot_vel) sets the duration."""
    start = workspace_state(mycobot)
    link = "link6_flange"
    t0 = start.frame_pose(link)
    goal = t0.copy()
    goal[:3, 3] += [0.0, 0.0, 0.005]
    goal[:3, :3] = t0[:3, :3] @ rpy_to_matrix([0.0, 0.0, 0.3])
    vs, acs = 0.1, 0.02
    response = plan_industrial(free_mycobot, request("arm", PoseGoal(goal), start, "LIN",
                                                     max_velocity_scaling_factor=vs, max_acceleration_scaling_factor=acs))
    assert_valid(free_mycobot, response, "arm", start)
    limits = load_cartesian_limits()
    state = start.copy()
    rates = []
    for row, qd in zip(response.trajectory.positions, response.trajectory.velocities):
        state.set_group_positions("arm", row)
        rates.append(np.linalg.norm(state.jacobian(link, "arm")[3:] @ qd))
    assert max(rates) <= limits.max_rot_vel * vs * (1 + 1e-6)
    assert "0.1911 m" in response.message  # path parameter = eqradius * 0.3 rad, not the 5 mm


def test_lin_joint_goal_and_analytic_derivatives(mycobot, free_mycobot):
    """A joint goal is turned into its flange pose (FK); velocities come from the Jacobian, and
    agree with finite differences of the positions away from the profile's phase boundaries."""
    start = workspace_state(mycobot)
    goal_state = start.copy()
    goal_state.set_joint_positions({"link2_to_link3": -0.42, "link3_to_link4": 1.45})
    goal = goal_state.group_positions("arm")
    response = plan_industrial(free_mycobot, request("arm", JointGoal(goal), start, "LIN",
                                                     max_velocity_scaling_factor=0.05, max_acceleration_scaling_factor=0.03))
    assert_valid(free_mycobot, response, "arm", start)
    traj = response.trajectory
    assert np.allclose(traj.positions[-1], goal, atol=1e-6)
    fd = np.gradient(traj.positions, traj.times, axis=0)
    h = np.diff(traj.times)
    regular = np.flatnonzero((np.abs(h[:-1] - 0.01) < 1e-9) & (np.abs(h[1:] - 0.01) < 1e-9)) + 1
    assert np.max(np.abs(fd[regular] - traj.velocities[regular])) < 1e-4
    assert np.max(np.abs(traj.velocities)) > 0.1
    # Accelerations (Jacobian time derivative) agree with differences of the velocities.
    fd_acc = np.gradient(traj.velocities, traj.times, axis=0)
    assert np.max(np.abs(fd_acc[regular] - traj.accelerations[regular])) < 1e-4
    assert np.max(np.abs(traj.accelerations)) > 0.1


def test_lin_panda_redundant(panda, free_panda):
    start = RobotState(panda)
    start.set_named("default", "arm_and_hand")
    link = panda.group("arm").tip_link
    t0 = start.frame_pose(link)
    goal = t0.copy()
    goal[:3, 3] += [0.1, 0.1, -0.1]
    response = plan_industrial(free_panda, request("arm", PoseGoal(goal), start, "LIN",
                                                   max_velocity_scaling_factor=0.1, max_acceleration_scaling_factor=0.05))
    assert_valid(free_panda, response, "arm", start)
    positions = flange_positions(panda, start, "arm", link, response.trajectory.positions)
    d = goal[:3, 3] - t0[:3, 3]
    along = (positions - t0[:3, 3]) @ d / (d @ d)
    assert np.max(np.linalg.norm(positions - t0[:3, 3] - along[:, None] * d, axis=1)) < 1e-4


def test_lin_joint_limits_checked_like_pilz(mycobot, free_mycobot):
    """At full scaling (1 m/s) the small myCobot cannot follow a line: PLANNING_FAILED naming
    the joint limit, the sample and the scaling factor to lower."""
    start = workspace_state(mycobot)
    goal = start.frame_pose("link6_flange")
    goal[:3, 3] += [0.03, -0.04, 0.03]
    response = plan_industrial(free_mycobot, request("arm", PoseGoal(goal), start, "LIN"))
    assert response.error_code.val == MoveItErrorCode.PLANNING_FAILED
    assert re.search(r"joint (velocity|acceleration) limit of link\d_to_link\d violated", response.message)
    assert "sample" in response.message and "scaling_factor" in response.message


def test_lin_unreachable_goal_names_the_sample(mycobot, free_mycobot):
    start = RobotState(mycobot)
    start.set_named("home")  # arm stretched straight up
    goal = start.frame_pose("link6_flange")
    goal[:3, 3] += [0.0, 0.0, 0.05]  # further up: out of reach from the first step on
    response = plan_industrial(free_mycobot, request("arm", PoseGoal(goal), start, "LIN",
                                                     max_velocity_scaling_factor=0.05, max_acceleration_scaling_factor=0.05))
    assert response.error_code.val == MoveItErrorCode.NO_IK_SOLUTION
    assert re.search(r"no IK solution for sample 1 of \d+ \(t=0.010 s\)", response.message)


# ---------------------------------------------------------------------------- CIRC
def circ_setup(model: RobotModel):
    start = workspace_state(model)
    t0 = start.frame_pose("link6_flange")
    centre = t0[:3, 3] + np.array([0.0, 0.03, 0.0])
    radial = t0[:3, 3] - centre

    def on_circle(angle: float) -> np.ndarray:
        c, s = math.cos(angle), math.sin(angle)
        return centre + np.array([c * radial[0] - s * radial[1], s * radial[0] + c * radial[1], radial[2]])

    goal = t0.copy()
    goal[:3, 3] = on_circle(math.pi / 2)
    goal[:3, :3] = rpy_to_matrix([0.0, 0.0, 0.2]) @ t0[:3, :3]
    return start, t0, centre, goal, on_circle


def check_arc(model, start, response, centre, radius, t0, goal) -> np.ndarray:
    traj = response.trajectory
    rows = np.concatenate([traj.positions, traj.sample(0.5 * (traj.times[:-1] + traj.times[1:]))[0]])
    points = flange_positions(model, start, "arm", "link6_flange", rows)
    assert np.max(np.abs(np.linalg.norm(points - centre, axis=1) - radius)) < 1e-4
    assert np.max(np.abs(points[:, 2] - centre[2])) < 1e-4  # in the circle's (horizontal) plane
    end = start.copy()
    end.set_group_positions("arm", traj.positions[-1])
    assert np.allclose(end.frame_pose("link6_flange"), goal, atol=1e-6)
    rotations = []
    for row in traj.positions:
        end.set_group_positions("arm", row)
        rotations.append(end.frame_pose("link6_flange")[:3, :3])
    progress = rotation_progress(t0[:3, :3], rotations, pin.log3(t0[:3, :3].T @ goal[:3, :3]))
    assert np.all(np.diff(progress) >= -1e-9)
    # Angle swept about the centre (counter-clockwise about +z), unwrapped.
    rel = points[: len(traj)] - centre
    angles = np.unwrap(np.arctan2(rel[:, 1], rel[:, 0]))
    return angles - angles[0]


@pytest.mark.parametrize("aux", ["centre", "interim"])
def test_circ_quarter_circle(mycobot, free_mycobot, aux):
    start, t0, centre, goal, on_circle = circ_setup(mycobot)
    kw = {"circ_center": centre} if aux == "centre" else {"circ_interim": on_circle(math.pi / 4)}
    response = plan_industrial(free_mycobot, request("arm", PoseGoal(goal), start, "CIRC",
                                                     max_velocity_scaling_factor=0.05,
                                                     max_acceleration_scaling_factor=0.03, **kw))
    assert_valid(free_mycobot, response, "arm", start)
    swept = check_arc(mycobot, start, response, centre, 0.03, t0, goal)
    assert swept[-1] == pytest.approx(math.pi / 2, abs=1e-6)
    assert np.all(np.diff(swept) >= -1e-9)


def test_circ_interim_takes_the_long_way(mycobot, free_mycobot):
    """An interim point on the far side makes the arc 270 degrees, through the interim."""
    start, t0, centre, goal, on_circle = circ_setup(mycobot)
    interim = on_circle(-math.pi / 2)
    response = plan_industrial(free_mycobot, request("arm", PoseGoal(goal), start, "CIRC", circ_interim=interim,
                                                     max_velocity_scaling_factor=0.05,
                                                     max_acceleration_scaling_factor=0.03))
    assert_valid(free_mycobot, response, "arm", start)
    swept = check_arc(mycobot, start, response, centre, 0.03, t0, goal)
    assert swept[-1] == pytest.approx(-3 * math.pi / 2, abs=1e-6)
    points = flange_positions(mycobot, start, "arm", "link6_flange", response.trajectory.positions)
    assert np.min(np.linalg.norm(points - interim, axis=1)) < 0.002


@pytest.mark.parametrize(
    "kind, words",
    [
        ("centre_opposite", "collinear: the circle's plane is undetermined"),
        ("interim_on_chord", "collinear (or coincide)"),
        ("centre_off", "no circle through both"),
        ("both", "exactly one auxiliary point"),
        ("neither", "exactly one auxiliary point"),
        ("nan", "must be 3 finite numbers"),
    ],
)
def test_circ_rejects_points_without_a_circle(mycobot, free_mycobot, kind, words):
    start, t0, centre, goal, on_circle = circ_setup(mycobot)
    kw = {
        "centre_opposite": {"circ_center": centre},
        "interim_on_chord": {"circ_interim": 0.5 * (t0[:3, 3] + goal[:3, 3])},
        "centre_off": {"circ_center": centre + np.array([0.02, 0.0, 0.0])},
        "both": {"circ_center": centre, "circ_interim": on_circle(1.0)},
        "neither": {},
        "nan": {"circ_center": [0.1, float("nan"), 0.2]},
    }[kind]
    if kind == "centre_opposite":
        goal = goal.copy()
        goal[:3, 3] = on_circle(math.pi)
    response = plan_industrial(free_mycobot, request("arm", PoseGoal(goal), start, "CIRC", **kw))
    assert response.error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN
    assert words in response.message


# ---------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "change, code, words",
    [
        ({"planner_id": "SPLINE"}, MoveItErrorCode.INVALID_MOTION_PLAN, "known: PTP, LIN, CIRC"),
        ({"planner_id": ""}, MoveItErrorCode.INVALID_MOTION_PLAN, "unknown planner_id ''"),
        ({"max_velocity_scaling_factor": 0.0}, MoveItErrorCode.INVALID_MOTION_PLAN, "max_velocity_scaling_factor"),
        ({"max_velocity_scaling_factor": 1.5}, MoveItErrorCode.INVALID_MOTION_PLAN, "max_velocity_scaling_factor"),
        ({"max_acceleration_scaling_factor": float("nan")}, MoveItErrorCode.INVALID_MOTION_PLAN, "max_acceleration_scaling_factor"),
        ({"group": "legs"}, MoveItErrorCode.INVALID_GROUP_NAME, "unknown planning group 'legs'"),
        ({"goal": JointGoal([0.0, float("nan"), 0, 0, 0, 0])}, MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "NaN"),
        ({"goal": JointGoal([0.0] * 5)}, MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "has 5 values"),
        ({"goal": NamedGoal("dance")}, MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "dance"),
        ({"goal": PoseGoal(np.full((4, 4), np.nan))}, MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "pose goal"),
        ({"goal": "home"}, MoveItErrorCode.UNRECOGNIZED_GOAL_TYPE, "str"),
    ],
)
@pytest.mark.parametrize("planner_id", ["PTP", "LIN"])
def test_bad_requests_get_moveit_codes(mycobot, free_mycobot, change, code, words, planner_id):
    start = RobotState(mycobot)
    start.set_named("ready")
    fields = {"group": "arm", "goal": NamedGoal("home"), "planner_id": planner_id}
    fields.update(change)
    req = MotionPlanRequest(fields.pop("group"), fields.pop("goal"), start_state=start, **fields)
    response = plan_industrial(free_mycobot, req)
    assert response.error_code.val == code, response.message
    assert words in response.message
    assert response.trajectory is None


def test_bad_call_arguments(mycobot, free_mycobot):
    start = RobotState(mycobot)
    start.set_named("ready")
    req = request("arm", NamedGoal("home"), start, "LIN")
    for sample_time in (0.0, -0.01, float("nan")):
        response = plan_industrial(free_mycobot, req, sample_time=sample_time)
        assert response.error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN and "sample_time" in response.message
    response = plan_industrial(free_mycobot, req, cartesian_limits={"max_trans_vel": 1.0})
    assert response.error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN and "missing" in response.message
    with pytest.raises(CartesianLimitsError):
        IndustrialMotionPlanner(cartesian_limits={"max_trans_vel": -1.0})


def test_start_state_in_collision(mycobot):
    scene = fallback_scene(mycobot, with_box=True)
    start = ready_with(mycobot, link1_to_link2=-TAU / 8)
    # Move the box onto the arm at the start state.
    scene.move_object("box", make_pose(start.frame_pose("link6_flange")[:3, 3]))
    response = plan_industrial(scene, request("arm", NamedGoal("home"), start, "PTP"))
    assert response.error_code.val == MoveItErrorCode.START_STATE_IN_COLLISION
    assert "'box'" in response.message
