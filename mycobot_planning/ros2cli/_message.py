"""The parts of rosidl_runtime_py that the verbs need (it is not published on PyPI).

Same behaviour as rosidl_runtime_py on Jazzy, so that `ros2 topic echo` prints the same YAML and
`ros2 topic pub` / `ros2 service call` accept the same YAML as with the real ros2cli:
- `get_message`, `get_service`, `get_interface`: type lookup from 'pkg/msg/Name' (or 'pkg/Name').
- `message_to_ordereddict`, `message_to_yaml`, `message_to_csv`: field order from the .msg file,
  strings/arrays truncated to `truncate_length`, `no_arr` / `no_str` abbreviations.
- `set_message_fields`: fill a message from a dict, nested messages and arrays of messages
  included, with the 'auto' Header and 'now' Time keywords of `ros2 topic pub`.
"""
from __future__ import annotations

import array
import copy
import importlib
import sys
from collections import OrderedDict
from functools import partial
from typing import Any, Callable

import yaml

# ---------------------------------------------------------------------------------------------
# Type lookup


def get_interface(identifier: str) -> Any:
    """The Python class of 'pkg/msg/Name', 'pkg/srv/Name' or 'pkg/action/Name'.

    Raises ValueError for a malformed name, ModuleNotFoundError / AttributeError for an unknown one
    (the exceptions ros2cli catches to say "The passed message type is invalid").
    """
    parts = identifier.split("/")
    if len(parts) != 3 or not all(parts):
        raise ValueError(f"Expected the full name of an interface, e.g. 'std_msgs/msg/String', got '{identifier}'")
    module = importlib.import_module(".".join(parts[:-1]))
    return getattr(module, parts[-1])


def _full_name(identifier: str, kind: str) -> str:
    parts = identifier.split("/")
    if len(parts) == 2:
        parts = [parts[0], kind, parts[1]]
    return "/".join(parts)


def get_message(identifier: str) -> Any:
    interface = get_interface(_full_name(identifier, "msg"))
    if not is_message(interface):
        raise ValueError(f"Expected a message type, got '{identifier}'")
    return interface


def get_service(identifier: str) -> Any:
    interface = get_interface(_full_name(identifier, "srv"))
    if not is_service(interface):
        raise ValueError(f"Expected a service type, got '{identifier}'")
    return interface


def is_message(interface: Any) -> bool:
    return hasattr(interface, "get_fields_and_field_types") and hasattr(interface, "SLOT_TYPES")


def is_service(interface: Any) -> bool:
    return hasattr(interface, "Request") and hasattr(interface, "Response")


def import_message_from_namespaced_type(namespaced_type: Any) -> Any:
    module = importlib.import_module(".".join(namespaced_type.namespaces))
    return getattr(module, namespaced_type.name)


# ---------------------------------------------------------------------------------------------
# Message -> YAML / dict / CSV


def _type_label(value_type: Any) -> str:
    from rosidl_parser import definition

    if isinstance(value_type, definition.BasicType):
        return value_type.typename
    if isinstance(value_type, definition.AbstractString):
        return "string"
    if isinstance(value_type, definition.AbstractWString):
        return "wstring"
    if isinstance(value_type, definition.NamedType):
        return value_type.name
    if isinstance(value_type, definition.NamespacedType):
        return "/".join(value_type.namespaced_name())
    return "unknown"


def _abbreviate_array_info(value: Any, field_type: Any) -> str:
    from rosidl_parser import definition

    label = _type_label(field_type.value_type)
    if isinstance(field_type, definition.Array):
        return f"<array type: {label}[{field_type.size}]>"
    if isinstance(field_type, definition.BoundedSequence):
        return f"<sequence type: {label}[{field_type.maximum_size}], length: {len(value)}>"
    if isinstance(field_type, definition.UnboundedSequence):
        return f"<sequence type: {label}, length: {len(value)}>"
    return "unknown"


def message_to_ordereddict(
    msg: Any, *, truncate_length: int | None = None, no_arr: bool = False, no_str: bool = False
) -> OrderedDict:
    """Fields in .msg order (a plain dict would lose nothing today, but ros2cli keeps OrderedDict)."""
    result: OrderedDict = OrderedDict()
    for field_name, field_type in zip(msg.get_fields_and_field_types().keys(), msg.SLOT_TYPES):
        value = getattr(msg, field_name, None)
        result[field_name] = _convert_value(
            value, field_type=field_type, truncate_length=truncate_length, no_arr=no_arr, no_str=no_str
        )
    return result


def _convert_value(value: Any, *, field_type: Any = None, truncate_length: int | None = None,
                   no_arr: bool = False, no_str: bool = False) -> Any:
    import numpy

    if isinstance(value, bytes):
        if truncate_length is not None and len(value) > truncate_length:
            value = "".join(chr(c) for c in value[:truncate_length]) + "..."
        else:
            value = "".join(chr(c) for c in value)
    elif isinstance(value, str):
        if no_str:
            value = f"<string length: <{len(value)}>>"
        elif truncate_length is not None and len(value) > truncate_length:
            value = value[:truncate_length] + "..."
    elif isinstance(value, (list, tuple, array.array, numpy.ndarray)):
        container = tuple if isinstance(value, tuple) else list
        if no_arr and field_type is not None:
            value = _abbreviate_array_info(value, field_type)
        elif truncate_length is not None and len(value) > truncate_length:
            value = container(
                [_convert_value(v, truncate_length=truncate_length, no_arr=no_arr, no_str=no_str)
                 for v in value[:truncate_length]] + ["..."]
            )
        else:
            value = container(
                [_convert_value(v, truncate_length=truncate_length, no_arr=no_arr, no_str=no_str) for v in value]
            )
    elif isinstance(value, dict):
        value = {
            _convert_value(k): _convert_value(v, truncate_length=truncate_length, no_arr=no_arr, no_str=no_str)
            for k, v in value.items()
        }
    elif isinstance(value, numpy.number):
        value = value.item()
    elif not isinstance(value, (bool, float, int)):
        value = message_to_ordereddict(value, truncate_length=truncate_length, no_arr=no_arr, no_str=no_str)
    return value


class _OrderedDumper(yaml.SafeDumper):
    """Dumps OrderedDict as a plain mapping in insertion order (ros2cli's representer)."""


def _represent_ordereddict(dumper: yaml.Dumper, data: OrderedDict) -> yaml.nodes.MappingNode:
    items = [(dumper.represent_data(k), dumper.represent_data(v)) for k, v in data.items()]
    return yaml.nodes.MappingNode("tag:yaml.org,2002:map", items)


_OrderedDumper.add_representer(OrderedDict, _represent_ordereddict)


def message_to_yaml(msg: Any, *, truncate_length: int | None = None, no_arr: bool = False,
                    no_str: bool = False, flow_style: bool = False) -> str:
    return yaml.dump(
        message_to_ordereddict(msg, truncate_length=truncate_length, no_arr=no_arr, no_str=no_str),
        Dumper=_OrderedDumper, allow_unicode=True, width=sys.maxsize, default_flow_style=flow_style,
    )


def message_to_csv(msg: Any, *, truncate_length: int | None = None, no_arr: bool = False,
                   no_str: bool = False) -> str:
    import numpy

    def to_string(val: Any, field_type: Any = None) -> str:
        if isinstance(val, (list, tuple, array.array, numpy.ndarray)):
            if no_arr and field_type is not None:
                return _abbreviate_array_info(val, field_type)
            parts = []
            for i, v in enumerate(val):
                if truncate_length is not None and i >= truncate_length:
                    parts.append("...")
                    break
                parts.append(to_string(v))
            return ",".join(parts)
        if isinstance(val, (bool, bytes, float, int, str, numpy.number)):
            if no_str and isinstance(val, str):
                val = f"<string length: <{len(val)}>>"
            elif isinstance(val, (bytes, str)) and truncate_length is not None and len(val) > truncate_length:
                val = val[:truncate_length] + (b"..." if isinstance(val, bytes) else "...")
            return str(val)
        return message_to_csv(val, truncate_length=truncate_length, no_arr=no_arr, no_str=no_str)

    return ",".join(
        to_string(getattr(msg, name), field_type)
        for name, field_type in zip(msg.get_fields_and_field_types().keys(), msg.SLOT_TYPES)
    )


# ---------------------------------------------------------------------------------------------
# dict -> message


def set_message_fields(msg: Any, values: Any, expand_header_auto: bool = False,
                       expand_time_now: bool = False) -> list[Callable[[Any], None]]:
    """Set `msg`'s fields from `values` (nested dicts and lists, as parsed from YAML).

    Returns setters for the 'auto' Header stamps and 'now' Time fields (when the expansions are
    enabled) so that the caller can stamp them with the current time at each publish.
    Raises AttributeError for an unknown field and TypeError / ValueError for a value that does not
    fit its field.
    """
    import numpy
    from rosidl_parser.definition import AbstractNestedType, NamespacedType

    timestamp_fields: list[Callable[[Any], None]] = []

    def fill(target: Any, field_values: Any) -> None:
        field_values = copy.deepcopy(field_values)
        try:
            items = field_values.items()
        except AttributeError:
            raise TypeError(
                f"Value '{field_values}' is expected to be a dictionary but is a {type(field_values).__name__}"
            ) from None
        slot_types = dict(zip(target.get_fields_and_field_types().keys(), target.SLOT_TYPES))
        for field_name, field_value in items:
            if field_name not in slot_types:
                raise AttributeError(f"'{type(target).__name__}' object has no attribute '{field_name}'")
            field = getattr(target, field_name)
            field_type = type(field)
            qualified = f"{field_type.__module__}.{field_type.__name__}"
            if field_type is array.array:
                value = field_type(field.typecode, field_value)
            elif field_type is numpy.ndarray:
                value = numpy.array(field_value, dtype=field.dtype)
            elif type(field_value) is field_type:
                value = field_value
            elif qualified == "std_msgs.msg._header.Header" and field_value == "auto" and expand_header_auto:
                timestamp_fields.append(partial(setattr, field, "stamp"))
                continue
            elif qualified == "builtin_interfaces.msg._time.Time" and field_value == "now" and expand_time_now:
                timestamp_fields.append(partial(setattr, target, field_name))
                continue
            else:
                try:
                    value = field_type(field_value)
                except TypeError:
                    value = field_type()
                    fill(value, field_value)
            rosidl_type = slot_types[field_name]
            if isinstance(rosidl_type, AbstractNestedType) and isinstance(rosidl_type.value_type, NamespacedType):
                element_type = import_message_from_namespaced_type(rosidl_type.value_type)
                for index in range(len(value)):
                    element = element_type()
                    fill(element, value[index])
                    value[index] = element
            setattr(target, field_name, value)

    fill(msg, values)
    return timestamp_fields


def populate_from_yaml(msg: Any, text: str) -> str | None:
    """Fill ``msg`` from the YAML ``text`` (empty or null: defaults), as `ros2 service call` and
    `ros2 action send_goal` do; their error sentence, or None when it worked."""
    try:
        values = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        return f"Failed to populate field: {exc}"
    try:
        set_message_fields(msg, values if values is not None else {})
    except Exception as exc:
        return f"Failed to populate field: {exc}"
    return None
