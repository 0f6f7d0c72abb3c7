"""Results that carry a MoveItErrorCode read the same way everywhere: ``bool(result)``, ``.success``
and ``.message`` come from the code, as MoveIt's MoveItErrorCode idiom has it."""
from __future__ import annotations

from interfaces_py.msgs import MoveItErrorCode


class ErrorCodeResult:
    """Mixin for dataclasses with an ``error_code`` field: true exactly when the code is SUCCESS."""

    error_code: MoveItErrorCode

    @property
    def success(self) -> bool:
        return bool(self.error_code)

    @property
    def message(self) -> str:
        return self.error_code.message

    def __bool__(self) -> bool:
        return self.success
