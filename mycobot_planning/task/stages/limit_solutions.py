"""LimitSolutions: a wrapper that passes on at most ``max_solutions`` of its child's solutions,
cheapest first among those waiting (MTC's stages::LimitSolutions); once that many went out the
child is not asked for more."""
from __future__ import annotations

import heapq
import itertools

from ..containers import WrapperBase
from ..errors import InitStageException
from ..stage import Stage
from ..storage import SolutionBase


class LimitSolutions(WrapperBase):
    def __init__(self, name: str = "LimitSolutions", child: Stage | None = None, max_solutions: int | None = None) -> None:
        super().__init__(name, child)
        self._properties.declare("max_solutions", max_solutions, "maximum number of solutions returned by this wrapper",
                                 type=int)
        self._waiting: list[tuple[float, int, SolutionBase]] = []
        self._order = itertools.count()
        self._forwarded = 0

    def reset(self) -> None:
        super().reset()
        self._waiting.clear()
        self._forwarded = 0

    def init(self, robot_model) -> None:
        errors = InitStageException().collect(super().init, robot_model)
        limit = self._properties["max_solutions"]
        if limit is None or limit < 0:
            errors.push_back(self, f"property 'max_solutions' must be a number >= 0, got {limit!r}")
        if errors:
            raise errors

    def _on_new_solution(self, solution: SolutionBase) -> None:
        heapq.heappush(self._waiting, (solution.cost, next(self._order), solution))

    def _can_compute(self) -> bool:
        more = bool(self._waiting) or super()._can_compute()
        return more and self._forwarded < self._properties["max_solutions"]

    def _compute(self) -> None:
        if super()._can_compute():
            super()._compute()
        if self._waiting and self._forwarded < self._properties["max_solutions"]:
            self._forwarded += 1
            self._lift_wrapped(heapq.heappop(self._waiting)[2])
