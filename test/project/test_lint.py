"""The lint configuration (ruff.toml) holds for the whole tree: pyflakes' checks catch undefined
names, unused imports and shadowed definitions before a test or a user meets them."""
from __future__ import annotations

import subprocess
from pathlib import Path

from ruff.__main__ import find_ruff_bin

ROOT = Path(__file__).resolve().parents[2]


def test_ruff_finds_nothing() -> None:
    result = subprocess.run([find_ruff_bin(), "check", "--no-cache", "--output-format", "concise",
                             "mycobot_planning", "interfaces_py", "test", "scripts", "setup.py"],
                            cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr


def test_ruff_would_catch_an_undefined_name(tmp_path: Path) -> None:
    """The configuration really selects pyflakes: a module using an undefined name is reported."""
    bad = tmp_path / "bad.py"
    bad.write_text("def f():\n    return undefined_name\n")
    result = subprocess.run([find_ruff_bin(), "check", "--no-cache", "--config", str(ROOT / "ruff.toml"),
                             str(bad)], capture_output=True, text=True, timeout=300)
    assert result.returncode == 1 and "F821" in result.stdout, result.stdout + result.stderr
