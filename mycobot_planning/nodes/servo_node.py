"""servo_node: the executable (``ros2 run mycobot_planning servo_node``). The node and its
documentation: mycobot_planning.ros.servo.servo_node (and docs/servo.md)."""
from __future__ import annotations

import sys

from mycobot_planning.ros.node_runtime import run_node


def _make():
    from mycobot_planning.ros.servo.servo_node import ServoNode

    try:
        return ServoNode()
    except TimeoutError as exc:  # move_group did not give the robot model
        raise ValueError(f"servo_node cannot load the robot model: {exc}") from None


def main(args: list[str] | None = None) -> None:
    # The loop thread shares the interpreter with the executor's: a thread waiting for the GIL
    # waits up to the switch interval (5 ms by default) -- half a servo period. 0.5 ms keeps the
    # loop's wake-ups within a millisecond at a small cost in throughput.
    sys.setswitchinterval(0.0005)
    # One executor thread (rclpy's SingleThreadedExecutor): every callback here is short, and the
    # multi-threaded executor's own work per message (/joint_states and commands at 100 Hz) was
    # most of the node's CPU. Bench servo, interleaved, 2 rounds: cpu_percent 48.4 / 44.5 -> 22.0 /
    # 21.7, loop_jitter_p99_ms 10.5 / 9.7 -> 5.2 / 3.2, command_to_motion_ms 33 / 42 -> 25 / 25.
    sys.exit(run_node(_make, args, threads=1))


if __name__ == "__main__":
    main()
