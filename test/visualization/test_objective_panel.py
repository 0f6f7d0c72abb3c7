"""The viewer's Objectives panel without ROS: what it shows from the objective_server's data
(library, status, the running tree with live statuses, blackboard, operator prompt) and what its
buttons ask for."""
from __future__ import annotations

import pytest

from mycobot_planning.behavior_tree import BehaviorTreeFactory, write_tree_to_xml
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.visualization.objective_panel import ObjectiveActions, tree_lines


class Recorder:
    def __init__(self):
        self.calls: list[tuple] = []

    def actions(self) -> ObjectiveActions:
        return ObjectiveActions(run=lambda name: self.calls.append(("run", name)),
                                stop=lambda: self.calls.append(("stop",)),
                                answer=lambda pid, answer, wp: self.calls.append(("answer", pid, answer, wp)))


@pytest.fixture
def viewer():
    from mycobot_planning.visualization.viewer import TaskViewer

    recorder = Recorder()
    v = TaskViewer(RobotModel.mycobot(), port=0, objective_actions=recorder.actions())
    v.recorder = recorder
    try:
        yield v
    finally:
        v.close()


XML = ('<root BTCPP_format="4" main_tree_to_execute="Main"><BehaviorTree ID="Main"><Sequence name="top">'
       '<AlwaysSuccess name="first"/><SubTree ID="Inner"/></Sequence></BehaviorTree>'
       '<BehaviorTree ID="Inner"><Fallback><AlwaysFailure/><AlwaysSuccess/></Fallback></BehaviorTree></root>')


def running_tree_state():
    tree = BehaviorTreeFactory().create_tree_from_text(XML)
    statuses, last = {}, {}

    def record(t, node, prev, new):
        statuses[str(node.uid)] = new.name
        if new.name != "IDLE":
            last[str(node.uid)] = new.name

    tree.subscribe_to_status_changes(record)
    xml = write_tree_to_xml(tree, add_metadata=True)
    tree.tick_exactly_once()
    return {"objective": "Main", "status": "Running", "xml": xml, "nodes": statuses, "last": last,
            "blackboard": {"count": 3, "who": "world"}}


def test_the_tree_is_drawn_with_subtrees_expanded_and_each_node_s_status():
    state = running_tree_state()
    lines = tree_lines(state["xml"], state["nodes"], state["last"])
    labels = [(depth, label) for depth, label, _, _ in lines]
    assert labels == [(0, "top (Sequence)"), (1, "first (AlwaysSuccess)"), (1, "Inner"), (2, "Fallback"),
                      (3, "AlwaysFailure"), (3, "AlwaysSuccess")]
    # the tree completed in one tick: every node is IDLE again, with what it answered kept
    assert {status for _, _, status, _ in lines} == {"IDLE"}
    assert [last for _, _, _, last in lines] == ["SUCCESS", "SUCCESS", "SUCCESS", "SUCCESS", "FAILURE", "SUCCESS"]


def test_the_panel_shows_library_status_tree_blackboard_and_runs_objectives(viewer):
    panel = viewer.objectives
    assert viewer.state()["objectives"]["objectives"] == []
    panel.click_run()  # nothing to run yet
    assert viewer.recorder.calls == []
    panel.on_library(["Open Gripper", "Pick Object"], ["Home", "Pick"])
    panel.on_status("Pick Object", "Running")
    panel.on_tree_state(running_tree_state())
    state = viewer.state()["objectives"]
    assert state["objectives"] == ["Open Gripper", "Pick Object"] and state["waypoints"] == ["Home", "Pick"]
    assert state["status"] == {"objective": "Pick Object", "status": "Running", "message": ""}
    assert state["tree"][0] == {"depth": 0, "label": "top (Sequence)", "status": "IDLE", "last": "SUCCESS"}
    assert state["blackboard"] == {"count": 3, "who": "world"}
    panel.click_run("Pick Object")
    panel.click_stop()
    assert viewer.recorder.calls == [("run", "Pick Object"), ("stop",)]


def test_the_operator_prompt_offers_continue_fail_and_a_waypoint_move(viewer):
    panel = viewer.objectives
    panel.click_answer("continue")  # no prompt: nothing is sent
    assert viewer.recorder.calls == []
    panel.on_prompt({"prompt_id": 4, "active": True, "prompt": "Please move to the pick pose",
                     "node_path": "Pick with Recovery/RequestTeleoperation", "waypoint_names": ["Home", "Pick"]})
    assert viewer.state()["objectives"]["prompt"]["prompt"] == "Please move to the pick pose"
    panel.click_answer("waypoint", "Pick")
    panel.click_answer("continue")
    assert viewer.recorder.calls[0] == ("answer", 4, "waypoint", "Pick")
    assert viewer.recorder.calls[1][:3] == ("answer", 4, "continue")
    panel.on_prompt({"prompt_id": 4, "active": False})
    assert viewer.state()["objectives"]["prompt"] is None
