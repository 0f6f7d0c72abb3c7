"""The self-collision matrix as MoveIt Setup Assistant computes it: which link pairs never need a check.

A careless SRDF leaves pairs enabled that touch in every state (overlapping fixed links) and every
plan then fails; a careful one disables pairs that can never meet, which also makes each check
cheaper. The Setup Assistant's rule, which MoveIt users know by its reasons, is rebuilt here:

- Adjacent: links joined by a joint, directly or through links without collision geometry;
- Default: in contact in the default state (all zeros, clipped to the limits);
- Always: in contact in at least ``always_fraction`` of the first ``always_samples`` random states;
- Never: in contact in none of ``samples`` random states (uniform within the joint limits).

Every other pair stays enabled. The sampling runs Pinocchio's computeCollisions (Coal underneath,
in C++) over only the pairs still undecided, so a pair drops out of the loop as soon as it is seen
in contact; the Panda with its meshes takes about 10 s at 10,000 states here.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from itertools import combinations
from typing import Callable

import numpy as np
import pinocchio as pin

from ..robot_model.robot_model import RobotModel

ADJACENT, DEFAULT, ALWAYS, NEVER = "Adjacent", "Default", "Always", "Never"
DEFAULT_SAMPLES = 10_000
ALWAYS_SAMPLES = 100
ALWAYS_FRACTION = 0.95

#: Called now and then while sampling: (states sampled, states in all, pairs still undecided).
Progress = Callable[[int, int, int], None]


@dataclass
class CollisionMatrix:
    """Disabled link pairs with their reason; `enabled` the pairs that must still be checked."""

    disabled: dict[tuple[str, str], str] = field(default_factory=dict)
    enabled: list[tuple[str, str]] = field(default_factory=list)
    samples: int = 0
    seconds: float = 0.0

    def count(self, reason: str) -> int:
        return sum(1 for r in self.disabled.values() if r == reason)


def _pair(a: str, b: str) -> tuple[str, str]:
    return (a, b) if a <= b else (b, a)


def adjacent_pairs(model: RobotModel, links: list[str]) -> set[tuple[str, str]]:
    """Links with geometry joined by a joint, or through a run of links without geometry."""
    with_geometry = set(links)
    neighbours: dict[str, set[str]] = {link: set() for link in model.link_names}
    for name in model.joint_names:
        joint = model.joint(name)
        neighbours[joint.parent_link].add(joint.child_link)
        neighbours[joint.child_link].add(joint.parent_link)
    pairs = set()
    for start in links:
        stack, seen = list(neighbours[start]), {start}
        while stack:
            link = stack.pop()
            if link in seen:
                continue
            seen.add(link)
            if link in with_geometry:
                pairs.add(_pair(start, link))
            else:
                stack.extend(neighbours[link])
    return pairs


def sample_positions(model: RobotModel, rng: np.random.Generator, count: int) -> np.ndarray:
    """Uniform states within the limits (unbounded joints over one turn)."""
    lower = np.where(np.isfinite(model.lower_limits), model.lower_limits, -np.pi)
    upper = np.where(np.isfinite(model.upper_limits), model.upper_limits, np.pi)
    return rng.uniform(lower, upper, size=(count, len(lower)))


class _PairChecker:
    """Pinocchio's collision pairs between the geometries of chosen link pairs."""

    def __init__(self, model: RobotModel, pairs: list[tuple[str, str]]) -> None:
        self.model = model
        self.geometry = model.pin_collision_model.copy()
        self.geometry.removeAllCollisionPairs()
        self.pair_of_link_pair: dict[tuple[str, str], list[int]] = {}
        for a, b in pairs:
            indices = []
            for ga in model.link_geometry_indices(a):
                for gb in model.link_geometry_indices(b):
                    indices.append(self.geometry.findCollisionPair(pin.CollisionPair(ga, gb))
                                   if self.geometry.existCollisionPair(pin.CollisionPair(ga, gb))
                                   else self._add(ga, gb))
            self.pair_of_link_pair[(a, b)] = indices
        self.data = model.pin_model.createData()
        self.geometry_data = pin.GeometryData(self.geometry)

    def _add(self, ga: int, gb: int) -> int:
        self.geometry.addCollisionPair(pin.CollisionPair(ga, gb))
        return len(self.geometry.collisionPairs) - 1

    def activate_only(self, link_pairs: set[tuple[str, str]]) -> None:
        self.geometry_data.deactivateAllCollisionPairs()
        for link_pair in link_pairs:
            for index in self.pair_of_link_pair[link_pair]:
                self.geometry_data.activateCollisionPair(index)

    def colliding(self, positions: np.ndarray, link_pairs: set[tuple[str, str]]) -> set[tuple[str, str]]:
        """The given (active) link pairs in contact at these positions."""
        pin.computeCollisions(self.model.pin_model, self.data, self.geometry, self.geometry_data,
                              self.model.to_q(positions), False)
        results = self.geometry_data.collisionResults
        return {lp for lp in link_pairs if any(results[i].isCollision() for i in self.pair_of_link_pair[lp])}


def compute_collision_matrix(model: RobotModel, samples: int = DEFAULT_SAMPLES, seed: int = 0,
                             progress: Progress | None = None, always_samples: int = ALWAYS_SAMPLES,
                             always_fraction: float = ALWAYS_FRACTION) -> CollisionMatrix:
    """The Setup Assistant's matrix over every pair of links with collision geometry."""
    if samples < 0:
        raise ValueError(f"samples must be >= 0, got {samples}")
    start = time.perf_counter()
    links = [link for link in model.link_names if model.link_geometry_indices(link)]
    all_pairs = [_pair(a, b) for a, b in combinations(links, 2)]
    matrix = CollisionMatrix(samples=samples)
    for pair in sorted(adjacent_pairs(model, links)):
        matrix.disabled[pair] = ADJACENT
    undecided = {p for p in all_pairs if p not in matrix.disabled}
    checker = _PairChecker(model, sorted(undecided))
    checker.activate_only(undecided)
    for pair in checker.colliding(model.default_positions(), undecided):
        matrix.disabled[pair] = DEFAULT
    undecided -= set(matrix.disabled)

    rng = np.random.default_rng(seed)
    states = sample_positions(model, rng, samples)
    first = min(always_samples, samples)
    hits = {pair: 0 for pair in undecided}
    checker.activate_only(undecided)
    for positions in states[:first]:
        for pair in checker.colliding(positions, undecided):
            hits[pair] += 1
    seen = set()
    for pair, count in hits.items():
        if first and count >= always_fraction * first:
            matrix.disabled[pair] = ALWAYS
        elif count:
            seen.add(pair)
    undecided -= set(matrix.disabled) | seen
    checker.activate_only(undecided)
    every = max(1, samples // 20)
    for index in range(first, samples):
        if not undecided:
            break
        hit = checker.colliding(states[index], undecided)
        if hit:
            undecided -= hit
            seen |= hit
            checker.activate_only(undecided)
        if progress is not None and (index + 1) % every == 0 and index + 1 < samples:
            progress(index + 1, samples, len(undecided))
    if progress is not None:
        progress(samples, samples, len(undecided))
    for pair in sorted(undecided):
        matrix.disabled[pair] = NEVER
    matrix.enabled = sorted(p for p in all_pairs if p not in matrix.disabled)
    matrix.disabled = dict(sorted(matrix.disabled.items()))
    matrix.seconds = time.perf_counter() - start
    return matrix
