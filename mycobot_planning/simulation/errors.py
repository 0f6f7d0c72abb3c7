"""Errors of the simulation layer: each names the part (link, object, file) it is about, so a
bad model or scene is refused before anything starts."""
from __future__ import annotations


class SimulationError(Exception):
    """Base class of everything the simulation layer raises on purpose."""


class SimulationModelError(SimulationError, ValueError):
    """The MuJoCo model cannot be built from the robot description, the settings or the scene
    (an unreadable mesh, a free body without mass, a bad scene file, ...)."""


class SpawnError(SimulationError, ValueError):
    """An object cannot be added to the running world (overlap, duplicate name, bad shape)."""


class CommandError(SimulationError, ValueError):
    """A command the simulator refuses (unknown joint, NaN, outside the limits)."""
