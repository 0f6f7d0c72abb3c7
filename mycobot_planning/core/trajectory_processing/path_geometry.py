"""Checks and geometry of a joint-space waypoint path shared by both timing methods."""
from __future__ import annotations

import numpy as np

from ..errors import TimeParameterizationError

# Two consecutive waypoints closer than this (max-norm) are the same waypoint: a zero-length
# segment has no direction and would make the per-segment problem ill-posed.
_DUPLICATE_TOL = 1e-10
# Segments whose unit direction differs from the first one of their run by at most this
# (max-norm) are one straight line: timing them as one implies a velocity jump below
# 1e-9 * speed at the waypoints inside, i.e. numerical noise.
COLLINEAR_TOL = 1e-9


def validate_path(path) -> np.ndarray:
    try:
        arr = np.array(path, dtype=float)  # copy: we never alias the caller's array
    except (TypeError, ValueError):
        raise TimeParameterizationError("path must be a numeric (N, d) array of waypoints") \
            from None
    if arr.ndim != 2 or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise TimeParameterizationError(
            f"path must have shape (N, d) with N >= 1 waypoints and d >= 1 joints, "
            f"got shape {arr.shape}")
    bad = ~np.all(np.isfinite(arr), axis=1)
    if np.any(bad):
        raise TimeParameterizationError(
            f"path waypoint(s) {np.flatnonzero(bad).tolist()} contain NaN or inf")
    return arr


def drop_duplicates(path: np.ndarray) -> np.ndarray:
    if path.shape[0] < 2 or np.all(np.max(np.abs(np.diff(path, axis=0)), axis=1) > _DUPLICATE_TOL):
        return path  # the usual case, without a Python loop over thousands of waypoints
    keep = [0]
    for i in range(1, path.shape[0]):
        if np.max(np.abs(path[i] - path[keep[-1]])) > _DUPLICATE_TOL:
            keep.append(i)
    return path[keep]


def turning_angles(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Turning angle (rad) at each interior waypoint, and whether the waypoint is a real bend
    (not collinear by the same test the segment method uses)."""
    delta = np.diff(pts, axis=0)
    dirs = delta / np.linalg.norm(delta, axis=1)[:, None]
    cosang = np.clip(np.einsum("ij,ij->i", dirs[:-1], dirs[1:]), -1.0, 1.0)
    bend = np.max(np.abs(dirs[1:] - dirs[:-1]), axis=1) > COLLINEAR_TOL
    return np.arccos(cosang), bend

