"""Runs one of MTC's demo scripts as its users do (``python script.py``), then checks what it planned.

Usage: ``python test/mtc_script_runner.py SCRIPT.py``. The script runs unchanged in this
process's ``__main__``; only ``time.sleep`` is capped at MAX_SLEEP s (2 s), because the scripts end by
sleeping (up to an hour) so that a user can look at the result in RViz. Afterwards every solution
of the script's ``task`` is checked with the core trajectory validator in the scene it starts from
(test/task_helpers.assert_solution_valid), and one line ``MTC_SCRIPT_RESULT {json}`` reports the
counts, which test/ros/test_mtc_demo_scripts.py reads.
"""
from __future__ import annotations

import json
import os
import runpy
import sys
import time
import traceback
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from task_helpers import assert_solution_valid  # noqa: E402

#: s; MTC_SCRIPT_MAX_SLEEP overrides (a test that looks at what the script shows while it sleeps)
MAX_SLEEP = float(os.environ.get("MTC_SCRIPT_MAX_SLEEP", "2.0"))
_real_sleep = time.sleep


def _capped_sleep(seconds: float) -> None:
    _real_sleep(min(float(seconds), MAX_SLEEP))


def main(script: str) -> int:
    time.sleep = _capped_sleep
    result: dict = {"script": Path(script).name}
    try:
        namespace = runpy.run_path(script, run_name="__main__")
    except BaseException as exc:  # report what the script raised, with its traceback
        traceback.print_exc()
        result["error"] = f"{type(exc).__name__}: {exc}"
        print("MTC_SCRIPT_RESULT " + json.dumps(result), flush=True)
        return 1
    task = namespace.get("task")
    if task is not None:
        result["solutions"] = len(task.solutions)
        result["failures"] = len(task.failures)
        valid, problems, trajectories = 0, [], 0
        for solution in task.solutions:
            try:
                trajectories += assert_solution_valid(solution)
                valid += 1
            except AssertionError as exc:
                problems.append(str(exc))
        result.update(valid=valid, trajectories=trajectories, problems=problems[:5])
        result["costs"] = [round(float(s.cost), 6) for s in task.solutions[:10]]
    print("MTC_SCRIPT_RESULT " + json.dumps(result), flush=True)
    # keep the script's latched publishers alive a while (MTC_SCRIPT_LINGER s) for a test's probe
    _real_sleep(float(os.environ.get("MTC_SCRIPT_LINGER", "0")))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
