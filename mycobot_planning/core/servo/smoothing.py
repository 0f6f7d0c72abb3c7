"""MoveIt's online_signal_smoothing ButterworthFilterPlugin: a first-order low-pass filter per
joint, y_t = (x_t + x_{t-1} - (1 - c) * y_{t-1}) / (1 + c), c = butterworth_filter_coeff > 1
(larger: smoother and slower). Its gain at rest is 1, so a constant input passes unchanged."""
from __future__ import annotations

import numpy as np


class ButterworthFilter:
    """One filter per joint over vectors of ``size`` values."""

    def __init__(self, size: int, coeff: float = 1.5) -> None:
        if not np.isfinite(coeff) or coeff <= 1.0:
            raise ValueError(f"butterworth_filter_coeff must be a finite number > 1, got {coeff}")
        self.coeff = float(coeff)
        self._x = np.zeros(size)
        self._y = np.zeros(size)

    def reset(self, value: np.ndarray | float = 0.0) -> None:
        """Start over as if ``value`` had been the input (and output) for ever."""
        self._x[:] = value
        self._y[:] = value

    def filter(self, x: np.ndarray) -> np.ndarray:
        c = self.coeff
        y = (x + self._x - (1.0 - c) * self._y) / (1.0 + c)
        self._x[:] = x
        self._y[:] = y
        return y.copy()
