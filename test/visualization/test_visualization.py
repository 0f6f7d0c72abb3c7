"""ROS-free pictures of robots, scenes and task solutions: meshes of the collision shapes, the
solution timeline (scene changes replayed, attached objects following their link), the stage
tree merged from the task messages, the PNG plots read back, the plot_solution tool, and the
browser viewer's scene and panel fed by direct calls (no ROS)."""
from __future__ import annotations

import json
import math
import time

import numpy as np
import pytest
from PIL import Image

from interfaces_py.msgs import (
    CollisionObject,
    JointTrajectory,
    JointTrajectoryPoint,
    Mesh,
    Pose,
    SolidPrimitive,
    TaskDescription,
    TaskSolution,
    TaskStatistics,
)
from mycobot_planning.core import RobotState
from mycobot_planning.nodes import plot_solution
from mycobot_planning.visualization.geometry import (
    box_mesh,
    capsule_mesh,
    coal_shape_mesh,
    cone_mesh,
    cylinder_mesh,
    object_shapes,
    robot_link_shapes,
    sphere_mesh,
)
from mycobot_planning.visualization.playback import Timeline, timeline_from_json
from mycobot_planning.visualization.plots import plot_scene, plot_trajectory, read_plot_info, snapshot_states
from mycobot_planning.visualization.task_tree import CHECK, CROSS, PENDING, TaskRegistry, TaskTree
from task_helpers import planned_pick_place, table_scene

ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6", "link6_to_link6_flange"]


@pytest.fixture(scope="module")
def planned(mycobot):
    return planned_pick_place(mycobot)


@pytest.fixture(scope="module")
def solution_msg(planned) -> TaskSolution:
    return TaskSolution.from_json(planned.to_msg().to_json())  # as received from the wire


def _closed(mesh) -> bool:
    """Every edge is shared by exactly two faces, in opposite directions (a closed, consistently
    oriented surface)."""
    edges: dict[tuple[int, int], int] = {}
    for a, b, c in mesh.faces:
        for e in ((a, b), (b, c), (c, a)):
            edges[e] = edges.get(e, 0) + 1
    return all(count == 1 and edges.get((e[1], e[0])) == 1 for e, count in edges.items())


def _volume(mesh) -> float:
    v = mesh.vertices[mesh.faces]
    return float(np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2])).sum() / 6.0)


# ---------------------------------------------------------------------------- geometry
@pytest.mark.parametrize("mesh, volume", [
    (box_mesh([0.1, 0.2, 0.3]), 0.1 * 0.2 * 0.3),
    (cylinder_mesh(0.35, 0.0125, 64), math.pi * 0.0125 ** 2 * 0.35),
    (cone_mesh(0.2, 0.05, 64), math.pi * 0.05 ** 2 * 0.2 / 3),
    (sphere_mesh(0.1, 64), 4 / 3 * math.pi * 0.1 ** 3),
    (capsule_mesh(0.2, 0.05, 64), math.pi * 0.05 ** 2 * 0.2 + 4 / 3 * math.pi * 0.05 ** 3),
])
def test_primitive_meshes_are_closed_outward_surfaces_of_the_right_volume(mesh, volume):
    assert _closed(mesh)
    assert _volume(mesh) == pytest.approx(volume, rel=0.02)  # positive: faces point outward


def test_robot_shapes_come_from_the_urdf_collision_geometry(mycobot):
    shapes = robot_link_shapes(mycobot)
    assert {s.link for s in shapes} == set(mycobot.links_with_collision_geometry())
    link3 = next(s for s in shapes if s.link == "link3")
    assert link3.kind == "cylinder"  # <cylinder radius="0.025" length="0.15"/> at xyz -0.058 0 0.059
    low, high = link3.mesh.bounds
    assert np.allclose(high - low, [0.05, 0.05, 0.15], atol=1e-3)
    assert np.allclose(link3.pose[:3, 3], [-0.058, 0.0, 0.059])
    base = next(s for s in shapes if s.link == "base_link")
    assert np.allclose(np.ptp(base.mesh.vertices, axis=0), [0.105, 0.14, 0.02])


def test_coal_meshes_and_object_shapes(panda):
    import coal

    kind, mesh = coal_shape_mesh(coal.Capsule(0.05, 0.2))
    assert kind == "capsule" and np.allclose(np.ptp(mesh.vertices, axis=0), [0.1, 0.1, 0.3], atol=2e-3)
    with pytest.raises(ValueError, match="cannot draw a Halfspace"):
        coal_shape_mesh(coal.Halfspace(np.array([0.0, 0.0, 1.0]), 0.0))
    # Panda links are triangle meshes (package:// STL files) in Coal BVHs
    kinds = {s.kind for s in robot_link_shapes(panda)}
    assert "mesh" in kinds or "convex" in kinds
    tri = Mesh.from_triangles([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    obj = CollisionObject(id="thing", primitives=[SolidPrimitive.box(0.1, 0.1, 0.1)],
                          primitive_poses=[Pose(position=[0.0, 0.0, 0.5])], meshes=[tri], mesh_poses=[Pose()])
    shapes = object_shapes(obj)
    assert [s.kind for s in shapes] == ["box", "mesh"]
    assert np.allclose(shapes[0].pose[:3, 3], [0.0, 0.0, 0.5])
    assert len(shapes[1].mesh.faces) == 1


# ---------------------------------------------------------------------------- timeline
def test_timeline_replays_steps_and_scene_changes(mycobot, planned, solution_msg):
    timeline = Timeline.from_task_solution(mycobot, solution_msg)
    subs = planned.solutions[0].sub_trajectories()
    assert [s.label for s in timeline.segments] == [s.creator.name for s in subs]
    assert timeline.duration == pytest.approx(solution_msg.duration)
    # the start is the task's start state; the end is the last step's end state
    assert np.allclose(timeline.sample(0.0).positions, subs[0].start.scene.current_state.positions)
    assert np.allclose(timeline.end_positions, subs[-1].end.scene.current_state.positions, atol=1e-9)
    # every step starts where its start state is
    for segment, sub in zip(timeline.segments, subs):
        assert np.allclose(segment.start_positions, sub.start.scene.current_state.positions, atol=1e-9), segment.label
    # the object is in the world until "attach object", then on the flange until "detach object"
    names = [s.label for s in timeline.segments]
    lift = timeline.segments[names.index("lift object")]
    mid = timeline.sample(lift.start_time + 0.5 * lift.duration)
    assert mid.label == "lift object" and mid.objects.attached["object"][0] == "link6_flange"
    state = RobotState(mycobot, mid.positions)
    flange = state.frame_pose("link6_flange")
    pose = mid.objects.poses({"link6_flange": flange})["object"]
    expected = planned.solutions[0].sub_trajectories()[names.index("lift object")]
    assert pose[2, 3] > 0.175  # lifted above where it stood
    assert "object" in expected.end.scene.attached_object_ids()
    assert "object" not in timeline.sample(0.0).objects.attached
    assert "object" not in timeline.end_objects.attached
    assert np.allclose(timeline.end_objects.world["object"].pose.position[:2], [-0.183, -0.14], atol=1e-3)


def test_a_slice_of_a_solution_starts_where_its_first_step_starts(mycobot, solution_msg):
    names = [s.info.stage_name for s in solution_msg.sub_trajectory]
    k = names.index("lift object")
    whole = Timeline.from_task_solution(mycobot, solution_msg)
    part = Timeline.from_task_solution(mycobot, solution_msg, [k])
    assert part.segments[0].start_time == 0.0 and part.duration == pytest.approx(whole.segments[k].duration)
    assert np.allclose(part.start_positions, whole.segments[k].start_positions)
    assert "object" in part.start_objects.attached  # the attach step before it has been replayed
    with pytest.raises(ValueError, match="step 99 out of range"):
        Timeline.from_task_solution(mycobot, solution_msg, [99])


def test_bare_trajectory_timeline_and_json_inputs(mycobot):
    traj = JointTrajectory(joint_names=ARM[:2], points=[
        JointTrajectoryPoint(positions=[0.0, 0.0], time_from_start=0.0),
        JointTrajectoryPoint(positions=[0.4, -0.2], time_from_start=2.0)])
    scene = table_scene(mycobot).get_planning_scene_msg()
    timeline = timeline_from_json(mycobot, traj.to_json(), scene.to_json())
    mid = timeline.sample(1.0).positions
    assert mid[0] == pytest.approx(0.2) and mid[1] == pytest.approx(-0.1)
    assert mid[2] == pytest.approx(scene.robot_state.positions[2])  # unnamed joints hold the scene's state
    assert set(timeline.start_objects.world) == {"table", "object"}
    times, names, p, v, a = timeline.dense()
    assert names == ARM[:2] and np.allclose(v[:, 0], 0.2)  # finite differences when no velocities are given
    with pytest.raises(ValueError, match="not joints of robot 'mycobot_280'"):
        timeline_from_json(mycobot, JointTrajectory(joint_names=["elbow"], points=[]).to_json())
    with pytest.raises(ValueError, match="not a TaskSolution"):
        timeline_from_json(mycobot, json.dumps({"stages": []}))
    with pytest.raises(ValueError, match="not JSON"):
        timeline_from_json(mycobot, "{oops")


# ---------------------------------------------------------------------------- stage tree
def test_stage_tree_rows_and_the_parts_each_stage_made(planned, solution_msg):
    registry = TaskRegistry()
    description = TaskDescription.from_json(planned.description().to_json())
    registry.on_description("/mtc_node", description)
    tree = registry.on_statistics("/mtc_node", TaskStatistics.from_json(planned.statistics().to_json()))
    assert registry.on_solution("/mtc_node", solution_msg) is tree
    registry.on_solution("/mtc_node", solution_msg)  # a duplicate is ignored
    assert len(tree.solutions) == 1 and tree.key == "/mtc_node: pick_place_task"
    rows = tree.rows()
    summary = {row["path"]: row for row in planned.stage_summary()}
    assert [r.name for r in rows] == [row["name"] for row in planned.stage_summary()]  # same pre-order as MTC
    for row in rows:
        if row.depth:
            expected = summary[row.path]
            assert (row.num_solved, row.num_failed) == (expected["solutions"], expected["failures"]), row.path
    by_name = {r.path or r.name: r for r in rows}
    assert by_name["pick object/grasp pose IK"].status == CHECK and by_name["pick object/grasp pose IK"].num_failed > 0
    # a primitive stage's part: its own step; a container's: its children's run; the root: all
    ids = [s.info.stage_id for s in solution_msg.sub_trajectory]
    lift = tree.solutions_of(by_name["pick object/lift object"].id)
    assert len(lift) == 1 and lift[0].steps == (ids.index(by_name["pick object/lift object"].id),)
    assert lift[0].solution_id == solution_msg.sub_trajectory[lift[0].steps[0]].info.id
    pick = tree.solutions_of(by_name["pick object"].id)[0]
    assert [solution_msg.sub_trajectory[k].info.stage_name for k in pick.steps][:2] == ["approach object",
                                                                                         "grasp pose IK"]
    assert pick.steps == tuple(range(pick.steps[0], pick.steps[-1] + 1))
    root = tree.solutions_of(rows[0].id)[0]
    assert root.steps == tuple(range(len(solution_msg.sub_trajectory))) and root.cost == solution_msg.cost
    assert tree.solutions_of(by_name["pick object/grasp pose IK/generate grasp pose"].id) == []  # wrapped by IK
    page = tree.html_table()
    assert page.count("<tr") >= len(rows) and "approach object" in page and CHECK in page


def test_stage_status_before_and_without_solutions():
    tree = TaskTree("/demo", "t")
    assert tree.rows() == [] and "waiting" in tree.html_table()
    tree.set_description(TaskDescription.from_dict({"task_id": "t", "stages": [
        {"id": 1, "name": "t", "type": "SerialContainer"}, {"id": 2, "parent_id": 1, "name": "IK"},
        {"id": 3, "parent_id": 1, "name": "later"}]}))
    tree.set_statistics(TaskStatistics.from_dict({"task_id": "t", "stages": [
        {"id": 1, "num_failed": 1}, {"id": 2, "failed": [7], "num_failed": 4, "total_compute_time": 0.5}]}))
    status = {r.name: (r.status, r.num_failed, r.depth) for r in tree.rows()}
    assert status == {"t": (CROSS, 1, 0), "IK": (CROSS, 4, 1), "later": (PENDING, 0, 1)}
    # a description with another tree drops solutions that belong to the old one
    tree.solutions.append(TaskSolution(task_id="t"))
    tree.set_description(TaskDescription.from_dict({"task_id": "t", "stages": [{"id": 1, "name": "t"}]}))
    assert tree.solutions == [] and tree.statistics is None


# ---------------------------------------------------------------------------- pictures
def _non_white_fraction(image: np.ndarray, box) -> float:
    x0, y0, x1, y1 = box
    region = image[max(y0, 0):y1, max(x0, 0):x1, :3].astype(int)
    return float(np.mean(np.any(region < 235, axis=2)))


def test_trajectory_plot_reads_back_with_one_subplot_per_joint_and_quantity(mycobot, solution_msg, tmp_path):
    timeline = Timeline.from_task_solution(mycobot, solution_msg)
    info = plot_trajectory(timeline, tmp_path / "traj.png")
    back = read_plot_info(tmp_path / "traj.png")
    moved = timeline.dense()[1]
    assert moved == ARM + ["gripper_controller"]
    assert back.kind == "trajectory" and back.subplots == 3 * len(moved) == info.subplots
    assert back.titles[:3] == ["link1_to_link2 position", "link1_to_link2 velocity", "link1_to_link2 acceleration"]
    with Image.open(tmp_path / "traj.png") as image:
        assert image.size == (back.width, back.height) and image.size[0] >= 1000 and image.size[1] >= 1000
        pixels = np.asarray(image.convert("RGB"))
    for title, box in zip(back.titles, back.boxes):
        assert 0.02 < _non_white_fraction(pixels, box) < 0.9, title  # curves, limits and grid, not blank
    # the joints' colours appear (curves and dashed limits), e.g. the first joint's blue
    assert np.sum(np.all(np.abs(pixels.astype(int) - [31, 119, 180]) < 30, axis=2)) > 500


def test_scene_snapshot_reads_back_with_one_view_per_state(mycobot, solution_msg, tmp_path):
    timeline = Timeline.from_task_solution(mycobot, solution_msg)
    states = snapshot_states(timeline)
    assert [s.label.split(" (")[0] for s in states] == ["start", "attach object", "detach object", "end"]
    assert "object" in states[1].objects.attached and "object" not in states[2].objects.attached
    info = plot_scene(mycobot, states, tmp_path / "scene.png", title="pick and place")
    back = read_plot_info(tmp_path / "scene.png")
    assert back.kind == "scene" and back.subplots == 4 == info.subplots and back.titles == info.titles
    with Image.open(tmp_path / "scene.png") as image:
        pixels = np.asarray(image.convert("RGB")).astype(int)
    for box in back.boxes:
        x0, y0, x1, y1 = box
        region = pixels[y0:y1, x0:x1]
        robot = np.sum(np.all(np.abs(region - [140, 158, 191]) < 45, axis=2))  # the robot's blue-grey
        assert robot > 300, box
    three = snapshot_states(timeline, ["start", 4.0, "lift object"])
    assert plot_scene(mycobot, three, tmp_path / "three.png").subplots == 3
    with pytest.raises(ValueError, match="neither start, end"):
        snapshot_states(timeline, ["teleport"])


def test_plot_solution_tool(solution_msg, mycobot, tmp_path, capsys):
    path = tmp_path / "pick_place.json"
    path.write_text(solution_msg.to_json())
    assert plot_solution.main([str(path)]) == 0
    out = capsys.readouterr().out
    traj, scene = tmp_path / "pick_place_trajectory.png", tmp_path / "pick_place_scene.png"
    assert f"wrote {traj}" in out and f"wrote {scene}" in out
    assert read_plot_info(traj).subplots == 21 and read_plot_info(scene).subplots == 4
    assert traj.stat().st_size > 20_000 and scene.stat().st_size > 20_000
    # a bare trajectory among the scene's objects, chosen states, one picture
    traj_json = tmp_path / "path.json"
    traj_json.write_text(JointTrajectory(joint_names=ARM, points=[
        JointTrajectoryPoint(positions=[0.0] * 6, time_from_start=0.0),
        JointTrajectoryPoint(positions=[0.5, -0.5, 0.3, 0.0, 0.2, 0.0], time_from_start=1.5)]).to_json())
    scene_json = tmp_path / "scene.json"
    scene_json.write_text(table_scene(mycobot).get_planning_scene_msg().to_json())
    assert plot_solution.main([str(traj_json), "--scene-json", str(scene_json), "--scene", str(tmp_path / "s.png"),
                               "--at", "start", "--at", "0.75", "--at", "end"]) == 0
    assert read_plot_info(tmp_path / "s.png").titles == ["start", "t = 0.75 s", "end (t = 1.50 s)"]
    assert not (tmp_path / "path_trajectory.png").exists()
    # bad input: one line, exit 2
    capsys.readouterr()
    assert plot_solution.main([str(scene_json)]) == 2
    assert "plot_solution: error: input: not a TaskSolution" in capsys.readouterr().err
    assert plot_solution.main([str(path), "--at", "nowhere"]) == 2
    assert "'nowhere' is neither" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        plot_solution.main([str(tmp_path / "missing.json")])
    assert exc.value.code == 2


# ---------------------------------------------------------------------------- viewer without ROS
@pytest.fixture
def viewer(mycobot):
    from mycobot_planning.visualization.viewer import TaskViewer

    v = TaskViewer(mycobot, port=0)
    try:
        yield v
    finally:
        v.close()


def test_viewer_shows_live_state_scene_and_task(viewer, mycobot, planned, solution_msg):
    assert viewer.url.startswith("http://127.0.0.1:") and viewer.port > 0
    viewer.on_scene(table_scene(mycobot).get_planning_scene_msg().to_json())
    ready = dict(zip(mycobot.variable_names, mycobot.default_positions()))
    ready.update(mycobot.named_state("ready", "arm"))
    viewer.on_joint_state(list(ready) + ["gripper_left_mimic_unknown"], list(ready.values()) + [9.0], time.time())
    assert viewer.wait_idle()
    state = viewer.state()
    assert state["live"]["positions"]["link2_to_link3"] == pytest.approx(ready["link2_to_link3"])
    assert set(state["live"]["objects"]) == {"table", "object"}
    assert state["live"]["objects"]["object"]["shapes"] == ["cylinder"]
    assert state["joint_states"]["applied"] == 1 and state["joint_states"]["lag_ms"]["median"] >= 0
    assert state["preview"] is None
    viewer.on_task_description("/mtc_node", planned.description())
    viewer.on_task_statistics("/mtc_node", planned.statistics())
    viewer.on_task_solution("/mtc_node", solution_msg)
    assert viewer.wait_idle()
    state = viewer.state()
    assert [t["key"] for t in state["tasks"]] == ["/mtc_node: pick_place_task"]
    assert state["preview"]["source"] == "task" and state["preview"]["stage"] == "pick_place_task"
    assert state["preview"]["duration"] == pytest.approx(solution_msg.duration, abs=1e-3)
    # choosing a stage's solution shows that part, from where it starts
    viewer.select(stage="lift object")
    viewer.pause()
    viewer.seek(0.0)
    assert viewer.wait_idle()
    state = viewer.state()
    preview = state["preview"]
    assert preview["stage"] == "lift object" and preview["steps"] == ["lift object"] and not preview["playing"]
    assert preview["objects"]["object"]["attached_to"] == "link6_flange"
    lift = Timeline.from_task_solution(mycobot, solution_msg,
                                       [[s.info.stage_name for s in solution_msg.sub_trajectory].index("lift object")])
    assert np.allclose([preview["positions"][n] for n in mycobot.variable_names], lift.start_positions, atol=1e-5)
    viewer.seek(lift.duration)
    assert viewer.wait_idle()
    moved = viewer.state()["preview"]["positions"]
    assert np.allclose([moved[n] for n in mycobot.variable_names], lift.end_positions, atol=1e-5)
    with pytest.raises(ValueError, match="has no stage 'nope'"):
        viewer.select(stage="nope")
    with pytest.raises(ValueError, match="unknown task"):
        viewer.select(task="/other: x")
    viewer.show_live()
    assert viewer.wait_idle() and viewer.state()["preview"] is None


def test_viewer_animates_a_planned_path_from_the_live_state(viewer, mycobot):
    viewer.on_planned_path(JointTrajectory(joint_names=ARM[:1], points=[
        JointTrajectoryPoint(positions=[0.0], time_from_start=0.0),
        JointTrajectoryPoint(positions=[1.0], time_from_start=0.5)]))
    assert viewer.wait_idle()
    preview = viewer.state()["preview"]
    assert preview["source"] == "planned_path" and preview["duration"] == pytest.approx(0.5)
    viewer.pause()
    viewer.seek(0.25)
    assert viewer.wait_idle()
    assert viewer.state()["preview"]["positions"]["link1_to_link2"] == pytest.approx(0.5)


def test_viewer_coalesces_a_burst_of_joint_states(viewer, mycobot):
    names = mycobot.variable_names
    for k in range(500):  # far faster than any display: only the newest matters
        viewer.on_joint_state(names, [0.001 * k] * len(names), time.time())
    assert viewer.wait_idle()
    deadline = time.monotonic() + 5.0
    while viewer.state()["live"]["positions"]["link1_to_link2"] != pytest.approx(0.499) and time.monotonic() < deadline:
        time.sleep(0.02)
    state = viewer.state()
    assert state["live"]["positions"]["link1_to_link2"] == pytest.approx(0.499)
    assert state["joint_states"]["received"] == 500 and state["joint_states"]["applied"] < 500
