"""Runs a script through ``mtc_script`` (the drop-in runner) as its users do, then checks what it planned.

Usage: ``python test/mtc_script_runner.py SCRIPT.py [ARGS ...]``. The script runs unchanged through
``mycobot_planning.ros.drop_in.runner`` (which serves ``moveit``, ``rclcpp`` and
``moveit_commander``); the only difference from ``ros2 run mycobot_planning mtc_script SCRIPT.py``
is that ``time.sleep`` is capped at MAX_SLEEP s (2 s), because MTC's scripts end by sleeping (up
to an hour) so that a user can look at the result in RViz, and that MTC_SCRIPT_SEED (when set)
seeds the generator MoveItPy's ``RobotState.set_to_random_positions`` draws from, so that a
tutorial's random goal is the same in every run. Afterwards every solution of the
script's ``task`` (if it has one) is checked with the core trajectory validator in the scene it
starts from (test/task_helpers.assert_solution_valid) and for the spacing of its waypoints
(task_helpers.waypoint_spacing), and one line ``MTC_SCRIPT_RESULT {json}`` reports the counts.
The process then exits as the script would have: 0, or what it raised / passed to sys.exit.
"""
from __future__ import annotations

import json
import os
import sys
import time
import traceback
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from task_helpers import assert_solution_valid, spacing_problems, waypoint_spacing  # noqa: E402

from mycobot_planning.ros.task.task_topics import MTC_SOLUTION_TOPIC  # noqa: E402
from mycobot_planning.ros.drop_in.runner import run_script  # noqa: E402

#: s; MTC_SCRIPT_MAX_SLEEP overrides (a test that looks at what the script shows while it sleeps)
MAX_SLEEP = float(os.environ.get("MTC_SCRIPT_MAX_SLEEP", "2.0"))
_real_sleep = time.sleep


def _capped_sleep(seconds: float) -> None:
    _real_sleep(min(float(seconds), MAX_SLEEP))


def report(script: str, namespace: dict) -> dict:
    result: dict = {"script": Path(script).name}
    task = namespace.get("task")
    if task is None or not hasattr(task, "solutions"):
        return result
    result["solutions"] = len(task.solutions)
    result["failures"] = len(task.failures)
    valid, problems, trajectories, spacing = 0, [], 0, []
    for solution in task.solutions:
        try:
            trajectories += assert_solution_valid(solution)
            valid += 1
        except AssertionError as exc:
            problems.append(str(exc))
    for solution in task.solutions[:3]:
        spacing += waypoint_spacing(solution)
    result.update(valid=valid, trajectories=trajectories, problems=problems[:5],
                  spacing=spacing, spacing_problems=spacing_problems(spacing)[:10])
    result["costs"] = [round(float(s.cost), 6) for s in task.solutions[:10]]
    return result


def main(script: str, args: list[str]) -> int:
    time.sleep = _capped_sleep
    if os.environ.get("MTC_SCRIPT_SEED"):
        from mycobot_planning.ros.drop_in.moveit.core import robot_state

        robot_state.seed(int(os.environ["MTC_SCRIPT_SEED"]))
    code = 0
    try:
        namespace = run_script(script, args)
    except SystemExit as exc:  # the script's own exit code
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        namespace = {}
    except BaseException as exc:  # report what the script raised, with its traceback, and fail as python would
        traceback.print_exc()
        print("MTC_SCRIPT_RESULT " + json.dumps({"script": Path(script).name,
                                                 "error": f"{type(exc).__name__}: {exc}"}), flush=True)
        return 1
    print("MTC_SCRIPT_RESULT " + json.dumps(report(script, namespace)), flush=True)
    linger(namespace.get("node"), float(os.environ.get("MTC_SCRIPT_LINGER", "0")))
    return code


def linger(node: object, seconds: float) -> None:
    """Keep the script's latched publishers alive for a test's probe on MTC's /solution: until
    the script's node sees a subscriber there (then the latched message is on its way; one more
    second delivers it), at most ``seconds``."""
    if seconds <= 0:
        return
    count = getattr(node, "count_subscribers", None)
    deadline = time.monotonic() + seconds
    while count is not None and time.monotonic() < deadline:
        if count(MTC_SOLUTION_TOPIC) > 0:
            _real_sleep(min(1.0, max(0.0, deadline - time.monotonic())))
            return
        _real_sleep(0.05)
    _real_sleep(max(0.0, deadline - time.monotonic()))


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2:]))
