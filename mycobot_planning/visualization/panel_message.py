"""The line of text a viewer panel shows under its controls (what happened, what to do next),
kept for the panel's ``state()`` as well: one implementation for the pose-target and teleop
panels, set from any thread."""
from __future__ import annotations

import threading
from typing import Any

__all__ = ["PanelMessage"]


class PanelMessage:
    """A markdown line added to ``gui`` where it is created (inside the panel's folder)."""

    def __init__(self, gui: Any) -> None:
        self._lock = threading.Lock()
        self._text = ""
        self._markdown = gui.add_markdown("")

    def show(self, text: str) -> None:
        with self._lock:
            self._text = text
            self._markdown.content = text

    @property
    def text(self) -> str:
        with self._lock:
            return self._text
