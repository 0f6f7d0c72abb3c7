"""ModifyPlanningScene takes moveit_msgs/CollisionObject as MTC's scripts build them (empty, then
field by field), plus the dict form; what cannot be an object is refused with the reason."""
from __future__ import annotations

import pytest
from geometry_msgs.msg import Pose
from moveit_msgs.msg import CollisionObject
from shape_msgs.msg import SolidPrimitive

from mycobot_planning.task import core, stages
from task_helpers import scene_at


def _sphere(name: str) -> CollisionObject:
    obj = CollisionObject()
    obj.header.frame_id = "world"
    obj.id = name
    sphere = SolidPrimitive()
    sphere.type = sphere.SPHERE
    sphere.dimensions = [0.02]
    pose = Pose()
    pose.position.x, pose.position.y, pose.position.z = 0.2, -0.15, 0.1
    obj.primitives.append(sphere)
    obj.primitive_poses.append(pose)
    obj.operation = CollisionObject.ADD
    return obj


def test_add_and_remove_objects_built_as_moveit_msgs(mycobot):
    task = core.Task("scene", mycobot, scene_at(mycobot, "ready"))
    task.add(stages.CurrentState("current"))
    add = stages.ModifyPlanningScene("add objects")
    add.addObject(_sphere("ball"))
    add.addObject({"id": "cube", "frame_id": "world", "primitives": [{"type": 1, "dimensions": [0.02, 0.02, 0.02]}],
                   "primitive_poses": [{"position": [0.2, 0.15, 0.1], "orientation": [0, 0, 0, 1]}]})
    task.add(add)
    remove = stages.ModifyPlanningScene("remove the cube")
    remove.removeObject("cube")
    task.add(remove)
    assert task.plan()
    scene = task.solutions[0].end.scene
    assert scene.has_object("ball") and not scene.has_object("cube")
    obj = scene.get_object("ball")
    ball = obj.pose.compose(obj.primitive_poses[0]).position
    assert ball == pytest.approx([0.2, -0.15, 0.1])


def test_an_object_that_is_not_an_add_is_refused(mycobot):
    stage = stages.ModifyPlanningScene("bad")
    obj = _sphere("ball")
    obj.operation = CollisionObject.REMOVE
    with pytest.raises(Exception, match="operation ADD"):
        stage.addObject(obj)
    with pytest.raises(Exception, match="addObject"):
        stage.addObject({"id": "x", "primitives": [{"type": 1, "dimensions": [-1, 0, 0]}]})


def test_fixed_state_takes_a_planning_scene_message(mycobot):
    msg = scene_at(mycobot, "home").get_planning_scene_msg()
    for form in (msg, msg.to_json()):
        task = core.Task("fixed", mycobot)
        fixed = stages.FixedState("start")
        fixed.setState(form)
        task.add(fixed)
        assert task.plan()
        assert task.solutions[0].end.scene.current_state.positions == pytest.approx(
            scene_at(mycobot, "home").current_state.positions)
    bad = stages.FixedState("bad")
    bad.setState({"robot_state": {"joint_state": {"name": ["no_such_joint"], "position": [0.0]}}})
    task = core.Task("bad", mycobot)
    task.add(bad)
    with pytest.raises(Exception, match="cannot be applied"):
        task.init()
    with pytest.raises(Exception, match="expected a PlanningScene"):
        stages.FixedState("x").setState(42)
