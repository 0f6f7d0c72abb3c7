"""The viewer's Pose target panel without ROS: the target placed at the tool, typed or dragged,
a plan asked for the shown target only, the preview withdrawn when the target moves, Execute
offered only for the plan of the target shown, bad text refused with a message."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mycobot_planning.core import RobotModel, RobotState
from mycobot_planning.core.transforms import make_pose
from mycobot_planning.visualization.pose_target import PoseTargetActions, format_pose, parse_pose

TOOL = "link6_flange"


class Recorder:
    def __init__(self) -> None:
        self.plans: list[tuple[int, np.ndarray, float]] = []
        self.executed: list[int] = []

    def actions(self) -> PoseTargetActions:
        return PoseTargetActions(plan=lambda token, pose, scaling: self.plans.append((token, pose, scaling)),
                                 execute=lambda token: self.executed.append(token))


@pytest.fixture
def viewer():
    from mycobot_planning.visualization.viewer import TaskViewer

    recorder = Recorder()
    v = TaskViewer(RobotModel.mycobot(), port=0, pose_target_actions=recorder.actions(), pose_target_link=TOOL)
    v.recorder = recorder
    try:
        yield v
    finally:
        v.close()


def test_pose_text_round_trips_and_bad_text_is_refused():
    pose = make_pose([0.1, -0.2, 0.3], [math.radians(10), math.radians(-20), math.radians(30)])
    assert np.allclose(parse_pose(format_pose(pose)), pose, atol=1e-3)
    assert np.allclose(parse_pose("0.1, -0.2, 0.3, 10, -20, 30"), pose, atol=1e-9)
    for bad, words in (("1 2 3", "6 numbers"), ("a b c d e f", "not 6 numbers"), ("1 2 3 4 5 nan", "finite")):
        with pytest.raises(ValueError, match=words):
            parse_pose(bad)


def test_the_target_starts_at_the_tool_and_a_plan_is_asked_for_it(viewer):
    panel, recorder = viewer.pose_target, viewer.recorder
    assert viewer.state()["pose_target"]["target"] is None
    panel.click_plan()
    assert recorder.plans == [] and "place the target first" in panel.state()["message"]
    panel.place_at_tool()
    tool = RobotState(viewer.model, viewer.model.default_positions()).frame_pose(TOOL)
    assert np.allclose(parse_pose(panel.state()["target"]), tool, atol=1e-3)
    panel.click_plan()
    token, pose, scaling = recorder.plans[-1]
    assert token == panel.state()["token"] and np.allclose(pose, tool)
    assert scaling == pytest.approx(0.1)  # RViz's MotionPlanning panel's default
    assert not panel.state()["previewed"]
    panel.on_plan(token, True, "planned")
    assert panel.state()["previewed"] and panel.state()["message"] == "planned"
    panel.click_execute()
    assert recorder.executed == [token]


def test_moving_the_target_withdraws_the_preview_and_late_answers_are_ignored(viewer):
    panel, recorder = viewer.pose_target, viewer.recorder
    panel.place_at_tool()
    panel.click_plan()
    old, _, _ = recorder.plans[-1]
    panel.on_plan(old, True, "planned")
    panel.type_pose("0.1 0.1 0.25 180 0 0")  # a user's edit: the preview is gone
    assert not panel.state()["previewed"] and "withdrawn" in panel.state()["message"]
    panel.click_execute()
    assert recorder.executed == [] and "plan first" in panel.state()["message"]
    panel.click_plan()
    new, pose, _ = recorder.plans[-1]
    assert new > old and np.allclose(pose[:3, 3], [0.1, 0.1, 0.25])
    panel.on_plan(old, True, "the old plan, answered late")  # for a target no longer shown
    assert not panel.state()["previewed"]
    panel.on_plan(new, False, "no plan to the target: NO_IK_SOLUTION")
    assert not panel.state()["previewed"] and "NO_IK_SOLUTION" in panel.state()["message"]
    panel.type_pose("0.1 0.1")  # refused, the target unchanged
    assert "6 numbers" in panel.state()["message"]
    assert np.allclose(parse_pose(panel.state()["target"])[:3, 3], [0.1, 0.1, 0.25])


def test_a_dragged_gizmo_is_the_new_target(viewer):
    panel = viewer.pose_target
    panel.place_at_tool()
    token = panel.state()["token"]
    panel.gizmo.position = (0.15, 0.0, 0.2)  # as a drag in the page leaves it
    panel.gizmo.wxyz = (0.0, 1.0, 0.0, 0.0)
    panel.gizmo_moved()  # what the gizmo's on_update calls
    state = panel.state()
    assert state["token"] == token + 1
    assert np.allclose(parse_pose(state["target"]), make_pose([0.15, 0.0, 0.2], [math.pi, 0.0, 0.0]), atol=1e-3)
