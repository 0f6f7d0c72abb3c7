"""The MuJoCo twin through the real nodes (issue 31): robot.sh --sim mujoco brings up mujoco_sim in
place of the mock controllers, and demo.sh --sim mujoco's pick and place (mtc_node, the
planning_server, the controllers, all unchanged) is judged by the simulator: the cylinder at the
place pose, upright, without slip; a grasp that does not close enough leaves the cylinder on the
table and the demo says FAILED.

demo.sh is `setup.sh` and then `python -m mycobot_planning.ros.demos.robot_demos demo "$@"`; the
tests run that module with this interpreter (setup.sh is tested on its own)."""
from __future__ import annotations

import re
import time
import shutil
import subprocess

import numpy as np
import pytest

from mycobot_planning.paths import config_file
from mycobot_planning.simulation.scene import load_scene
from ros_testing import PYTHON, REPO, NodeProcess, ros_env, use_session_domain, wait_until

DEMO = [PYTHON, "-m", "mycobot_planning.ros.demos.robot_demos", "demo", "--sim", "mujoco"]
FIGURES = re.compile(r"Simulated object at \(([-0-9.]+), ([-0-9.]+), ([-0-9.]+)\) m; figures: place_error_mm "
                     r"([0-9.]+), tilt_deg ([0-9.]+), slip_mm ([0-9.na]+)")


def run_demo(tmp_path, *args: str, which: str = "demo") -> tuple[int, str]:
    """robot_demos' ``which`` (demo.sh's "demo" or perception_demo.sh's "perception") with --sim mujoco."""
    env = ros_env()
    env["MYCOBOT_DEMO_DIR"] = str(tmp_path / "demo")
    command = [*DEMO[:3], which, *DEMO[4:], *args]
    run = subprocess.run(command, cwd=REPO, env=env, capture_output=True, text=True, timeout=600)
    return run.returncode, run.stdout + run.stderr


def figures(out: str) -> tuple[np.ndarray, float, float, float]:
    found = FIGURES.search(out)
    assert found, out[-4000:]
    values = [float(v) for v in found.groups()]
    return np.array(values[:3]), values[3], values[4], values[5]


def test_demo_sim_mujoco_places_the_cylinder_as_the_simulator_judges_it(tmp_path):
    code, out = run_demo(tmp_path)
    assert code == 0, out[-6000:]
    assert "starting mujoco_sim (the MuJoCo twin) and the planning_server" in out
    assert "Task executed successfully" in out
    assert "SUCCESS: the simulator says the object stands at the place pose" in out
    position, place_error_mm, tilt_deg, slip_mm = figures(out)
    # the seeds' place pose: (-0.183, -0.14), its centre half the 0.35 m height above the floor at -0.03
    assert np.linalg.norm(position - [-0.183, -0.14, 0.145]) <= 0.01
    assert place_error_mm <= 10.0 and tilt_deg <= 5.0 and slip_mm <= 5.0
    sim_log = (tmp_path / "demo" / "mujoco_sim.log").read_text()
    assert "mujoco_sim ready: arm_controller (6 joints, 100 Hz), grip_action_controller" in sim_log
    assert "Traceback" not in sim_log
    assert not (tmp_path / "demo" / "run" / "mujoco_sim.pid").exists()  # stopped again


def test_perception_demo_sim_mujoco_picks_the_cylinder_the_rendered_cloud_shows(tmp_path):
    """perception_demo.sh --sim mujoco: the cylinder's pose comes from the twin's rendered cloud
    (perception_server), not from the simulator; perceived within 5 mm of the true pose, then
    picked and placed as the simulator judges it."""
    code, out = run_demo(tmp_path, which="perception")
    assert code == 0, out[-6000:]
    found = re.search(r"perception error: the perceived cylinder's centre is ([0-9.]+) mm from the simulated one", out)
    assert found and float(found.group(1)) <= 5.0, out[-6000:]
    assert "SUCCESS: the simulator says the object stands at the place pose" in out
    position, place_error_mm, tilt_deg, slip_mm = figures(out)
    assert np.linalg.norm(position - [-0.183, -0.14, 0.145]) <= 0.01
    assert place_error_mm <= 10.0 and tilt_deg <= 5.0 and slip_mm <= 5.0
    assert "Traceback" not in (tmp_path / "demo" / "mujoco_sim.log").read_text()


def barely_closing_config(directory) -> str:
    """The myCobot's configuration with one more gripper state, 'barely_closed' (-0.2 rad: the pads
    stop short of the 25 mm cylinder, which they touch at -0.33)."""
    directory.mkdir()
    for name in ("mycobot_280.urdf", "joint_limits.yaml", "kinematics.yaml", "ompl_planning.yaml",
                 "moveit_controllers.yaml"):
        shutil.copy(config_file(name), directory / name)
    srdf = config_file("mycobot_280.srdf").read_text()
    state = '  <group_state name="barely_closed" group="gripper">\n' \
            '    <joint name="gripper_controller" value="-0.2"/>\n  </group_state>\n'
    anchor = '  <group_state name="closed" group="gripper">'
    assert anchor in srdf
    (directory / "mycobot_280.srdf").write_text(srdf.replace(anchor, state + anchor))
    return str(directory)


def test_a_grasp_that_does_not_close_enough_leaves_the_cylinder_on_the_table_and_the_demo_fails(tmp_path):
    config = barely_closing_config(tmp_path / "barely")
    code, out = run_demo(tmp_path, "-p", f"robot_config:={config}", "-p", "gripper_close_pose:=barely_closed")
    assert code == 1, out[-6000:]
    assert "FAILED: the simulator says:" in out
    # the twin stopped the lift when the cylinder stayed behind: the execution failed, the arm held
    assert "the held object 'object' left the hand" in out
    assert "mtc_node exited with code 3" in out
    position, place_error_mm, tilt_deg, _ = figures(out)
    start = load_scene(config_file("mujoco_scene.yaml")).object("object").pose[:3, 3]
    assert np.linalg.norm(position - start) < 0.005, (position, start)  # still standing on the table
    assert tilt_deg < 5.0
    assert place_error_mm > 100.0


def test_robot_sh_sim_mujoco_brings_up_the_twin_with_its_topics_and_stops_it(tmp_path):
    use_session_domain()
    env = ros_env()
    base = [PYTHON, "-m", "mycobot_planning.ros.bringup"]
    dirs = ["--log-dir", str(tmp_path / "logs"), "--run-dir", str(tmp_path / "run")]
    start = subprocess.run([*base, "start", "--sim", "mujoco", "--sim-param", "object_pose_rate:=10.0", *dirs],
                           cwd=REPO, env=env, capture_output=True, text=True, timeout=300)
    try:
        assert start.returncode == 0, start.stdout + start.stderr
        assert "mujoco_sim: started" in start.stdout and "mock_controllers" not in start.stdout
        assert "simulation: mujoco_sim simulates the arm" in start.stdout
        status = subprocess.run([*base, "status", *dirs], cwd=REPO, env=env, capture_output=True, text=True,
                                timeout=60)
        assert status.returncode == 0 and "mujoco_sim: running" in status.stdout, status.stdout
        from mycobot_planning.ros.demos.sim_verdict import TwinObserver

        with TwinObserver("test_twin_observer") as observer:
            pose = observer.wait_for_pose("object", 30.0)
            assert pose is not None, "no /mujoco_sim/object_poses"
            scene_pose = load_scene(config_file("mujoco_scene.yaml")).object("object").pose
            assert np.linalg.norm(pose[:3, 3] - scene_pose[:3, 3]) < 0.002  # standing where the scene put it
            # a status that has seen a full second of running carries the real-time factor
            assert wait_until(lambda: (observer.status_after(0.0, 1.0) or {}).get("time", 0.0) > 1.5, 30.0)
            status_msg = observer.status_after(0.0, 1.0)
            assert status_msg["running"] and status_msg["speed_factor"] == 1.0
            assert status_msg["real_time_factor"] > 0.5 and status_msg["holds"] == []
    finally:
        stop = subprocess.run([*base, "stop", *dirs], cwd=REPO, env=env, capture_output=True, text=True, timeout=120)
    assert stop.returncode == 0, stop.stdout + stop.stderr
    assert "mujoco_sim: stopped" in stop.stdout


@pytest.mark.parametrize("problem, named", [
    ("mass: 0.0", "object 'object' is a free body with mass 0"),
])
def test_mujoco_sim_refuses_a_bad_scene_before_anything_starts(tmp_path, problem, named):
    scene = config_file("mujoco_scene.yaml").read_text().replace("mass: 0.07", problem)
    assert problem in scene
    (tmp_path / "camera_scene.yaml").write_text(config_file("camera_scene.yaml").read_text())
    path = tmp_path / "bad_scene.yaml"
    path.write_text(scene)
    node = NodeProcess("mycobot_planning.nodes.mujoco_sim", ["--ros-args", "-p", f"scene_file:={path}"])
    try:
        assert wait_until(lambda: not node.running(), 60.0), "mujoco_sim kept running with a bad scene"
        assert node.returncode() == 1
        out = node.output()
        assert named in out, out
        assert "Traceback" not in out and "ready" not in out
    finally:
        node.stop()


def test_sim_usage_errors_of_robot_sh_and_demo_sh():
    base = [PYTHON, "-m", "mycobot_planning.ros.bringup"]
    for args, message in ((["start", "--sim", "gazebo"], "--sim needs a simulator (mujoco), got 'gazebo'"),
                          (["start", "--sim", "mujoco", "--hardware", "emulated"], "--sim and --hardware exclude"),
                          (["start", "--sim-param", "speed_factor:=0.5"], "--sim-param needs --sim"),
                          (["status", "--sim", "mujoco"], "--sim and --sim-param are for start/restart only")):
        result = subprocess.run([*base, *args], cwd=REPO, capture_output=True, text=True, timeout=60)
        assert result.returncode == 1 and message in result.stderr, (args, result.stderr)
    result = subprocess.run([*base, "--help"], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert result.returncode == 0 and "--sim mujoco" in result.stdout
    demo = subprocess.run([*DEMO[:-1], "gazebo"], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert demo.returncode == 2 and "--sim needs a simulator (mujoco), got 'gazebo'" in demo.stderr
    perception = subprocess.run([*DEMO[:3], "perception", "--sim=gazebo"], cwd=REPO, capture_output=True, text=True,
                                timeout=60)
    assert perception.returncode == 2 and "perception_demo.sh: --sim needs a simulator" in perception.stderr


def test_the_twins_rendered_cloud_shows_perception_the_cylinder_where_the_physics_has_it():
    """mujoco_sim's camera (camera_rate) -> perception_server: the perceived cylinder within 5 mm of
    its true position. The three settings of this world (docs/simulation.md, the depth camera):
    the floor 3 cm below the table, whose top is 10 x 20 cm."""
    from interfaces_py.perception_client import PerceptionClient
    from mycobot_planning.ros.demos.sim_verdict import TwinObserver

    use_session_domain()
    sim = NodeProcess("mycobot_planning.nodes.mujoco_sim", ["--ros-args", "-p", "camera_rate:=2.0"])
    perception = NodeProcess("mycobot_planning.nodes.perception_server", [
        "--ros-args", "--params-file", str(config_file("perception_server.yaml")), "-p", "z_tolerance:=0.01",
        "-p", "plane_voxel_leaf_size:=0.008", "-p", "min_cluster_size:=30", "-p", "cloud_frame_id:=world",
        "-p", "cloud_frame_pose:=[0.0, 0.0, 0.0, 0.0, 0.0, 0.0]", "-p", "apply_to_planning_server:=false"])
    try:
        with TwinObserver("test_perception_truth") as observer, PerceptionClient(timeout=30.0) as client:
            truth = observer.wait_for_rest("object", 60.0)
            assert truth is not None, sim.output()[-3000:]
            assert wait_until(lambda: "published the first rendered cloud" in sim.output(), 60.0), sim.output()[-3000:]
            result = None

            def detected() -> bool:
                nonlocal result
                result = client.get_planning_scene("cylinder", [0.35, 0.0125], apply=False)
                return bool(result)

            assert wait_until(detected, 60.0, period=1.0), (result.message if result else "", perception.output()[-3000:])
            target = next(s for s in result.summaries if s["id"] == result.target_object_id)
            assert target["shape"] == "cylinder"
            error = float(np.linalg.norm(np.asarray(target["position"]) - truth[:3, 3]))
            print(f"perception error against the simulated cylinder: {error * 1000:.2f} mm")
            assert error < 0.005, (target, truth[:3, 3])
            assert target["dimensions"][0] == pytest.approx(0.35, abs=0.01)
    finally:
        perception.stop()
        sim.stop()


def test_world_services_reset_pause_step_spawn_remove_and_speed():
    """mujoco_sim's world services (ros/controllers/sim_services.py) through the JSON face and
    std_srvs, with the object poses the simulator publishes as the judge: an overlapping spawn is
    refused naming what it overlaps, a free one falls onto the table and can be removed; pause
    freezes simulated time and step advances it by exactly the steps asked; reset brings the
    world back to the scene file, and is refused while the arm follows a goal."""
    from rclpy.parameter import Parameter
    from std_srvs.srv import SetBool
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    from interfaces_py.json_rpc import BAD_REQUEST, JsonRpcClient, RpcError
    from mycobot_planning.ros.controllers.sim_services import NO_SUCH_OBJECT, SIM_BUSY, SPAWN_REFUSED
    from mycobot_planning.ros.demos.sim_verdict import TwinObserver
    from ros_testing import ProbeNode

    def refused(method: str, params: dict, code: int, words: str) -> None:
        with pytest.raises(RpcError) as caught:
            rpc.call(method, params, timeout=30.0)
        assert caught.value.code == code and words in caught.value.message, (caught.value.code, caught.value.message)

    use_session_domain()
    sim = NodeProcess("mycobot_planning.nodes.mujoco_sim", [])
    probe = ProbeNode("test_world_services")
    probe.spin_in_background()
    try:
        rpc = JsonRpcClient(probe.node, "/mujoco_sim")
        with TwinObserver("test_world_truth") as observer:
            assert wait_until(lambda: "mujoco_sim ready" in sim.output(), 90.0), sim.output()[-3000:]
            assert rpc.wait_for_server(30.0)
            start = observer.wait_for_rest("object", 60.0)
            assert start is not None, sim.output()[-3000:]
            # spawning: refused when it overlaps (named, nothing added), bad input refused, a free one falls
            box = {"id": "crate", "shape": "box", "size": [0.03, 0.03, 0.03], "pose": [0.22, 0.12, 0.1, 0, 0, 0],
                   "mass": 0.05}
            refused("spawn_object", {"object": box}, SPAWN_REFUSED, "it overlaps 'object'")
            refused("spawn_object", {"object": {**box, "shape": "cone"}}, SPAWN_REFUSED, "shape must be one of")
            refused("spawn_object", {"thing": box}, BAD_REQUEST, "takes one parameter, object")
            free = {**box, "pose": [0.22, 0.20, 0.08, 0, 0, 0]}
            assert rpc.call("spawn_object", {"object": free}, timeout=30.0)["id"] == "crate"
            refused("spawn_object", {"object": free}, SPAWN_REFUSED, "'crate'")
            landed = observer.wait_for_rest("crate", 30.0)
            assert landed is not None and landed[2, 3] == pytest.approx(0.015, abs=0.003), landed  # on the table
            refused("remove_object", {"id": "ghost"}, NO_SUCH_OBJECT, "no object 'ghost'")
            assert "crate" not in rpc.call("remove_object", {"id": "crate"}, timeout=30.0)["objects"]
            assert wait_until(lambda: observer.pose("crate") is None, 10.0)
            # pause and step
            refused("step", {"steps": 10}, SIM_BUSY, "pause it first")
            answer = probe.call(SetBool, "/mujoco_sim/pause", SetBool.Request(data=True))
            assert answer.success, answer.message
            paused_at = rpc.call("sim_status", {}, timeout=30.0)
            assert paused_at["paused"]
            time.sleep(0.3)
            assert rpc.call("sim_status", {}, timeout=30.0)["time"] == paused_at["time"]
            stepped = rpc.call("step", {"steps": 100}, timeout=30.0)
            assert stepped["time"] == pytest.approx(paused_at["time"] + 100 * 0.001, abs=1e-6), (stepped, paused_at)
            refused("step", {"steps": 0}, BAD_REQUEST, "steps must be an integer")
            refused("step", {"steps": 1.5}, BAD_REQUEST, "steps must be an integer")
            answer = probe.call(SetBool, "/mujoco_sim/pause", SetBool.Request(data=False))
            assert answer.success, answer.message
            assert wait_until(lambda: rpc.call("sim_status", {}, timeout=30.0)["time"] > stepped["time"] + 0.2, 10.0)
            # reset: refused while the arm follows a goal, then the world as the scene file has it
            rpc.call("spawn_object", {"object": free}, timeout=30.0)
            assert observer.wait_for_pose("crate", 10.0) is not None
            command = probe.node.create_publisher(JointTrajectory, "/arm_controller/joint_trajectory", 10)
            point = JointTrajectoryPoint(positions=[0.3, 0.0, 0.0, 0.0, 0.0, 0.0])
            point.time_from_start.sec = 3
            msg = JointTrajectory(joint_names=[*(f"link{i}_to_link{i + 1}" for i in range(1, 6)), "link6_to_link6_flange"],
                                 points=[point])
            assert wait_until(lambda: command.get_subscription_count() > 0, 10.0)
            mark = len(sim.output())
            command.publish(msg)
            assert wait_until(lambda: "executing goal" in sim.output()[mark:], 10.0), sim.output()[-2000:]
            busy = probe.trigger("/mujoco_sim/reset_world")
            assert not busy.success and "arm_controller is executing goal" in busy.message, busy.message
            assert observer.pose("crate") is not None  # nothing was reset
            speed = probe.set_param("mujoco_sim", Parameter("speed_factor", value=0.5))
            assert not speed.successful and "cannot change speed_factor while arm_controller" in speed.reason
            assert probe.trigger("/arm_controller/stop").success
            # the speed factor, settable while no goal runs
            assert probe.set_param("mujoco_sim", Parameter("speed_factor", value=0.5)).successful
            assert rpc.call("sim_status", {}, timeout=30.0)["speed_factor"] == 0.5
            assert not probe.set_param("mujoco_sim", Parameter("speed_factor", value=-1.0)).successful
            assert probe.set_param("mujoco_sim", Parameter("speed_factor", value=0.0)).successful  # the file's
            assert rpc.call("sim_status", {}, timeout=30.0)["speed_factor"] == 1.0
            done = probe.trigger("/mujoco_sim/reset_world")
            assert done.success, done.message
            assert wait_until(lambda: observer.pose("crate") is None, 10.0)
            back = observer.wait_for_rest("object", 30.0)
            assert back is not None and np.linalg.norm(back[:3, 3] - start[:3, 3]) < 0.002, (back, start)
            assert "Traceback" not in sim.output()
    finally:
        probe.close()
        sim.stop()


def test_the_viewer_shows_the_simulated_world_at_its_true_poses():
    """task_viewer beside mujoco_sim: the page draws the simulator's objects where the physics has
    them (its /mujoco_sim/object_poses), with their shapes from the simulator's ``world``; an
    object spawned in the simulation appears, a removed one goes."""
    from interfaces_py.json_rpc import JsonRpcClient
    from mycobot_planning.ros.demos.sim_verdict import TwinObserver
    from ros_testing import ProbeNode

    use_session_domain()
    sim = NodeProcess("mycobot_planning.nodes.mujoco_sim", [])
    viewer = NodeProcess("mycobot_planning.nodes.task_viewer", ["--ros-args", "-p", "port:=0", "-p", "servo_node:=''"])
    probe = ProbeNode("test_sim_world_view")
    probe.spin_in_background()
    try:
        sim_rpc, page = JsonRpcClient(probe.node, "/mujoco_sim"), JsonRpcClient(probe.node, "/task_viewer")
        with TwinObserver("test_sim_world_truth") as observer:
            assert wait_until(lambda: "mujoco_sim ready" in sim.output(), 90.0), sim.output()[-3000:]
            assert page.wait_for_server(90.0), viewer.output()[-3000:]
            truth = observer.wait_for_rest("object", 60.0)
            assert truth is not None, sim.output()[-3000:]
            world = {o["id"]: o for o in sim_rpc.call("world", {}, timeout=30.0)["objects"]}
            assert world["object"]["shape"] == "cylinder"

            def shown() -> dict:
                return page.call("get_state", {}, timeout=15.0)["sim_world"]["objects"]
            assert wait_until(lambda: set(world) <= set(shown()), 60.0), (shown(), viewer.output()[-2000:])
            drawn = shown()["object"]
            assert np.linalg.norm(np.array(drawn["position"]) - truth[:3, 3]) < 0.001, (drawn, truth)
            assert drawn["shapes"] == ["cylinder"]
            assert drawn["colour"] == [int(round(255 * c)) for c in world["object"]["color"][:3]]
            crate = {"id": "crate", "shape": "box", "size": [0.03, 0.03, 0.03], "pose": [0.22, 0.20, 0.08, 0, 0, 0],
                     "mass": 0.05}
            sim_rpc.call("spawn_object", {"object": crate}, timeout=30.0)
            landed = observer.wait_for_rest("crate", 30.0)
            assert landed is not None
            assert wait_until(lambda: "crate" in shown() and np.linalg.norm(
                np.array(shown()["crate"]["position"]) - landed[:3, 3]) < 0.001, 30.0), shown()
            sim_rpc.call("remove_object", {"id": "crate"}, timeout=30.0)
            assert wait_until(lambda: "crate" not in shown(), 30.0), shown()
        assert "Traceback" not in viewer.output() and "Traceback" not in sim.output()
    finally:
        probe.close()
        viewer.stop()
        sim.stop()
