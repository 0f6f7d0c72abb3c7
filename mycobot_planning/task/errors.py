"""Exceptions of the task constructor.

MTC reports a badly configured task when it is initialised (``InitStageException``, listing
every stage that failed and why), not half-way through planning. We do the same: every
misconfiguration a stage can detect without planning (no group, an unknown named state, no
monitored stage, an empty container, a property of the wrong type) is collected by
``Task.init()`` and raised as one :class:`InitStageException` naming each stage and property.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Callable, Iterator

from ..core.errors import PlanningError

if TYPE_CHECKING:  # pragma: no cover
    from .stage import Stage


class TaskError(PlanningError):
    """Base class of everything the task constructor raises."""


class InitStageException(TaskError, ValueError):
    """One or more stages are misconfigured (MTC's InitStageException).

    ``errors`` lists ``(stage_name, message)`` pairs in the order they were found; ``str()``
    gives MTC's text: ``Error initializing stage(s):`` followed by one ``name: message`` line
    per problem.
    """

    def __init__(self, stage: "Stage | str | None" = None, message: str = "") -> None:
        self.errors: list[tuple[str, str]] = []
        if stage is not None:
            self.push_back(stage, message)
        super().__init__(str(self))

    def push_back(self, stage: "Stage | str", message: str) -> None:
        name = stage if isinstance(stage, str) else stage.name
        self.errors.append((name, message))
        self.args = (str(self),)

    def append(self, other: "InitStageException") -> None:
        self.errors.extend(other.errors)
        self.args = (str(self),)

    def collect(self, init: Callable[..., Any], *args: Any) -> "InitStageException":
        """Call ``init(*args)`` (a stage's or a base class's init), its InitStageException
        appended here rather than raised; returns self."""
        try:
            init(*args)
        except InitStageException as exc:
            self.append(exc)
        return self

    @property
    def stage_names(self) -> list[str]:
        return [name for name, _ in self.errors]

    def __bool__(self) -> bool:
        return bool(self.errors)

    def __iter__(self) -> Iterator[tuple[str, str]]:
        return iter(self.errors)

    def __str__(self) -> str:
        if not self.errors:
            return "Error initializing stage(s)"
        head = "Error initializing stage" + ("s" if len(self.errors) > 1 else "") + ":"
        return "\n".join([head] + [f"{name}: {message}" for name, message in self.errors])


class PropertyError(TaskError):
    """A property was used wrongly; names the property (and the stage, when known)."""

    def __init__(self, property_name: str, problem: str, stage_name: str | None = None) -> None:
        self.property_name = property_name
        self.problem = problem
        self.stage_name = stage_name
        where = f"stage '{stage_name}': " if stage_name else ""
        super().__init__(f"{where}property '{property_name}': {problem}")


class PropertyUndeclared(PropertyError, LookupError):
    """The property was never declared on this stage (usually a typo)."""


class PropertyTypeError(PropertyError, TypeError):
    """The value does not have the property's declared type."""


class PropertyUndefined(PropertyError, ValueError):
    """The property has neither a value nor a default where one is required."""
