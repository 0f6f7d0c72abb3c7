"""GenerateRandomPose spawns the seed pose and up to max_solutions - 1 random poses around it; each
reachable one becomes an IK solution of the wrapping ComputeIK."""
from __future__ import annotations

import numpy as np
import pytest

from mycobot_planning.task import core, stages
from task_helpers import assert_solution_valid, scene_at

FLANGE = "link6_flange"


def _task(model, samplers, max_solutions=6, seed=5):
    target = scene_at(model, "ready", link1_to_link2=0.25).current_state.frame_pose(FLANGE)
    task = core.Task("random", model, scene_at(model, "ready"), seed=seed)
    current = stages.CurrentState("current")
    task.add(current)
    task.add(stages.Connect("connect", [("arm", core.JointInterpolationPlanner())]))
    generator = stages.GenerateRandomPose("random pose")
    generator.setPose(core.PoseStamped("world", target))
    generator.properties["max_solutions"] = max_solutions
    for sampler in samplers:
        generator.sampleDimension(*sampler)
    generator.setMonitoredStage(current)
    ik = stages.ComputeIK("pose IK", generator)
    ik.group = "arm"
    ik.properties.configureInitFrom(core.Stage.INTERFACE, ["target_pose"])
    task.add(ik)
    return task, generator, target


def test_random_poses_around_the_seed_in_its_own_frame(mycobot):
    task, generator, target = _task(mycobot, [("Z", 0.01, "uniform"), ("YAW", 0.2, "normal")])
    assert task.plan()
    assert len(generator.solutions) == 6  # the seed and five samples
    poses = [s.end.properties["target_pose"].pose for s in generator.solutions]
    assert np.allclose(poses[0], target)
    local = [np.linalg.inv(target) @ p for p in poses[1:]]
    assert all(abs(t[2, 3]) <= 0.005 + 1e-12 and np.allclose(t[:2, 3], 0.0, atol=1e-12) for t in local)
    assert len({round(float(t[2, 3]), 9) for t in local}) == 5  # five different samples
    for solution in task.solutions:
        assert_solution_valid(solution)


def test_the_same_task_seed_gives_the_same_samples(mycobot):
    def samples():
        task, generator, _ = _task(mycobot, [("X", 0.01, "normal")], max_solutions=4)
        task.plan()
        return [s.end.properties["target_pose"].pose[0, 3] for s in generator.solutions]
    assert samples() == samples()


def test_without_samplers_only_the_seed_and_bad_samplers_are_refused(mycobot):
    task, generator, _ = _task(mycobot, [])
    assert task.plan()
    assert len(generator.solutions) == 1
    with pytest.raises(Exception, match="unknown pose dimension"):
        generator.sampleDimension("W", 0.1)
    with pytest.raises(Exception, match="distribution"):
        generator.sampleDimension("X", 0.1, "cauchy")
