"""numba's just-in-time compilation for the core's hot kernels, in one place.

numba is a pinned dependency; on an install without it ``compiled`` leaves functions as they are
and ``numba_available()`` is False, so callers keep their Pinocchio/NumPy paths.
"""
from __future__ import annotations

try:
    from numba import njit
except ImportError:  # pragma: no cover - exercised only on an install without numba
    njit = None

__all__ = ["compiled", "numba_available"]


def numba_available() -> bool:
    return njit is not None


def compiled(function):
    """numba's njit, cached on disk (a fresh install compiles once) and releasing the GIL (the
    kernels run beside other threads' plans); the function itself without numba."""
    return njit(cache=True, nogil=True)(function) if njit is not None else function
