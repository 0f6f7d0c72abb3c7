"""mtc_script: the executable (``ros2 run mycobot_planning mtc_script SCRIPT.py``, or
``python -m mycobot_planning.nodes.mtc_script SCRIPT.py``). The runner and its documentation:
mycobot_planning.ros.drop_in.runner."""
from __future__ import annotations

import sys

from mycobot_planning.ros.drop_in.runner import run_command_line


def main(args: list[str] | None = None) -> int:
    return run_command_line(args)


if __name__ == "__main__":
    sys.exit(main())
