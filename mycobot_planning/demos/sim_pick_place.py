"""The seeds' pick and place executed in the MuJoCo twin, ROS-free.

The task is planned with the core exactly as mtc_node plans it (``build_pick_place_task``); its
sub-trajectories are then executed on a :class:`MujocoSimulator` the way the planning_server
executes them through the controllers: arm joints as a followed trajectory (checked against the
start and goal tolerances), the gripper joint as a GripperCommand of the last point, waited for
until it reached its goal or stalled on the object. Nothing is welded or attached in the
simulator: the planning scene's attach stays a planning concept, physics decides whether the
object comes along. The verdict is the simulator's (simulation.grasp_monitor): the object
within 1 cm of the place pose and upright within 5 degrees once the gripper has left, and never
more than 5 mm of slip in the hand while carried. docs/simulation.md, section "Pick and place
in physics".
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from interfaces_py.msgs import CollisionObject

from ..core.robot_model import RobotModel
from ..core.robot_trajectory import TimedTrajectory
from ..simulation.grasp_monitor import PlaceOutcome, SlipMonitor, judge_place
from ..paths import config_file
from ..simulation.scene import load_scene
from ..simulation.simulator import MujocoSimulator
from .pick_place import PickPlaceParameters, build_pick_place_task, expected_place_pose, pick_place_scene, \
    vector_to_pose

#: rad: the first point of a trajectory vs where the arm is (planning_server's allowed_start_tolerance)
START_TOLERANCE = 0.01
#: rad: the last point vs where the arm settled (the arm controller's goal_tolerance)
GOAL_TOLERANCE = 0.01
#: s: how long the arm may take after a trajectory's end to settle within GOAL_TOLERANCE
SETTLE_TIMEOUT = 1.0
#: s: time the object gets to come to rest once the robot is done, before the verdict
REST_TIME = 0.5
#: m: an object this far from where it was held has been lost (execution stops there)
LOST_DISTANCE = 0.02


@dataclass
class StepReport:
    """One executed sub-trajectory: what moved, the worst tracking error of the arm (|desired -
    actual| over joints and time, rad), the final error, the gripper's result, and problems."""

    name: str
    duration: float = 0.0
    max_tracking_error: float = 0.0
    final_error: float = 0.0
    gripper: Any = None
    ok: bool = True
    message: str = ""


@dataclass
class SimPickPlaceResult:
    """The verdict (``outcome``), every step's report, and why it stopped early if it did."""

    outcome: PlaceOutcome | None
    steps: list[StepReport] = field(default_factory=list)
    message: str = ""

    @property
    def success(self) -> bool:
        return self.outcome is not None and self.outcome.success and all(s.ok for s in self.steps)

    @property
    def max_tracking_error(self) -> float:
        return max((s.max_tracking_error for s in self.steps), default=0.0)


#: m: added to the object's radius in the planning scene only (see plan_pick_place)
PLANNING_CLEARANCE = 0.005
#: m: the planning scene's floor lies this much below the simulated one (see plan_pick_place)
FLOOR_CLEARANCE = 0.001
FLOOR_ID = "floor"


def planning_scene_for(robot: RobotModel, params: PickPlaceParameters, floor_z: float | None = None):
    """The seed's planning scene (table and object), plus the simulated world's floor when
    ``floor_z`` is given: a 2 m square slab whose top is FLOOR_CLEARANCE below it."""
    scene = pick_place_scene(robot, params)
    if floor_z is not None:
        scene.apply_collision_object(floor_object(floor_z, params.world_frame))
    return scene


def floor_object(floor_z: float, frame_id: str) -> CollisionObject:
    """The simulated world's floor as a planning obstacle: a 2 m square slab whose top is
    FLOOR_CLEARANCE below ``floor_z`` (see plan_pick_place)."""
    pose = np.eye(4)
    pose[2, 3] = floor_z - FLOOR_CLEARANCE - 0.005
    return CollisionObject.box(FLOOR_ID, [2.0, 2.0, 0.01], pose, frame_id=frame_id)


def padded_dimensions(params: PickPlaceParameters, clearance: float = PLANNING_CLEARANCE) -> list[float]:
    """The object's [height, radius] with ``clearance`` added to the radius (see plan_pick_place)."""
    height, radius = params.object_dimensions
    return [height, radius + clearance]


def plan_pick_place(robot: RobotModel, params: PickPlaceParameters | None = None, seed: int = 0,
                    clearance: float = PLANNING_CLEARANCE, floor_z: float | None = None):
    """The best solution of the seeds' task (params.max_solutions of them, as mtc_node), or None
    when planning found none.

    Two differences from the seed's planning scene, both because physics tells: ``clearance``
    (m) is added to the object's radius (the planner keeps no distance from obstacles, as MoveIt
    whose padding defaults to 0, and its paths may pass the cylinder at half a millimetre; an
    arm with a millimetre of tracking error at the wrist then knocks it over), and the world's
    floor (``floor_z``) is an obstacle (the seed's scene has none, and a path may swing the
    carried 35 cm cylinder through it). The floor lies FLOOR_CLEARANCE lower than the real one
    because the seed's place pose sets the cylinder exactly on it (touching counts as a
    collision). The grasp and place poses depend on neither."""
    params = params or PickPlaceParameters()
    if clearance:
        params = params.with_changes(object_dimensions=padded_dimensions(params, clearance))
    task = build_pick_place_task(robot, params, planning_scene_for(robot, params, floor_z), seed=seed)
    task.plan(params.max_solutions)
    if not task.numSolutions():
        return None
    return min(task.solutions, key=lambda s: s.cost)


def solution_steps(solution) -> list[tuple[str, TimedTrajectory | None]]:
    """(stage name, trajectory or None) per sub-trajectory, in execution order."""
    out = []
    for sub in solution.sub_trajectories():
        name = sub.creator.name if sub.creator is not None else ""
        traj = sub.trajectory if sub.trajectory is not None and len(sub.trajectory) > 0 else None
        out.append((name, traj))
    return out


def simulation_scene_for(sim_scene, params: PickPlaceParameters):
    """The simulator's scene with the object where the task parameters put it (its centre
    place_pose_z_offset_factor x height above object_pose, as the seed does)."""
    pose = vector_to_pose(params.object_pose)
    pose[2, 3] += params.place_pose_z_offset_factor * params.object_dimensions[0]
    return sim_scene.with_object(sim_scene.object(params.object_name).moved_to(pose))


class _Runner:
    def __init__(self, sim: MujocoSimulator, hand_link: str, object_name: str) -> None:
        self.sim = sim
        self.hand_link = hand_link
        self.object_name = object_name
        self.slip: SlipMonitor | None = None

    def _watch(self, report: StepReport) -> bool:
        """Sample tracking error and slip; False once a carried object is lost."""
        err = float(np.max(np.abs(self.sim.arm_target() - self.sim.arm_positions())))
        report.max_tracking_error = max(report.max_tracking_error, err)
        if self.slip is not None:
            slip = self.slip.sample(self.sim.link_pose(self.hand_link), self.sim.object_pose(self.object_name))
            if slip > LOST_DISTANCE:
                return False
        return True

    def run_step(self, name: str, traj: TimedTrajectory, close_position: float | None) -> StepReport:
        sim = self.sim
        report = StepReport(name)
        start = sim.time
        arm_columns = [i for i, n in enumerate(traj.joint_names) if n in sim.arm_joints]
        grip_column = traj.joint_names.index(sim.gripper_joint) if sim.gripper_joint in traj.joint_names else None
        gripper_goal = None
        if grip_column is not None:
            gripper_goal = float(traj.positions[-1, grip_column])
            if close_position is not None and name == "close gripper":
                gripper_goal = close_position
            command = sim.gripper_state().command
            if command is None or abs(command.position - gripper_goal) > 1e-9 or not arm_columns:
                sim.command_gripper(gripper_goal)
        if arm_columns:
            names = [traj.joint_names[i] for i in arm_columns]
            current = dict(zip(sim.arm_joints, sim.arm_positions()))
            deviation = max(abs(traj.positions[0, i] - current[n]) for i, n in zip(arm_columns, names))
            if deviation > START_TOLERANCE:
                report.ok = False
                report.message = (f"starts {deviation:.4f} rad from where the arm is (allowed_start_tolerance "
                                  f"{START_TOLERANCE})")
                return report
            sim.follow_trajectory(traj)
            check = max(1, int(round(0.001 / sim.timestep)))
            while sim.trajectory_active:
                sim.step(check)
                if not self._watch(report):
                    sim.stop_arm()
                    report.ok = False
                    report.message = (f"the object was lost from the hand (it moved {self.slip.slip * 1000:.0f} mm "
                                      "from where it was held): execution stopped")
                    report.duration = sim.time - start
                    return report
            last = np.array([traj.positions[-1, i] for i in arm_columns])
            index = [sim.arm_joints.index(n) for n in names]

            def settled(s: MujocoSimulator) -> bool:
                return float(np.max(np.abs(s.arm_positions()[index] - last))) <= GOAL_TOLERANCE

            if not sim.run_until(settled, SETTLE_TIMEOUT):
                report.ok = False
                report.message = (f"the arm did not settle within {GOAL_TOLERANCE} rad of the last point "
                                  f"{SETTLE_TIMEOUT} s after the trajectory's end")
            report.final_error = float(np.max(np.abs(sim.arm_positions()[index] - last)))
        if gripper_goal is not None:
            timeout = sim.settings.gripper.stall_timeout + 3.0
            sim.run_until(lambda s: not s.gripper_state().active, timeout)
            state = sim.gripper_state()
            report.gripper = state
            if state.active:
                report.ok = False
                report.message = f"the gripper neither reached {gripper_goal:g} nor stalled within {timeout:g} s"
        report.duration = sim.time - start
        return report


def execute_in_simulation(sim: MujocoSimulator, steps: Sequence[tuple[str, TimedTrajectory | None]],
                          params: PickPlaceParameters | None = None, *,
                          close_position: float | None = None) -> SimPickPlaceResult:
    """Execute the planned steps on ``sim`` and judge the result (see the module docstring).

    ``close_position``: command the gripper here instead of the planned close pose (a grasp
    that does not close enough, to see the twin say no)."""
    params = params or PickPlaceParameters()
    runner = _Runner(sim, params.gripper_frame, params.object_name)
    result = SimPickPlaceResult(None)
    names = [name for name, _ in steps]
    closed = names.index("close gripper") if "close gripper" in names else -1
    opened = max((i for i, n in enumerate(names) if n == "open gripper"), default=-1)
    carried: SlipMonitor | None = None
    for k, (name, traj) in enumerate(steps):
        if traj is None:
            continue
        if 0 <= closed < k < opened and carried is None:
            carried = runner.slip = SlipMonitor()  # held from here (the gripper finished closing)
        if k == opened:
            runner.slip = None
        report = runner.run_step(name, traj, close_position)
        result.steps.append(report)
        if not report.ok:
            result.message = f"step '{name}' failed: {report.message}"
            break
    sim.advance(REST_TIME)
    slip = carried.slip if carried is not None and carried.samples else math.nan
    result.outcome = judge_place(sim.object_pose(params.object_name), expected_place_pose(params), slip)
    if not result.message:
        result.message = result.outcome.message
    return result


def run_sim_pick_place(robot: RobotModel, params: PickPlaceParameters | None = None, *, seed: int = 0,
                       sim: MujocoSimulator | None = None, close_position: float | None = None,
                       **sim_options: Any) -> SimPickPlaceResult:
    """Plan the seeds' pick and place for ``params`` and execute it in ``sim``, or in a new
    simulator of config/mujoco_scene.yaml whose object stands where ``params.object_pose`` says
    (``sim_options`` go to it; it is closed afterwards)."""
    params = params or PickPlaceParameters()
    if sim is None:
        scene = simulation_scene_for(load_scene(config_file("mujoco_scene.yaml")), params)
        with MujocoSimulator(robot, scene, **sim_options) as own:
            return run_sim_pick_place(robot, params, seed=seed, sim=own, close_position=close_position)
    floor = sim.scene.floor.z if sim.scene.floor is not None else None
    solution = plan_pick_place(robot, params, seed, floor_z=floor)
    if solution is None:
        return SimPickPlaceResult(None, message="planning found no solution")
    return execute_in_simulation(sim, solution_steps(solution), params, close_position=close_position)


def main(argv: list[str] | None = None) -> int:
    """``python -m mycobot_planning.demos.sim_pick_place [--seed N] [--object-xy X Y]
    [--close-position P]``: plan the seeds' pick and place, execute it in physics, print each
    step and the verdict; exit 0 only when the simulator says it held."""
    import argparse

    parser = argparse.ArgumentParser(prog="python -m mycobot_planning.demos.sim_pick_place",
                                     description="The seeds' pick and place in the MuJoCo twin (ROS-free).")
    parser.add_argument("--seed", type=int, default=0, help="random seed of the planning (default 0)")
    parser.add_argument("--object-xy", type=float, nargs=2, metavar=("X", "Y"),
                        help="where the cylinder stands (default: the seed's object_pose)")
    parser.add_argument("--close-position", type=float, default=None,
                        help="close the gripper here instead of the planned close pose (a bad grasp)")
    args = parser.parse_args(argv)
    params = PickPlaceParameters()
    if args.object_xy:
        params = params.with_changes(object_pose=[args.object_xy[0], args.object_xy[1], 0.0, 0.0, 0.0, 0.0])
    result = run_sim_pick_place(RobotModel.mycobot(), params, seed=args.seed, close_position=args.close_position,
                                camera=False)
    for step in result.steps:
        grip = ""
        if step.gripper is not None:
            g = step.gripper
            grip = (f"; gripper at {g.position:.3f} (reached_goal {g.reached_goal}, stalled {g.stalled}, "
                    f"touching {', '.join(g.contacts) or 'nothing'})")
        print(f"{step.name:28s} {step.duration:5.2f} s, tracking error {step.max_tracking_error * 1000:4.1f} mrad"
              f"{grip}{'' if step.ok else '  FAILED: ' + step.message}")
    if result.outcome is not None:
        print("Figures: " + ", ".join(f"{k} {v}" for k, v in result.outcome.figures().items()))
    print(("SUCCESS: " if result.success else "FAILED: ") + result.message)
    return 0 if result.success else 1


if __name__ == "__main__":
    import sys

    sys.exit(main())
