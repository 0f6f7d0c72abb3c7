"""Command line of the setup assistant (also `ros2 run mycobot_planning setup_assistant`)."""
from __future__ import annotations

import argparse
import logging
import sys
import time

from ..core.collision_detection.collision_matrix import ADJACENT, ALWAYS, DEFAULT, DEFAULT_SAMPLES, NEVER
from ..core.errors import RobotModelError
from .assistant import build_config
from .default_groups import GroupSpec, parse_end_effector


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m mycobot_planning.setup_assistant",
        description="Write a robot configuration directory (SRDF with the self-collision matrix, planning "
                    "groups, named states, end effectors; joint_limits, kinematics, ompl_planning and controller "
                    "YAML files) for a URDF, as MoveIt Setup Assistant does. Load it with "
                    "RobotModel.from_config(OUT_DIR) or the nodes' robot_config parameter.")
    p.add_argument("robot", help="the robot's URDF (.urdf) or xacro file (.urdf.xacro, .xacro)")
    p.add_argument("-o", "--output", required=True, metavar="OUT_DIR", help="directory to write (created if needed)")
    p.add_argument("--srdf", metavar="EXISTING.srdf",
                   help="an SRDF to start from: its valid groups, states, end effectors and disabled pairs are kept")
    p.add_argument("--group", action="append", default=[], metavar="NAME:BASE_LINK:TIP_LINK",
                   help="a planning group: a chain NAME:BASE_LINK:TIP_LINK or joints NAME:J1,J2,... (repeatable; "
                        "default when neither this nor --srdf gives one: 'arm', the longest chain from the root, "
                        "and 'gripper' for fingers at its end)")
    p.add_argument("--end-effector", action="append", default=[], metavar="NAME:PARENT_LINK:GROUP",
                   help="an end effector: its name, the link it hangs from, its own group (repeatable)")
    p.add_argument("--samples", type=int, default=DEFAULT_SAMPLES,
                   help=f"random states sampled for the collision matrix (default {DEFAULT_SAMPLES})")
    p.add_argument("--seed", type=int, default=0, help="random seed of the sampling (default 0)")
    p.add_argument("--xacro-arg", action="append", default=[], metavar="NAME:=VALUE",
                   help="an argument for a xacro file (repeatable)")
    return p


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="warning: %(message)s")
    if args.samples < 0:
        print("error: --samples must be >= 0", file=sys.stderr)
        return 2
    try:
        groups = [GroupSpec.parse(text) for text in args.group]
        eefs = [parse_end_effector(text) for text in args.end_effector]
        xacro_args = {}
        for text in args.xacro_arg:
            if ":=" not in text:
                raise ValueError(f"--xacro-arg '{text}': expected NAME:=VALUE")
            key, value = text.split(":=", 1)
            xacro_args[key] = value
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2

    started = time.monotonic()

    tty = sys.stderr.isatty()
    last_quarter = [-1]

    def progress(done: int, total: int, undecided: int) -> None:
        """One updating line on a terminal; a line per quarter into a pipe or a log."""
        line = f"sampling self-collisions: {done}/{total} states, {undecided} pairs not yet seen in contact"
        if tty:
            print("\r" + line, end="\n" if done >= total else "", file=sys.stderr, flush=True)
            return
        quarter = 4 * done // max(total, 1)
        if quarter > last_quarter[0]:
            last_quarter[0] = quarter
            print(line, file=sys.stderr, flush=True)

    try:
        report = build_config(args.robot, args.output, args.srdf, groups, eefs, args.samples, args.seed,
                              progress, xacro_args)
    except (RobotModelError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    m = report.matrix
    print(f"robot '{report.robot_name}': groups {report.groups}, end effectors {report.end_effectors}")
    print(f"self-collision matrix from {m.samples} states in {m.seconds:.1f} s: "
          f"{len(m.disabled)} pairs disabled ({m.count(ADJACENT)} Adjacent, {m.count(DEFAULT)} Default, "
          f"{m.count(ALWAYS)} Always, {m.count(NEVER)} Never), {len(m.enabled)} checked")
    for path in report.files:
        print(f"wrote {path}")
    print(f"done in {time.monotonic() - started:.1f} s; load it with RobotModel.from_config('{report.directory}') "
          f"or --ros-args -p robot_config:={report.directory}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
