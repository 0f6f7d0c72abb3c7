"""scan_n_plan: the executable (``ros2 run mycobot_planning scan_n_plan``). The node and its documentation:
mycobot_planning.ros.demos.scan_n_plan."""
from __future__ import annotations

import sys

from mycobot_planning.ros.demos.scan_n_plan import ScanNPlan
from mycobot_planning.ros.workflow_runtime import run_workflow


def main(args: list[str] | None = None) -> None:
    sys.exit(run_workflow(ScanNPlan, args))


if __name__ == "__main__":
    main()
