"""bench servo's tick lateness: how late each of the servo's ticks is on the ideal schedule."""
from __future__ import annotations

import numpy as np
import pytest

from mycobot_planning.bench.servo_scenarios import PERIOD, _lateness_p99_ms


def test_lateness_counts_each_late_tick_once_on_the_schedule():
    ticks = 1000.0 + PERIOD * np.arange(100)
    ticks[[10, 40, 70]] += 0.004  # three ticks 4 ms late, the others on time
    assert _lateness_p99_ms(ticks) == pytest.approx(4.0, abs=1e-6)


def test_lateness_ignores_a_missing_tick_and_takes_the_earliest_as_the_schedule():
    ticks = 1000.0 + PERIOD * np.arange(100) + 0.002
    ticks[0] += 0.003  # the first tick is late: the schedule comes from the others
    ticks = np.delete(ticks, 50)  # a command not received
    assert _lateness_p99_ms(ticks) < 0.1
