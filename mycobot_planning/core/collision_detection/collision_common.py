"""What a collision check answers (MoveIt's collision_detection/collision_common.h): the body
kinds, the security margin, and the contact, collision and distance reports."""
from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["KIND_ORDER", "OBJECT", "ROBOT_ATTACHED", "ROBOT_LINK", "SECURITY_MARGIN", "CollisionReport", "Contact",
           "DistanceReport"]

#: Body kinds, spelled as MoveIt's collision_detection::BodyType names them in contact messages.
ROBOT_LINK = "Robot link"
ROBOT_ATTACHED = "Robot attached"
OBJECT = "Object"
KIND_ORDER = {OBJECT: 0, ROBOT_ATTACHED: 1, ROBOT_LINK: 2}

#: Objects closer than this count as touching (see docs/core.md (mycobot_planning.core.collision_detection.collision) for why it is not 0).
SECURITY_MARGIN = 1e-6

# ---------------------------------------------------------------------------------------------
# Reports
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Contact:
    """Two bodies in contact. ``depth`` is the penetration depth in metres (0.0 when unknown,
    e.g. between two triangle meshes); ``position`` is a world point between the bodies or None."""

    body_a: str
    kind_a: str
    body_b: str
    kind_b: str
    depth: float = 0.0
    position: tuple[float, float, float] | None = None

    def __str__(self) -> str:
        return f"contact between '{self.body_a}' ({self.kind_a}) and '{self.body_b}' ({self.kind_b})"

    def involves(self, name: str) -> bool:
        return name in (self.body_a, self.body_b)

    @property
    def bodies(self) -> frozenset[str]:
        return frozenset((self.body_a, self.body_b))


@dataclass(frozen=True)
class CollisionReport:
    """Result of PlanningScene.check_collision: the verdict and the contacts that make it."""

    collision: bool
    contacts: list[Contact] = field(default_factory=list)

    def __bool__(self) -> bool:
        """``if scene.check_collision(state):`` reads as "if in collision" (a report object is
        otherwise always truthy, which would make that natural line a silent bug)."""
        return self.collision

    def __str__(self) -> str:
        if not self.collision:
            return "no collision"
        return "; ".join(str(c) for c in self.contacts) or "collision"

    def pairs(self) -> set[frozenset[str]]:
        """The colliding body pairs, order-free (handy in tests and logs)."""
        return {c.bodies for c in self.contacts}


@dataclass(frozen=True)
class DistanceReport:
    """Result of PlanningScene.distance over the active (not allowed) pairs.

    ``min_distance`` is negative when bodies penetrate and ``inf`` when no pair was considered.
    ``per_link`` maps each robot body (link or attached object) that takes part in a considered
    pair to (its minimum distance, the body realising it) — what MTC's Clearance cost reads.
    """

    min_distance: float
    body_a: str | None = None
    kind_a: str | None = None
    body_b: str | None = None
    kind_b: str | None = None
    point_a: tuple[float, float, float] | None = None
    point_b: tuple[float, float, float] | None = None
    per_link: dict[str, tuple[float, str]] = field(default_factory=dict)

    def __str__(self) -> str:
        if self.body_a is None:
            return "no collision pairs to measure"
        return (
            f"minimum distance {self.min_distance:.6f} m between '{self.body_a}' ({self.kind_a}) "
            f"and '{self.body_b}' ({self.kind_b})"
        )
