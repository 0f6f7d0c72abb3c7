"""Timing of joint-space paths (MoveIt's trajectory_processing): the front door and its two methods."""
from .time_parameterization import *  # noqa: F401,F403 - the front door's names
from .time_parameterization import __all__  # noqa: F401
