"""servo_keyboard_input: the executable (``ros2 run mycobot_planning servo_keyboard_input``),
MoveIt Servo's keyboard teleop for servo_node. The node and its key map:
mycobot_planning.ros.servo.keyboard_input (and docs/servo.md)."""
from __future__ import annotations

import sys


def main(args: list[str] | None = None) -> None:
    if not sys.stdin.isatty():
        print("[ERROR] servo_keyboard_input reads keys from a terminal: run it in one (stdin is not a tty)",
              file=sys.stderr)
        sys.exit(1)
    import rclpy

    from mycobot_planning.paths import use_fast_discovery
    from mycobot_planning.ros.servo.keyboard_input import KeyboardServo, key_loop

    use_fast_discovery()
    rclpy.init(args=args if args is not None else sys.argv)
    node = None
    try:
        try:
            node = KeyboardServo()
        except ValueError as exc:
            print(f"[ERROR] {exc}", file=sys.stderr)
            sys.exit(1)
        key_loop(node, sys.stdin.fileno(), lambda: rclpy.spin_once(node, timeout_sec=0.0))
    except KeyboardInterrupt:
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
