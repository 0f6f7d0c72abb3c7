"""The ROS-free servo (core/servo): twist, joint jog and pose commands move the group as
commanded; velocity limits, singularity, collision and joint-limit scaling and halts; the
Butterworth filter; refused commands."""
from __future__ import annotations

import math

import numpy as np
import pytest

from interfaces_py.msgs import CollisionObject
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.servo import (
    ButterworthFilter,
    CommandError,
    JointJogCommand,
    PoseCommand,
    Servo,
    ServoParameters,
    StatusCode,
    TwistCommand,
    collision_velocity_scale,
)
from mycobot_planning.core.transforms import make_pose

WORK = [0.0, -0.5, -1.0, -0.2, 0.3, 0.0]  # an ordinary pose of the myCobot (condition number 47)
#: the myCobot's thresholds (config/servo_node.yaml)
MYCOBOT = dict(lower_singularity_threshold=100.0, hard_stop_singularity_threshold=200.0)


def make_servo(model: RobotModel, arm=WORK, **params) -> Servo:
    servo = Servo(model, ServoParameters(**{**MYCOBOT, **params}))
    full = model.default_positions().astype(float)
    full[servo.indices] = arm
    servo.reset(full)
    return servo


def angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    return math.degrees(math.acos(np.clip(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)), -1, 1)))


def test_butterworth_passes_a_constant_and_smooths_a_step():
    f = ButterworthFilter(2, 1.5)
    out = [f.filter(np.array([1.0, -2.0])) for _ in range(40)]
    assert 0 < out[0][0] < 0.5 and np.allclose(out[-1], [1.0, -2.0])
    assert all(b[0] >= a[0] for a, b in zip(out, out[1:]))  # no overshoot
    with pytest.raises(ValueError):
        ButterworthFilter(1, 1.0)


@pytest.mark.parametrize("frame, linear, about_ee", [
    ("base_link", (1.0, 0.0, 0.0), True),
    ("base_link", (0.0, 0.6, -0.8), True),
    ("link6_flange", (0.0, 0.0, 1.0), True),
    ("link6_flange", (0.0, 1.0, 0.0), False),
])
def test_twist_moves_the_tip_along_the_command(mycobot, frame, linear, about_ee):
    servo = make_servo(mycobot, apply_twist_commands_about_ee_frame=about_ee)
    rotation = servo.frame_pose(frame)[:3, :3]
    command = TwistCommand(frame, linear, (0.0, 0.0, 0.0))
    servo.check_command(command)
    start = servo.tip_pose()
    for _ in range(20):
        step = servo.step(command)
    assert step.status == StatusCode.NO_WARNING
    moved = servo.tip_pose()[:3, 3] - start[:3, 3]
    assert angle_deg(moved, rotation @ np.array(linear)) < 2.0
    # unitless 1.0 is scale.linear m/s; the smoothing's ramp takes a little of the first 0.2 s
    assert 0.4 * 0.4 * 0.2 < np.linalg.norm(moved) <= 0.4 * 0.2 + 1e-9
    rotation_change = servo.tip_pose()[:3, :3] @ start[:3, :3].T
    assert np.linalg.norm(np.array([rotation_change[2, 1], rotation_change[0, 2], rotation_change[1, 0]])) < 5e-3  # first-order drift only


def test_speed_units_twist_is_capped_and_velocities_stay_within_limits(mycobot):
    servo = make_servo(mycobot, command_in_type="speed_units", scale_linear=10.0, scale_rotational=10.0)
    command = TwistCommand("base_link", (0.0, 0.0, -5.0), (0.0, 0.0, 0.0))
    for _ in range(30):
        step = servo.step(command)
        assert np.all(np.abs(step.velocities) <= servo.vmax * (1 + 1e-9))
    assert np.isclose(np.max(np.abs(step.velocities) / servo.vmax), 1.0, atol=0.02)


def test_joint_jog_moves_that_joint_at_scale_joint(mycobot):
    servo = make_servo(mycobot)
    before = servo.positions
    for _ in range(100):
        step = servo.step(JointJogCommand(("link1_to_link2",), (1.0,)))
    moved = servo.positions - before
    assert np.all(moved[1:] == 0) and 0.45 < moved[0] < 0.5  # 0.5 rad/s for 1 s, less the ramp
    assert math.isclose(step.velocities[0], 0.5, rel_tol=1e-3)


def test_no_command_brings_the_motion_to_rest(mycobot):
    servo = make_servo(mycobot)
    for _ in range(20):
        servo.step(JointJogCommand(("link1_to_link2",), (1.0,)))
    at_stop = servo.positions
    steps = [servo.step(None) for _ in range(15)]
    assert not steps[-1].moving and np.all(steps[-1].velocities == 0)
    assert np.max(np.abs(servo.positions - at_stop)) < 0.5 * 0.01 * 2  # the filter's tail only


def test_pose_tracking_ends_within_tolerances(mycobot):
    servo = make_servo(mycobot)
    start = servo.tip_pose()
    target = start.copy()
    target[:3, 3] += [0.03, -0.02, 0.02]
    target[:3, :3] = target[:3, :3] @ make_pose(rpy=[0.1, -0.1, 0.15])[:3, :3]
    command = PoseCommand("base_link", target)
    servo.check_command(command)
    for _ in range(600):
        step = servo.step(command)
        if step.reached:
            break
    assert step.reached
    reached = servo.tip_pose()
    assert np.linalg.norm(reached[:3, 3] - target[:3, 3]) <= 0.001
    cos = (np.trace(reached[:3, :3].T @ target[:3, :3]) - 1) / 2
    assert math.acos(min(1.0, cos)) <= 0.01


def test_extending_the_arm_decelerates_then_halts_for_singularity(mycobot):
    servo = make_servo(mycobot)
    statuses = []
    for _ in range(500):
        step = servo.step(TwistCommand("base_link", (0.0, 0.0, 1.0), (0.0, 0.0, 0.0)))
        statuses.append(step.status)
        if step.status == StatusCode.HALT_FOR_SINGULARITY:
            break
    assert StatusCode.DECELERATE_FOR_APPROACHING_SINGULARITY in statuses
    assert statuses[-1] == StatusCode.HALT_FOR_SINGULARITY and not step.moving
    # moving back away is allowed (decelerating while leaving)
    step = servo.step(TwistCommand("base_link", (0.0, 0.0, -1.0), (0.0, 0.0, 0.0)))
    step = servo.step(TwistCommand("base_link", (0.0, 0.0, -1.0), (0.0, 0.0, 0.0)))
    assert step.moving and step.status in (StatusCode.DECELERATE_FOR_LEAVING_SINGULARITY, StatusCode.NO_WARNING)


@pytest.mark.parametrize("halt_all", [True, False])
def test_jog_toward_a_limit_halts_inside_the_margin(mycobot, halt_all):
    servo = make_servo(mycobot, arm=[2.6, -0.5, -1.0, -0.2, 0.3, 0.0], halt_all_joints_in_joint_mode=halt_all)
    command = JointJogCommand(("link1_to_link2", "link2_to_link3"), (1.0, 0.2))
    for _ in range(200):
        step = servo.step(command)
        if step.status == StatusCode.JOINT_BOUND:
            break
    assert step.status == StatusCode.JOINT_BOUND
    upper = servo.upper[0]
    assert upper - 0.1 - 0.01 < servo.positions[0] <= upper
    assert step.velocities[0] == 0.0
    assert (step.velocities[1] == 0.0) == halt_all


def test_collision_scale_is_moveits_exponential():
    assert collision_velocity_scale(1.0, 1.0, 0.01, 0.02) == (1.0, StatusCode.NO_WARNING)
    scale, status = collision_velocity_scale(1.0, 0.01, 0.01, 0.02)
    assert status == StatusCode.DECELERATE_FOR_COLLISION and math.isclose(scale, 1000 ** -0.5)
    assert collision_velocity_scale(0.005, 1.0, 0.01, 0.02)[0] == pytest.approx(1000 ** -0.5)
    assert collision_velocity_scale(1.0, 0.0, 0.01, 0.02) == (0.0, StatusCode.HALT_FOR_COLLISION)


def test_a_step_into_collision_is_refused(mycobot):
    servo = make_servo(mycobot)
    scene = PlanningScene(mycobot)
    tip = servo.tip_pose()[:3, 3]
    scene.add_object(CollisionObject.box("box", [0.04, 0.04, 0.04], make_pose(tip + [0.0, 0.07, 0.0])))
    state = RobotState(mycobot)

    def collides(full):
        state.set_positions(full)
        return scene.is_state_colliding(state)

    command = TwistCommand("base_link", (0.0, 1.0, 0.0), (0.0, 0.0, 0.0))
    halted = False
    for _ in range(300):
        step = servo.step(command, collides=collides)
        state.set_positions(servo.full_positions)
        assert not scene.is_state_colliding(state)
        if step.status == StatusCode.HALT_FOR_COLLISION:
            halted = True
            break
    assert halted and not step.moving
    assert scene.distance(state, include_self=False).min_distance > 0


@pytest.mark.parametrize("command, words", [
    (TwistCommand("base_link", (math.nan, 0, 0), (0, 0, 0)), "NaN or infinite"),
    (TwistCommand("base_link", (0, 0, 0), (0, math.inf, 0)), "NaN or infinite"),
    (TwistCommand("", (0.1, 0, 0), (0, 0, 0)), "empty header.frame_id"),
    (TwistCommand("no_such_frame", (0.1, 0, 0), (0, 0, 0)), "unknown frame 'no_such_frame'"),
    (TwistCommand("base_link", (2.0, 0, 0), (0, 0, 0)), "unitless"),
    (JointJogCommand(("link1_to_link2", "link2_to_link3"), (0.1,)), "2 joint_names and 1 velocities"),
    (JointJogCommand(("elbow",), (0.1,)), "['elbow'], not joints of group 'arm'"),
    (JointJogCommand(("link1_to_link2",), (math.nan,)), "NaN or infinite"),
    (PoseCommand("base_link", make_pose([0.0, 0.0, 5.0])), "unreachable"),
    (PoseCommand("nowhere", make_pose([0.1, 0.0, 0.2])), "unknown frame"),
])
def test_bad_commands_are_refused_with_a_reason(mycobot, command, words):
    servo = make_servo(mycobot)
    with pytest.raises(CommandError, match=None) as info:
        servo.check_command(command)
    assert words in str(info.value)


def test_bad_parameters_are_refused(mycobot):
    with pytest.raises(ValueError, match="hard_stop_singularity_threshold"):
        Servo(mycobot, ServoParameters(lower_singularity_threshold=40.0, hard_stop_singularity_threshold=30.0))
    with pytest.raises(ValueError, match="move_group_name 'legs'"):
        Servo(mycobot, ServoParameters(move_group_name="legs"))
    with pytest.raises(ValueError, match="joint_limit_margins"):
        Servo(mycobot, ServoParameters(joint_limit_margins=[0.1, 0.1]))
