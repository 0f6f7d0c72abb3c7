"""Running a bench scenario from a test: small settings, once, its JSON records read back."""
from __future__ import annotations

import json
import os
import sys
from typing import Any, Callable


def run_bench(monkeypatch: Any, capsys: Any, bench: Callable[..., None], *, seed: int = 0, own_domain: bool = False,
              **settings: Any) -> list[dict]:
    """Run ``bench`` once (``repeat=1``) with its module's constants ``settings`` made small for
    the test; the JSON records it printed, the summary last. ``own_domain``: its ROS nodes run
    on a domain of this test process (MYCOBOT_BENCH_DOMAIN_ID)."""
    module = sys.modules[bench.__module__]
    for name, value in settings.items():
        monkeypatch.setattr(module, name, value)
    if own_domain:
        monkeypatch.setenv("MYCOBOT_BENCH_DOMAIN_ID", str(150 + os.getpid() % 50))
    bench(repeat=1, seed=seed)
    return [json.loads(line) for line in capsys.readouterr().out.splitlines() if line.startswith("{")]
