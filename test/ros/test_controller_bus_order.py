"""The planning_server's controller bus keeps a goal's end: a feedback message handled after the
goal's result (feedback is a topic, the result a service answer; the client may take them in
either order) must not turn a finished goal back into "executing". Seen with the MuJoCo twin: a
gripper goal that ended in one control cycle was reported TIMED_OUT ("'grip_action_controller'
is executing") although the controller had answered succeeded."""
from __future__ import annotations

from mycobot_planning.core.trajectory_execution.controller_manager import GRIPPER_COMMAND, ControllerInfo
from mycobot_planning.ros.move_group.controller_bus import ActionControllerBus
from ros_testing import ProbeNode, use_session_domain


def test_a_late_feedback_does_not_undo_a_goals_result():
    use_session_domain()
    probe = ProbeNode("test_controller_bus_order")
    try:
        controller = ControllerInfo("grip_action_controller", ("gripper_controller",), GRIPPER_COMMAND, "gripper_cmd")
        bus = ActionControllerBus(probe.node, probe.node, [controller], lambda: None)
        bus._record(controller.name, bus._state(controller.name, "g1", "executing", "goal accepted"))
        bus._record(controller.name, bus._state(controller.name, "g1", "succeeded", "goal succeeded"))
        bus._on_action_feedback(controller.name, "g1", None)  # the feedback handled after the result
        state = bus.controller_state(controller.name, "g1")
        assert state.status == "succeeded" and not state.active
        # a new goal still reports executing
        bus._on_action_feedback(controller.name, "g2", None)
        assert bus.controller_state(controller.name, "g2").status == "executing"
        assert bus.controller_state(controller.name).goal_id == "g2"
        bus.close()
    finally:
        probe.close()
