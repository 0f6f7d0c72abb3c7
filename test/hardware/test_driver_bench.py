"""Bench scenario driver_tracking: registered, runs once, prints its summary keys (no timing asserted)."""
from __future__ import annotations

import json

import pytest

pytest.importorskip("pymycobot", reason="pymycobot 4.0.7 is installed by scripts/setup.sh")

from mycobot_planning.bench.scenarios import SCENARIOS  # noqa: E402


def test_driver_tracking_summary(capsys):
    SCENARIOS["driver_tracking"](repeat=1, seed=0)
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines() if line.startswith("{")]
    summary = lines[-1]
    assert summary["scenario"] == "driver_tracking" and summary["summary"] is True
    for key in ("max_error_rad", "rms_error_rad", "command_rate_hz", "readback_rate_hz"):
        assert isinstance(summary[key], float) and summary[key] > 0, key
    assert summary["rms_error_rad"] <= summary["max_error_rad"]
    # measured, not bounded: the goal was aborted for the lost port after some time
    assert 0.0 < summary["port_loss_abort_s"] <= summary["port_loss_abort_max_s"]
    done, total = (int(v) for v in summary["goals_succeeded"].split("/"))
    assert total > 0 and done == total  # every trajectory of the pick and place was followed to its end
