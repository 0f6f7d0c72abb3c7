"""The `robots` benchmark: every arm example-robot-data ships, configured by the setup assistant.

"Any arm given as URDF + SRDF" is a claim; this measures it. For each arm: its shipped SRDF (if
any) must load (forgivingly), then the setup assistant writes a configuration from the URDF (and
the shipped SRDF where there is one, keeping its valid parts), and on that configuration we
measure IK on FK poses of random valid states, OMPL on random valid joint goals (every path
through the independent validator) and a 0.1 m Cartesian line from a non-singular state. The
test over the same set (test/setup_assistant/test_example_arms.py) runs `evaluate_arm` with fewer
samples; this module is the one implementation both use.
"""
from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core import PlanningScene, RobotModel, RobotState
from ..core.planners.cartesian.cartesian_path import compute_cartesian_path
from ..core.collision_detection.collision_matrix import sample_positions
from ..core.kinematics.ik_solver import IKSolver
from ..core.planners.ompl import OmplPlanner
from ..core.planning_interface.planning_interface import JointGoal, MotionPlanRequest
from ..core.trajectory_processing.trajectory_validator import validate_trajectory
from ..paths import example_robot_data_dir
from ..setup_assistant import GroupSpec, build_config
from .common import emit, machine


@dataclass(frozen=True)
class ExampleArm:
    """One arm of example-robot-data: its URDF, its shipped SRDF, the group to plan for."""

    robot: str
    urdf: str
    srdf: str | None = None
    group: GroupSpec | None = None  # given to the setup assistant (None: its default or the SRDF's)
    plan_group: str = "arm"  # the group measured

    @property
    def group_name(self) -> str:
        return self.group.name if self.group else self.plan_group


#: Every arm example-robot-data 6.0.0 ships (a base with legs or wheels counts when it carries
#: an arm: b1-z1 plans its arm with the floating base held). Groups are given only where the
#: shipped SRDF has one for the arm under another name or the default chain would pick a leg.
EXAMPLE_ARMS: tuple[ExampleArm, ...] = (
    ExampleArm("panda", "panda_description/urdf/panda.urdf", "panda_description/srdf/panda.srdf"),
    ExampleArm("ur3_gripper", "ur_description/urdf/ur3_gripper.urdf", "ur_description/srdf/ur3_gripper.srdf",
               GroupSpec("arm", base_link="base_link", tip_link="tool0")),
    ExampleArm("ur5", "ur_description/urdf/ur5_robot.urdf", "ur_description/srdf/ur5.srdf",
               GroupSpec("arm", base_link="base_link", tip_link="tool0")),
    ExampleArm("ur10", "ur_description/urdf/ur10_robot.urdf", None),
    ExampleArm("kinova", "kinova_description/robots/kinova.urdf", "kinova_description/srdf/kinova.srdf",
               GroupSpec("arm", base_link="base", tip_link="j2s6s200_end_effector")),
    ExampleArm("xarm7", "xarm_description/urdf/xarm7.urdf", "xarm_description/srdf/xarm7.srdf", plan_group="xarm7"),
    ExampleArm("z1", "z1_description/urdf/z1.urdf", "z1_description/srdf/z1.srdf"),
    ExampleArm("so100", "so_arm_description/urdf/so100.urdf", None),
    ExampleArm("so101", "so_arm_description/urdf/so101.urdf", None),
    ExampleArm("baxter", "baxter_description/urdf/baxter.urdf", "baxter_description/srdf/baxter_manipulation.srdf",
               GroupSpec("left_arm", base_link="base", tip_link="left_gripper")),
    ExampleArm("b1_z1", "b1_description/urdf/b1-z1.urdf", "b1_description/srdf/b1-z1.srdf"),
    ExampleArm("anymal_kinova", "anymal_b_simple_description/robots/anymal-kinova.urdf",
               "anymal_b_simple_description/srdf/anymal-kinova.srdf"),
    ExampleArm("tiago", "tiago_description/robots/tiago.urdf", None,
               GroupSpec("arm", base_link="torso_lift_link", tip_link="arm_tool_link")),
)


@dataclass
class ArmResult:
    robot: str
    dof: int
    group: str
    ik_success_rate: float
    ik_median_ms: float
    ompl_success_rate: float
    ompl_median_ms: float
    invalid_paths: int
    cartesian_fraction: float
    matrix_seconds: float
    disabled_pairs: int
    shipped_srdf_warnings: int

    def record(self) -> dict:
        return {"robot": self.robot, "dof": self.dof, "group": self.group,
                "ik_success_rate": self.ik_success_rate, "ik_median_ms": round(self.ik_median_ms, 4),
                "ompl_success_rate": self.ompl_success_rate, "ompl_median_ms": round(self.ompl_median_ms, 3),
                "invalid_paths": self.invalid_paths, "cartesian_fraction": round(self.cartesian_fraction, 4),
                "matrix_seconds": round(self.matrix_seconds, 3), "disabled_pairs": self.disabled_pairs,
                "shipped_srdf_warnings": self.shipped_srdf_warnings}


def load_shipped(arm: ExampleArm) -> RobotModel:
    """The arm with its shipped SRDF as MoveIt would read it (forgiving), or none."""
    robots = example_robot_data_dir()
    srdf = robots / arm.srdf if arm.srdf else None
    if srdf is None:
        return RobotModel.from_strings((robots / arm.urdf).read_text(), '<robot name=""/>',
                                       package_dirs=[str(robots.parent.parent)])
    return RobotModel.from_files(robots / arm.urdf, srdf, package_dirs=[str(robots.parent.parent)])


def configure(arm: ExampleArm, out_dir: Path, samples: int, seed: int = 0):
    robots = example_robot_data_dir()
    return build_config(robots / arm.urdf, out_dir, robots / arm.srdf if arm.srdf else None,
                        [arm.group] if arm.group else [], samples=samples, seed=seed)


def _valid_states(scene: PlanningScene, group: str, count: int, rng: np.random.Generator) -> list[RobotState]:
    model = scene.model
    jmg = model.group(group)
    out: list[RobotState] = []
    for _ in range(count * 200):
        state = RobotState(model)
        state.set_group_positions(group, sample_positions(model, rng, 1)[0][jmg.variable_indices])
        if scene.is_state_valid(state):
            out.append(state)
            if len(out) == count:
                return out
    raise RuntimeError(f"fewer than {count} valid states of group '{group}' in {count * 200} samples")


def _cartesian_fraction(scene: PlanningScene, group: str, rng: np.random.Generator) -> float:
    """A 0.1 m line of the tip along world z (down if up leaves the workspace) from the first
    valid state whose Jacobian's smallest singular value is at least 0.05 (not near a singularity)."""
    model = scene.model
    tip = model.group(group).tip_link
    for state in _valid_states(scene, group, 100, rng):
        jacobian = state.jacobian(tip, group)
        singular = np.linalg.svd(jacobian[:3] if jacobian.shape[1] < 6 else jacobian, compute_uv=False)
        if singular.min() < 0.05:
            continue
        best = 0.0
        for direction in ((0, 0, 0.1), (0, 0, -0.1)):
            goal = state.frame_pose(tip).copy()
            goal[:3, 3] += direction
            result = compute_cartesian_path(scene, group, state, [goal], eef_step=0.005)
            best = max(best, float(result.fraction))
            if best >= 1.0:
                return best
        return best
    return 0.0


def evaluate_arm(arm: ExampleArm, config_dir: Path, samples: int = 10_000, ik_poses: int = 200,
                 ompl_goals: int = 50, seed: int = 0, planned_goals: int | None = None) -> ArmResult:
    """``planned_goals``: plan only the first that many of the ``ompl_goals`` goal states (all
    are still drawn, so the random draws after them, the Cartesian check's, stay the same)."""
    shipped = load_shipped(arm)
    report = configure(arm, config_dir, samples, seed)
    model = RobotModel.from_config(config_dir)
    group = arm.group_name
    scene = PlanningScene(model)
    rng = np.random.default_rng(seed)
    tip = model.group(group).tip_link
    dof = model.group(group).variable_count
    position_only = dof < 6

    solver = IKSolver(model, group)
    solver.solve(RobotState(model).frame_pose(tip), position_only=position_only)  # seed table, untimed
    ik_times, ik_ok = [], 0
    for state in _valid_states(scene, group, ik_poses, rng):
        target = state.frame_pose(tip)
        start = time.perf_counter()
        solutions = solver.solve(target, rng=rng, validity=scene.is_state_valid, position_only=position_only)
        ik_times.append(time.perf_counter() - start)
        ik_ok += bool(solutions)

    planner = OmplPlanner()
    start_state = RobotState(model)
    start_state.set_named("home", group)
    plan_times, plan_ok, invalid = [], 0, 0
    planned = ompl_goals if planned_goals is None else min(planned_goals, ompl_goals)
    for k, goal_state in enumerate(_valid_states(scene, group, ompl_goals, rng)):
        if k >= planned:
            continue
        goal = dict(zip(model.group(group).joint_names, goal_state.group_positions(group)))
        request = MotionPlanRequest(group, JointGoal(goal), start_state=start_state, seed=seed * 1000 + k + 1)
        begin = time.perf_counter()
        response = planner.plan(scene, request)
        plan_times.append(time.perf_counter() - begin)
        if response.success:
            plan_ok += 1
            if not validate_trajectory(scene, response.trajectory, group, start_state):
                invalid += 1
    fraction = _cartesian_fraction(scene, group, rng)
    return ArmResult(
        arm.robot, dof, group, ik_ok / ik_poses, float(np.median(ik_times)) * 1e3, plan_ok / planned,
        float(np.median(plan_times)) * 1e3, invalid, fraction, report.matrix.seconds,
        len(model.disabled_collision_pairs), len(shipped.load_warnings))


def bench_robots(repeat: int, seed: int) -> None:
    """One JSON line per arm (repeats: the median run of each figure), then a summary."""
    results: list[ArmResult] = []
    with tempfile.TemporaryDirectory(prefix="robots_bench_") as tmp:
        for arm in EXAMPLE_ARMS:
            runs = [evaluate_arm(arm, Path(tmp) / f"{arm.robot}_{i}", seed=seed + i) for i in range(repeat)]
            record = runs[0].record()
            for key in ("ik_success_rate", "ik_median_ms", "ompl_success_rate", "ompl_median_ms",
                        "cartesian_fraction", "matrix_seconds"):
                record[key] = round(float(np.median([r.record()[key] for r in runs])), 4)
            record["invalid_paths"] = sum(r.invalid_paths for r in runs)
            emit({"scenario": "robots", **record})
            results.append(runs[0])
    summary = {
        "scenario": "robots", "summary": True, "robots": len(results),
        "min_ik_success_rate": min(r.ik_success_rate for r in results),
        "min_ompl_success_rate": min(r.ompl_success_rate for r in results),
        "min_cartesian_fraction": min(r.cartesian_fraction for r in results),
        "max_matrix_seconds": round(max(r.matrix_seconds for r in results), 3),
        "invalid_paths": sum(r.invalid_paths for r in results),
    }
    summary["median_ik_ms"] = round(float(np.median([r.ik_median_ms for r in results])), 4)
    summary["median_ompl_ms"] = round(float(np.median([r.ompl_median_ms for r in results])), 3)
    emit({**summary, **machine()})
