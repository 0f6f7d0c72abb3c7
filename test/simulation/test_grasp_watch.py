"""GraspWatch: which object the gripper holds and how far it slips, from samples of the state (the
mujoco_sim node's grasp report and its stop on a lost grasp build on it)."""
from __future__ import annotations

import numpy as np

from mycobot_planning.core.transforms import make_pose
from mycobot_planning.simulation.grasp_monitor import LOST_DISTANCE, GraspWatch
from mycobot_planning.simulation.gripper import GripperCommand, GripperState

CLOSE, OPEN = GripperCommand(-0.34), GripperCommand(0.0)


def gripper(position, command, active=False, contacts=()):
    return GripperState(position, 0.0, 0.0, not active and position != command.position, not active and
                        position == command.position, active, command, tuple(contacts))


def test_a_close_on_the_object_holds_it_until_the_open_and_measures_its_slip():
    watch = GraspWatch(open_position=0.0)
    hand, obj = make_pose([0.2, 0.1, 0.3]), make_pose([0.2, 0.1, 0.2])
    watch.sample(0.0, gripper(0.0, OPEN), hand, {"object": obj})
    watch.sample(0.1, gripper(-0.1, CLOSE, active=True), hand, {"object": obj})
    assert watch.current is None  # closing: not held yet
    watch.sample(0.2, gripper(-0.33, CLOSE, contacts=["object"]), hand, {"object": obj})
    assert watch.current is not None and watch.current.object == "object"
    # carried 10 cm up, 3 mm of slip downwards in the hand
    watch.sample(0.3, gripper(-0.33, CLOSE, contacts=["object"]), make_pose([0.2, 0.1, 0.4]),
                 {"object": make_pose([0.2, 0.1, 0.297])})
    ended = watch.sample(0.4, gripper(-0.3, OPEN, active=True), make_pose([0.2, 0.1, 0.4]),
                         {"object": make_pose([0.2, 0.1, 0.297])})
    assert ended is watch.last_hold("object")
    assert ended.ended == "opened" and ended.end == 0.4
    assert abs(ended.slip - 0.003) < 1e-9


def test_a_close_that_touches_nothing_still_holds_what_is_between_the_pads_and_sees_it_lost():
    watch = GraspWatch(open_position=0.0)
    obj = make_pose([0.2, 0.1, 0.2])
    barely = GripperCommand(-0.2)
    watch.sample(0.0, gripper(0.0, OPEN), make_pose([0.2, 0.1, 0.3]), {"object": obj})
    watch.sample(0.1, gripper(-0.2, barely), make_pose([0.2, 0.1, 0.3]), {"object": obj},
                 candidates=lambda: ["object"])
    assert watch.current is not None and watch.current.object == "object"
    ended = None
    for k, z in enumerate(np.arange(0.3, 0.36, 0.005)):  # the hand lifts, the object stays
        ended = ended or watch.sample(0.2 + k * 0.01, gripper(-0.2, barely), make_pose([0.2, 0.1, z]),
                                      {"object": obj}, candidates=lambda: ["object"])
    assert ended is not None and ended.ended == "lost"
    assert ended.slip > LOST_DISTANCE
    # one hold per command: the object between the pads does not start a second one
    assert len(watch.holds) == 1 and watch.current is None


def test_an_open_command_never_starts_a_hold_of_what_is_between_the_pads():
    watch = GraspWatch(open_position=0.0)
    hand, obj = make_pose([0.2, 0.1, 0.3]), make_pose([0.2, 0.1, 0.2])
    watch.sample(0.0, gripper(-0.33, CLOSE), hand, {"object": obj})
    watch.sample(0.1, gripper(-0.2, OPEN, active=True), hand, {"object": obj}, candidates=lambda: ["object"])
    watch.sample(0.2, gripper(0.0, OPEN), hand, {"object": obj}, candidates=lambda: ["object"])
    assert watch.holds == [] and watch.last_hold("object") is None
