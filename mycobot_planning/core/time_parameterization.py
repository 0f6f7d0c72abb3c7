"""Where time parameterisation used to live: the names stay importable from here.

New code imports the trajectory type from core.robot_trajectory and the timing from
core.trajectory_processing.
"""
from .robot_trajectory import DEFAULT_SAMPLE_PERIOD, TimedTrajectory
from .trajectory_processing import (
    DEFAULT_MAX_DEVIATION,
    TimeParameterizationError,
    path_deviation,
    retime,
    time_parameterize,
)

__all__ = [
    "DEFAULT_MAX_DEVIATION",
    "DEFAULT_SAMPLE_PERIOD",
    "TimeParameterizationError",
    "TimedTrajectory",
    "path_deviation",
    "retime",
    "time_parameterize",
]
