"""What the tests of the trajectory-optimisation planners (CHOMP, STOMP) share: the myCobot swing
through a box, requests to a pipeline, the validator's plain check, the refusal of bad parameters
and the pipeline being selectable wherever pipelines are (registry, JSON face, MTC)."""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np
import pytest

from interfaces_py.msgs import CollisionObject, MoveItErrorCode
from mycobot_planning.core.planning_interface.planning_interface import MotionPlanRequest
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory
from mycobot_planning.core.transforms import make_pose

# Two myCobot arm states whose joint-space line sweeps the flange around the base, through a box.
LEFT = np.array([-1.2, 0.0, 1.5708, 1.5708, 0.0, 0.0])
RIGHT = np.array([1.2, 0.0, 1.5708, 1.5708, 0.0, 0.0])
TIP = "link6_flange"
# generous: the planners need well under 1 s here; the budget only has to survive a loaded 2-core machine
BUDGET_S = 30.0


def arm_state(model, values) -> RobotState:
    state = RobotState(model)
    state.set_group_positions("arm", values)
    return state


def boxed_scene(model) -> tuple[PlanningScene, RobotState]:
    """A scene with a 4 cm box where the straight line from LEFT to RIGHT passes the flange."""
    start = arm_state(model, LEFT)
    where = arm_state(model, (LEFT + RIGHT) / 2).frame_pose(TIP)[:3, 3]
    scene = PlanningScene(model, start)
    scene.add_object(CollisionObject.box("box", [0.04] * 3, make_pose(where)))
    return scene, start


def optimizer_request(pipeline_id: str, goal, start, seed=0, **kw) -> MotionPlanRequest:
    return MotionPlanRequest("arm", goal, start_state=start, pipeline_id=pipeline_id, seed=seed,
                             allowed_planning_time=kw.pop("allowed_planning_time", BUDGET_S), **kw)


def assert_plain_valid(scene, response, start, group="arm") -> None:
    """The validator's plain exact check of every pair (all_pairs, the default) every 0.005 rad."""
    assert response.success, response.error_code.message
    report = validate_trajectory(scene, response.trajectory, group, start_state=start)
    assert report.valid, report.problems


def assert_parameters_refused(planner_type: type, planner_id: str, params: Mapping[str, str], words: str) -> None:
    """``params`` refused with ``words``, all or nothing, by set_planner_params and the constructor."""
    planner = planner_type()
    before = planner.params
    problem = planner.set_planner_params(planner_id, params)
    assert problem is not None and words in problem, problem
    assert planner.params == before  # all or nothing
    with pytest.raises(ValueError, match=f"{planner_id} parameter|unknown {planner_id}"):
        planner_type(params)


def assert_listed_and_selectable(model, pipeline, pipeline_id: str, planner_id: str, param: str, default: str,
                                 bad: Mapping[str, Any], why: str) -> None:
    """The pipeline is in the registry, on the JSON face (listed, its parameters read and refused,
    a plan) and behind MTC's PipelinePlanner."""
    from mycobot_planning.capabilities.json_face import MoveGroupJsonFace
    from mycobot_planning.core.trajectory_execution import ControllerInfo, ExecutionSettings
    from mycobot_planning.task import core, stages
    from task_helpers import assert_solution_valid, scene_at

    assert pipeline_id in pipeline.pipeline_ids and pipeline.planner_id_problem(planner_id, ["arm"]) is None

    class IdleBus:
        def is_available(self, controller):
            return False

    arm = tuple(model.group("arm").joint_names)
    face = MoveGroupJsonFace(model, pipeline, [ControllerInfo("arm_controller", arm)], IdleBus(), ExecutionSettings())
    names = list(model.variable_names)
    assert face.update_joint_state(names, [0.0] * len(names)) is None
    assert {"name": planner_id, "pipeline_id": pipeline_id, "planner_ids": [planner_id]} in face.planner_interfaces()
    assert face.get_planner_params(pipeline_id, planner_id)[param] == default
    assert why in face.set_planner_params(pipeline_id, planner_id, dict(bad))
    result = face.plan({"group": "arm", "goal": {"named": "ready"}, "pipeline_id": pipeline_id,
                        "planner_id": planner_id})
    assert result["error_code"]["val"] == MoveItErrorCode.SUCCESS, result["error_code"]

    task = core.Task(pipeline_id, model, scene_at(model, "ready"))
    task.add(stages.CurrentState("current"))
    move = stages.MoveTo("home", core.PipelinePlanner(pipeline_id, planner_id))
    move.group = "arm"
    move.setGoal("home")
    task.add(move)
    assert task.plan()
    assert_solution_valid(task.solutions[0])
