"""The Cartesian path's chunked steps (the IK of up to ``_CHUNK`` steps, then their checks in
order) give exactly the path of one step at a time: the same fraction, stop reason and states,
on the myCobot and the Panda, from random valid starts toward random targets that run through a
box, out of reach or clear, with and without MoveIt's relative jump test; and the chunk's
collision checks through the batch sphere test stop where the plain exact check of every state
stops."""
from __future__ import annotations

import numpy as np
import pytest

from interfaces_py.msgs import CollisionObject
from mycobot_planning.core import PlanningScene, RobotState
from mycobot_planning.core.planners.cartesian import cartesian_path
from mycobot_planning.core.transforms import make_pose

CHUNK = cartesian_path._CHUNK  # the chunk size the planner uses


def _random_valid_start(scene: PlanningScene, group: str, rng: np.random.Generator) -> RobotState:
    model = scene.robot_model
    indices = model.group(group).variable_indices
    low, high = model.lower_limits[indices], model.upper_limits[indices]
    while True:
        state = RobotState(model)
        state.set_group_positions(group, rng.uniform(low, high))
        if scene.is_state_valid(state):
            return state


@pytest.mark.parametrize("robot, group, reach", [("mycobot", "arm", 0.3), ("panda", "arm", 0.8)])
def test_chunked_steps_give_the_one_step_at_a_time_path(robot, group, reach, mycobot, panda, monkeypatch):
    model = {"mycobot": mycobot, "panda": panda}[robot]
    scene = PlanningScene(model)
    scene.add_object(CollisionObject.box("box", [0.3 * reach] * 3, make_pose([0.5 * reach, 0.0, 0.4 * reach])))
    tip = model.group(group).tip_link
    rng = np.random.default_rng(7)
    reasons = set()
    for _ in range(24):
        start = _random_valid_start(scene, group, rng)
        target = start.frame_pose(tip).copy()
        target[:3, 3] += rng.normal(size=3) * 0.15 * reach
        for jump in (0.0, 2.0):
            results = []
            for chunk, batch in ((CHUNK, True), (1, True), (1, False)):
                monkeypatch.setattr(cartesian_path, "_CHUNK", chunk)
                with monkeypatch.context() as patch:
                    if not batch:  # the plain exact check on every state, no sphere test at all
                        patch.setattr(scene, "batch_free_checker", lambda *args, **kwargs: None)
                    results.append(cartesian_path.compute_cartesian_path(
                        scene, group, start, [target], eef_step=0.004 * reach, jump_threshold=jump))
            single = results[1]
            for other in (results[0], results[2]):
                assert other.fraction == single.fraction
                assert other.stop_reason == single.stop_reason
                assert other.path.shape == single.path.shape
                np.testing.assert_allclose(other.path, single.path, rtol=0.0, atol=1e-12)
                assert other.error_code.message == single.error_code.message
            reasons.add(single.stop_reason)
    # the cases reached every way a path ends
    assert reasons == {"complete", "collision", "no_ik_solution", "joint_space_jump"}, reasons
