"""ROS-free physics simulation of the robot and its world in MuJoCo (the digital twin).

Nothing here imports rclpy: the ``mujoco_sim`` node and the controller manager's plant wrap
:class:`MujocoSimulator`. docs/simulation.md describes the model, the gains, the contact
settings, the scene file and the API.

Rendering is headless through EGL unless MUJOCO_GL says otherwise; MuJoCo reads the variable
once, when it is first imported, so it is set here before anything imports mujoco.
"""
import os

os.environ.setdefault("MUJOCO_GL", "egl")

from .camera import DepthFrame, SimDepthCamera  # noqa: E402
from .errors import CommandError, SimulationError, SimulationModelError, SpawnError  # noqa: E402
from .gripper import GripperCommand, GripperState  # noqa: E402
from .grasp_monitor import PlaceOutcome, SlipMonitor, judge_place, tilt_deg  # noqa: E402
from .model_builder import BuiltModel, build_model  # noqa: E402
from .scene import Floor, SceneObject, SimScene, load_scene  # noqa: E402
from .settings import SimulationSettings, load_settings  # noqa: E402
from .simulator import JointStates, MujocoSimulator, SimulatorStatus  # noqa: E402

__all__ = [
    "BuiltModel", "CommandError", "DepthFrame", "Floor", "GripperCommand", "GripperState", "JointStates",
    "MujocoSimulator", "PlaceOutcome", "SceneObject", "SimDepthCamera", "SimScene", "SimulationError",
    "SimulationModelError", "SimulationSettings", "SimulatorStatus", "SlipMonitor", "SpawnError", "build_model",
    "judge_place", "load_scene", "load_settings", "tilt_deg",
]
