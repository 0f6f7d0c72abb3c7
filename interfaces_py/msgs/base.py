"""The machinery every message shares: validation against the field types, dict and JSON forms, bounds on values that cannot be right."""
from __future__ import annotations

import functools
import json
import math
import typing
from collections.abc import Mapping, Sequence
from dataclasses import MISSING, fields
from typing import Any, TypeVar

import numpy as np

M = TypeVar("M", bound="_Message")

# Bounds on values that cannot be right: a message beyond them is refused with the bound, so an
# absurd number never reaches collision checking or planning arithmetic (1e300 m boxes overflow
# Coal's bounding volumes; 1e308 positions overflow IK).
#: m: the largest coordinate of any pose or mesh vertex. The myCobot reaches 0.28 m and large
#: industrial arms a few metres; a scene beyond a kilometre is a unit mistake or an attack.
WORKSPACE_BOUND = 1000.0
#: m: the largest primitive dimension (box side, radius, height): a 100 m wall is already a floor.
MAX_OBJECT_EXTENT = 100.0
#: Vertices and triangles of one explicit mesh at most (the perception pipeline's are thousands, a
#: detailed CAD part tens of thousands). Issue 27: a 1,000,000-vertex mesh (the old bound) took 10 s
#: to add, 18.9 s to read back with /get_planning_scene and ~460 MB of the planning_server's
#: memory; both faces read meshes through this message, so the budget holds for both.
MAX_MESH_VERTICES = 100_000
MAX_MESH_TRIANGLES = 200_000
#: Characters of an identifier (object id, link, joint, frame or ACM entry name) at most.
MAX_NAME_LENGTH = 256


def printable(text: str, limit: int = 200, keep: str = "") -> str:
    """``text`` safe to show in a log line or an error message: control characters (but those in
    ``keep``) and lone surrogates (which UTF-8, and so rclpy's logging, cannot encode) escaped,
    cut at ``limit`` characters with a note of how many more there were."""
    text = str(text)
    if len(text) > limit:
        text = text[:limit] + f"... ({len(text) - limit} more characters)"
    if text.isprintable():
        return text
    # isprintable() is False for control characters and for lone surrogates (category Cs).
    return "".join(ch if ch in keep or ch.isprintable() else ascii(ch)[1:-1] for ch in text)


def _text_problem(value: str) -> str | None:
    """Why a string cannot travel in a message (UTF-8 cannot encode it, or it holds NUL)."""
    if "\x00" in value:
        return f"must not contain NUL characters: '{printable(value, 80)}'"
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        return f"is not valid Unicode (it holds a lone surrogate): '{printable(value, 80)}'"
    return None


def _require_name(path: str, value: str, required: bool = True) -> None:
    """An identifier: non-empty (when required), no control characters, at most MAX_NAME_LENGTH."""
    if not value:
        if required:
            raise MessageError(path, "must be a non-empty string")
        return
    if len(value) > MAX_NAME_LENGTH:
        raise MessageError(path, f"is {len(value)} characters long; names have at most {MAX_NAME_LENGTH}")
    if not value.isprintable():
        raise MessageError(path, f"must not contain control characters: '{printable(value, 80)}'")


class MessageError(ValueError):
    """A message field is missing, mistyped or out of range, or the JSON is malformed.

    ``field`` is the dotted path of the offending field (``"Pose.orientation"``,
    ``"PlanningScene.world.collision_objects[2].id"``) so callers and users can find the
    problem in a large message; ``problem`` says what is wrong with it.
    """

    def __init__(self, field: str, problem: str) -> None:
        super().__init__(f"{field}: {problem}")
        self.field = field
        self.problem = problem


# --------------------------------------------------------------------------------------
# Generic dataclass <-> dict machinery (shared by every message class)
# --------------------------------------------------------------------------------------


def _describe(value: Any) -> str:
    text = printable(repr(value), 10_000)
    return f"{type(value).__name__} {text if len(text) <= 40 else text[:37] + '...'}"


@functools.cache
def _list_item(tp: Any) -> Any:
    """The item type of a ``list[...]`` annotation, None for anything else (resolved once)."""
    return typing.get_args(tp)[0] if typing.get_origin(tp) is list else None


def _convert(tp: Any, value: Any, path: str) -> Any:
    """Check ``value`` against the field annotation ``tp`` and return its canonical form.

    Canonical means plain Python types (list, float, int, bool, str, message instances), so
    equality, copying and ``json.dumps`` behave predictably whatever the caller passed in
    (tuples, numpy arrays, numpy scalars, or dicts for nested messages).
    """
    item_tp = _list_item(tp)
    if item_tp is not None:
        # fast path: a list of finite Python floats (what tolist() gives; a planned trajectory
        # is thousands of them) is already canonical; copied as every list is
        if item_tp is float and type(value) is list and all(type(v) is float for v in value) \
                and all(map(math.isfinite, value)):
            return list(value)
        # Any sequence (list, tuple, array.array from ROS messages, numpy array) but not text.
        if isinstance(value, (str, bytes, bytearray)) or not (
            isinstance(value, Sequence) or (isinstance(value, np.ndarray) and value.ndim > 0)
        ):
            raise MessageError(path, f"expected a list, got {_describe(value)}")
        return [_convert(item_tp, v, f"{path}[{i}]") for i, v in enumerate(value)]
    if tp is float:
        if isinstance(value, (bool, np.bool_)) or not isinstance(
            value, (int, float, np.integer, np.floating)
        ):
            raise MessageError(path, f"expected a number, got {_describe(value)}")
        number = float(value)
        if not math.isfinite(number):
            raise MessageError(path, f"must be finite, got {number}")
        return number
    if tp is int:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
            raise MessageError(path, f"expected an integer, got {_describe(value)}")
        return int(value)
    if tp is bool:
        if not isinstance(value, (bool, np.bool_)):
            raise MessageError(path, f"expected true/false, got {_describe(value)}")
        return bool(value)
    if tp is str:
        if not isinstance(value, str):
            raise MessageError(path, f"expected a string, got {_describe(value)}")
        problem = _text_problem(value)
        if problem is not None:
            raise MessageError(path, problem)
        return value
    if isinstance(tp, type) and issubclass(tp, _Message):
        if isinstance(value, tp):
            return value
        if isinstance(value, Mapping):
            try:
                return tp.from_dict(value)
            except MessageError as err:
                # Re-root the nested error's path ("Pose.position" -> "X.pose.position").
                prefix = tp.__name__
                if err.field == prefix or err.field.startswith(prefix + "."):
                    raise MessageError(path + err.field[len(prefix):], err.problem) from None
                raise MessageError(path, str(err)) from None
        raise MessageError(path, f"expected {tp.__name__} or a dict, got {_describe(value)}")
    raise TypeError(f"unsupported message field type {tp!r} at {path}")  # programming error


def _encode(value: Any) -> Any:
    if isinstance(value, _Message):
        return value.to_dict()
    if isinstance(value, list):
        return [_encode(v) for v in value]
    return value


@functools.cache
def _schema(cls: type) -> tuple[tuple[str, Any, bool], ...]:
    """(name, resolved type, has_default) per dataclass field; resolved once per class."""
    hints = typing.get_type_hints(cls)
    return tuple(
        (f.name, hints[f.name], f.default is not MISSING or f.default_factory is not MISSING)
        for f in fields(cls)
    )


class _Message:
    """Base of all message dataclasses: validation, dict and JSON conversion.

    Subclasses are ``@dataclass`` classes with typed fields and override ``_validate`` for
    the rules types cannot express (lengths, ranges, enum values, cross-field consistency).
    """

    def __post_init__(self) -> None:
        name = type(self).__name__
        for fname, tp, _ in _schema(type(self)):
            setattr(self, fname, _convert(tp, getattr(self, fname), f"{name}.{fname}"))
        self._validate()

    def _validate(self) -> None:
        """Class-specific checks after type conversion; raise MessageError."""

    def to_dict(self) -> dict[str, Any]:
        """Plain dict of JSON-compatible values (nested messages become dicts)."""
        return {fname: _encode(getattr(self, fname)) for fname, _, _ in _schema(type(self))}

    @classmethod
    def from_dict(cls: type[M], d: Mapping[str, Any]) -> M:
        """Build from a dict; omitted fields take their defaults, unknown keys are errors."""
        name = cls.__name__
        if not isinstance(d, Mapping):
            raise MessageError(name, f"expected a JSON object, got {_describe(d)}")
        schema = _schema(cls)
        known = {fname for fname, _, _ in schema}
        unknown = sorted(str(k) for k in d if k not in known)
        if unknown:
            raise MessageError(
                f"{name}.{unknown[0]}", f"unknown field; {name} has {', '.join(sorted(known))}"
            )
        for fname, _, has_default in schema:
            if not has_default and fname not in d:
                raise MessageError(f"{name}.{fname}", "missing required field")
        return cls(**d)

    def to_json(self) -> str:
        """Compact JSON text; floats are written with ``repr`` so they parse back exactly."""
        return json.dumps(self.to_dict(), allow_nan=False, separators=(",", ":"))

    @classmethod
    def from_json(cls: type[M], s: str | bytes) -> M:
        """Parse JSON text produced by ``to_json`` (or written by hand / another language)."""
        if not isinstance(s, (str, bytes, bytearray)):
            raise MessageError(cls.__name__, f"expected JSON text, got {_describe(s)}")
        try:
            data = json.loads(s)
        except ValueError as err:  # JSONDecodeError and UnicodeDecodeError
            raise MessageError(cls.__name__, f"malformed JSON: {err}") from None
        return cls.from_dict(data)


def _require_len(path: str, values: Sequence[Any], n: int, what: str = "values") -> None:
    if len(values) != n:
        raise MessageError(path, f"expected {n} {what}, got {len(values)}")


def _require_unique_names(path: str, names: Sequence[str]) -> None:
    seen: set[str] = set()
    for i, n in enumerate(names):
        _require_name(f"{path}[{i}]", n)
        if n in seen:
            raise MessageError(path, f"duplicate name '{n}'")
        seen.add(n)
