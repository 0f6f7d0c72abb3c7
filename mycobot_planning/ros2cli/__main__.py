"""Entry point of our `ros2` command: `python -m mycobot_planning.ros2cli <command> <verb> ...`.

Error handling follows ros2cli: a verb's error sentence goes to stderr and the exit code is 1;
argparse usage errors exit 2; Ctrl-C (or SIGTERM) ends a streaming verb (echo, hz, pub, call)
quietly. A Python traceback is never shown: an unexpected exception is reported in one line.
"""
from __future__ import annotations

import argparse
import signal
import sys
from typing import Sequence

from . import action, interface, node, param, pkg, run, service, topic
from ._common import CliError

COMMANDS = (action, interface, node, param, pkg, run, service, topic)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="ros2",
        description="ros2 is an extensible command-line tool for ROS 2 "
                    "(mycobot_planning's rclpy implementation for pip installs).",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    commands = parser.add_subparsers(title="Commands", dest="command",
                                     metavar="Call `ros2 <command> -h` for more detailed usage.")
    for module in COMMANDS:
        module.register(commands)
    parser.set_defaults(func=lambda args: parser.print_help() or 0)
    return parser


_interrupted = False


def _raise_interrupt(signum: int, frame: object) -> None:
    """SIGINT/SIGTERM: stop the verb. rclpy shuts its context down first and chains to this
    handler, so a call in flight may fail with a RuntimeError: `_interrupted` tells it apart."""
    global _interrupted
    _interrupted = True
    raise KeyboardInterrupt


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(list(argv) if argv is not None else None)
    signal.signal(signal.SIGINT, _raise_interrupt)
    signal.signal(signal.SIGTERM, _raise_interrupt)
    try:
        result = args.func(args)
    except KeyboardInterrupt:
        return 0
    except BrokenPipeError:  # `ros2 topic echo /x | head`: the reader left, stop quietly
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except (CliError, RuntimeError) as exc:
        if _interrupted:
            return 0
        print(str(exc), file=sys.stderr)
        return 1
    except Exception as exc:  # noqa: BLE001 - the user gets one line, never a traceback
        if _interrupted or type(exc).__name__ == "ExternalShutdownException":
            return 0
        print(f"{type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    finally:
        sys.stdout.flush()
    if isinstance(result, str):
        print(result, file=sys.stderr)
        return 1
    return int(result or 0)


if __name__ == "__main__":
    sys.exit(main())
