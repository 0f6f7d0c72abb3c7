"""Ports: typed, described inputs and outputs of a node, and the string conversions of
BehaviorTree.CPP (numbers, bools, ``a;b;c`` vectors, NodeStatus, ``json:`` values, poses).

A port's type carries the name BT.CPP's TreeNodesModel shows (``int``, ``double``,
``std::string``, ...) so that Groot2 displays our nodes as it displays C++ ones, and the
conversion a literal XML value goes through. Conversions are strict: ``12abc`` is not an
integer here (BT.CPP's ``from_chars`` would read 12), because a typo in an objective should be
refused when it is loaded, not become a different number.
"""
from __future__ import annotations

import enum
import json
import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Callable

from interfaces_py.msgs import MessageError, Pose
from interfaces_py.pose_conversion import PoseError, pose_message

from .basic_types import NodeStatus, PortDirection, is_allowed_port_name
from .exceptions import LogicError


class ConversionError(ValueError):
    """A value that cannot become the port's type; the message says what was expected."""


_INT = re.compile(r"[+-]?[0-9]+")
_FLOAT = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|[+-]?(?:inf|infinity|nan)", re.I)
_BOOL = {"1": True, "true": True, "TRUE": True, "True": True,
         "0": False, "false": False, "FALSE": False, "False": False}


def split_string(text: str, delimiter: str = ";") -> list[str]:
    """BT.CPP's splitString: ``""`` is no element, a trailing delimiter adds none."""
    parts: list[str] = []
    pos = 0
    while pos < len(text):
        end = text.find(delimiter, pos)
        if end < 0:
            end = len(text)
        parts.append(text[pos:end])
        pos = end + 1
    return parts


def parse_int(text: str, low: int = -(2 ** 31), high: int = 2 ** 31 - 1) -> int:
    if not isinstance(text, str) or not _INT.fullmatch(text):
        raise ConversionError(f"can't convert string [{text}] to integer")
    value = int(text)
    if not low <= value <= high:
        raise ConversionError(f"value out of bound when converting [{text}] to integer")
    return value


def parse_double(text: str) -> float:
    if not isinstance(text, str) or not _FLOAT.fullmatch(text.strip()):
        raise ConversionError(f"can't convert string [{text}] to a number")
    return float(text)


def parse_bool(text: str) -> bool:
    try:
        return _BOOL[text]
    except (KeyError, TypeError):
        raise ConversionError(f"invalid bool conversion of [{text}] (expected true/false, 1/0)") from None


def parse_node_status(text: str) -> NodeStatus:
    try:
        return NodeStatus[text]
    except (KeyError, TypeError):
        raise ConversionError(f"cannot convert [{text}] to NodeStatus "
                              "(IDLE, RUNNING, SUCCESS, FAILURE or SKIPPED)") from None


def number_to_string(value: Any) -> str:
    """A number as BT.CPP's Any turns it into a string (std::to_string: 6 decimals for doubles)."""
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, int):
        return str(value)
    return f"{value:f}"


def cast_int(value: Any, low: int | None = None, high: int | None = None) -> int:
    """A number as an integer, refused when that would lose something (BT.CPP's safe casts)."""
    if isinstance(value, bool):
        value = int(value)
    if isinstance(value, float):
        if not math.isfinite(value) or value != math.floor(value):
            raise ConversionError(f"invalid floating point to integer conversion of {value!r}")
        value = int(value)
    if not isinstance(value, int):
        raise ConversionError(f"no known safe conversion of {type(value).__name__} to an integer")
    if (low is not None and value < low) or (high is not None and value > high):
        raise ConversionError(f"value {value} outside the numerical limits [{low}, {high}]")
    return value


def cast_bool(value: Any) -> bool:
    """Integers 0/1 and any double (non-zero is true) become bools, as in BT.CPP."""
    if isinstance(value, bool):
        return value
    if isinstance(value, int):
        if value in (0, 1):
            return bool(value)
        raise ConversionError(f"implicit casting of {value} to bool is not allowed (only 0 and 1)")
    if isinstance(value, float):
        return value != 0.0
    raise ConversionError(f"no known safe conversion of {type(value).__name__} to bool")


@dataclass(frozen=True, eq=False)
class PortType:
    """A port's type: its BT.CPP name, how a string becomes a value, how a blackboard value is cast.

    ``strongly_typed`` is False for BT.CPP's AnyTypeAllowed and BT::Any: such ports take any
    value and keep strings as strings.
    """

    name: str
    parse: Callable[[str], Any] | None = None
    cast: Callable[[Any], Any] | None = None
    strongly_typed: bool = True
    python_types: tuple[type, ...] = ()

    def from_string(self, text: str) -> Any:
        """A literal (from XML, a default or a string blackboard entry) as a value of this type.

        ``json:`` values are parsed as JSON first, as BT.CPP does for types with a JSON form.
        """
        if self.parse is None:
            return text
        if isinstance(text, str) and text.startswith("json:"):
            try:
                decoded = json.loads(text[5:])
            except ValueError as exc:
                raise ConversionError(f"invalid JSON after 'json:': {exc}") from None
            return self.convert(decoded)
        return self.parse(text)

    def convert(self, value: Any) -> Any:
        """A blackboard value read through a port of this type (strings are parsed)."""
        if isinstance(value, str) and self.parse is not None:
            return self.from_string(value)
        if self.cast is not None:
            return self.cast(value)
        if self.python_types and not isinstance(value, self.python_types):
            raise ConversionError(f"expected {self.name}, got {type(value).__name__}")
        return value

    def __repr__(self) -> str:
        return f"PortType({self.name!r})"


def _cast_string(value: Any) -> str:
    if isinstance(value, str):
        return value
    if isinstance(value, (int, float)):
        return number_to_string(value)
    raise ConversionError(f"no known safe conversion of {type(value).__name__} to std::string")


def _cast_double(value: Any) -> float:
    if isinstance(value, (int, float)):
        return float(value)
    raise ConversionError(f"no known safe conversion of {type(value).__name__} to double")


def _cast_status(value: Any) -> NodeStatus:
    if isinstance(value, NodeStatus):
        return value
    if isinstance(value, int) and not isinstance(value, bool) and 0 <= value <= 4:
        return NodeStatus(value)
    raise ConversionError(f"no known safe conversion of {value!r} to NodeStatus")


def _vector(element: PortType, name: str) -> PortType:
    def parse(text: str) -> list:
        return [element.from_string(part) for part in split_string(text)]

    def cast(value: Any) -> list:
        if isinstance(value, (str, bytes)) or not isinstance(value, Iterable):
            raise ConversionError(f"expected {name}, got {type(value).__name__}")
        return [element.convert(v) for v in value]

    return PortType(name, parse, cast)


ANY = PortType("BT::AnyTypeAllowed", strongly_typed=False)
ANY_VALUE = PortType("BT::Any", strongly_typed=False)
STRING = PortType("std::string", parse=lambda text: text, cast=_cast_string)
INT = PortType("int", parse=parse_int, cast=lambda v: cast_int(v, -(2 ** 31), 2 ** 31 - 1))
UINT = PortType("unsigned int", parse=lambda text: parse_int(text, 0, 2 ** 32 - 1),
                cast=lambda v: cast_int(v, 0, 2 ** 32 - 1))
INT64 = PortType("int64_t", parse=lambda text: parse_int(text, -(2 ** 63), 2 ** 63 - 1),
                 cast=lambda v: cast_int(v, -(2 ** 63), 2 ** 63 - 1))
DOUBLE = PortType("double", parse=parse_double, cast=_cast_double)
BOOL = PortType("bool", parse=parse_bool, cast=cast_bool)
NODE_STATUS = PortType("BT::NodeStatus", parse=parse_node_status, cast=_cast_status)
VECTOR_INT = _vector(INT, "std::vector<int>")
VECTOR_DOUBLE = _vector(DOUBLE, "std::vector<double>")
VECTOR_BOOL = _vector(BOOL, "std::vector<bool>")
VECTOR_STRING = _vector(STRING, "std::vector<std::string>")


@dataclass
class PoseStamped:
    """A pose in a named frame (geometry_msgs/PoseStamped without the time stamp)."""

    frame_id: str = ""
    pose: Pose = field(default_factory=Pose)

    def to_dict(self) -> dict[str, Any]:
        return {"header": {"frame_id": self.frame_id}, "pose": self.pose.to_dict()}


def _numbers(text: str, what: str) -> list[float]:
    return [parse_double(part.strip()) for part in split_string(text)] if text else []


def _pose_from_numbers(values: Sequence[float], what: str) -> Pose:
    if len(values) not in (6, 7):
        raise ConversionError(f"{what} needs 7 numbers x;y;z;qx;qy;qz;qw or 6 numbers "
                              f"x;y;z;roll;pitch;yaw, got {len(values)}")
    try:
        return pose_message(list(values), what)
    except (PoseError, MessageError) as exc:
        raise ConversionError(str(exc)) from None


def _cast_pose(value: Any) -> Pose:
    if isinstance(value, Pose):
        return value
    if isinstance(value, PoseStamped):
        return value.pose
    if isinstance(value, Mapping) and "pose" in value:
        value = value["pose"]
    try:
        return pose_message(value, "pose")
    except (PoseError, MessageError, TypeError, ValueError) as exc:
        raise ConversionError(str(exc)) from None


def _parse_pose_stamped(text: str) -> PoseStamped:
    parts = split_string(text)
    frame = ""
    if parts and not _FLOAT.fullmatch(parts[0].strip()):
        frame, parts = parts[0].strip(), parts[1:]
    numbers = [parse_double(p.strip()) for p in parts]
    return PoseStamped(frame, _pose_from_numbers(numbers, "pose"))


def _cast_pose_stamped(value: Any) -> PoseStamped:
    if isinstance(value, PoseStamped):
        return value
    if isinstance(value, Mapping) and "pose" in value:
        header = value.get("header") or {}
        frame = header.get("frame_id", "") if isinstance(header, Mapping) else ""
        return PoseStamped(str(frame), _cast_pose(value["pose"]))
    return PoseStamped("", _cast_pose(value))


POSE = PortType("geometry_msgs::msg::Pose", parse=lambda text: _pose_from_numbers(_numbers(text, "pose"), "pose"),
                cast=_cast_pose)
POSE_STAMPED = PortType("geometry_msgs::msg::PoseStamped", parse=_parse_pose_stamped, cast=_cast_pose_stamped)


def queue_type(element: PortType) -> PortType:
    """The ``SharedQueue<T>`` of BT.CPP's Loop nodes: ``a;b;c`` or a list, consumed front first."""
    vector = _vector(element, f"std::shared_ptr<std::deque<{element.name}>>")
    return vector


QUEUE_INT = queue_type(INT)
QUEUE_DOUBLE = queue_type(DOUBLE)
QUEUE_BOOL = queue_type(BOOL)
QUEUE_STRING = queue_type(STRING)


def enum_type(enum_cls: type) -> PortType:
    """A port taking the members of an IntEnum by name (or their integer values)."""
    def parse(text: str) -> Any:
        if text in enum_cls.__members__:
            return enum_cls.__members__[text]
        try:
            return enum_cls(parse_int(text))
        except ValueError:
            raise ConversionError(f"[{text}] is not a {enum_cls.__name__} "
                                  f"({', '.join(enum_cls.__members__)})") from None

    def cast(value: Any) -> Any:
        try:
            return enum_cls(cast_int(value))
        except ValueError:
            raise ConversionError(f"{value!r} is not a {enum_cls.__name__}") from None

    return PortType(enum_cls.__name__, parse, cast)


def type_of_value(value: Any) -> PortType:
    """The type a blackboard entry takes from the first value written to it (BT.CPP's
    ``set<T>``): bools, integers and doubles lock their entry's type; strings do not."""
    if isinstance(value, bool):
        return BOOL
    if isinstance(value, int):
        return INT64
    if isinstance(value, float):
        return DOUBLE
    return ANY


#: the default of a port that has none
NO_DEFAULT: Any = object()
_NO_DEFAULT = NO_DEFAULT


@dataclass(eq=False)
class PortInfo:
    """One port of a node model: name, direction, type, default and description.

    ``required`` defaults to "an input without a default"; an optional input without a default
    (a port the node reads only if it is given) says ``required=False``.
    """

    name: str
    direction: PortDirection = PortDirection.INPUT
    type: PortType = ANY
    default: Any = _NO_DEFAULT
    description: str = ""
    required: bool | None = None

    def __post_init__(self) -> None:
        if not is_allowed_port_name(self.name):
            raise LogicError(f"the name of a port must start with a letter and must not be 'name', "
                             f"'ID' or a reserved attribute: [{self.name}]")
        if self.has_default and self.direction is PortDirection.OUTPUT:
            text = self.default_string
            if not (len(text) >= 3 and text[0] == "{" and text[-1] == "}"):
                raise LogicError(f"output port [{self.name}]: its default can only be a blackboard "
                                 f"entry, i.e. '{{{self.name}}}'")

    @property
    def has_default(self) -> bool:
        return self.default is not _NO_DEFAULT

    @property
    def default_string(self) -> str:
        """The default as the XML would write it ("" when there is none)."""
        text = self.default_text()
        if text is not None:
            return text
        return str(self.default) if self.has_default else ""

    def default_text(self) -> str | None:
        """The default as text that converts back to the same value (None when there is no
        default or it has no such text: then ``get_input`` hands out the object itself)."""
        if not self.has_default:
            return None
        return _literal(self.default)

    @property
    def is_required(self) -> bool:
        if self.required is not None:
            return self.required
        return self.direction is not PortDirection.OUTPUT and not self.has_default


def _literal(value: Any) -> str | None:
    if isinstance(value, str):
        return value
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, enum.Enum):
        return value.name
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, Pose):
        return ";".join(repr(float(v)) for v in [*value.position, *value.orientation])
    if isinstance(value, PoseStamped):
        pose = _literal(value.pose)
        return f"{value.frame_id};{pose}" if value.frame_id else pose
    if isinstance(value, (list, tuple)):
        parts = [_literal(v) for v in value]
        if all(p is not None and ";" not in p for p in parts):
            return ";".join(parts)
    return None


def input_port(name: str, type: PortType = ANY, default: Any = _NO_DEFAULT, description: str = "",
               required: bool | None = None) -> PortInfo:
    """BT.CPP's InputPort<T>(name, [default,] description)."""
    return PortInfo(name, PortDirection.INPUT, type, default, description, required)


def output_port(name: str, type: PortType = ANY, default: Any = _NO_DEFAULT, description: str = "") -> PortInfo:
    """BT.CPP's OutputPort<T>(name, [default "{key}",] description)."""
    return PortInfo(name, PortDirection.OUTPUT, type, default, description)


def bidirectional_port(name: str, type: PortType = ANY, default: Any = _NO_DEFAULT, description: str = "",
                       required: bool | None = None) -> PortInfo:
    """BT.CPP's BidirectionalPort<T>(name, [default,] description)."""
    return PortInfo(name, PortDirection.INOUT, type, default, description, required)


PortsList = dict  # name -> PortInfo, in declaration order


def ports_list(ports: Iterable[PortInfo] | Mapping[str, PortInfo] | None) -> dict[str, PortInfo]:
    """Ports given as a list (or a dict) as the name -> PortInfo dict the factory keeps."""
    if ports is None:
        return {}
    if isinstance(ports, Mapping):
        ports = ports.values()
    out: dict[str, PortInfo] = {}
    for port in ports:
        if not isinstance(port, PortInfo):
            raise LogicError(f"a port must be a PortInfo (input_port(...), output_port(...)), got {port!r}")
        if port.name in out:
            raise LogicError(f"port [{port.name}] declared twice")
        out[port.name] = port
    return out


def is_blackboard_pointer(text: str) -> bool:
    """``{key}`` (spaces around allowed, as BT.CPP strips them)."""
    stripped = text.strip(" ")
    return len(stripped) >= 3 and stripped[0] == "{" and stripped[-1] == "}"


def strip_blackboard_pointer(text: str) -> str:
    """The key of ``{key}``; "" when the text is not a blackboard pointer."""
    stripped = text.strip(" ")
    if len(stripped) >= 3 and stripped[0] == "{" and stripped[-1] == "}":
        return stripped[1:-1]
    return ""


def remapped_key(port_name: str, remapped: str) -> str | None:
    """The blackboard key a port's XML value points to (``{=}`` and ``=`` mean the port's own
    name), None when the value is a literal."""
    if remapped == "{=}" or remapped == "=":
        return port_name
    key = strip_blackboard_pointer(remapped)
    return key or None
