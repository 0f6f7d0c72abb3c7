"""pilz_cartesian_limits.yaml: the Cartesian speed and acceleration limits of LIN and CIRC."""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Mapping

import yaml

from mycobot_planning.paths import config_file
from ...errors import PlanningError

CARTESIAN_KEYS = ("max_trans_vel", "max_trans_acc", "max_trans_dec", "max_rot_vel")


class CartesianLimitsError(PlanningError, ValueError):
    """A pilz_cartesian_limits file or mapping is missing a value or holds an impossible one."""


# ---------------------------------------------------------------------------- Cartesian limits
@dataclass(frozen=True)
class CartesianLimits:
    """pilz_cartesian_limits.yaml: translational velocity/acceleration/deceleration, rotational
    velocity. ``max_trans_dec`` is negative, as in MoveIt's file."""

    max_trans_vel: float
    max_trans_acc: float
    max_trans_dec: float
    max_rot_vel: float

    @property
    def equivalent_radius(self) -> float:
        """Metres of path per radian of rotation (KDL's eqradius): with it, one speed limit on the
        path parameter keeps both the translational and the rotational speed within limits."""
        return self.max_trans_vel / self.max_rot_vel


def load_cartesian_limits(source: str | Path | Mapping | CartesianLimits | None = None) -> CartesianLimits:
    """Cartesian limits from a YAML file path, a mapping, or the package default file.

    The mapping may be the file's content (``{"cartesian_limits": {...}}``) or the inner mapping.
    All four values are required: max_trans_vel > 0, max_trans_acc > 0, max_trans_dec < 0 (a
    deceleration, MoveIt's sign convention), max_rot_vel > 0. Raises CartesianLimitsError naming
    the offending entry.
    """
    if isinstance(source, CartesianLimits):
        return source
    where = "cartesian limits"
    if source is None:
        source = config_file("pilz_cartesian_limits.yaml")
    if isinstance(source, (str, Path)):
        where = str(source)
        try:
            with open(source, encoding="utf-8") as handle:
                data = yaml.safe_load(handle)
        except OSError as exc:
            raise CartesianLimitsError(f"cannot read Cartesian limits file {source}: {exc}") from None
        except yaml.YAMLError as exc:
            raise CartesianLimitsError(f"{source} is not valid YAML: {exc}") from None
    else:
        data = source
    if not isinstance(data, Mapping):
        raise CartesianLimitsError(f"{where}: expected a mapping, got {type(data).__name__}")
    if "cartesian_limits" in data:
        extra = sorted(set(data) - {"cartesian_limits"})
        if extra:
            raise CartesianLimitsError(f"{where}: unknown top-level keys {extra}; expected only 'cartesian_limits'")
        data = data["cartesian_limits"]
        if not isinstance(data, Mapping):
            raise CartesianLimitsError(f"{where}: 'cartesian_limits' must be a mapping")
    unknown = sorted(set(data) - set(CARTESIAN_KEYS))
    if unknown:
        raise CartesianLimitsError(f"{where}: unknown keys {unknown}; expected {list(CARTESIAN_KEYS)}")
    missing = [k for k in CARTESIAN_KEYS if k not in data]
    if missing:
        raise CartesianLimitsError(f"{where}: missing {missing}; all of {list(CARTESIAN_KEYS)} are required")
    values = {}
    for key in CARTESIAN_KEYS:
        value = data[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise CartesianLimitsError(f"{where}: {key} must be a finite number, got {value!r}")
        values[key] = float(value)
    for key in ("max_trans_vel", "max_trans_acc", "max_rot_vel"):
        if values[key] <= 0.0:
            raise CartesianLimitsError(f"{where}: {key} must be > 0, got {values[key]}")
    if values["max_trans_dec"] >= 0.0:
        raise CartesianLimitsError(
            f"{where}: max_trans_dec must be negative (a deceleration, as in MoveIt's "
            f"pilz_cartesian_limits.yaml), got {values['max_trans_dec']}"
        )
    return CartesianLimits(**values)


@lru_cache(maxsize=1)
def default_cartesian_limits() -> CartesianLimits:
    return load_cartesian_limits(None)

