"""The Pilz pipeline's names, defaults and tolerances, and the collision check every generator's samples pass."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from interfaces_py.msgs import MoveItErrorCode

from ...kinematics.ik_solver import IKOptions
from ...planning_interface.planning_interface import (
    JointGoal,
    NamedGoal,
    failure,
    goal_state_in_scene,
    joint_goal_vector,
)
from ...planning_scene.planning_scene import PlanningScene
from ...robot_model.robot_model import JointModelGroup, RobotModel
from ...robot_state.robot_state import RobotState

PILZ_PIPELINE_ID = "pilz_industrial_motion_planner"
PTP, LIN, CIRC = "PTP", "LIN", "CIRC"
KNOWN_PLANNER_IDS = (PTP, LIN, CIRC)

#: Seconds between samples. (MoveIt's Pilz default ``max_sample_time`` is 0.1 s; a 10 ms grid is
#: what a ros2_control controller runs at and keeps the sample-only collision check meaningful.)
DEFAULT_SAMPLE_TIME = 0.01
#: Default joint step (rad or m, max over the group's joints) at which the motion between samples
#: is collision-checked, the trajectory validator's default resolution.
DEFAULT_COLLISION_CHECK_RESOLUTION = 0.005
#: MoveIt's code for a generated trajectory that fails the scene check (ValidateSolution adapter).
COLLISION_ERROR_CODE = MoveItErrorCode.INVALID_MOTION_PLAN

# Below this (rad or m, max over joints / path length) nothing moves: one-point trajectory.
NO_MOTION = 1e-9
# Grid samples closer than this fraction of the sample time to a phase boundary or the end are
# dropped, so no interval is pathologically short (same rule as time_parameterization).
MIN_SAMPLE_FRACTION = 0.01
# LIN/CIRC samples come from IK: intervals shorter than this fraction of the sample time would
# turn IK round-off into large apparent joint speeds, so the grid keeps its distance from phase
# boundaries.
MIN_CARTESIAN_SAMPLE_FRACTION = 0.1
# Relative slack on the joint-limit checks of LIN/CIRC samples (rounding).
LIMIT_SLACK = 1e-6
# IK tolerances for LIN/CIRC samples: far below the solver's defaults (1e-5 m, 1e-4 rad) because
# sample positions are differenced over a few milliseconds; Gauss-Newton converges
# quadratically, so this costs about one extra iteration per sample.
TRACKING_IK = IKOptions(position_tolerance=1e-9, orientation_tolerance=1e-9)


@dataclass
class PilzContext:
    scene: PlanningScene
    model: RobotModel
    jmg: JointModelGroup
    start: RobotState
    sample_time: float
    resolution: float | None


# ---------------------------------------------------------------------------- scene check
def check_in_scene(ctx: PilzContext, positions: np.ndarray,
                    between: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> None:
    """Every sample (and, at ctx.resolution, the motion between samples) must be valid in the
    scene; otherwise COLLISION_ERROR_CODE with MoveIt's "Invalid states at index locations" text
    and the first contact.

    ``between(intervals, fractions)`` gives the group positions at those fractions of those
    sample intervals (vectorised: one call for the whole trajectory). Rows are built as full
    robot vectors up front so the loop is nothing but the scene's hot-path check.
    """
    is_valid = ctx.scene.is_valid_positions
    n = len(positions)
    fulls = full_rows(ctx, positions)
    invalid = [i for i in range(n) if not is_valid(fulls[i])]
    if invalid:
        raise failure(
            COLLISION_ERROR_CODE,
            "Computed path is not valid. Invalid states at index locations: [ "
            + "".join(f"{i} " for i in invalid)
            + f"] out of {n}; " + explain_collision(ctx, fulls[invalid[0]]),
        )
    if ctx.resolution is None or n < 2:
        return
    steps = np.max(np.abs(np.diff(positions, axis=0)), axis=1)
    counts = np.ceil(steps / ctx.resolution).astype(int)
    counts[steps <= ctx.resolution] = 1
    if not np.any(counts > 1):
        return
    intervals = np.repeat(np.arange(n - 1), counts - 1)
    # k-th of (count - 1) intermediate states of an interval sits at fraction k / count.
    first = np.cumsum(counts - 1) - (counts - 1)
    k = np.arange(len(intervals)) - np.repeat(first, counts - 1) + 1
    fractions = k / counts[intervals]
    rows = full_rows(ctx, between(intervals, fractions))
    for j in range(len(rows)):
        if not is_valid(rows[j]):
            i = int(intervals[j])
            raise failure(
                COLLISION_ERROR_CODE,
                f"Computed path is not valid. The motion between index locations {i} and {i + 1} "
                f"(out of {n}) is invalid although both states are valid; " + explain_collision(ctx, rows[j]),
            )


def full_rows(ctx: PilzContext, group_rows: np.ndarray) -> np.ndarray:
    fulls = np.repeat(ctx.start.positions[None, :], len(group_rows), axis=0)
    fulls[:, ctx.jmg.variable_indices] = group_rows
    return fulls


def explain_collision(ctx: PilzContext, full: np.ndarray) -> str:
    """The first contact of an invalid state (or the joint limits it violates)."""
    state = RobotState(ctx.model, full)
    report = ctx.scene.check_collision(state, max_contacts=1)
    if report.collision and report.contacts:
        return str(report.contacts[0])
    violated = state.violated_bounds()
    if violated:
        return "joint limits violated: " + "; ".join(violated)
    return "state invalid"


def joint_goal_state(ctx: PilzContext, goal: object) -> RobotState:
    if not isinstance(goal, (JointGoal, NamedGoal)):
        raise failure(MoveItErrorCode.UNRECOGNIZED_GOAL_TYPE, f"unrecognised goal type {type(goal).__name__}")
    state = ctx.start.copy()
    state.set_group_positions(ctx.jmg.name, joint_goal_vector(ctx.model, ctx.jmg, goal))
    goal_state_in_scene(ctx.scene, state)
    return state


