"""The blackboard: typed entries shared by the nodes of a tree, one per (sub)tree, with
BehaviorTree.CPP's scoping — a SubTree's blackboard reaches its parent's entries only through
the SubTree's port remapping, ``_autoremap`` or a ``@key`` (the root blackboard).

Entries keep a type: the type of the port that first declared them when the tree was loaded,
or the type of the first number or bool written to them (BT.CPP's rule "once declared, the type
of a port shall not change"). Strings written to a typed entry are converted, numbers are cast
only when nothing is lost.
"""
from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from typing import Any

from .exceptions import BehaviorTreeRuntimeError, LogicError, PortError
from .ports import ANY, STRING, ConversionError, PortType, type_of_value


class _Empty:
    """The value of an entry that was declared (by a port) but never written."""

    __slots__ = ()

    def __repr__(self) -> str:
        return "<empty>"

    def __bool__(self) -> bool:
        return False


EMPTY: Any = _Empty()


class Entry:
    """One blackboard entry: value, type, and how many times it was written (``sequence_id``)."""

    __slots__ = ("value", "type", "sequence_id", "stamp")

    def __init__(self, port_type: PortType = ANY, value: Any = EMPTY):
        self.value = value
        self.type = port_type
        self.sequence_id = 0
        self.stamp = 0.0

    def touch(self) -> None:
        self.sequence_id += 1
        self.stamp = time.monotonic()

    def __repr__(self) -> str:
        return f"Entry({self.value!r}, {self.type.name})"


def coerce_for_entry(port_type: PortType, value: Any, key: str) -> Any:
    """``value`` as the entry's type, or a PortError saying the type may not change."""
    try:
        if port_type.name == STRING.name and not isinstance(value, str):
            raise ConversionError(f"a {type(value).__name__} is not a string")
        return port_type.convert(value)
    except ConversionError as exc:
        raise PortError(f"blackboard entry [{key}]: once declared, the type of an entry shall not "
                        f"change: it is {port_type.name} and {value!r} does not convert ({exc})") from None


class Blackboard:
    """Key/value storage of one (sub)tree. Create with ``Blackboard.create(parent)``."""

    def __init__(self, parent: Blackboard | None = None):
        self._storage: dict[str, Entry] = {}
        self._parent = parent
        self._internal_to_external: dict[str, str] = {}
        self._autoremapping = False
        self._lock = threading.RLock()

    @classmethod
    def create(cls, parent: Blackboard | None = None) -> Blackboard:
        return cls(parent)

    # -- scoping ----------------------------------------------------------------------------

    @property
    def parent(self) -> Blackboard | None:
        return self._parent

    def enable_auto_remapping(self, remapping: bool) -> None:
        """Reach the parent's entries of the same name (SubTree ``_autoremap="true"``);
        keys starting with ``_`` stay private."""
        self._autoremapping = bool(remapping)

    def add_subtree_remapping(self, internal: str, external: str) -> None:
        """Make ``internal`` here the parent's entry ``external`` (a SubTree port remapping)."""
        self._internal_to_external[internal] = external

    @property
    def remappings(self) -> dict[str, str]:
        return dict(self._internal_to_external)

    def root_blackboard(self) -> Blackboard:
        bb = self
        while bb._parent is not None:
            bb = bb._parent
        return bb

    # -- entries ----------------------------------------------------------------------------

    def get_entry(self, key: str) -> Entry | None:
        """The entry ``key`` names here (following ``@``, remapping and autoremapping), or None."""
        if key[:1] == "@":
            return self.root_blackboard().get_entry(key[1:])
        entry = self._storage.get(key)
        if entry is not None:
            return entry
        parent = self._parent
        if parent is not None:
            external = self._internal_to_external.get(key)
            if external is not None:
                return parent.get_entry(external)
            if self._autoremapping and key[:1] != "_":
                return parent.get_entry(key)
        return None

    def create_entry(self, key: str, port_type: PortType = ANY) -> Entry:
        """The entry ``key`` names, created (empty, typed) where the remapping leads if missing.

        Raises LogicError if the entry exists with another strong type.
        """
        if key[:1] == "@":
            if "@" in key[1:]:
                raise LogicError(f"character '@' used multiple times in the key [{key}]")
            return self.root_blackboard()._create_entry_impl(key[1:], port_type)
        return self._create_entry_impl(key, port_type)

    def _create_entry_impl(self, key: str, port_type: PortType) -> Entry:
        with self._lock:
            entry = self._storage.get(key)
            if entry is not None:
                previous = entry.type
                if (previous.strongly_typed and port_type.strongly_typed and previous.name != port_type.name):
                    raise LogicError(f"blackboard entry [{key}]: once declared, the type of a port shall not "
                                     f"change. Previously declared type [{previous.name}], current type "
                                     f"[{port_type.name}]")
                return entry
            external = self._internal_to_external.get(key)
            if external is not None:
                if self._parent is None:
                    raise LogicError("missing parent blackboard")
                return self._parent.create_entry(external, port_type)
            if self._autoremapping and key[:1] != "_":
                if self._parent is None:
                    raise LogicError("missing parent blackboard")
                return self._parent.create_entry(key, port_type)
            entry = Entry(port_type)
            self._storage[key] = entry
            return entry

    def entry_type(self, key: str) -> PortType | None:
        entry = self.get_entry(key)
        return None if entry is None else entry.type

    # -- values -----------------------------------------------------------------------------

    def get(self, key: str, default: Any = EMPTY) -> Any:
        """The value of ``key``; ``default`` if given and the entry is missing or empty."""
        entry = self.get_entry(key)
        if entry is None or entry.value is EMPTY:
            if default is not EMPTY:
                return default
            what = "missing key" if entry is None else "entry that was never written"
            raise BehaviorTreeRuntimeError(f"blackboard: {what} [{key}]")
        return entry.value

    def set(self, key: str, value: Any) -> None:
        """Write ``key`` (creating it where the remapping leads); a typed entry converts strings
        and casts numbers, and refuses values of another type."""
        if key[:1] == "@":
            self.root_blackboard().set(key[1:], value)
            return
        with self._lock:
            entry = self._storage.get(key)
            if entry is None:
                existing = self.get_entry(key)
                if existing is None:
                    entry = self.create_entry(key, ANY if isinstance(value, str) else type_of_value(value))
                    entry.value = value
                    entry.touch()
                    return
                entry = existing
            self.assign(entry, key, value)

    @staticmethod
    def assign(entry: Entry, key: str, value: Any) -> None:
        """Write an entry found before (``set`` without the lookup)."""
        port_type = entry.type
        if port_type.strongly_typed:
            value = coerce_for_entry(port_type, value, key)
        elif not isinstance(value, str):
            inferred = type_of_value(value)
            if inferred.strongly_typed:
                entry.type = inferred
        entry.value = value
        entry.touch()

    def unset(self, key: str) -> None:
        """Remove ``key`` from this blackboard's own storage (BT.CPP: remapped keys are not
        followed)."""
        with self._lock:
            self._storage.pop(key, None)

    def __contains__(self, key: str) -> bool:
        entry = self.get_entry(key)
        return entry is not None and entry.value is not EMPTY

    def keys(self) -> list[str]:
        """The keys stored here (not those reached through remapping)."""
        return list(self._storage)

    def items(self) -> Iterator[tuple[str, Any]]:
        """(key, value) of the entries stored here that hold a value."""
        for key, entry in list(self._storage.items()):
            if entry.value is not EMPTY:
                yield key, entry.value

    def clone_into(self, other: Blackboard) -> None:
        """Copy this blackboard's own entries into ``other`` (BT.CPP's cloneInto)."""
        with self._lock:
            other._storage = {}
            for key, entry in self._storage.items():
                copy = Entry(entry.type, entry.value)
                copy.sequence_id = entry.sequence_id
                other._storage[key] = copy

    def __repr__(self) -> str:
        return f"Blackboard({dict(self.items())!r})"
