"""AllowedCollisionMatrix: which pairs of bodies may touch, with MoveIt's semantics.

Bodies are named: robot links by link name, world and attached objects by their id. A planning
group name given to ``allow``/``forbid`` stands for all the links the group moves (its link_names
plus updated links), which is how MTC's ``allowCollisions(object, group_links)`` is used. Names
need not exist yet (MoveIt accepts entries for objects added later), but must be non-empty strings.

Lookup order (``is_allowed``): an explicit pair entry wins; otherwise the default entries of the
two names decide (MoveIt's ``default_entry``): one default → that value, both → allowed only if
both allow (NEVER wins, as in MoveIt), none → not allowed.

The matrix starts with the SRDF's disabled pairs. It notifies its owner (the PlanningScene) on
every change, so the scene recompiles its collision pairs lazily; a copy has no owner until a
scene adopts it.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Callable, Iterable

from interfaces_py.msgs import AllowedCollisionMatrix as AllowedCollisionMatrixMsg

from ..errors import SceneError

if TYPE_CHECKING:  # pragma: no cover
    from ..robot_model.robot_model import RobotModel

Names = str | Iterable[str]


class AllowedCollisionMatrix:
    """Allowed-collision entries between named bodies, plus per-name default entries."""

    __slots__ = ("_model", "_entries", "_defaults", "_listener")

    def __init__(self, model: "RobotModel | None" = None, include_srdf: bool = True) -> None:
        self._model = model
        self._entries: dict[frozenset[str], bool] = {}
        self._defaults: dict[str, bool] = {}
        self._listener: Callable[[], None] | None = None
        if model is not None and include_srdf:
            for pair in model.disabled_collision_pairs:
                if len(pair) == 2:
                    self._entries[frozenset(pair)] = True

    # ------------------------------------------------------------------ names
    def expand(self, names: Names) -> list[str]:
        """Names with planning groups replaced by their links (a link name is never expanded).

        Raises SceneError for an empty or non-string name, so a typo'd call changes nothing.
        """
        if isinstance(names, str):
            names = [names]
        try:
            items = list(names)
        except TypeError:
            raise SceneError(f"collision names must be a string or a list of strings, got {names!r}") from None
        out: list[str] = []
        model = self._model
        for name in items:
            if not isinstance(name, str) or not name:
                raise SceneError(f"invalid collision body name {name!r}: must be a non-empty string")
            if model is not None and not model.has_link(name) and model.has_group(name):
                group = model.group(name)
                out.extend(dict.fromkeys(group.link_names + group.updated_link_names))
            else:
                out.append(name)
        return list(dict.fromkeys(out))

    # ------------------------------------------------------------------ updates
    def set_entry(self, names_a: Names, names_b: Names, allowed: bool) -> None:
        """Set every pair (a, b) with a in names_a and b in names_b (groups expanded)."""
        first = self.expand(names_a)
        second = self.expand(names_b)
        allowed = bool(allowed)
        changed = False
        for a in first:
            for b in second:
                if a == b:
                    continue  # a body is never checked against itself
                key = frozenset((a, b))
                if self._entries.get(key) is not allowed:
                    self._entries[key] = allowed
                    changed = True
        if changed:
            self._notify()

    def allow(self, names_a: Names, names_b: Names | None = None) -> None:
        """Allow collisions between names_a and names_b; with names_b None, between names_a and anything
        (sets their default entries and overrides their explicit entries, like MoveIt's setEntry(name, true)).
        """
        if names_b is None:
            self._set_all(names_a, True)
        else:
            self.set_entry(names_a, names_b, True)

    def forbid(self, names_a: Names, names_b: Names | None = None) -> None:
        """Forbid collisions between names_a and names_b; with names_b None, between names_a and anything
        (including pairs the SRDF disabled)."""
        if names_b is None:
            self._set_all(names_a, False)
        else:
            self.set_entry(names_a, names_b, False)

    def _set_all(self, names: Names, allowed: bool) -> None:
        expanded = self.expand(names)
        for name in expanded:
            self._defaults[name] = allowed
            for key in self._entries:
                if name in key:
                    self._entries[key] = allowed
        if expanded:
            self._notify()

    def set_default(self, names: Names, allowed: bool) -> None:
        """MoveIt's default entry: what a name's pairs are when no explicit entry exists."""
        expanded = self.expand(names)
        for name in expanded:
            self._defaults[name] = bool(allowed)
        if expanded:
            self._notify()

    def remove_default(self, names: Names) -> None:
        expanded = self.expand(names)
        removed = [self._defaults.pop(name) for name in expanded if name in self._defaults]
        if removed:
            self._notify()

    def remove_entry(self, names_a: Names, names_b: Names) -> None:
        """Drop explicit entries so the defaults decide again."""
        first, second = self.expand(names_a), self.expand(names_b)
        removed = [self._entries.pop(frozenset((a, b)), None) for a in first for b in second if a != b]
        if any(r is not None for r in removed):
            self._notify()

    def remove_name(self, name: str) -> None:
        """Forget every entry and default that mentions a name (e.g. a removed object)."""
        keys = [key for key in self._entries if name in key]
        for key in keys:
            del self._entries[key]
        had_default = self._defaults.pop(name, None) is not None
        if keys or had_default:
            self._notify()

    def clear(self) -> None:
        self._entries.clear()
        self._defaults.clear()
        self._notify()

    # ------------------------------------------------------------------ queries
    def get_entry(self, a: str, b: str) -> bool | None:
        """The explicit entry for (a, b), or None when there is none."""
        return self._entries.get(frozenset((a, b)))

    def get_default(self, name: str) -> bool | None:
        return self._defaults.get(name)

    def is_allowed(self, a: str, b: str) -> bool:
        """May a and b collide? Explicit entry first, then the two default entries (both must allow)."""
        value = self._entries.get(frozenset((a, b)))
        if value is not None:
            return value
        da = self._defaults.get(a)
        db = self._defaults.get(b)
        if da is None:
            return bool(db)
        if db is None:
            return da
        return da and db

    @property
    def entry_names(self) -> list[str]:
        """Every name with an explicit entry or a default, sorted."""
        names = {n for key in self._entries for n in key} | set(self._defaults)
        return sorted(names)

    def entries(self) -> dict[frozenset[str], bool]:
        return dict(self._entries)

    def defaults(self) -> dict[str, bool]:
        return dict(self._defaults)

    def __len__(self) -> int:
        return len(self._entries)

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, AllowedCollisionMatrix)
            and self._entries == other._entries
            and self._defaults == other._defaults
        )

    def __repr__(self) -> str:
        allowed = sum(1 for v in self._entries.values() if v)
        return (
            f"AllowedCollisionMatrix({len(self._entries)} entries, {allowed} allowed, "
            f"{len(self._defaults)} defaults)"
        )

    # ------------------------------------------------------------------ copies and messages
    def copy(self) -> "AllowedCollisionMatrix":
        """Independent copy (no owner: changes to it notify nobody until a scene adopts it)."""
        clone = AllowedCollisionMatrix.__new__(AllowedCollisionMatrix)
        clone._model = self._model
        clone._entries = dict(self._entries)
        clone._defaults = dict(self._defaults)
        clone._listener = None
        return clone

    def to_msg(self) -> "AllowedCollisionMatrixMsg":
        """interfaces_py.msgs.AllowedCollisionMatrix (square symmetric matrix over the sorted names).

        A message entry is always explicit on the receiving side (MoveIt reads every matrix cell as
        an entry), so pairs without an explicit entry here are written with their effective value
        (``is_allowed``, defaults applied): the round trip preserves what is allowed.
        Defaults travel in default_entry_names/values.
        """
        names = sorted({n for key in self._entries for n in key})
        values = [[False] * len(names) for _ in names]
        for i, a in enumerate(names):
            for j in range(i + 1, len(names)):
                values[i][j] = values[j][i] = self.is_allowed(a, names[j])
        default_names = sorted(self._defaults)
        return AllowedCollisionMatrixMsg(
            entry_names=names,
            entry_values=values,
            default_entry_names=default_names,
            default_entry_values=[self._defaults[n] for n in default_names],
        )

    @classmethod
    def from_msg(cls, msg: "AllowedCollisionMatrixMsg", model: "RobotModel | None" = None) -> "AllowedCollisionMatrix":
        """Build from a message; every pair of entry_names becomes an explicit entry (as in MoveIt)."""
        acm = cls(model, include_srdf=False)
        names = list(msg.entry_names)
        if len(msg.entry_values) != len(names) or any(len(row) != len(names) for row in msg.entry_values):
            raise SceneError("AllowedCollisionMatrix message: entry_values is not a square matrix over entry_names")
        if len(msg.default_entry_values) != len(msg.default_entry_names):
            raise SceneError("AllowedCollisionMatrix message: default_entry_values and default_entry_names differ in length")
        for name in list(names) + list(msg.default_entry_names):
            if not isinstance(name, str) or not name:
                raise SceneError(f"AllowedCollisionMatrix message: invalid entry name {name!r}")
        for i, a in enumerate(names):
            for j in range(i + 1, len(names)):
                if msg.entry_values[i][j] != msg.entry_values[j][i]:
                    raise SceneError(
                        f"AllowedCollisionMatrix message: entry ('{a}', '{names[j]}') is not symmetric"
                    )
                acm._entries[frozenset((a, names[j]))] = bool(msg.entry_values[i][j])
        for name, value in zip(msg.default_entry_names, msg.default_entry_values):
            acm._defaults[name] = bool(value)
        return acm

    # ------------------------------------------------------------------ owner notification
    def _set_listener(self, listener: Callable[[], None] | None) -> None:
        self._listener = listener

    def _notify(self) -> None:
        if self._listener is not None:
            self._listener()
