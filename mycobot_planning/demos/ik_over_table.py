"""Demo: load the myCobot, solve IK for a grasp pose over the seeds' table, check it, print it.

This is what ./scripts/demo.sh runs until the pick-and-place task exists: every piece is the
real core (URDF/SRDF model, Pinocchio IK), so a failure here is a failure of the package.
"""
from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from interfaces_py.msgs import CollisionObject
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.kinematics.ik_solver import solve_ik
from mycobot_planning.core.transforms import make_pose, matrix_to_rpy

#: The seeds' table: 0.10 x 0.20 x 0.03 box, top at z = 0, centred at (0.22, 0.12).
TABLE_CENTRE = (0.22, 0.12, -0.015)
#: The seeds' cylinder standing on it: height 0.35, radius 0.0125.
CYLINDER_CENTRE = (0.22, 0.12, 0.175)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--height", type=float, default=0.16, help="flange height above the table top (m)")
    parser.add_argument("--solutions", type=int, default=4, help="distinct IK solutions to look for")
    args = parser.parse_args(argv)

    robot = RobotModel.mycobot()
    print(f"Loaded {robot}")
    scene = PlanningScene(robot)
    scene.add_object(CollisionObject.box("table", [0.10, 0.20, 0.03], make_pose(TABLE_CENTRE)))
    scene.add_object(CollisionObject.cylinder("cylinder", 0.35, 0.0125, make_pose(CYLINDER_CENTRE)))
    print(f"Planning scene: {', '.join(scene.world_object_ids())}")
    # Flange over the table's near edge, pointing straight down (rotated pi about x).
    target = make_pose([TABLE_CENTRE[0] - 0.05, TABLE_CENTRE[1] - 0.08, args.height], rpy=[math.pi, 0.0, 0.0])
    seed = RobotState(robot)
    seed.set_named("ready")
    solutions = solve_ik(
        robot, "arm", target, seed=seed, max_solutions=args.solutions, min_solution_distance=0.5, timeout=0.5, rng=0
    )
    # Collision-aware IK: the scene rejects colliding solutions inside the solver.
    valid_solutions = solve_ik(
        robot, "arm", target, seed=seed, max_solutions=1, timeout=0.5, rng=0, scene=scene
    )
    print(f"Collision-aware IK: {'found a valid solution' if valid_solutions else 'no valid solution'}")
    print(f"Target flange pose: xyz={np.round(target[:3, 3], 4).tolist()} rpy={np.round(matrix_to_rpy(target), 4).tolist()}")
    if not solutions:
        print("No IK solution found: the target is out of reach.")
        return 1
    valid = 0
    for index, state in enumerate(solutions):
        reached = state.frame_pose("link6_flange")
        error_mm = 1000.0 * float(np.linalg.norm(reached[:3, 3] - target[:3, 3]))
        joints = ", ".join(f"{v:+.3f}" for v in state.group_positions("arm"))
        report = scene.check_collision(state)
        verdict = "collision-free" if not report.collision else "; ".join(str(c) for c in report.contacts)
        valid += not report.collision
        print(f"  solution {index}: arm = [{joints}]  position error {error_mm:.3f} mm  {verdict}")
    clearance = scene.distance(solutions[0])
    print(
        f"Solution 0 clearance: {1000 * clearance.min_distance:.1f} mm between "
        f"'{clearance.body_a}' and '{clearance.body_b}'"
    )
    if not valid or not valid_solutions:
        print("Every solution collides with the scene.")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
