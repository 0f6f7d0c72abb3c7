"""Every interface of our nodes under hundreds of bad inputs (issue 13): mock_controllers,
planning_server and mtc_node in real processes, the cases of mycobot_planning.bench.robustness
(the same ones the `robustness` bench runs). Each must be refused with a reason, leave the scene
and the robot unchanged, and leave every node alive and answering."""
from __future__ import annotations

from collections import Counter

import pytest

from mycobot_planning.bench.robustness import RobustnessSystem, all_cases
from ros_testing import session_domain_id

CASES = all_cases()


@pytest.fixture(scope="module")
def system():
    with RobustnessSystem(session_domain_id()) as system:
        yield system


def test_there_are_hundreds_of_systematic_cases_over_every_interface():
    kinds = Counter(case.interface for case in CASES)
    assert len(CASES) >= 300, kinds
    assert set(kinds) == {"rpc", "rpc_raw", "topic", "controller", "param", "moveit"}
    # issue 27: at least 400 inputs through the real ROS types: moveit_msgs/control_msgs/MTC requests
    # and goals, trajectory_msgs on the controllers' topics, rcl_interfaces parameters
    assert kinds["moveit"] >= 340 and kinds["moveit"] + kinds["controller"] + kinds["param"] >= 400, kinds
    names = {case.name for case in CASES}
    for required in ("objects: 11 MB batch with one bad box", "nested 5000 deep", "execute whip 1.5 rad in 1 ms",
                     "mtc_node arm_group_name='legs'", "planning_server planner_id='Magic'",
                     "/planning_server/collision_object surrogate id", "plan.allowed_planning_time[1]=1000000000.0",
                     "move_action group_name='legs'", "move_action joint goal position=nan",
                     "move_action pose goal box region with a negative side", "compute_ik timeout 2^31-1 s",
                     "check_state_validity violated constraint", "compute_cartesian_path max_step=0.0",
                     "set_planner_params range,goal_bias,foo", "execute_trajectory accelerations without velocities",
                     "follow_joint_trajectory goal_tolerance for nojoint", "apply_planning_scene ACM naming a ghost",
                     "move_action plan_only group_name='legs'", "move_action planning_scene_diff padding NaN",
                     "execute_task_solution action scene_diff scale -1", "execute_task_solution action NaN position",
                     "set_planner_params range and key 'legs'", "compute_ik seed beyond limits"):
        assert required in names, required


def test_every_bad_input_is_refused_and_nothing_changes(system):
    report = system.runner().run(CASES)
    summary = report.summary()
    assert summary["inputs"] == len(CASES)
    failing = "\n".join(f"{o.verdict}: {o.case.interface} {o.case.name}: {o.detail[:300]}" for o in report.failures())
    for key in ("accepted_bad", "crashes", "hangs", "half_applied", "unsafe_motions"):
        assert summary[key] == 0, f"{key}: {summary[key]}\n{failing}"
    # the nodes still do their job afterwards: a good plan succeeds
    answer = system.prober.call("plan", {"group": "arm", "goal": {"named": "ready"}, "display": False}, 30.0)
    assert answer["ok"] and answer["result"]["error_code"]["val"] == 1, answer


@pytest.mark.parametrize("answer, verdict", [
    ({"ok": True, "result": {"error_code": {"val": 1, "message": ""}}}, "accepted_bad"),  # a success
    ({"ok": True, "result": {"applied": 1}}, "accepted_bad"),
    ({"ok": False, "error": {"code": -1003, "message": "IndexError: index 4000 is out of bounds"}}, "accepted_bad"),
    ({"ok": False, "error": {"code": -1001, "message": ""}}, "accepted_bad"),  # no reason given
    ({"ok": True, "result": {"error_code": {"val": -16, "message": "goal tolerance must not be negative"}}}, "refused"),
    ({"ok": False, "error": {"code": -1001, "message": "malformed JSON"}}, "refused"),
])
def test_the_judge_tells_a_refusal_from_an_acceptance_or_a_leak(answer, verdict):
    from mycobot_planning.bench.robustness import Runner

    assert Runner._judge_rpc(answer)[0] == verdict
