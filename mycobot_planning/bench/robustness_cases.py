"""The robustness bench's bad inputs (issue 13): cases generated systematically from a few good
requests, per interface of our nodes (the planning_server's RPC, raw garbage, topics, the
controllers, ``ros2 param set``, MoveIt's face through robustness_moveit.py). What is done with
them, and what counts as refused: robustness.py (the runner).
"""
from __future__ import annotations

import copy
import json
from dataclasses import dataclass
from typing import Any

from .ros_scenarios import ARM_JOINTS

__all__ = ["Case", "all_cases", "controller_cases", "moveit_cases", "param_cases", "raw_cases", "rpc_cases",
           "topic_cases"]

NAN, INF = float("nan"), float("inf")
#: Values that are wrong for any field whatever its type (besides the per-field ones).
ODD_STRINGS = ["t\ud800x", "bad\x00id", "bell\x07", "x" * 5000]
HOME = [0.0] * 6


@dataclass
class Case:
    """One bad input: where it goes and what it is."""

    interface: str  # "rpc", "rpc_raw", "topic", "param", "controller", "moveit"
    name: str
    payload: Any
    target: str = ""  # method, topic, node or controller
    timeout: float = 15.0
    #: For garbage without a readable id, nobody can be answered: the server must log the refusal.
    logged: str = ""


def _box(**change: Any) -> dict[str, Any]:
    box = {"id": "fuzz_box", "primitives": [{"type": 1, "dimensions": [0.05, 0.05, 0.05]}],
           "primitive_poses": [{}], "pose": {"position": [0.25, -0.2, 0.3]}}
    box.update(change)
    return box


def _mutations(base: dict[str, Any], bad: dict[str, list[Any]], prefix: str) -> list[tuple[str, dict[str, Any]]]:
    """``base`` with each field replaced by each of its bad values, one at a time; a value of
    the marker ``...`` removes the field."""
    out = []
    for key, values in bad.items():
        for k, value in enumerate(values):
            request = copy.deepcopy(base)
            target, path = request, key.split(".")
            for part in path[:-1]:
                target = target[part]
            if value is Ellipsis:
                target.pop(path[-1], None)
                label = f"{prefix}.{key}=<missing>"
            else:
                target[path[-1]] = value
                label = f"{prefix}.{key}[{k}]={_short(value)}"
            out.append((label, request))
    return out


def _short(value: Any) -> str:
    text = ascii(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _trajectory(points: list[tuple[list[float], float]], names: list[str] | None = None, **extra: Any) -> dict:
    return {"joint_names": names or ARM_JOINTS,
            "points": [{"positions": p, "time_from_start": t, **extra} for p, t in points]}


def _bad_trajectories() -> list[tuple[str, dict]]:
    """Trajectories that must never move the arm (positions relative to the home pose)."""
    whip = [0.0, 1.5, 0.0, 0.0, 0.0, 0.0]
    return [
        ("whip 1.5 rad in 1 ms", _trajectory([(HOME, 0.0), (whip, 0.001)])),
        ("lead-in whip", _trajectory([(whip, 0.001)])),
        ("stated overspeed", {"joint_names": ARM_JOINTS, "points": [
            {"positions": HOME, "velocities": [0.0] * 6, "time_from_start": 0.0},
            {"positions": [0.0, 0.05, 0, 0, 0, 0], "velocities": [0, 50.0, 0, 0, 0, 0], "time_from_start": 1.0}]}),
        ("unknown joint", _trajectory([(HOME, 0.0), (HOME, 1.0)], names=ARM_JOINTS[:5] + ["elbow_of_mars"])),
        ("duplicate joint", _trajectory([(HOME, 0.0), (HOME, 1.0)], names=ARM_JOINTS[:5] + [ARM_JOINTS[0]])),
        ("too few positions", _trajectory([([0.0] * 5, 0.0), ([0.0] * 5, 1.0)])),
        ("too many positions", _trajectory([([0.0] * 7, 0.0), ([0.0] * 7, 1.0)])),
        ("NaN position", _trajectory([(HOME, 0.0), ([NAN] + [0.0] * 5, 1.0)])),
        ("infinite position", _trajectory([(HOME, 0.0), ([INF] + [0.0] * 5, 1.0)])),
        ("beyond joint limits", _trajectory([(HOME, 0.0), ([0.0, 9.0, 0, 0, 0, 0], 20.0)])),
        ("times not increasing", _trajectory([(HOME, 0.0), ([0.0, 0.1, 0, 0, 0, 0], 1.0), (HOME, 0.5)])),
        ("negative time", _trajectory([(HOME, -1.0), ([0.0, 0.1, 0, 0, 0, 0], 1.0)])),
        ("far from the start", _trajectory([([0.0, 1.0, 0, 0, 0, 0], 0.0), ([0.0, 1.1, 0, 0, 0, 0], 1.0)])),
    ]


def rpc_cases() -> list[Case]:
    """JSON-RPC requests to the planning_server, mutated field by field."""
    cases: list[Case] = []
    plan = {"group": "arm", "goal": {"named": "ready"}, "allowed_planning_time": 2.0}
    wrong = [True, "text", [], {}, *ODD_STRINGS[:2]]
    plan_bad = {
        "group": [1, "", "legs", *ODD_STRINGS, ["arm"], {"a": 1}],
        "goal": [Ellipsis, 1, "ready", [], {}, {"named": 1}, {"named": "moon"}, {"named": "ready", "joints": HOME},
                 {"joints": [0.1, 0.2]}, {"joints": [NAN] * 6}, {"joints": [1e308] * 6}, {"joints": "a"},
                 {"joints": {"elbow_of_mars": 0.0}}, {"pose": [1e308, 0, 0.2, 1, 0, 0, 0]},
                 {"pose": [0.15, 0.0, 0.2, 0, 0, 0, 0]}, {"pose": [0.1] * 6}, {"pose": "up"},
                 {"pose": [NAN, 0, 0.2, 1, 0, 0, 0]}, {"named": "ready", "tolerance": -1},
                 {"named": "ready", "tolerance": NAN}, {"named": "ready", "extra": 1},
                 {"pose": [0.15, 0, 0.2, 1, 0, 0, 0], "position_tolerance": -0.1},
                 {"pose": [0.15, 0, 0.2, 1, 0, 0, 0], "orientation_tolerance": -1},
                 {"pose": [0.15, 0, 0.2, 1, 0, 0, 0], "link": "nolink"}, {"named": "t\ud800x"}],
        "allowed_planning_time": [-1.0, 1e9, INF, NAN, *wrong],
        "num_planning_attempts": [-1, 10 ** 9, 1.5, *wrong],
        "max_velocity_scaling_factor": [-0.5, 2.0, INF, *wrong],
        "max_acceleration_scaling_factor": [-0.5, 7.0, NAN, *wrong],
        "pipeline_id": ["magic", 1, *ODD_STRINGS[:2]],
        "planner_id": ["Magic", 5, "t\ud800x"],
        "start_state": [1, "x", {"joint_names": ["elbow_of_mars"], "positions": [0.0]},
                        {"joint_names": ["link2_to_link3"], "positions": [9.0]},
                        {"joint_names": ["link2_to_link3"], "positions": []},
                        {"joint_names": ["link2_to_link3"], "positions": [NAN]},
                        {"joint_names": ["link2_to_link3", "link2_to_link3"], "positions": [0.0, 0.0]}],
        "seed": ["x", 1.5, []],
        "circ_center": [[1, 2], "x", [NAN, 0, 0]],
        "num_ik_goals": [0, -1, "x"],
        "bogus": [1],
    }
    for label, request in _mutations(plan, plan_bad, "plan"):
        cases.append(Case("rpc", label, request, "plan"))
    for label, request in _mutations(plan, {"goal": plan_bad["goal"][1:8], "group": plan_bad["group"][:4]},
                                     "plan_and_execute"):
        cases.append(Case("rpc", label, request, "plan_and_execute"))

    cartesian = {"group": "arm", "waypoints": [[0.15, 0.0, 0.2, 1.0, 0.0, 0.0, 0.0]]}
    cartesian_bad = {
        "group": [1, "legs", "t\ud800x"],
        "waypoints": [Ellipsis, [], "x", [[1e308, 0, 0, 1, 0, 0, 0]], [[0.9, 0.0, 0.2, 1, 0, 0, 0]] * 100_000,
                      [[NAN] * 7], [[0.1] * 3], [{"position": [0.1]}], [[0, 0, 0, 0, 0, 0, 0]]],
        "frame": ["mars", "", 1, "t\ud800x"],
        "link": ["nolink", 1],
        "eef_step": [0.0, -0.01, NAN, 1e-12, "x"],
        "jump_threshold": [-1.0, NAN, "x"],
        "avoid_collisions": ["yes", 1],
        "max_velocity_scaling_factor": [5.0, -1.0],
        "ik_frame_offset": [[1e9, 0, 0, 0, 0, 0, 1], "x"],
        "start_state": [{"joint_names": ["link2_to_link3"], "positions": [9.0]}],
        "bogus": [1],
    }
    for label, request in _mutations(cartesian, cartesian_bad, "cartesian"):
        cases.append(Case("rpc", label, request, "compute_cartesian_path", timeout=40.0))

    for label, trajectory in _bad_trajectories():
        cases.append(Case("rpc", f"execute {label}", {"trajectory": trajectory}, "execute"))
    cases += [Case("rpc", f"execute.{k}", p, "execute") for k, p in [
        ("trajectory=1", {"trajectory": 1}), ("trajectory=text", {"trajectory": "x"}),
        ("controllers=nope", {"trajectory": _trajectory([(HOME, 0.0), (HOME, 1.0)]), "controllers": ["nope"]}),
        ("controllers=1", {"controllers": 1}), ("wait=yes", {"wait": "yes"}), ("bogus", {"bogus": 1}),
        ("empty trajectory", {"trajectory": {"joint_names": ARM_JOINTS, "points": []}}),
        ("no joints", {"trajectory": {"joint_names": [], "points": [{"positions": [], "time_from_start": 0.0}]}}),
    ]]
    for label, trajectory in _bad_trajectories()[:6]:
        cases.append(Case("rpc", f"execute_task_solution {label}", {"steps": [{"trajectory": trajectory}]},
                          "execute_task_solution"))
    cases += [Case("rpc", f"execute_task_solution.{k}", p, "execute_task_solution") for k, p in [
        ("steps=1", {"steps": 1}), ("steps=[1]", {"steps": [1]}), ("solution=x", {"solution": "x"}),
        ("bogus", {"bogus": 1}), ("scene diff bad", {"steps": [{"scene_diff": {"world": 1}}]}),
    ]]

    object_bad = {
        "id": [Ellipsis, "", 1, *ODD_STRINGS, "tab\tid", "line\nid"],
        "frame_id": ["", 1, "bad\x00frame", "t\ud800x"],
        "primitives": [1, [{"type": 9, "dimensions": [0.1]}], [{"type": 1, "dimensions": [0.1, 0.1]}],
                       [{"type": 1, "dimensions": [1e9, 0.1, 0.1]}], [{"type": 1, "dimensions": [1e300, 1, 1]}],
                       [{"type": 1, "dimensions": [0.1, -0.1, 0.1]}], [{"type": 1, "dimensions": [0.1, 0.0, 0.1]}],
                       [{"type": 2, "dimensions": [NAN]}], [{"type": 3, "dimensions": [INF, 0.1]}]],
        "primitive_poses": [[], [{}, {}], [{"position": [1e9, 0, 0]}], [{"orientation": [0, 0, 0, 0]}]],
        "pose": [{"position": [1e9, 0.0, 0.0]}, {"position": [1e300, 0, 0]}, {"position": [NAN, 0, 0]},
                 {"position": [0, 0]}, {"orientation": [0, 0, 0, 0]}, "x"],
        "operation": [7, -1, "ADD"],
        "meshes": [[{"vertices": [[0, 0, 0], [1e6, 0, 0], [0, 1, 0]], "triangles": [[0, 1, 2]]}],
                   [{"vertices": [[0, 0, 0]], "triangles": [[0, 1, 2]]}]],
        "bogus": [1],
    }
    for label, obj in _mutations(_box(), object_bad, "object"):
        cases.append(Case("rpc", label, {"object": obj}, "apply_collision_object"))
    # an 11 MB batch of good boxes with one bad one: all or nothing
    batch = [_box(id=f"batch_{i}") for i in range(24_000)] + [_box(id="batch_bad", primitives=[
        {"type": 1, "dimensions": [0.1, -0.1, 0.1]}])]
    cases.append(Case("rpc", "objects: 11 MB batch with one bad box", {"objects": batch}, "apply_collision_object",
                      timeout=60.0))
    cases += [Case("rpc", f"apply_collision_object.{k}", p, "apply_collision_object") for k, p in [
        ("both", {"object": _box(), "objects": [_box()]}), ("neither", {}), ("objects=[]", {"objects": []}),
        ("objects=1", {"objects": 1}), ("remove unknown", {"object": {"id": "nothing_here", "operation": 1}}),
        ("move unknown", {"object": {"id": "nothing_here", "operation": 3}}),
    ]]

    attach_bad = {
        "object_id": [Ellipsis, "", 1, "nothing_here", *ODD_STRINGS[:3]],
        "link_name": ["nolink", 1, "t\ud800x"],
        "touch_links": ["x", [1], ["finger\x00"]],
        "weight": [-1.0, "x", NAN],
        "bogus": [1],
    }
    for label, request in _mutations({"object_id": "table", "link_name": "link6_flange"}, attach_bad, "attach"):
        cases.append(Case("rpc", label, request, "attach_object"))
    cases += [Case("rpc", f"attach.attached_object[{k}]", {"attached_object": a}, "attach_object") for k, a in [
        (0, {"link_name": "nolink", "object": _box()}), (1, {"link_name": "link6_flange", "object": _box(id="")}),
        (2, {"link_name": "link6_flange", "object": _box(), "weight": -2.0}),
        (3, {"link_name": "link6_flange", "object": _box(), "touch_links": ["bad\x00"]}), (4, 1)]]
    for k, value in enumerate(["", 1, "nothing_here", "t\ud800x", None, []]):
        cases.append(Case("rpc", f"detach.object_id[{k}]={_short(value)}", {"object_id": value}, "detach_object"))
    cases += [Case("rpc", f"get_objects.ids[{k}]={_short(v)}", {"ids": v}, "get_objects")
              for k, v in enumerate(["x", [1], {"a": 1}])]
    cases += [Case("rpc", f"{m}.bogus", {"bogus": 1}, m) for m in ("get_planning_scene", "get_objects",
                                                                     "detach_object")]

    scene_bad = [
        ("robot_state outside limits", {"robot_state": {"joint_names": ["link2_to_link3"], "positions": [9.0],
                                                        "is_diff": True}}),
        ("robot_state unknown joint", {"robot_state": {"joint_names": ["elbow_of_mars"], "positions": [0.0],
                                                       "is_diff": True}}),
        ("robot_state NaN", {"robot_state": {"joint_names": ["link2_to_link3"], "positions": [NAN]}}),
        ("robot_state count", {"robot_state": {"joint_names": ["link2_to_link3"], "positions": [0.0, 0.1]}}),
        ("acm unknown entry", {"allowed_collision_matrix": {"entry_names": ["ghost", "link1"],
                                                            "entry_values": [[False, True], [True, False]]}}),
        ("acm unknown default", {"allowed_collision_matrix": {"default_entry_names": ["nowhere"],
                                                              "default_entry_values": [True]}}),
        ("acm not square", {"allowed_collision_matrix": {"entry_names": ["link1"], "entry_values": [[True, True]]}}),
        ("acm asymmetric", {"allowed_collision_matrix": {"entry_names": ["link1", "link2"],
                                                         "entry_values": [[False, True], [False, False]]}}),
        ("acm bad name", {"allowed_collision_matrix": {"default_entry_names": ["bad\x00"],
                                                       "default_entry_values": [True]}}),
        ("world bad object", {"world": {"collision_objects": [_box(id="ok_one"), _box(id="t\ud800x")]}}),
        ("world huge box", {"world": {"collision_objects": [_box(primitives=[
            {"type": 1, "dimensions": [1e9, 1, 1]}])]}}),
        ("attached to nolink", {"robot_state": {"is_diff": True, "attached_collision_objects": [
            {"link_name": "nolink", "object": _box()}]}}),
        ("other robot", {"robot_model_name": "ur5"}),
        ("world=1", {"world": 1}), ("bogus", {"bogus": 1}), ("name bad", {"name": "bad\x00"}),
    ]
    for label, diff in scene_bad:
        cases.append(Case("rpc", f"apply_planning_scene {label}", {"scene": {"is_diff": True, **diff}},
                          "apply_planning_scene"))
    cases += [Case("rpc", "apply_planning_scene.scene=<missing>", {}, "apply_planning_scene"),
              Case("rpc", "apply_planning_scene.scene=1", {"scene": 1}, "apply_planning_scene")]
    return cases


def raw_cases() -> list[Case]:
    """Protocol-level garbage on /planning_server/requests (answered when an id can be read)."""
    def envelope(method: Any = "get_state", params: Any = None, **extra: Any) -> str:
        body = {"id": "RID", "method": method, "params": {} if params is None else params, **extra}
        return json.dumps(body)

    deep = '{"id": "RID", "method": "plan", "params": {"goal": ' + "[" * 5000 + "]" * 5000 + "}}"
    unanswerable = [Case("rpc_raw", name, text, "requests", logged="rejected a request") for name, text in [
        ("JSON array", '["RID"]'), ("JSON number", "42"), ("empty text", ""), ("id not a string", '{"id": 5}')]]
    return unanswerable + [Case("rpc_raw", name, text, "requests", timeout=20.0) for name, text in [
        ("not JSON", '{"id": "RID", garbage'), ("unknown method", envelope("fly")), ("method not a string", envelope(7)),
        ("method surrogate", envelope("t\ud800x")), ("params not an object", envelope(params=[1])),
        ("unknown envelope key", envelope(extra=1)), ("nested 5000 deep", deep),
        ("nested 100 deep", envelope("plan", {"goal": json.loads("[" * 100 + "]" * 100)})),
        ("17 MB payload", envelope("plan", {"goal": {"named": "x" * (17 * 1024 * 1024)}})),
        ("NaN literal", '{"id": "RID", "method": "plan", "params": {"goal": {"joints": [NaN, 0, 0, 0, 0, 0]}}}'),
        ("key surrogate", '{"id": "RID", "method": "plan", "params": {"\\ud800": 1}}'),
    ]]


def topic_cases() -> list[Case]:
    """JSON on the scene topics: refused (logged), nothing applied, node alive."""
    cases = []
    texts = [("not JSON", "{garbage"), ("array", "[1, 2]"), ("deep", "[" * 5000 + "]" * 5000),
             ("surrogate id", json.dumps(_box(id="bad\ud800id"))), ("NUL id", json.dumps(_box(id="bad\x00id"))),
             ("huge box", json.dumps(_box(primitives=[{"type": 1, "dimensions": [1e300, 1, 1]}]))),
             ("far box", json.dumps(_box(pose={"position": [1e9, 0, 0]}))),
             ("negative box", json.dumps(_box(primitives=[{"type": 1, "dimensions": [0.1, -0.1, 0.1]}]))),
             ("unknown field", json.dumps(_box(bogus=1)))]
    for name, text in texts:
        cases.append(Case("topic", f"/planning_server/collision_object {name}", text, "/planning_server/collision_object"))
    for name, text in [("not JSON", "{garbage"), ("array", "[1, 2]"),
                       ("nolink", json.dumps({"link_name": "nolink", "object": _box()})),
                       ("surrogate", json.dumps({"link_name": "link6_flange", "object": _box(id="t\ud800x")}))]:
        cases.append(Case("topic", f"/planning_server/attached_collision_object {name}", text, "/planning_server/attached_collision_object"))
    for name, text in [("not JSON", "{garbage"), ("acm ghost", json.dumps({"is_diff": True, "allowed_collision_matrix": {
            "default_entry_names": ["ghost"], "default_entry_values": [True]}})),
            ("robot_state outside", json.dumps({"is_diff": True, "robot_state": {
                "joint_names": ["link2_to_link3"], "positions": [9.0], "is_diff": True}}))]:
        cases.append(Case("topic", f"/planning_server/planning_scene {name}", text, "/planning_server/planning_scene"))
    return cases


def controller_cases() -> list[Case]:
    """trajectory_msgs/JointTrajectory straight to /arm_controller/joint_trajectory: nothing moves."""
    return [Case("controller", name, trajectory, "arm_controller") for name, trajectory in _bad_trajectories()
            if name not in ("NaN position", "infinite position")] + [
        Case("controller", "NaN position", _trajectory([(HOME, 0.0), ([NAN] + [0.0] * 5, 1.0)]), "arm_controller"),
        Case("controller", "gripper whip", {"joint_names": ["gripper_controller"], "points": [
            {"positions": [0.0], "time_from_start": 0.0}, {"positions": [-0.5], "time_from_start": 0.0005}]},
            "grip_action_controller")]


def param_cases() -> list[Case]:
    """`ros2 param set` with values that name nothing or are out of range."""
    server = [("planner_id", "Magic"), ("goal.joint_values", [0.1, 0.2]), ("goal.group", "legs"),
              ("goal.named_target", "moon"), ("goal.link", "nolink"), ("goal.pose", [0.1, 0.2]),
              ("goal.pose", [0.1, 0.2, 0.3, 0.0, 0.0, 0.0, 0.0]), ("planning_time", -1.0), ("planning_time", 1e9),
              ("planning_attempts", 0), ("max_velocity_scaling_factor", 2.0), ("planning_pipeline", "magic"),
              ("joint_state_timeout", 0.0), ("scene_publish_rate", 0.0), ("trajectory_execution.goal_tolerance", -1.0),
              ("trajectory_execution.allowed_start_tolerance", -0.5), ("trajectory_execution.limit_tolerance", -1.0),
              ("trajectory_execution.allowed_execution_duration_scaling", 0.5), ("planning_time", "fast"),
              ("robot_description", "<robot/>")]
    mtc = [("arm_group_name", "legs"), ("gripper_group_name", "claws"), ("gripper_frame", "nolink"),
           ("world_frame", "mars"), ("arm_home_pose", "moon"), ("gripper_open_pose", "wide"),
           ("controller_names", ["nope"]), ("table_dimensions", [0.1]), ("table_dimensions", [0.1, -0.2, 0.03]),
           ("object_name", ""), ("object_pose", [0.1, 0.2]), ("cartesian_step_size", 0.0),
           ("approach_object_min_dist", 5.0), ("max_solutions", -1), ("planning_timeout", -1.0),
           ("lift_object_direction_z", 0.0), ("table_reference_frame", "mars"), ("planning_server", "/other")]
    controllers = [("publish_rate", 0.0), ("publish_rate", 1e9), ("arm_controller.fail_after", NAN),
                   ("limit_tolerance", 0.5), ("initial_positions.link2_to_link3", 9.0)]
    cases = [Case("param", f"planning_server {n}={_short(v)}", (n, v), "planning_server") for n, v in server]
    cases += [Case("param", f"mtc_node {n}={_short(v)}", (n, v), "mtc_node") for n, v in mtc]
    cases += [Case("param", f"controller_manager {n}={_short(v)}", (n, v), "controller_manager")
              for n, v in controllers]
    return cases


def moveit_cases() -> list[Case]:
    """MoveIt's face: real moveit_msgs requests and goals (see robustness_moveit)."""
    from .robustness_moveit import moveit_inputs

    return [Case("moveit", name, given, given.name, timeout=30.0) for name, given in moveit_inputs()]


def all_cases() -> list[Case]:
    return rpc_cases() + raw_cases() + topic_cases() + controller_cases() + param_cases() + moveit_cases()
