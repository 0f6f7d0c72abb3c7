"""config/planning_server.yaml says it lists the planning_server's parameters with their
defaults: every value it gives for a parameter of planning_server_parameter_specs must be that
parameter's declared default (it said 0.01 s for trajectory_sample_period for a week after the
default became MoveIt's 0.1 s, so a user loading the file got ten times the points)."""
from __future__ import annotations

import yaml

from mycobot_planning.core import RobotModel
from mycobot_planning.core.planning_interface.planning_pipeline import PlanningPipeline
from mycobot_planning.paths import config_file
from mycobot_planning.ros.move_group.planning_server_parameters import planning_server_parameter_specs


def test_the_planning_server_file_gives_the_declared_defaults():
    values = yaml.safe_load(config_file("planning_server.yaml").read_text())["planning_server"]["ros__parameters"]
    specs = planning_server_parameter_specs(RobotModel.mycobot(), PlanningPipeline(), lambda: "arm")
    compared = [spec.name for spec in specs if spec.name in values]
    assert len(compared) >= 15, compared
    wrong = {spec.name: (values[spec.name], spec.default) for spec in specs
             if spec.name in values and values[spec.name] != spec.default}
    assert wrong == {}, f"file value vs declared default: {wrong}"
