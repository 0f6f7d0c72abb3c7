"""PTP: a synchronised trapezoidal move in joint space to a joint, named or pose goal."""
from __future__ import annotations

import numpy as np

from ...planning_interface.planning_interface import (
    MotionPlanRequest,
    PoseGoal,
    goal_states,
)
from ...robot_trajectory.robot_trajectory import TimedTrajectory
from .common import NO_MOTION, PilzContext, check_in_scene, joint_goal_state
from .trapezoid_profile import TrapezoidProfile, sample_times


# ---------------------------------------------------------------------------- PTP
def plan_ptp(ctx: PilzContext, request: MotionPlanRequest, vel_scale: float, acc_scale: float
              ) -> tuple[TimedTrajectory, str]:
    model, jmg = ctx.model, ctx.jmg
    idx = jmg.variable_indices
    names = list(jmg.joint_names)
    if isinstance(request.goal, PoseGoal):
        timeout = float(model.kinematics(jmg.name)["kinematics_solver_timeout"])
        rng = np.random.default_rng(request.seed)
        # Nearest (to the start) of the collision-free IK solutions, searched from the start.
        goal = goal_states(ctx.scene, jmg, ctx.start, request.goal, max(1, request.num_ik_goals), timeout, rng)[0]
    else:
        goal = joint_goal_state(ctx, request.goal)
    q0 = ctx.start.positions[idx].copy()
    q1 = goal.positions[idx].copy()
    delta = q1 - q0
    moving = np.abs(delta) > NO_MOTION
    if not moving.any():
        trajectory = TimedTrajectory(names, [0.0], q0[None, :], np.zeros((1, len(idx))), np.zeros((1, len(idx))),
                                     interpolation="cubic")
        return trajectory, "PTP: goal already reached (one point)"
    vmax = model.velocity_limits[idx] * vel_scale
    amax = model.acceleration_limits[idx] * acc_scale
    dist = np.abs(delta[moving])
    # Normalised progress s in [0, 1]: joint j moves delta_j * s(t). The fastest s keeping every
    # joint within its limits has these bounds; all joints then share one profile's phases.
    profile = TrapezoidProfile(
        1.0,
        float(np.min(vmax[moving] / dist)),
        float(np.min(amax[moving] / dist)),
    )
    # Pilz's leading axis: the joint whose own fastest profile takes longest.
    own = [TrapezoidProfile(float(d), float(v), float(a)).duration for d, v, a in zip(dist, vmax[moving], amax[moving])]
    leading = np.array(names)[moving][int(np.argmax(own))]
    times = sample_times(profile.duration, profile.breakpoints, ctx.sample_time)
    s, sd, sdd = profile.evaluate(times)
    positions = q0[None, :] + s[:, None] * delta[None, :]
    velocities = sd[:, None] * delta[None, :]
    accelerations = sdd[:, None] * delta[None, :]
    positions[-1] = q1
    velocities[-1] = 0.0
    accelerations[-1] = 0.0

    def between(intervals: np.ndarray, fractions: np.ndarray) -> np.ndarray:
        t = times[intervals] + fractions * (times[intervals + 1] - times[intervals])
        return q0[None, :] + profile.evaluate(t)[0][:, None] * delta[None, :]

    check_in_scene(ctx, positions, between)
    trajectory = TimedTrajectory(names, times, positions, velocities, accelerations, interpolation="cubic")
    message = (f"PTP: {len(times)} samples, {profile.duration:.3f} s, leading axis {leading}")
    return trajectory, message
