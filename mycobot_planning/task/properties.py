"""Stage properties with MTC's semantics: typed, with defaults, inherited from the parent stage
or initialised from the interface state a stage is working on.

Why a property system instead of plain attributes: MTC tasks are configured top-down. A task
sets ``group``, ``eef``, ``ik_frame`` and ``trajectory_execution_info`` once; containers expose
them to their children (``exposeTo``); children pull them in when the task is initialised
(``configureInitFrom(Stage.PARENT, [...])``), and stages such as ComputeIK read ``target_pose``
from each state a generator hands them (``configureInitFrom(Stage.INTERFACE, [...])``). Where a
value came from decides what wins, as in MTC: a value set by hand beats one inherited from the
parent, which beats one read from the interface; values not set by hand are forgotten when the
task is reset, so a re-planned task inherits afresh.

A value of ``None`` means "undefined" (MTC's empty ``boost::any``): reading an undefined
property gives ``None``; stages that need a value report it at ``init()``.
"""
from __future__ import annotations

import math
from typing import Any, Callable, Iterable, Iterator, Mapping

from .errors import PropertyError, PropertyTypeError, PropertyUndeclared, PropertyUndefined


class PropertyInitializerSource:
    """Where a property may be initialised from (MTC's Stage::PropertyInitializerSource).

    The numbers order the sources by priority: a smaller number wins (MANUAL > CURRENT >
    PARENT > INTERFACE), exactly as in MTC's ``performInitFrom``.
    """

    MANUAL = 0
    CURRENT = 1
    PARENT = 2
    INTERFACE = 4


_UNSET = 1 << 30  # "initialised from nowhere" (MTC uses the largest value)


def _type_name(expected: Any) -> str:
    if expected is None:
        return "any"
    if isinstance(expected, tuple):
        return " or ".join(t.__name__ for t in expected)
    return expected.__name__


def check_value(name: str, value: Any, expected: Any, coerce: Callable[[Any], Any] | None) -> Any:
    """The value in canonical form, or PropertyTypeError (without stage name; callers add it).

    ``float`` properties accept integers (stored as float) but not bools, because a timeout of
    ``5`` is obviously 5.0 s while ``True`` is a mistake.
    """
    if value is None:
        return None
    if coerce is not None:
        try:
            value = coerce(value)
        except PropertyError:
            raise
        except (TypeError, ValueError) as exc:
            raise PropertyTypeError(name, f"cannot use {type(value).__name__} {value!r}: {exc}") from None
    if expected is None:
        return value
    types = expected if isinstance(expected, tuple) else (expected,)
    if float in types and isinstance(value, (int, float)) and not isinstance(value, bool):
        value = float(value)
        if math.isnan(value):
            raise PropertyTypeError(name, "value is NaN")
        return value
    if int in types and isinstance(value, bool) and bool not in types:
        raise PropertyTypeError(name, f"type bool doesn't match declared type {_type_name(expected)}")
    if not isinstance(value, types):
        raise PropertyTypeError(name, f"type {type(value).__name__} doesn't match declared type {_type_name(expected)}")
    return value


class Property:
    """One typed property: a value, a default, and how it is initialised. The methods read as
    MTC's Python Property: ``value()``, ``defaultValue()``, ``description()``, ``defined()``,
    ``setValue`` (current and default), ``setCurrentValue``, ``setDescription``, ``reset``."""

    __slots__ = ("name", "_description", "type", "coerce", "_default", "_value", "initialized_from",
                 "source_flags", "initializer")

    def __init__(self, name: str = "", type_: Any = None, description: str = "", default: Any = None,
                 coerce: Callable[[Any], Any] | None = None) -> None:
        self.name = name
        self._description = description
        self.type = type_
        self.coerce = coerce
        self._default = check_value(name, default, type_, coerce)
        self._value: Any = None
        self.initialized_from = _UNSET
        self.source_flags = 0
        self.initializer: Callable[[Any], Any] | None = None

    # -------------------------------------------------------------- values
    def value(self) -> Any:
        """The current value, else the default, else None (undefined)."""
        return self._value if self._value is not None else self._default

    def defaultValue(self) -> Any:
        return self._default

    def description(self) -> str:
        return self._description

    def setDescription(self, description: str) -> None:
        self._description = str(description)

    def defined(self) -> bool:
        """Whether the property has a value (its own or the default)."""
        return self.value() is not None

    def setValue(self, value: Any) -> None:
        """Set by hand, as current and default value (MTC's setValue): survives reset() and beats
        inherited values."""
        checked = check_value(self.name, value, self.type, self.coerce)
        self._value = checked
        self._default = checked
        self.initialized_from = PropertyInitializerSource.MANUAL if value is not None else _UNSET

    def setCurrentValue(self, value: Any) -> None:
        self._value = check_value(self.name, value, self.type, self.coerce)
        self.initialized_from = PropertyInitializerSource.CURRENT

    def setDefaultValue(self, value: Any) -> None:
        self._default = check_value(self.name, value, self.type, self.coerce)

    def reset(self) -> None:
        """Forget everything but a hand-set value (called when the task is reset)."""
        if self.initialized_from == PropertyInitializerSource.MANUAL:
            return
        self._value = None
        self.initialized_from = _UNSET

    # -------------------------------------------------------------- initialisation
    def initsFrom(self, source: int) -> bool:
        return bool(self.source_flags & source)

    def configureInitFrom(self, source: int, other_name: str | Callable[[Any], Any] | None = None) -> "Property":
        """Initialise from ``source`` (PARENT or INTERFACE), reading ``other_name`` there (default:
        the same name) or calling a function of the source's properties."""
        if self.initializer is not None and self.source_flags and source != self.source_flags:
            raise PropertyError(self.name, "was already configured for initialization from another source")
        if callable(other_name):
            self.initializer = other_name
        else:
            key = self.name if other_name is None else other_name
            self.initializer = lambda other, key=key: _lookup(other, key)
        self.source_flags = source
        return self

    def __repr__(self) -> str:
        return f"Property({self.name!r}, value={self.value()!r})"


def _lookup(other: Any, key: str) -> Any:
    """A property's value in a PropertyMap or a plain dict; LookupError when not declared."""
    if isinstance(other, PropertyMap):
        return other.property(key).value()
    if isinstance(other, Mapping):
        if key not in other:
            raise PropertyUndeclared(key, "not present")
        return other[key]
    raise PropertyUndeclared(key, f"cannot read properties from {type(other).__name__}")


class PropertyMap:
    """The properties of one stage (or solver): declare, set, inherit, expose.

    ``owner_name`` is a callable giving the owner's name for error messages (the stage may be
    renamed after its properties were declared).
    """

    __slots__ = ("_props", "_owner_name")

    def __init__(self, owner_name: Callable[[], str | None] | None = None) -> None:
        self._props: dict[str, Property] = {}
        self._owner_name = owner_name

    def _where(self) -> str | None:
        return self._owner_name() if self._owner_name is not None else None

    def _error(self, exc: PropertyError) -> PropertyError:
        if exc.stage_name is None and self._where():
            return type(exc)(exc.property_name, exc.problem, self._where())
        return exc

    # -------------------------------------------------------------- declaration
    def declare(self, name: str, default: Any = None, description: str = "", type: Any = None,
                coerce: Callable[[Any], Any] | None = None) -> Property:
        """Declare a property (idempotent if the type matches, as in MTC)."""
        existing = self._props.get(name)
        if existing is not None:
            if existing.type is not None and type is not None and existing.type != type:
                raise self._error(PropertyTypeError(
                    name, f"declared again with type {_type_name(type)}, already declared as {_type_name(existing.type)}"))
            return existing
        try:
            prop = Property(name, type, description, default, coerce)
        except PropertyError as exc:
            raise self._error(exc) from None
        self._props[name] = prop
        return prop

    def hasProperty(self, name: str) -> bool:
        return name in self._props

    __contains__ = hasProperty

    def property(self, name: str) -> Property:
        prop = self._props.get(name)
        if prop is None:
            known = ", ".join(sorted(self._props)) or "none"
            raise self._error(PropertyUndeclared(name, f"undeclared (declared: {known})"))
        return prop

    # -------------------------------------------------------------- values
    def get(self, name: str, default: Any = None) -> Any:
        """The value (or default) of a declared property; ``default`` when it is undefined."""
        value = self.property(name).value()
        return default if value is None else value

    def require(self, name: str) -> Any:
        """The value of a property that must be defined (PropertyUndefined otherwise)."""
        value = self.property(name).value()
        if value is None:
            raise self._error(PropertyUndefined(name, "undefined"))
        return value

    def set(self, name: str, value: Any) -> None:
        """Set by hand; an undeclared name is declared with the value's type (MTC's set)."""
        prop = self._props.get(name)
        if prop is None:
            if value is None:
                raise self._error(PropertyUndeclared(name, "trying to set an undeclared property to None"))
            kind = type(value)
            prop = self.declare(name, type=kind if kind in (str, bool, float, int) else None)
        try:
            prop.setValue(value)
        except PropertyError as exc:
            raise self._error(exc) from None

    def setCurrent(self, name: str, value: Any) -> None:
        try:
            self.property(name).setCurrentValue(value)
        except PropertyError as exc:
            raise self._error(exc) from None

    def __getitem__(self, name: str) -> Any:
        return self.property(name).value()

    def __setitem__(self, name: str, value: Any) -> None:
        self.set(name, value)

    def __iter__(self) -> Iterator[str]:
        return iter(self._props)

    def update(self, values: Mapping[str, Any]) -> None:
        """Set several properties at once (MTC's ``PropertyMap.update``): all or none, a bad value
        is refused before anything changes."""
        values = dict(values)
        for name, value in values.items():
            prop = self._props.get(name)
            if prop is not None:
                try:
                    check_value(name, value, prop.type, prop.coerce)
                except PropertyError as exc:
                    raise self._error(exc) from None
        for name, value in values.items():
            self.set(name, value)

    def __len__(self) -> int:
        return len(self._props)

    def items(self) -> Iterator[tuple[str, Any]]:
        return ((name, prop.value()) for name, prop in self._props.items())

    def defined(self) -> dict[str, Any]:
        return {name: prop.value() for name, prop in self._props.items() if prop.value() is not None}

    def reset(self) -> None:
        for prop in self._props.values():
            prop.reset()

    # -------------------------------------------------------------- inheritance
    def configureInitFrom(self, source: int, names: str | Iterable[str] | None = None) -> None:
        """Initialise the named properties (all declared ones when ``names`` is None) from
        ``source``. Names that are not declared here are ignored, as in MTC."""
        if isinstance(names, str):
            names = [names]
        wanted = set(names) if names else None  # MTC: an empty list means every property
        for name, prop in self._props.items():
            if wanted is None or name in wanted:
                try:
                    prop.configureInitFrom(source)
                except PropertyError as exc:
                    raise self._error(exc) from None

    def exposeTo(self, other: "PropertyMap", names: str | Iterable[str],
                 other_names: str | Iterable[str] | None = None) -> None:
        """Declare these properties (type, description, default) in ``other`` too; with
        ``other_names`` under those names there (MTC's ``exposeTo(other, name, other_name)``)."""
        if isinstance(other_names, str):
            other_names = [other_names]
        if isinstance(names, str):
            names = [names]
        names = list(names)
        targets = list(other_names) if other_names is not None else names
        for name, target in zip(names, targets):
            prop = self.property(name)
            other.declare(target, prop.defaultValue(), prop.description(), prop.type, prop.coerce)

    def performInitFrom(self, source: int, other: "PropertyMap | Mapping[str, Any]") -> None:
        """Pull values from ``other`` into every property configured for ``source``, unless a
        higher-priority source already defined it. Raises PropertyTypeError for a value of the
        wrong type (naming the property)."""
        for name, prop in self._props.items():
            if prop.initialized_from < source and prop.defined():
                continue
            if not prop.initsFrom(source) or prop.initializer is None:
                continue
            try:
                value = prop.initializer(other)
            except LookupError:
                continue
            try:
                prop.setCurrentValue(value)
            except PropertyError as exc:
                raise self._error(PropertyTypeError(
                    name, f"value inherited from {'parent' if source == PropertyInitializerSource.PARENT else 'interface'}"
                          f" has the wrong type: {exc.problem}")) from None
            prop.initialized_from = source

    def __repr__(self) -> str:
        return "PropertyMap(" + ", ".join(f"{k}={v!r}" for k, v in self.items()) + ")"


class PropertySetter:
    """MTC's one-line setter of a declared property, as a method: ``setGroup = PropertySetter("group",
    str)`` gives ``stage.setGroup(value)``, which sets the property 'group' of its PropertyMap."""

    def __init__(self, name: str, value_type: Any = Any) -> None:
        def setter(self: Any, value: Any) -> None:  # (this self: the object the setter is called on)
            self._properties.set(name, value)

        setter.__annotations__ = {"value": value_type, "return": None}
        setter.__doc__ = f"Set the property '{name}'."
        self._setter = setter

    def __set_name__(self, owner: type, attribute: str) -> None:
        self._setter.__name__ = attribute
        self._setter.__qualname__ = f"{owner.__qualname__}.{attribute}"

    def __get__(self, obj: Any, owner: type | None = None) -> Callable[..., None]:
        return self._setter.__get__(obj, owner)


class PropertyAttributes:
    """Declared properties read and written as attributes (``stage.group = "arm"``) or through
    ``properties``, as in MTC's Python bindings: the base of the stages and the solvers, which
    keep their PropertyMap in ``_properties``."""

    _properties: PropertyMap

    @property
    def properties(self) -> PropertyMap:
        return self._properties

    def setProperty(self, name: str, value: Any) -> None:
        self._properties.set(name, value)

    setTimeout = PropertySetter("timeout", float)

    def _attribute_owner(self) -> str:
        """How the attribute errors name this object."""
        return type(self).__name__

    def _undeclared_hint(self, name: str) -> str:
        """Appended to the error for setting the undeclared property ``name``."""
        return ""

    def __getattr__(self, name: str) -> Any:
        # Only called when normal lookup fails: expose declared properties as attributes.
        if name.startswith("_"):
            raise AttributeError(name)
        props = self.__dict__.get("_properties")
        if props is not None and name in props:
            return props[name]
        raise AttributeError(f"{self._attribute_owner()} has no attribute or property '{name}'")

    def __setattr__(self, name: str, value: Any) -> None:
        if name.startswith("_") or hasattr(type(self), name):
            object.__setattr__(self, name, value)
            return
        props = self.__dict__.get("_properties")
        if props is not None and name in props:
            props.set(name, value)
            return
        known = ", ".join(sorted(props)) if props is not None else ""
        raise AttributeError(f"{self._attribute_owner()} has no property '{name}' (declared: {known})"
                             f"{self._undeclared_hint(name)}")
