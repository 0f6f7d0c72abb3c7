"""The viewer's simulated world without ROS: a twin's objects drawn at the poses given, in the
simulator's colours (grey when it gives none), apart from the planning scene's objects, hidden by
the "Simulated world" checkbox, gone when the simulator no longer has them."""
from __future__ import annotations

import pytest

from interfaces_py.msgs import CollisionObject
from mycobot_planning.core import RobotModel
from mycobot_planning.core.transforms import make_pose
from mycobot_planning.visualization.viewer import SIM_COLOUR, TaskViewer


@pytest.fixture
def viewer():
    v = TaskViewer(RobotModel.mycobot(), port=0)
    try:
        yield v
    finally:
        v.close()


def test_the_simulated_world_is_drawn_at_its_poses_and_can_be_hidden(viewer):
    cylinder = CollisionObject.cylinder("object", 0.1, 0.02, make_pose([0.2, 0.1, 0.05]))
    crate = CollisionObject.box("crate", [0.03] * 3, make_pose([0.1, -0.2, 0.015]))
    viewer.on_sim_world({"object": cylinder, "crate": crate}, {"object": (255, 0, 0)})
    assert viewer.wait_idle()
    shown = viewer.state()["sim_world"]
    assert shown["visible"] and set(shown["objects"]) == {"object", "crate"}
    assert shown["objects"]["object"]["position"] == pytest.approx([0.2, 0.1, 0.05])
    assert shown["objects"]["object"]["colour"] == [255, 0, 0]
    assert shown["objects"]["crate"]["colour"] == list(SIM_COLOUR)
    assert shown["objects"]["object"]["shapes"] == ["cylinder"]
    assert viewer.state()["live"]["objects"] == {}  # the planning scene's objects are apart
    # the cylinder moved (it toppled in the physics): drawn where it is now
    viewer.on_sim_world({"object": CollisionObject.cylinder("object", 0.1, 0.02, make_pose([0.25, 0.1, 0.02],
                                                                                          [1.5708, 0.0, 0.0]))})
    assert viewer.wait_idle()
    shown = viewer.state()["sim_world"]["objects"]
    assert set(shown) == {"object"} and shown["object"]["position"] == pytest.approx([0.25, 0.1, 0.02])
    viewer.set_sim_visible(False)
    assert viewer.wait_idle() and not viewer.state()["sim_world"]["visible"]
    viewer.set_sim_visible(True)
    assert viewer.wait_idle() and viewer.state()["sim_world"]["visible"]
