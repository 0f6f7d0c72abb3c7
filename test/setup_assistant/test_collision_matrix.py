"""The generated self-collision matrix against sampled ground truth, and against the Panda's SRDF."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from mycobot_planning.core.collision_detection.collision_matrix import (
    ADJACENT, ALWAYS, DEFAULT, NEVER, adjacent_pairs, compute_collision_matrix, sample_positions)
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.paths import example_robot_data_dir

GROUND_TRUTH_STATES = 3000


def _ground_truth(model: RobotModel, seed: int) -> set[tuple[str, str]]:
    """Link pairs seen in contact in independent random states: every geometry pair checked
    directly with Coal (no Pinocchio pair lists, none of the matrix code)."""
    seen: set[tuple[str, str]] = set()
    for positions in sample_positions(model, np.random.default_rng(seed), GROUND_TRUTH_STATES):
        seen |= _contacts_at(model, positions)
    return seen


@pytest.fixture(scope="module")
def panda() -> RobotModel:
    robots = example_robot_data_dir()
    return RobotModel.from_files(robots / "panda_description/urdf/panda.urdf",
                                 robots / "panda_description/srdf/panda.srdf",
                                 package_dirs=[str(robots.parent.parent)])


@pytest.fixture(scope="module")
def panda_matrix(panda: RobotModel):
    return compute_collision_matrix(panda, samples=10_000, seed=1)


@pytest.fixture(scope="module")
def panda_truth(panda: RobotModel) -> set[tuple[str, str]]:
    return _ground_truth(panda, seed=7)


def test_no_pair_disabled_as_never_collides_in_independent_samples(panda_matrix, panda_truth) -> None:
    never = {pair for pair, reason in panda_matrix.disabled.items() if reason == NEVER}
    assert never, "the Panda has pairs that can never meet"
    assert not never & panda_truth
    # Pairs that do collide are disabled only with a reason that says so
    for pair in panda_truth & set(panda_matrix.disabled):
        assert panda_matrix.disabled[pair] in (ADJACENT, DEFAULT, ALWAYS), pair


def test_every_pair_the_shipped_srdf_disables_and_that_never_collides_is_disabled(
        panda: RobotModel, panda_matrix, panda_truth) -> None:
    shipped = {tuple(sorted(p)) for p in panda.disabled_collision_pairs}
    with_geometry = {link for link in panda.link_names if panda.link_geometry_indices(link)}
    relevant = {p for p in shipped if set(p) <= with_geometry}
    never_colliding = relevant - panda_truth
    assert never_colliding
    assert never_colliding <= set(panda_matrix.disabled)


def test_enabled_pairs_were_seen_in_contact(panda_matrix, panda_truth) -> None:
    """An enabled pair is one the sampling saw touch: most of them touch in the ground truth too."""
    assert panda_matrix.enabled
    assert len(set(panda_matrix.enabled) & panda_truth) >= 0.8 * len(panda_matrix.enabled)


def test_adjacency_passes_through_links_without_geometry(mycobot: RobotModel) -> None:
    links = [link for link in mycobot.link_names if mycobot.link_geometry_indices(link)]
    pairs = adjacent_pairs(mycobot, links)
    for name in mycobot.joint_names:
        joint = mycobot.joint(name)
        if joint.parent_link in links and joint.child_link in links:
            assert tuple(sorted((joint.parent_link, joint.child_link))) in pairs


def test_default_state_contacts_are_disabled_as_default(mycobot: RobotModel) -> None:
    """The pairs in contact at the default state (zeros, clipped) that are not Adjacent are
    exactly the Default ones; every pair gets one of the four reasons or stays enabled."""
    matrix = compute_collision_matrix(mycobot, samples=200)
    assert matrix.samples == 200 and matrix.seconds > 0
    assert set(matrix.disabled.values()) <= {ADJACENT, DEFAULT, ALWAYS, NEVER}
    assert set(matrix.disabled).isdisjoint(matrix.enabled)
    touching = _contacts_at(mycobot, mycobot.default_positions())
    default = {pair for pair, reason in matrix.disabled.items() if reason == DEFAULT}
    adjacent = {pair for pair, reason in matrix.disabled.items() if reason == ADJACENT}
    assert default == touching - adjacent


def _contacts_at(model: RobotModel, positions: np.ndarray) -> set[tuple[str, str]]:
    import coal

    geometry = model.pin_collision_model
    data = model.pin_model.createData()
    geometry_data = pin.GeometryData(geometry)
    pin.updateGeometryPlacements(model.pin_model, data, geometry, geometry_data, model.to_q(positions))
    owner = [model.pin_model.frames[g.parentFrame].name for g in geometry.geometryObjects]
    out = set()
    for a in range(len(owner)):
        for b in range(a + 1, len(owner)):
            if owner[a] == owner[b]:
                continue
            pa, pb = geometry_data.oMg[a], geometry_data.oMg[b]
            if coal.collide(geometry.geometryObjects[a].geometry, coal.Transform3s(pa.rotation, pa.translation),
                            geometry.geometryObjects[b].geometry, coal.Transform3s(pb.rotation, pb.translation),
                            coal.CollisionRequest(), coal.CollisionResult()):
                out.add(tuple(sorted((owner[a], owner[b]))))
    return out


def test_negative_samples_are_refused(mycobot: RobotModel) -> None:
    with pytest.raises(ValueError, match="samples must be >= 0"):
        compute_collision_matrix(mycobot, samples=-1)
