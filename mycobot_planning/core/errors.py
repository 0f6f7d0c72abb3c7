"""Exceptions of the planning core.

Every bad input raises one of these with a message that names the offending thing, so callers
(nodes, tests, users at a prompt) can report it without a traceback. They subclass ValueError
because bad input is what they are.
"""


class PlanningError(Exception):
    """Base of every error raised by mycobot_planning's core."""


class RobotModelError(PlanningError, ValueError):
    """Malformed URDF/SRDF/YAML, or an unknown group, link, joint or named state."""


class StateError(PlanningError, ValueError):
    """A joint vector of the wrong length, with NaN, or naming an unknown joint."""


class KinematicsError(PlanningError, ValueError):
    """A kinematics request that cannot be posed (NaN pose, unknown frame, bad options)."""


class SceneError(PlanningError, ValueError):
    """A planning-scene update that cannot be applied; the scene is left unchanged."""


class TimeParameterizationError(PlanningError, ValueError):
    """Bad input to time parameterisation or a malformed timed trajectory (NaN, wrong shape,
    non-positive limits, bad scaling), or a profile Ruckig could not compute."""
