"""Command line of the benchmarks; see mycobot_planning/bench/__init__.py."""
from __future__ import annotations

import argparse
import sys

from . import scenarios


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m mycobot_planning.bench",
        description="Run a benchmark scenario; prints JSON lines, the last one a summary.",
    )
    parser.add_argument("scenario", choices=sorted(scenarios.SCENARIOS), help="what to measure")
    parser.add_argument("--repeat", type=int, default=3, help="independent repeats (default 3)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error("--repeat must be >= 1")
    scenarios.SCENARIOS[args.scenario](repeat=args.repeat, seed=args.seed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
