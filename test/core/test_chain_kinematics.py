"""The compiled SE(3) logarithm and its Jacobian (kinematics/chain_kinematics.py) are Pinocchio's.

pin.log6 and pin.Jlog6 judge them on random transforms, on rotations of 1e-9 to 1e-2 rad (where
both switch to series) and close to pi; chain_tables declines what its kernels do not model.
(log3, poses and Jacobians over chains: test_step_solver.py.)
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from mycobot_planning.core.collision_detection.batch_check import numba_available
from mycobot_planning.core.kinematics.chain_kinematics import chain_tables, jlog6, log6

pytestmark = pytest.mark.skipif(not numba_available(), reason="numba is not installed (scripts/requirements.txt)")


def _transforms() -> list[pin.SE3]:
    rng = np.random.default_rng(11)
    out = [pin.SE3.Random() for _ in range(1000)]
    for scale in (1e-9, 1e-7, 1e-5, 1e-4, 1e-3, 1e-2):
        out += [pin.exp6(pin.Motion(rng.normal(size=6) * scale)) for _ in range(100)]
    for _ in range(100):  # rotations within 1e-3 rad of pi
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        out.append(pin.SE3(pin.exp3(axis * (np.pi - 10.0 ** rng.uniform(-6, -3))), rng.normal(size=3)))
    return out


def test_log6_is_pinocchios():
    for transform in _transforms():
        ours = log6(transform.rotation, transform.translation)
        assert np.allclose(ours, pin.log6(transform).vector, rtol=0.0, atol=1e-9), transform


def test_jlog6_is_pinocchios():
    """Relative to the matrix's size: near pi its entries grow like 1 / (1 - cos)."""
    for transform in _transforms():
        ours, theirs = jlog6(transform.rotation, transform.translation), pin.Jlog6(transform)
        assert np.abs(ours - theirs).max() <= 1e-7 * max(1.0, np.abs(theirs).max()), transform


def test_chain_tables_decline_what_the_kernels_do_not_model(panda):
    assert chain_tables(panda, panda.group("arm").variable_indices, "panda_hand_tcp") is not None
    # the hand's finger drives a mimic follower: its variable is not a plain configuration slot
    assert chain_tables(panda, panda.group("hand").variable_indices, "panda_leftfinger") is None
