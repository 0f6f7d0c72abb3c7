"""Exceptions of the perception layer.

They subclass :class:`mycobot_planning.core.errors.PlanningError` (the base of every error the
package raises) and ``ValueError``, because every one of them means "this input cannot be used":
a point cloud with the wrong fields, a cloud with no finite points, a parameter out of range.
A node turns them into ``success: false`` with the message; nothing here should ever surface
as a crash with a NumPy traceback.
"""
from __future__ import annotations

from mycobot_planning.core.errors import PlanningError


class PerceptionError(PlanningError, ValueError):
    """Base of the perception errors (bad parameters, bad clouds, bad requests)."""


class CloudFormatError(PerceptionError):
    """A point cloud whose layout or content cannot be read: missing x/y/z fields, a data
    buffer of the wrong length, wrong array shape, no finite point at all."""


class ParameterError(PerceptionError):
    """A perception parameter that is unknown, of the wrong type, or out of its range."""


class RequestError(PerceptionError):
    """A get-planning-scene request that cannot be answered as asked (unknown target shape,
    wrong number of target dimensions)."""
