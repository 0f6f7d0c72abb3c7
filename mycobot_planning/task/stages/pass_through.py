"""PassThrough: a wrapper that passes its child's solutions on unchanged (MTC's stages::PassThrough),
the place to hang a cost term (``setCostTerm``) over a child that has its own."""
from __future__ import annotations

from ..containers import WrapperBase
from ..stage import Stage


class PassThrough(WrapperBase):
    def __init__(self, name: str = "PassThrough", child: Stage | None = None) -> None:
        super().__init__(name, child)
