"""PredicateFilter: pass on only the child's solutions a predicate accepts (MTC's
stages::PredicateFilter); rejected ones become failures with the predicate's comment."""
from __future__ import annotations

import math
from typing import Any, Callable

from ..containers import WrapperBase
from ..errors import InitStageException
from ..properties import PropertySetter
from ..stage import Stage
from ..storage import SolutionBase


def _as_predicate(value: Any) -> Callable:
    if not callable(value):
        raise TypeError("the predicate must be callable: f(solution) -> bool or (bool, comment)")
    return value


class PredicateFilter(WrapperBase):
    def __init__(self, name: str = "predicate filter", child: Stage | None = None,
                 predicate: Callable[[SolutionBase], Any] | None = None) -> None:
        super().__init__(name, child)
        self._properties.declare("predicate", predicate, "predicate to filter wrapped solutions", coerce=_as_predicate)
        self._properties.declare("ignore_filter", False, "ignore predicate and forward all solutions", type=bool)

    setPredicate = PropertySetter("predicate", Callable[[SolutionBase], Any])
    setIgnoreFilter = PropertySetter("ignore_filter", bool)

    def init(self, robot_model) -> None:
        errors = InitStageException().collect(super().init, robot_model)
        if self._properties["predicate"] is None:
            errors.push_back(self, "property 'predicate' is not specified")
        if errors:
            raise errors

    def _on_new_solution(self, solution: SolutionBase) -> None:
        cost, comment = solution.cost, solution.comment
        if not self._properties["ignore_filter"]:
            result = self._properties["predicate"](solution)
            if isinstance(result, tuple):
                accepted, comment = bool(result[0]), str(result[1])
            else:
                accepted = bool(result)
            if not accepted:
                cost = math.inf
        self._lift_wrapped(solution, cost, comment)
