"""jit_warm_up (run by scripts/setup.sh) reaches every numba kernel of the core: after it, each
has a compiled signature, so no node or test pays the compilation on its first request."""
from __future__ import annotations

import pytest

from mycobot_planning.core.collision_detection import batch_check
from mycobot_planning.core.jit import numba_available
from mycobot_planning.core.jit_warm_up import warm_up
from mycobot_planning.core.kinematics import chain_kinematics, compiled_descent
from mycobot_planning.core.planners.cartesian import step_solver
from mycobot_planning.core.robot_trajectory import robot_trajectory
from mycobot_planning.core.trajectory_processing import dense_path_topp, trajectory_validator

pytestmark = pytest.mark.skipif(not numba_available(), reason="numba is not installed (scripts/requirements.txt)")

# the kernels called from Python (the others are compiled into these)
KERNELS = [
    (batch_check, "_free_states"), (batch_check, "one_state_free"), (chain_kinematics, "frame_kinematics"),
    (compiled_descent, "_descend"), (compiled_descent, "_descend_batch"),
    (step_solver, "_correct"), (step_solver, "_follow"),
    (robot_trajectory, "_sample_kernel"), (robot_trajectory, "_max_steps_kernel"), (dense_path_topp, "_topp_kernel"), (dense_path_topp, "_bezier_deviation_kernel"),
    (trajectory_validator, "_initial_times_kernel"),
]

def test_warm_up_compiles_every_kernel():
    assert warm_up() > 0.0
    missing = [f"{module.__name__}.{name}" for module, name in KERNELS if not getattr(module, name).signatures]
    assert not missing, f"not reached by the warm-up: {missing}"


def test_warm_up_of_a_robot_builds_its_per_model_tables_before_the_first_plan():
    """What the planning_server runs before it says it is ready, on another robot than the
    myCobot: each group's once-per-model work is done, so the first plan does not pay it."""
    from mycobot_planning.core import RobotModel
    from mycobot_planning.core.collision_detection.collision import RobotCollisionInfo
    from mycobot_planning.paths import example_robot_data_dir

    root = example_robot_data_dir() / "xarm_description"
    model = RobotModel.from_files(root / "urdf" / "xarm7.urdf", root / "srdf" / "xarm7.srdf")  # group xarm7
    assert RobotCollisionInfo.for_model(model)._link_covers is None
    assert warm_up(model) > 0.0
    covers = RobotCollisionInfo.for_model(model)._link_covers
    assert covers is not None and len(covers) == len(RobotCollisionInfo.for_model(model).geometry_objects)
