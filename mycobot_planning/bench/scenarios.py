"""Benchmark scenarios. Scenario names and summary keys are a contract: keep them stable."""
from __future__ import annotations

from typing import Callable

import numpy as np

from interfaces_py.msgs import CollisionObject
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.kinematics.ik_solver import IKSolver
from mycobot_planning.core.planners.ompl import OmplPlanner
from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest
from mycobot_planning.core.transforms import make_pose

from .common import emit, machine, spread, stats, timed
from .driver_scenarios import bench_driver_tracking
from .benchmark_runner_scenarios import BENCHMARK_RUNNER_SCENARIOS
from .idle_scenarios import IDLE_SCENARIOS
from .concurrency_scenarios import CONCURRENCY_SCENARIOS
from .objectives_scenarios import OBJECTIVES_SCENARIOS
from .peers.parts import bench_peers_parts
from .perception_scenarios import bench_perception
from .react_scenarios import REACT_SCENARIOS
from .pick_place_scenarios import PICK_PLACE_SCENARIOS
from .planners_scenarios import PLANNERS_SCENARIOS
from .robots_scenarios import bench_robots
from .robustness import bench_robustness
from .sim_scenarios import SIM_SCENARIOS
from .soak_scenarios import SOAK_SCENARIOS
from .ros_scenarios import ROS_SCENARIOS
from .servo_scenarios import SERVO_SCENARIOS
from .task_scenarios import TASK_SCENARIOS
from .time_parameterization_scenarios import TIME_PARAMETERIZATION_SCENARIOS
from .trajectory_cache_scenarios import TRAJECTORY_CACHE_SCENARIOS
from .viewer_scenarios import VIEWER_SCENARIOS


def random_arm_states(
    model: RobotModel, count: int, rng: np.random.Generator, scene: PlanningScene | None = None
) -> list[RobotState]:
    """Uniform random arm states within the joint limits (and valid in `scene`, when given)."""
    jmg = model.group("arm")
    low, high = model.lower_limits[jmg.variable_indices], model.upper_limits[jmg.variable_indices]
    states: list[RobotState] = []
    while len(states) < count:
        state = RobotState(model)
        state.set_group_positions("arm", rng.uniform(low, high))
        if scene is None or scene.is_state_valid(state):
            states.append(state)
    return states


def seeds_table_scene(model: RobotModel) -> PlanningScene:
    """The seeds' scene: table 0.10 x 0.20 x 0.03 with its top at z = 0 centred at (0.22, 0.12),
    and a cylinder of height 0.35, radius 0.0125 standing on it."""
    scene = PlanningScene(model)
    scene.add_object(CollisionObject.box("table", [0.10, 0.20, 0.03], make_pose([0.22, 0.12, -0.015])))
    scene.add_object(CollisionObject.cylinder("cylinder", 0.35, 0.0125, make_pose([0.22, 0.12, 0.175])))
    return scene


def bench_collision(repeat: int, seed: int) -> None:
    """Validity (limits + self + world collision) of random arm states in the seeds' scene."""
    model = RobotModel.mycobot()
    scene = seeds_table_scene(model)
    rng = np.random.default_rng(seed)

    def check(state: RobotState) -> tuple[float, bool]:
        positions = state.positions
        elapsed, valid = timed(lambda: scene.is_valid_positions(positions))
        return elapsed, not valid

    _bench_timed_trials("collision", repeat, lambda: random_arm_states(model, 5000, rng), check,
                        "states", "invalid_fraction", 1e6, "us")


def bench_fk(repeat: int, seed: int) -> None:
    """Forward kinematics of the flange: one Pinocchio call per state."""
    model = RobotModel.mycobot()
    rng = np.random.default_rng(seed)
    medians = []
    for index in range(repeat):
        samples = []
        for state in random_arm_states(model, 2000, rng):
            elapsed, _ = timed(lambda: state.frame_pose("link6_flange"))
            samples.append(elapsed)
        record = {"scenario": "fk", "repeat": index, "states": len(samples), **stats(samples, 1e6, "us")}
        medians.append(record["median_us"])
        emit(record)
    emit({"scenario": "fk", "summary": True, "median_us": float(np.median(medians)), **spread(medians), **machine()})


def bench_ik(repeat: int, seed: int) -> None:
    """IK round trip: 1000 flange poses from FK of random valid (self-collision-free) arm states,
    solved from the home state."""
    model = RobotModel.mycobot()
    empty_scene = PlanningScene(model)
    solver = IKSolver(model, "arm")
    solver.solve(RobotState(model).frame_pose("link6_flange"))  # builds the seed table once, untimed
    rng = np.random.default_rng(seed)

    def solve(state: RobotState) -> tuple[float, bool]:
        target = state.frame_pose("link6_flange")
        elapsed, solutions = timed(lambda: solver.solve(target, rng=rng))
        return elapsed, bool(solutions)

    _bench_timed_trials("ik", repeat, lambda: random_arm_states(model, 1000, rng, empty_scene), solve,
                        "poses", "success_rate", 1e3, "ms")


def _bench_timed_trials(scenario: str, repeat: int, states: Callable[[], list[RobotState]],
                        trial: Callable[[RobotState], tuple[float, bool]], count_key: str, fraction_key: str,
                        scale: float, unit: str) -> None:
    """Per repeat, run ``trial`` (elapsed seconds, counted or not) on each of ``states()`` and emit
    its timing stats and the counted fraction; then the summary over all repeats."""
    medians = []
    all_samples, counted = [], 0
    for index in range(repeat):
        samples, hits = [], 0
        for state in states():
            elapsed, hit = trial(state)
            samples.append(elapsed)
            hits += hit
        record = {"scenario": scenario, "repeat": index, count_key: len(samples), fraction_key: hits / len(samples)}
        record.update(stats(samples, scale, unit))
        medians.append(record[f"median_{unit}"])
        emit(record)
        all_samples += samples
        counted += hits
    summary = {"scenario": scenario, "summary": True, fraction_key: counted / len(all_samples)}
    summary.update({k: v for k, v in stats(all_samples, scale, unit).items() if k in (f"median_{unit}", f"p90_{unit}")})
    emit({**summary, **spread(medians), **machine()})


def fallback_case_c(model: RobotModel) -> tuple[PlanningScene, RobotState, dict[str, float]]:
    """The seeds' fallbacks_move_to case (c): ready with link1_to_link2 = -tau/8 to ready with
    link1_to_link2 = +tau/8, past a thin box 0.005 x 0.1 x 0.32 centred at (0.02, -0.20, 0.16)."""
    scene = PlanningScene(model)
    scene.add_object(CollisionObject.box("box", [0.005, 0.1, 0.32], make_pose([0.02, -0.20, 0.16]), frame_id="base_link"))
    start = RobotState(model)
    start.set_named("ready")
    start.set_joint_positions({"link1_to_link2": -np.pi / 4})
    goal = dict(model.named_state("ready", "arm"), link1_to_link2=np.pi / 4)
    return scene, start, goal


def bench_plan_ompl(repeat: int, seed: int) -> None:
    """OMPL RRTConnect on fallback case (c), 100 seeds per repeat (planning incl. simplification
    and Ruckig timing, as a move_group plan call)."""
    model = RobotModel.mycobot()
    planner = OmplPlanner()
    scene, start, goal = fallback_case_c(model)
    all_times, successes, medians = [], 0, []
    for index in range(repeat):
        times, ok = [], 0
        for k in range(100):
            request = MotionPlanRequest("arm", JointGoal(goal), start_state=start, seed=seed * 1000 + index * 100 + k + 1)
            elapsed, response = timed(lambda: planner.plan(scene, request))
            times.append(elapsed)
            ok += response.success
        record = {"scenario": "plan_ompl", "repeat": index, "problems": len(times), "success_rate": ok / len(times)}
        record.update(stats(times, 1.0, "s"))
        medians.append(record["median_s"])
        emit(record)
        all_times += times
        successes += ok
    summary = {"scenario": "plan_ompl", "summary": True, "success_rate": successes / len(all_times)}
    summary.update({k: v for k, v in stats(all_times, 1.0, "s").items() if k in ("median_s", "p90_s")})
    emit({**summary, **spread(medians), **machine()})


def cartesian_line_start(model: RobotModel) -> tuple[RobotState, np.ndarray, np.ndarray]:
    """A state with the flange pointing down at (0.18, -0.15, 0.20), and the 0.3 m line to
    (0.18, +0.15, 0.20) across the front of the robot."""
    start_pose = make_pose([0.18, -0.15, 0.20], rpy=[np.pi, 0.0, 0.0])
    end_pose = make_pose([0.18, 0.15, 0.20], rpy=[np.pi, 0.0, 0.0])
    from mycobot_planning.core.planners.cartesian.cartesian_path import compute_cartesian_path

    seed = RobotState(model)
    seed.set_named("ready")
    solutions = IKSolver(model, "arm").solve(
        start_pose, seed=seed, rng=0, timeout=0.5, max_solutions=6, min_solution_distance=0.5
    )
    # The elbow-down branch collides with the base half-way; start on a branch that completes.
    scene = PlanningScene(model)
    for state in solutions:
        if compute_cartesian_path(scene, "arm", state, [end_pose], eef_step=0.01).fraction == 1.0:
            return state, start_pose, end_pose
    raise RuntimeError("benchmark set-up: no IK branch completes the Cartesian line")


def bench_cartesian(repeat: int, seed: int) -> None:
    """compute_cartesian_path along a 0.3 m line at eef_step 0.00025 (1200 IK steps), timed."""
    from mycobot_planning.core.planners.cartesian.cartesian_path import compute_cartesian_path

    model = RobotModel.mycobot()
    scene = PlanningScene(model)
    start, _, end_pose = cartesian_line_start(model)
    all_times, fractions, medians = [], [], []
    for index in range(repeat):
        times = []
        for _ in range(10):
            elapsed, result = timed(
                lambda: compute_cartesian_path(scene, "arm", start, [end_pose], eef_step=0.00025, jump_threshold=0.0)
            )
            times.append(elapsed)
            fractions.append(result.fraction)
        record = {"scenario": "cartesian", "repeat": index, "runs": len(times), "fraction": fractions[-1]}
        record.update(stats(times, 1e3, "ms"))
        medians.append(record["median_ms"])
        emit(record)
        all_times += times
    summary = {"scenario": "cartesian", "summary": True, "fraction": float(np.min(fractions))}
    summary.update({k: v for k, v in stats(all_times, 1e3, "ms").items() if k in ("median_ms", "p90_ms")})
    emit({**summary, **spread(medians), **machine()})


def bench_ptp(repeat: int, seed: int) -> None:
    """Industrial PTP ready -> home on the myCobot, free space, collision-checked."""
    from mycobot_planning.core.planners.pilz import IndustrialMotionPlanner

    model = RobotModel.mycobot()
    scene = PlanningScene(model)
    planner = IndustrialMotionPlanner()
    start = RobotState(model)
    start.set_named("ready")
    request = MotionPlanRequest("arm", JointGoal(model.named_state("home", "arm")), start_state=start,
                                pipeline_id="pilz_industrial_motion_planner", planner_id="PTP")
    all_times, medians = [], []
    for index in range(repeat):
        times = []
        for _ in range(50):
            elapsed, response = timed(lambda: planner.plan(scene, request))
            if not response.success:
                raise RuntimeError(f"PTP benchmark plan failed: {response.error_code}")
            times.append(elapsed)
        record = {"scenario": "ptp", "repeat": index, "runs": len(times)}
        record.update(stats(times, 1e3, "ms"))
        medians.append(record["median_ms"])
        emit(record)
        all_times += times
    summary = {"scenario": "ptp", "summary": True}
    summary.update({k: v for k, v in stats(all_times, 1e3, "ms").items() if k in ("median_ms", "p90_ms")})
    emit({**summary, **spread(medians), **machine()})


SCENARIOS: dict[str, Callable[..., None]] = {
    "cartesian": bench_cartesian,
    "collision": bench_collision,
    "driver_tracking": bench_driver_tracking,
    "fk": bench_fk,
    "ik": bench_ik,
    "peers": bench_peers_parts,
    "perception": bench_perception,
    "plan_ompl": bench_plan_ompl,
    "ptp": bench_ptp,
    "robots": bench_robots,
    "robustness": bench_robustness,
    **TASK_SCENARIOS,
    **ROS_SCENARIOS,
    **PICK_PLACE_SCENARIOS,
    **PLANNERS_SCENARIOS,
    **VIEWER_SCENARIOS,
    **TIME_PARAMETERIZATION_SCENARIOS,
    **OBJECTIVES_SCENARIOS,
    **SIM_SCENARIOS,
    **CONCURRENCY_SCENARIOS,
    **REACT_SCENARIOS,
    **SOAK_SCENARIOS,
    **SERVO_SCENARIOS,
    **IDLE_SCENARIOS,
    **TRAJECTORY_CACHE_SCENARIOS,
    **BENCHMARK_RUNNER_SCENARIOS,
}
