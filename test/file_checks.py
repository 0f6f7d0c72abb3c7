"""Checks that a loader refuses a bad file with a clear error (shared by the config-file tests
of OMPL, Pilz and the MTC demos)."""
from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

import pytest


def assert_file_refused(load: Callable[[Path], Any], error: type[Exception], path: Path, text: str | None,
                        match: str) -> None:
    """``load(path)`` raises ``error`` matching ``match`` once ``path`` holds ``text`` (None:
    the file is not written)."""
    if text is not None:
        path.write_text(text)
    with pytest.raises(error, match=match):
        load(path)
