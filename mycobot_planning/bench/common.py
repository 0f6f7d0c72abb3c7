"""Shared benchmark plumbing: timing, statistics and the JSON line format."""
from __future__ import annotations

import json
import platform
import sys
import time
from typing import Any, Callable, Iterable

import numpy as np


def emit(record: dict[str, Any]) -> None:
    """One JSON object per line on stdout, flushed so a reader sees progress."""
    print(json.dumps(record, sort_keys=False), flush=True)


def stats(samples: Iterable[float], scale: float, unit: str) -> dict[str, float]:
    """median / p90 / min / max of samples (seconds) scaled into `unit`."""
    arr = np.asarray(list(samples), dtype=float) * scale
    if arr.size == 0:
        return {f"median_{unit}": float("nan"), f"p90_{unit}": float("nan")}
    return {
        f"median_{unit}": round(float(np.median(arr)), 4),
        f"p90_{unit}": round(float(np.percentile(arr, 90)), 4),
        f"min_{unit}": round(float(arr.min()), 4),
        f"max_{unit}": round(float(arr.max()), 4),
    }


def timed(fn: Callable[[], Any]) -> tuple[float, Any]:
    start = time.perf_counter()
    result = fn()
    return time.perf_counter() - start, result


def machine() -> dict[str, str]:
    return {"python": sys.version.split()[0], "machine": platform.machine()}


def spread(values: list[float]) -> dict[str, float]:
    """Spread of per-repeat medians, so a reader sees how stable the figure is."""
    if not values:
        return {}
    return {"repeat_min": round(min(values), 4), "repeat_max": round(max(values), 4)}


def rest_time(history: list, asked: float, threshold: float = 1e-6) -> float | None:
    """The time of the first (time, positions) sample at or after ``asked`` followed by two that
    differ from it by less than ``threshold`` (the arm at rest), or None when none is."""
    samples = [(t, p) for t, p in history if t >= asked]
    for i in range(len(samples) - 2):
        t, p = samples[i]
        if all(np.max(np.abs(samples[j][1] - p)) < threshold for j in (i + 1, i + 2)):
            return t
    return None
