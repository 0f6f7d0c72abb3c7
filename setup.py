"""ament_python package: builds with colcon on a ROS machine and installs with pip elsewhere."""
import os
from glob import glob
from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = "mycobot_planning"
REQUIREMENTS = Path(__file__).resolve().parent / "scripts" / "requirements.txt"
RUNTIME_END = "# ---- end of runtime"


def runtime_requirements() -> list[str]:
    """The pins of scripts/requirements.txt above its end-of-runtime line: one list of versions
    for setup.sh's .venv and for `pip install .` (tests and build tools stay below the line)."""
    lines = REQUIREMENTS.read_text().splitlines()
    end = next(i for i, line in enumerate(lines) if line.startswith(RUNTIME_END))
    return [line.strip() for line in lines[:end] if line.strip() and not line.lstrip().startswith("#")]


setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(include=[PACKAGE, f"{PACKAGE}.*", "interfaces_py", "interfaces_py.*"]),
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", sorted(f for f in glob("config/*") if os.path.isfile(f))),
        (f"share/{PACKAGE}/config/panda", sorted(glob("config/panda/*"))),
        (f"share/{PACKAGE}/config/objectives", sorted(glob("config/objectives/*.xml"))),
        (f"share/{PACKAGE}/config/waypoints", sorted(glob("config/waypoints/*.yaml"))),
        (f"share/{PACKAGE}/config/groot", sorted(glob("config/groot/*.xml"))),
    ],
    install_requires=runtime_requirements(),
    # Optional: moveit_run_benchmark --ray spreads benchmark runs over Ray (docs/benchmarking.md).
    extras_require={"ray": ["ray[default]==2.40.0"]},
    zip_safe=True,
    maintainer="mycobot_planning developers",
    maintainer_email="dev@mycobot-planning.invalid",
    description="MoveIt move_group and Task Constructor stand-in for the myCobot 280, in Python.",
    license="Apache-2.0",
    python_requires=">=3.10",
    entry_points={
        "console_scripts": [
            f"ik_over_table = {PACKAGE}.demos.ik_over_table:main",
            f"mock_controllers = {PACKAGE}.nodes.mock_controllers:main",
            f"mycobot_driver = {PACKAGE}.nodes.mycobot_driver:main",
            f"mujoco_sim = {PACKAGE}.nodes.mujoco_sim:main",
            f"mycobot_emulator = {PACKAGE}.hardware.emulator:main",
            f"planning_server = {PACKAGE}.nodes.planning_server:main",
            f"robot_state_publisher = {PACKAGE}.nodes.robot_state_publisher:main",
            f"servo_node = {PACKAGE}.nodes.servo_node:main",
            f"servo_keyboard_input = {PACKAGE}.nodes.servo_keyboard_input:main",
            f"modular = {PACKAGE}.nodes.modular:main",
            f"fallbacks_move_to = {PACKAGE}.nodes.fallbacks_move_to:main",
            f"ik_clearance_cost = {PACKAGE}.nodes.ik_clearance_cost:main",
            f"move_group_exercise_1_1 = {PACKAGE}.nodes.move_group_exercise_1_1:main",
            f"move_group_exercise_1_2 = {PACKAGE}.nodes.move_group_exercise_1_2:main",
            f"fake_marker_publisher = {PACKAGE}.nodes.fake_marker_publisher:main",
            f"part_localizer = {PACKAGE}.nodes.part_localizer:main",
            f"scan_n_plan = {PACKAGE}.nodes.scan_n_plan:main",
            f"mtc_node = {PACKAGE}.nodes.mtc_node:main",
            f"mtc_script = {PACKAGE}.nodes.mtc_script:main",
            f"pick_place_demo = {PACKAGE}.nodes.pick_place_demo:main",
            f"camera_simulator = {PACKAGE}.nodes.camera_simulator:main",
            f"perception_server = {PACKAGE}.nodes.perception_server:main",
            f"task_viewer = {PACKAGE}.nodes.task_viewer:main",
            f"plot_solution = {PACKAGE}.nodes.plot_solution:main",
            f"run_objective = {PACKAGE}.nodes.run_objective:main",
            f"objective_server = {PACKAGE}.nodes.objective_server:main",
            f"hybrid_planning = {PACKAGE}.nodes.hybrid_planning:main",
            f"setup_assistant = {PACKAGE}.setup_assistant.__main__:main",
            f"moveit_run_benchmark = {PACKAGE}.benchmarks.__main__:main",
            f"ros2 = {PACKAGE}.ros2cli.__main__:main",
        ],
    },
)
