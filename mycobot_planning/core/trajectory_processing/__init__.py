"""Timing of joint-space paths (MoveIt's trajectory_processing): the front door and its two methods."""
from .time_parameterization import (
    DEFAULT_MAX_DEVIATION,
    DEFAULT_SAMPLE_PERIOD,
    TimeParameterizationError,
    TimedTrajectory,
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
