"""The `objectives` benchmark's ROS part runs (its own processes and domain) and measures what it
says: a completed My Pick and Place and a canceled motion that came to rest. No timing is
asserted."""
from __future__ import annotations

from mycobot_planning.bench.objectives_scenarios import objectives_over_ros


def test_the_ros_part_measures_a_pick_and_place_and_a_cancel():
    pick_place, cancel_to_rest = objectives_over_ros(1)
    assert len(pick_place) == 1 and pick_place[0] > 0
    assert len(cancel_to_rest) == 1 and cancel_to_rest[0] >= 0
