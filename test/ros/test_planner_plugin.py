"""A planner added by installing one module (test/data/planner_plugin: the module and the
dist-info that registers it in the ``mycobot_planning.planners`` entry-point group): the
planning_server lists it on /query_planner_interface, accepts its ids as parameter values, and
plans with it through move_group's /plan_kinematic_path."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from moveit_msgs.msg import Constraints, JointConstraint, MoveItErrorCodes
from moveit_msgs.srv import GetMotionPlan, QueryPlannerInterfaces
from rclpy.parameter import Parameter

from ros_testing import ProbeNode, robot_processes

PLUGIN_DIR = Path(__file__).resolve().parents[1] / "data" / "planner_plugin"
ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6",
       "link6_to_link6_flange"]
GOAL = [0.4, -0.5, 0.7, 0.1, -0.2, 0.3]


@pytest.fixture(scope="module")
def probe():
    saved = os.environ.get("PYTHONPATH")
    os.environ["PYTHONPATH"] = os.pathsep.join([str(PLUGIN_DIR), *([saved] if saved else [])])
    try:
        with robot_processes():
            node = ProbeNode("planner_plugin_test")
            node.spin_in_background()
            try:
                assert node.wait_for_move_group()
                yield node
            finally:
                node.close()
    finally:
        if saved is None:
            os.environ.pop("PYTHONPATH", None)
        else:
            os.environ["PYTHONPATH"] = saved


def test_the_plugin_is_listed(probe: ProbeNode):
    interfaces = probe.call(QueryPlannerInterfaces, "/query_planner_interface",
                            QueryPlannerInterfaces.Request()).planner_interfaces
    by_pipeline = {i.pipeline_id: (i.name, list(i.planner_ids)) for i in interfaces}
    assert by_pipeline["straight_line"] == ("Straight line (test plugin)", ["StraightLine"])
    assert "RRTConnectkConfigDefault" in by_pipeline["ompl"][1]


def test_plan_kinematic_path_plans_with_the_plugin(probe: ProbeNode):
    request = GetMotionPlan.Request()
    r = request.motion_plan_request
    r.group_name, r.pipeline_id, r.planner_id = "arm", "straight_line", "StraightLine"
    r.goal_constraints = [Constraints(joint_constraints=[JointConstraint(
        joint_name=j, position=v, tolerance_above=1e-3, tolerance_below=1e-3, weight=1.0) for j, v in zip(ARM, GOAL)])]
    response = probe.call(GetMotionPlan, "/plan_kinematic_path", request, timeout=30.0).motion_plan_response
    assert response.error_code.val == MoveItErrorCodes.SUCCESS, response.error_code.message
    points = response.trajectory.joint_trajectory.points
    index = [list(response.trajectory.joint_trajectory.joint_names).index(j) for j in ARM]
    assert np.allclose(np.asarray(points[-1].positions)[index], GOAL, atol=1e-6)
    # a straight line in joint space: every point lies on the segment from the first to the last
    first, last = np.asarray(points[0].positions)[index], np.asarray(points[-1].positions)[index]
    direction = (last - first) / np.linalg.norm(last - first)
    for point in points:
        offset = np.asarray(point.positions)[index] - first
        assert np.linalg.norm(offset - direction * (offset @ direction)) < 1e-6
    # an id the plugin does not have is refused with MoveIt's code, not planned by another planner
    r.planner_id = "RRTConnectkConfigDefault"
    refused = probe.call(GetMotionPlan, "/plan_kinematic_path", request).motion_plan_response
    assert refused.error_code.val != MoveItErrorCodes.SUCCESS


def test_its_ids_are_valid_parameter_values(probe: ProbeNode):
    for name, value in (("planning_pipeline", "straight_line"), ("planner_id", "StraightLine")):
        result = probe.set_param("planning_server", Parameter(name, value=value))
        assert result.successful, result.reason
    result = probe.set_param("planning_server", Parameter("planning_pipeline", value="teleport"))
    assert not result.successful and "straight_line" in result.reason
