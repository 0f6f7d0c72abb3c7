"""task_viewer as a real process, fed over ROS, and its page in headless Chromium.

The test plays a task node: it plans the seed's pick-and-place (the mtc_node stage tree) and
publishes it on the task topics, with the seeds' table scene on /monitored_planning_scene and
joint states on /joint_states. Then it looks at what a user sees: the viewer's state (JSON-RPC
get_state), and the page itself in Debian's headless Chromium — the stage tree with the seed's
stage names, the robot, the table and the cylinder in the screenshot, and a stage's solution
chosen in the page's dropdown moving the shown robot.
"""
from __future__ import annotations

import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest
import rclpy
from matplotlib.colors import rgb_to_hsv
from PIL import Image
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory as JointTrajectoryMsg

import headless_chromium
from interfaces_py.background_spin import BackgroundSpin
from interfaces_py.json_rpc import JsonRpcClient, RpcError
from interfaces_py.msgs import JointTrajectory, JointTrajectoryPoint
from interfaces_py.ros_conversions import joint_trajectory_to_msg
from mycobot_planning.ros.task.task_topics import TaskIntrospection, parse_task_topic, task_topics
from ros_testing import NodeProcess, use_session_domain, wait_until
from task_helpers import planned_pick_place, table_scene

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
TASK_NODE = "pick_place_demo"
TASK_KEY = f"/{TASK_NODE}: pick_place_task"
# the seed's mtc_node stage names
SEED_STAGES = ["current state", "open gripper", "move to pick", "pick object", "approach object",
               "generate grasp pose", "grasp pose IK", "allow collision (gripper,object)", "close gripper",
               "attach object", "allow collision (object,support)", "lift object",
               "forbid collision (object,surface)", "move to place", "place object", "lower object",
               "generate place pose", "place pose IK", "forbid collision (gripper,object)", "detach object",
               "retreat after place", "move home"]
SHOTS = Path("/tmp/mycobot_test_logs")


class TaskNode:
    """The test's stand-in for a task node: task topics, the scene, joint states at 50 Hz."""

    def __init__(self, model, task) -> None:
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = Node(TASK_NODE, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.introspection = TaskIntrospection(self.node)
        self.scene_pub = self.node.create_publisher(String, "/planning_server/monitored_planning_scene", LATCHED)
        self.path_pub = self.node.create_publisher(JointTrajectoryMsg, "/planned_path", LATCHED)
        self.js_pub = self.node.create_publisher(JointState, "/joint_states", 10)
        self.url: list[str] = []
        self.node.create_subscription(String, "/task_viewer/url", lambda m: self.url.append(m.data), LATCHED)
        scene = table_scene(model)
        # the live robot stands at 'ready', away from the solution's start at 'home', so that
        # both robots are seen in the page
        self.joints = dict(zip(model.variable_names, scene.current_state.positions.tolist()))
        self.joints.update(model.named_state("ready", "arm"))
        self.scene_pub.publish(String(data=scene.get_planning_scene_msg().to_json()))
        self.published = self.introspection.publish(task, solutions=1)
        self.node.create_timer(0.02, self._publish_joint_states)
        self.rpc = JsonRpcClient(self.node, "/task_viewer")
        self.spinner = BackgroundSpin(self.executor, name="task node executor")

    def _publish_joint_states(self) -> None:
        msg = JointState(name=list(self.joints), position=list(self.joints.values()))
        msg.header.stamp = self.node.get_clock().now().to_msg()
        self.js_pub.publish(msg)

    def state(self) -> dict:
        return self.rpc.call("get_state", timeout=15.0)

    def close(self) -> None:
        self.spinner.stop()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


@pytest.fixture(scope="module")
def planned(mycobot):
    return planned_pick_place(mycobot)


@pytest.fixture(scope="module")
def system(mycobot, planned):
    use_session_domain()
    viewer = NodeProcess("mycobot_planning.nodes.task_viewer", ["--ros-args", "-p", "port:=0"])
    publisher = None
    try:
        assert viewer.wait_for_output("task_viewer: open http://127.0.0.1:", 60), viewer.output()
        publisher = TaskNode(mycobot, planned)
        assert publisher.rpc.wait_for_server(30.0), viewer.output()

        def ready() -> bool:
            state = publisher.state()
            return (bool(state["tasks"]) and state["tasks"][0]["solutions"] == 1
                    and set(state["live"]["objects"]) == {"table", "object"} and state["joint_states"]["applied"] > 0)

        assert wait_until(ready, 60.0, period=0.3), publisher.state()
        yield {"viewer": viewer, "node": publisher}
    finally:
        if publisher is not None:
            publisher.close()
        viewer.stop()


def test_task_topic_names():
    assert task_topics("mtc_node").solution == "/mtc_node/task/solution"
    assert task_topics("/ns/demo/").statistics == "/ns/demo/task/statistics"
    assert parse_task_topic("/ns/demo/task/description") == ("/ns/demo", "description")
    assert parse_task_topic("/task/solution") is None and parse_task_topic("/demo/task/other") is None


def test_viewer_serves_this_machine_only_and_tells_its_address(system):
    node = system["node"]
    state = node.state()
    url = state["url"]
    assert url.startswith("http://127.0.0.1:")
    assert wait_until(lambda: bool(node.url), 20.0) and node.url[-1] == url  # latched ~/url
    port = int(url.rstrip("/").rsplit(":", 1)[1])
    listening = []
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            local, state_code = line.split()[1], line.split()[3]
            if state_code == "0A" and int(local.rsplit(":", 1)[1], 16) == port:
                listening.append(local.rsplit(":", 1)[0])
    assert listening == ["0100007F"], listening  # 127.0.0.1, not 0.0.0.0
    with urllib.request.urlopen(url, timeout=10) as answer:
        assert answer.status == 200 and b"<html" in answer.read(4096).lower()


def test_viewer_state_follows_topics(system, mycobot, planned):
    state = system["node"].state()
    assert state["robot"]["name"] == "mycobot_280" and "gripper_base" in state["robot"]["links"]
    tree = next(t for t in state["tasks"] if t["key"] == TASK_KEY)
    names = [s["name"] for s in tree["stages"]]
    assert names[0] == "pick_place_task" and all(n in names for n in SEED_STAGES)
    summary = {row["name"]: row for row in planned.stage_summary()}
    ik = next(s for s in tree["stages"] if s["name"] == "grasp pose IK")
    assert ik["status"] == "✓" and (ik["solutions"], ik["failures"]) == (summary["grasp pose IK"]["solutions"],
                                                                         summary["grasp pose IK"]["failures"])
    live = state["live"]
    home = system["node"].joints
    assert all(live["positions"][n] == pytest.approx(home[n], abs=1e-6) for n in mycobot.variable_names)
    table = live["objects"]["table"]
    assert table["shapes"] == ["box"] and table["position"] == pytest.approx([0.22, 0.12, -0.015])
    assert live["objects"]["object"]["shapes"] == ["cylinder"]
    assert state["joint_states"]["lag_ms"]["median"] < 1000.0  # the stamps are recent: it keeps up


def test_select_requests_are_checked(system):
    rpc = system["node"].rpc
    with pytest.raises(RpcError, match="has no stage 'teleport'"):
        rpc.call("select", {"task": TASK_KEY, "stage": "teleport"})
    with pytest.raises(RpcError, match="unknown task '/nobody: x'"):
        rpc.call("select", {"task": "/nobody: x"})
    with pytest.raises(RpcError, match="no solution index 3"):
        rpc.call("select", {"task": TASK_KEY, "stage": "move home", "solution": 3})
    with pytest.raises(RpcError, match="'time' must be a number"):
        rpc.call("seek", {"time": "soon"})
    state = rpc.call("select", {"task": TASK_KEY, "stage": "move home"})
    assert state["preview"]["stage"] == "move home" and state["preview"]["steps"] == ["move home"]
    assert system["viewer"].alive()


def test_planned_path_is_animated(system, mycobot):
    node = system["node"]
    start = [node.joints[n] for n in mycobot.variable_names[:6]]
    goal = list(start)
    goal[0] += 0.8
    trajectory = JointTrajectory(joint_names=mycobot.variable_names[:6], points=[
        JointTrajectoryPoint(positions=start, time_from_start=0.0),
        JointTrajectoryPoint(positions=goal, time_from_start=2.0)])
    node.path_pub.publish(joint_trajectory_to_msg(trajectory))
    assert wait_until(lambda: (node.state()["preview"] or {}).get("source") == "planned_path", 20.0)
    node.rpc.call("pause")
    state = node.rpc.call("seek", {"time": 1.0})
    assert state["preview"]["positions"]["link1_to_link2"] == pytest.approx(start[0] + 0.4, abs=1e-6)
    assert not state["preview"]["playing"]


def _hue_pixels(hsv: np.ndarray, rgb, keep: np.ndarray, tolerance_deg: float = 12.0) -> int:
    """Pixels of the colour's hue (any shade the lighting gives it), inside the ``keep`` mask."""
    hue = rgb_to_hsv(np.asarray(rgb, dtype=float) / 255.0)[0]
    distance = np.abs(((hsv[..., 0] - hue + 0.5) % 1.0) - 0.5) * 360.0
    return int(np.sum((distance < tolerance_deg) & (hsv[..., 1] > 0.15) & (hsv[..., 2] > 0.2) & keep))


def _scene_mask(page, shape) -> np.ndarray:
    """The 3D view: everything left of the side panel, without the toast in the corner."""
    keep = np.ones(shape[:2], dtype=bool)
    panel = page.evaluate("(() => { const t = document.querySelector('table.mp-task-tree');"
                          " return t ? t.getBoundingClientRect().left : null; })()")
    assert panel, "the stage tree table is not on the page"
    keep[:, int(panel) - 20:] = False
    toast = page.rect_of_text("Software WebGL")
    if toast:
        left, top, right, bottom = (int(v) for v in toast)
        keep[max(top - 10, 0):bottom + 10, max(left - 20, 0):right + 10] = False
    return keep


def _counts(page, path: Path, colours: dict) -> dict[str, int]:
    page.screenshot(path)
    with Image.open(path) as image:
        pixels = np.asarray(image.convert("RGB"))
    keep = _scene_mask(page, pixels.shape)
    columns = np.flatnonzero(keep.any(axis=0))
    view = slice(0, int(columns.max()) + 1 if len(columns) else 0)  # the 3D view only, once in HSV
    hsv = rgb_to_hsv(pixels[:, view, :3].astype(np.float32) / 255.0)
    return {name: _hue_pixels(hsv, rgb, keep[:, view]) for name, rgb in colours.items()}


def _shown(state: dict, names) -> np.ndarray:
    return np.array([state["preview"]["positions"][n] for n in names])


@pytest.mark.skipif(not headless_chromium.available(),
                    reason="needs Debian's chromium (/usr/bin/chromium; apt-get install -y chromium)")
def _pause(node, page, timeout: float = 20.0) -> bool:
    """Pause the preview from the page; a click can land while the page re-renders (or the
    preview ends on its own at that moment), so click again until the node says it stopped."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if not node.state()["preview"]["playing"]:
            return True
        try:
            page.click_button("Pause", timeout=2.0)
        except headless_chromium.BrowserError:
            pass  # labelled "Play" by now: the preview just ended
        if wait_until(lambda: not node.state()["preview"]["playing"], 2.0):
            return True
    return not node.state()["preview"]["playing"]


def test_page_in_headless_chromium(system, mycobot):
    node = system["node"]
    state = node.state()
    colours = {"live robot": state["colours"]["live_robot"], "solution robot": state["colours"]["preview_robot"],
               "table": state["live"]["objects"]["table"]["colour"], "cylinder": state["live"]["objects"]["object"]["colour"],
               "attached": state["colours"]["attached"]}
    SHOTS.mkdir(parents=True, exist_ok=True)
    with headless_chromium.Chromium(width=1280, height=800) as page:
        page.navigate(state["url"])
        assert page.wait_for("document.body && document.body.innerText.includes('retreat after place')", 90), \
            page.text()[:2000]
        assert wait_until(lambda: node.state()["clients"] >= 1, 30.0)
        text = page.text()
        for name in SEED_STAGES:  # the stage tree, with the seed's stage names
            assert name in text, name
        assert "pick_place_task" in text and "✓" in text
        rows = page.evaluate("[...document.querySelectorAll('table.mp-task-tree tr[data-stage-id]')]"
                             ".map(r => [...r.cells].map(c => c.innerText.trim()))")
        by_name = {r[0]: r for r in rows}
        assert by_name["move to pick"][1] == "✓" and by_name["generate grasp pose"][2] == "24"

        # choose the stage "move to pick" in the page, pause, and look at its first instant
        page.select_option("Stage", "move to pick")
        assert wait_until(lambda: (node.state()["preview"] or {}).get("stage") == "move to pick", 20.0)
        assert _pause(node, page), node.state()["preview"]
        first = node.rpc.call("seek", {"time": 0.0})
        assert first["preview"]["steps"] == ["move to pick"]
        needed = ("live robot", "solution robot", "table", "cylinder")
        shot = SHOTS / "task_viewer_move_to_pick.png"
        counts = wait_until(lambda: (lambda c: c if all(c[k] > 150 for k in needed) else None)(
            _counts(page, shot, colours)), 60.0, period=1.0)
        assert counts, f"robot, table or cylinder missing from {shot}: {_counts(page, shot, colours)}"

        # choose "lift object": the shown robot moves, and the cylinder is now in the gripper
        page.select_option("Stage", "lift object")
        assert wait_until(lambda: (node.state()["preview"] or {}).get("stage") == "lift object", 20.0)
        assert _pause(node, page), node.state()["preview"]
        second = node.rpc.call("seek", {"time": 0.0})
        arm = mycobot.variable_names[:6]
        assert np.max(np.abs(_shown(second, arm) - _shown(first, arm))) > 0.1  # the shown state changed
        assert second["preview"]["objects"]["object"]["attached_to"] == "link6_flange"
        shot2 = SHOTS / "task_viewer_lift_object.png"
        counts2 = wait_until(lambda: (lambda c: c if c["attached"] > 150 and c["cylinder"] < 50 else None)(
            _counts(page, shot2, colours)), 60.0, period=1.0)
        assert counts2, f"the attached cylinder is not shown in {shot2}: {_counts(page, shot2, colours)}"
        with Image.open(shot) as a, Image.open(shot2) as b:
            changed = np.any(np.abs(np.asarray(a.convert("RGB"), dtype=int) - np.asarray(b.convert("RGB"), dtype=int))
                             > 30, axis=2)
        assert changed.sum() > 2000  # the picture changed too

        # the page works offline: everything it loaded came from the viewer itself
        outside = [u for u in page.requests
                   if not u.startswith((state["url"].rstrip("/"), "data:", "blob:", "about:"))]
        assert outside == []
        assert page.exceptions == []
    assert system["viewer"].alive()


def test_bad_configuration_exits_with_one_line_reason():
    use_session_domain()
    proc = NodeProcess("mycobot_planning.nodes.task_viewer", ["--ros-args", "-p", "port:=70000"],
                       name="task_viewer_bad")
    try:
        assert proc.proc.wait(60) == 1
        output = proc.output()
        assert "port" in output and "Traceback" not in output, output
    finally:
        proc.stop()
