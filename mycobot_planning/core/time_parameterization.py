"""Where time parameterisation used to live: the names stay importable from here.

New code imports the trajectory type from core.robot_trajectory and the timing from
core.trajectory_processing.
"""
from .trajectory_processing import *  # noqa: F401,F403 - the old module's public names
from .trajectory_processing import __all__  # noqa: F401
