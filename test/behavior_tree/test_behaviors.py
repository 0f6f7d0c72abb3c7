"""The ROS-free behaviors (poses, data, waypoints, the operator prompt) on a plain
BehaviorContext: what an objective using them ends with, tick by tick where timing matters."""
from __future__ import annotations

import math

import pytest

from mycobot_planning.behavior_tree import (
    FAILURE,
    RUNNING,
    SUCCESS,
    BehaviorTreeFactory,
    Blackboard,
    FakeClock,
    TreeLoadError,
)
from mycobot_planning.behavior_tree.behaviors import (
    CORE_BEHAVIORS,
    BehaviorContext,
    JointStateValue,
    Waypoint,
    WaypointError,
    WaypointStore,
    register_core_behaviors,
)
from mycobot_planning.behavior_tree.objectives import blackboard_json
from mycobot_planning.paths import config_dir

OBJECTIVES = config_dir() / "objectives"
WAYPOINTS = config_dir() / "waypoints" / "mycobot_waypoints.yaml"


class RecordingContext(BehaviorContext):
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.logged: list[tuple[str, str]] = []
        self.shown: list[tuple[str, object]] = []
        self.joints = JointStateValue(["a", "b"], [0.1, 0.2])

    def log(self, level, text):
        self.logged.append((level, text))

    def visualize_pose(self, marker_name, pose, size, lifetime, text):
        self.shown.append((marker_name, pose))

    def current_joint_state(self):
        return self.joints


def make(context=None):
    context = context or RecordingContext(waypoints=WaypointStore(WAYPOINTS))
    factory = BehaviorTreeFactory()
    register_core_behaviors(factory, context)
    return factory, context


def tree_of(body: str, factory, blackboard=None, clock=None):
    xml = f'<root BTCPP_format="4"><BehaviorTree ID="T">{body}</BehaviorTree></root>'
    return factory.create_tree_from_text(xml, blackboard, clock)


def clocked_tree(body: str):
    """A tree of ``body`` on a FakeClock the test advances: (tree, clock, behavior context)."""
    factory, context = make()
    clock = FakeClock()
    return tree_of(body, factory, clock=clock), clock, context


def test_my_transform_pose_creates_transforms_and_shows_the_pose():
    factory, context = make()
    blackboard = Blackboard.create()
    tree = factory.create_tree_from_file(OBJECTIVES / "my_transform_pose.xml", blackboard)
    assert tree.tick_while_running() is SUCCESS
    entries = blackboard_json(blackboard)
    assert entries["stamped_pose"]["pose"]["position"] == [0.0, 1.0, 0.0]
    assert entries["output_pose"] == {"header": {"frame_id": "world"},
                                      "pose": {"position": [0.0, 1.0, 1.0], "orientation": [0.0, 0.0, 0.0, 1.0]}}
    assert [name for name, _ in context.shown] == ["pose"]
    assert context.shown[0][1].pose.position == [0.0, 1.0, 1.0]


def test_transform_pose_offsets_in_the_pose_s_own_axes():
    factory, _ = make()
    blackboard = Blackboard.create()
    # the input is turned 90 deg about z: its own x axis is the world's y axis
    s = math.sqrt(0.5)
    tree = tree_of(f'<Sequence><CreatePoseStamped reference_frame="base_link" position_xyz="1;0;0" '
                   f'orientation_xyzw="0;0;{s};{s}" pose_stamped="{{p}}"/>'
                   '<TransformPose input_pose="{p}" translation_xyz="0.5;0;0" output_pose="{q}"/></Sequence>',
                   factory, blackboard)
    assert tree.tick_while_running() is SUCCESS
    q = blackboard.get("q")
    assert q.frame_id == "base_link"
    assert q.pose.position == pytest.approx([1.0, 0.5, 0.0])
    assert q.pose.orientation == pytest.approx([0.0, 0.0, s, s])


def test_transform_pose_accepts_the_older_port_names_and_may_overwrite_its_input():
    factory, _ = make()
    blackboard = Blackboard.create()
    tree = tree_of('<Sequence><CreateStampedPose position_xyz="0;0;1" stamped_pose="{p}"/>'
                   '<TransformPose input_pose="{p}" position_xyz="0;0;0.25" orientation_xyzw="0;0;0;1" '
                   'output_pose="{p}"/></Sequence>', factory, blackboard)
    assert tree.tick_while_running() is SUCCESS
    assert blackboard.get("p").pose.position == pytest.approx([0.0, 0.0, 1.25])


def test_a_position_with_the_wrong_count_fails_the_behavior_and_says_why():
    factory, context = make()
    tree = tree_of('<CreatePoseStamped position_xyz="0;1" pose_stamped="{p}"/>', factory)
    assert tree.tick_while_running() is FAILURE
    assert any("position_xyz needs 3 numbers" in text for _, text in context.logged)


def test_transform_pose_frame_without_a_transform_fails():
    factory, context = make()
    tree = tree_of('<Sequence><CreatePoseStamped reference_frame="camera" pose_stamped="{p}"/>'
                   '<TransformPoseFrame input_pose="{p}" target_frame_id="world" output_pose="{q}"/></Sequence>',
                   factory)
    assert tree.tick_while_running() is FAILURE
    assert any("no transform from 'camera' to 'world'" in text for _, text in context.logged)


def test_a_pose_literal_that_does_not_convert_is_refused_at_load_naming_the_node():
    factory, _ = make()
    with pytest.raises(TreeLoadError) as error:
        tree_of('<CreatePoseStamped position_xyz="0;x;1" pose_stamped="{p}"/>', factory)
    assert "CreatePoseStamped" in str(error.value) and "position_xyz" in str(error.value)


def test_for_each_runs_its_child_once_per_element_one_per_tick():
    factory, context = make()
    blackboard = Blackboard.create()
    tree = tree_of('<ForEach vector_in="a;b;c" out="{item}" index="{i}">'
                   '<LogMessage message="{item}"/></ForEach>', factory, blackboard)
    statuses = [tree.tick_exactly_once() for _ in range(3)]
    assert statuses == [RUNNING, RUNNING, SUCCESS]
    assert [text for _, text in context.logged] == ["a", "b", "c"]
    assert blackboard.get("i") == 2


def test_for_each_fails_when_its_child_fails_and_succeeds_on_an_empty_vector():
    factory, _ = make()
    tree = tree_of('<ForEach vector_in="a;b" out="{item}"><AlwaysFailure/></ForEach>', factory)
    assert tree.tick_while_running() is FAILURE
    blackboard = Blackboard.create()
    blackboard.set("empty", [])
    tree = tree_of('<ForEach vector_in="{empty}" out="{item}"><AlwaysFailure/></ForEach>', factory, blackboard)
    assert tree.tick_while_running() is SUCCESS


def test_wait_for_duration_runs_for_its_duration_on_the_tree_clock():
    tree, clock, _ = clocked_tree('<WaitForDuration delay_duration="1.5"/>')
    assert tree.tick_exactly_once() is RUNNING
    clock.advance(1.0)
    assert tree.tick_exactly_once() is RUNNING
    clock.advance(0.5)
    assert tree.tick_exactly_once() is SUCCESS


def test_log_message_refuses_an_unknown_level():
    factory, context = make()
    assert tree_of('<LogMessage message="hi" log_level="loud"/>', factory).tick_while_running() is FAILURE
    assert tree_of('<LogMessage message="hi" log_level="warn"/>', factory).tick_while_running() is SUCCESS
    assert ("warn", "hi") in context.logged


def test_retrieve_waypoint_reads_the_shipped_waypoints():
    factory, context = make()
    blackboard = Blackboard.create()
    tree = tree_of('<RetrieveWaypoint waypoint_name="Pick" waypoint_joint_state="{js}"/>', factory, blackboard)
    assert tree.tick_while_running() is SUCCESS
    state = blackboard.get("js")
    assert state.name[0] == "link1_to_link2" and len(state.position) == 6
    tree = tree_of('<RetrieveWaypoint waypoint_name="Nowhere" waypoint_joint_state="{js}"/>', factory)
    assert tree.tick_while_running() is FAILURE
    assert any("no waypoint named 'Nowhere'" in text and "Pick" in text for _, text in context.logged)


def test_save_waypoint_and_save_current_state_use_the_robot_s_joints(tmp_path):
    path = tmp_path / "waypoints.yaml"
    path.write_text("[]\n")
    context = RecordingContext(waypoints=WaypointStore(path))
    factory, _ = make(context)
    blackboard = Blackboard.create()
    tree = tree_of('<Sequence><SaveWaypoint waypoint_name="here"/><SaveCurrentState saved_robot_state="{s}"/>'
                   '</Sequence>', factory, blackboard)
    assert tree.tick_while_running() is SUCCESS
    assert blackboard.get("s").as_dict() == {"a": 0.1, "b": 0.2}
    reloaded = WaypointStore(path)
    assert reloaded.names() == ["here"]
    assert reloaded.get("here").positions == [0.1, 0.2]


@pytest.mark.parametrize("text, why", [
    ("{not a list", "cannot read"),
    ("{a: 1}", "must hold a list"),
    ("- {description: x}", "needs a name"),
    ("- {name: w, joint_state: {name: [a], position: [1, 2]}}", "as many positions"),
    ("- {name: w, joint_state: {name: [a], position: [x]}}", "must be numbers"),
    ("- {name: w, joint_state: {name: [a], position: [1]}}\n- {name: w, joint_state: {name: [a], position: [1]}}",
     "defined twice"),
])
def test_a_bad_waypoints_file_is_refused_naming_it(tmp_path, text, why):
    path = tmp_path / "w.yaml"
    path.write_text(text)
    with pytest.raises(WaypointError) as error:
        WaypointStore(path)
    assert why in str(error.value) and str(path) in str(error.value)


def test_request_teleoperation_waits_for_the_operator_continue():
    factory, context = make()
    prompts = []
    context.operator.subscribe(prompts.append)
    tree = tree_of('<Fallback><AlwaysFailure/><RequestTeleoperation enable_user_interaction="true" '
                   'user_interaction_prompt="Please move to place pose"/></Fallback>', factory)
    assert tree.tick_exactly_once() is RUNNING
    assert tree.tick_exactly_once() is RUNNING
    prompt = context.operator.current()
    assert prompt.text == "Please move to place pose" and prompt.active
    assert context.operator.answer(prompt.prompt_id + 1, True)[0] is False  # not the open prompt
    assert context.operator.answer(prompt.prompt_id, True) == (True, "continue")
    assert context.operator.answer(prompt.prompt_id, False)[0] is False  # answered once
    assert tree.tick_exactly_once() is SUCCESS
    assert context.operator.current() is None
    assert [p.active for p in prompts] == [False, False]  # the same prompt object: opened, then withdrawn


def test_request_teleoperation_fails_on_the_operator_fail():
    factory, context = make()
    tree = tree_of('<RequestTeleoperation/>', factory)
    assert tree.tick_exactly_once() is RUNNING
    assert "Teleoperate" in context.operator.current().text
    context.operator.answer(0, False)
    assert tree.tick_exactly_once() is FAILURE


def test_a_halted_prompt_is_withdrawn():
    tree, clock, context = clocked_tree('<Timeout msec="1000"><RequestTeleoperation/></Timeout>')
    assert tree.tick_exactly_once() is RUNNING
    assert context.operator.current() is not None
    clock.advance(1.0)
    assert tree.tick_exactly_once() is FAILURE
    assert context.operator.current() is None
    assert context.operator.answer(0, True) == (False, "no operator prompt is open")


def test_wait_for_user_trajectory_approval_writes_the_answer():
    factory, context = make()
    blackboard = Blackboard.create()
    tree = tree_of('<WaitForUserTrajectoryApproval approved="{ok}"/>', factory, blackboard)
    assert tree.tick_exactly_once() is RUNNING
    assert context.operator.current().kind == "approval"
    context.operator.answer(0, False)
    assert tree.tick_exactly_once() is FAILURE
    assert blackboard.get("ok") is False


def test_every_core_behavior_is_described_with_described_ports():
    factory, _ = make()
    for _, registration_id, _ in CORE_BEHAVIORS:
        manifest = factory.manifests[registration_id]
        assert manifest.description, registration_id
        assert all(port.description for port in manifest.ports.values()), registration_id
    model = factory.write_tree_nodes_model_xml()
    assert '<Action ID="RequestTeleoperation">' in model and '<Decorator ID="ForEach">' in model
    assert '<Metadata subcategory="Operator" />' in model


def test_the_waypoint_store_keeps_what_is_saved_in_memory_without_a_file():
    store = WaypointStore()
    store.save(Waypoint("w", ["a"], [1.0]))
    assert store.get("w").positions == [1.0]
