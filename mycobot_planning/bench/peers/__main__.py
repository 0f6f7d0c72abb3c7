"""Peers only, from the command line: ``python -m mycobot_planning.bench.peers``.

For setting up or checking the peer venvs and the peers' side of the benchmark without our
planner; the ``peers`` scenario of ``python -m mycobot_planning.bench`` adds our planner. Prints
JSON lines on stdout (one per planner); progress goes to stderr.
"""
from __future__ import annotations

import argparse
import sys

from ..common import emit, machine
from . import PEER_NAMES, compare, panda_pose_problems, report_records, run_peers
from .venvs import PeerUnavailable, ensure_peer_venv


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m mycobot_planning.bench.peers",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=20, help="number of problems (default 20)")
    parser.add_argument("--seed", type=int, default=0, help="problem seed (default 0)")
    parser.add_argument("--time-limit", type=float, default=1.0, help="seconds per problem")
    parser.add_argument("--peers", nargs="+", default=list(PEER_NAMES), choices=PEER_NAMES)
    parser.add_argument("--no-obstacles", action="store_true", help="leave the boxes out")
    parser.add_argument("--setup-only", action="store_true", help="only create the peer venvs")
    args = parser.parse_args(argv)

    if args.setup_only:
        status = 0
        for name in args.peers:
            try:
                emit({"peer": name, "python": str(ensure_peer_venv(name)), "available": True})
            except PeerUnavailable as error:
                emit({"peer": name, "available": False, "reason": error.reason})
                status = 1
        return status

    problems = panda_pose_problems(args.count, args.seed, obstacles=not args.no_obstacles)
    runs = run_peers(problems, args.peers, time_limit=args.time_limit)
    report = compare(None, runs)
    for record in report_records(report):
        emit({**record, "seed": args.seed, "time_limit_s": args.time_limit, **machine()})
    return 0


if __name__ == "__main__":
    sys.exit(main())
