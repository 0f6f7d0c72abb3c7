"""The test tree itself: pytest imports test modules by basename (rootdir-relative, no packages),
so two test modules with one name make the whole suite fail to collect, though each file passes
when run alone."""
from __future__ import annotations

from collections import defaultdict
from pathlib import Path

TESTS = Path(__file__).resolve().parent.parent


def test_every_test_module_has_a_basename_of_its_own():
    seen: dict[str, list[str]] = defaultdict(list)
    for path in TESTS.rglob("test_*.py"):
        if ".venv" not in path.parts:
            seen[path.name].append(str(path.relative_to(TESTS)))
    assert len(seen) > 100
    twice = {name: paths for name, paths in seen.items() if len(paths) > 1}
    assert twice == {}, f"rename one of each: {twice}"
