"""fast_log.Throttle: one line per period of each kind (the cheap throttle the controllers and
servo_node use instead of rclpy's throttle_duration_sec)."""
from __future__ import annotations

from mycobot_planning.ros.fast_log import Throttle


def test_throttle_lets_one_line_per_kind_through_per_period():
    throttle = Throttle(period=1e6)
    assert throttle("preempted") and throttle("executing")
    assert not throttle("preempted") and not throttle("executing")
    assert throttle("aborted")


def test_throttle_with_no_period_lets_every_line_through():
    throttle = Throttle(period=0.0)
    assert all(throttle("same") for _ in range(3))
