"""Robustness: hundreds of bad inputs over every interface of our nodes, as a careless or hostile
client would send them (issue 13). Shared by the ``robustness`` bench and test/test_robustness.py.

The cases are generated systematically from a few good requests: each field of a good request
gets the values that are wrong for it (wrong types, missing and extra fields, non-finite and
extreme numbers, odd strings: empty, NUL, control characters, lone surrogates, oversized), plus
protocol-level garbage (not JSON, deep nesting, oversized payloads), bad trajectories on the
controllers' topics and bad ``ros2 param set`` values on every node; and (issue 27) MoveIt's
face: real moveit_msgs / control_msgs requests and goals to move_group's services and actions
and to the controllers' FollowJointTrajectory actions (robustness_moveit.py).

Summary keys: inputs, refused, accepted_bad, crashes, hangs, half_applied (a refused input left
the scene or a planner's parameters changed), unsafe_motions (the robot moved); all but
refused must be 0.

For each case the runner checks what a user relies on:
* the node answers it (a hang is a case that got no answer within its timeout),
* the answer refuses it and names the problem (RPC ``ok: false`` with a message, a MoveIt error
  code other than SUCCESS with a message, a parameter refusal with a reason); an answer that
  leaks Python internals (``Traceback``, ``IndexError`` ...) counts as accepted_bad,
* the planning scene and the robot are unchanged afterwards (else half_applied, unsafe_motion),
  and every node is still alive.

Inputs without an answer (topics) are refused when the node stays alive and nothing changed.
"""
from __future__ import annotations

import copy
import json
import math
import os
import threading
import time
import uuid
from dataclasses import dataclass, field
from typing import Any, Callable

from .common import emit, machine
from .ros_scenarios import ARM_JOINTS, RobotProcesses, bench_domain_id

NAN, INF = float("nan"), float("inf")
INTERNAL_WORDS = ("Traceback", "IndexError", "KeyError", "TypeError:", "AttributeError", "ZeroDivisionError",
                  "RecursionError", "UnicodeEncodeError", "NoneType")
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


@dataclass
class Outcome:
    case: Case
    verdict: str  # refused, accepted_bad, half_applied, unsafe_motion, crash, hang
    detail: str = ""


@dataclass
class Report:
    outcomes: list[Outcome] = field(default_factory=list)

    def count(self, verdict: str) -> int:
        return sum(1 for o in self.outcomes if o.verdict == verdict)

    def failures(self) -> list[Outcome]:
        return [o for o in self.outcomes if o.verdict != "refused"]

    def summary(self) -> dict[str, Any]:
        return {"inputs": len(self.outcomes), "refused": self.count("refused"),
                "accepted_bad": self.count("accepted_bad"), "crashes": self.count("crash"),
                "hangs": self.count("hang"), "half_applied": self.count("half_applied"),
                "unsafe_motions": self.count("unsafe_motion"),
                "failing_cases": [f"{o.case.interface}:{o.case.name}: {o.verdict} ({o.detail[:160]})"
                                  for o in self.failures()[:20]]}


# ---------------------------------------------------------------------------- the cases
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


# ---------------------------------------------------------------------------- the runner
class Prober:
    """One private rclpy node that sends every kind of input and reads the answers."""

    def __init__(self) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState
        from std_msgs.msg import String
        from trajectory_msgs.msg import JointTrajectory
        from interfaces_py.background_spin import BackgroundSpin

        from interfaces_py.json_rpc import RPC_QOS

        self.context = Context()
        rclpy.init(context=self.context)
        self.node = Node(f"robustness_prober_{os.getpid()}", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.lock = threading.Lock()
        self.answers: dict[str, dict] = {}
        self.joints: dict[str, float] = {}
        self.requests = self.node.create_publisher(String, "/planning_server/requests", RPC_QOS)
        self.node.create_subscription(String, "/planning_server/responses", self._on_answer, RPC_QOS)
        self.node.create_subscription(JointState, "/joint_states", self._on_joints, 10)
        self.topics = {t: self.node.create_publisher(String, t, QoSProfile(
            depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE))
            for t in ("/planning_server/collision_object", "/planning_server/attached_collision_object", "/planning_server/planning_scene")}
        self.controllers = {c: self.node.create_publisher(JointTrajectory, f"/{c}/joint_trajectory", 10)
                            for c in ("arm_controller", "grip_action_controller")}
        self._param_clients: dict[str, Any] = {}
        self._moveit_clients: dict[str, Any] = {}
        self.spinner = BackgroundSpin(self.executor, name="robustness probe")

    def _on_answer(self, msg: Any) -> None:
        try:
            envelope = json.loads(msg.data)
        except ValueError:
            return
        if isinstance(envelope, dict) and isinstance(envelope.get("id"), str):
            with self.lock:
                self.answers[envelope["id"]] = envelope

    def _on_joints(self, msg: Any) -> None:
        with self.lock:
            self.joints = dict(zip(msg.name, msg.position))

    def wait_ready(self, timeout: float = 60.0) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if (self.requests.get_subscription_count() > 0 and self.node.count_publishers("/planning_server/responses")
                    and self.joints and all(p.get_subscription_count() > 0 for p in self.topics.values())
                    and all(p.get_subscription_count() > 0 for p in self.controllers.values())):
                try:
                    self.call("get_state", {}, 10.0)
                    return
                except TimeoutError:
                    pass
            time.sleep(0.1)
        raise RuntimeError("the nodes do not answer")

    def send_raw(self, text: str, request_id: str, timeout: float) -> dict | None:
        from std_msgs.msg import String

        self.requests.publish(String(data=text))
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self.lock:
                if request_id in self.answers:
                    return self.answers.pop(request_id)
            time.sleep(0.005)
        return None

    def call(self, method: str, params: Any, timeout: float = 15.0) -> dict:
        request_id = uuid.uuid4().hex
        text = json.dumps({"id": request_id, "method": method, "params": params})
        answer = self.send_raw(text, request_id, timeout)
        if answer is None:
            raise TimeoutError(f"{method}: no answer within {timeout} s")
        return answer

    def set_param(self, node: str, name: str, value: Any, timeout: float = 10.0) -> Any:
        from rcl_interfaces.srv import SetParameters
        from rclpy.parameter import Parameter

        client = self._param_clients.get(node)
        if client is None:
            client = self._param_clients[node] = self.node.create_client(SetParameters, f"/{node}/set_parameters")
        if not client.wait_for_service(timeout_sec=timeout):
            return None
        future = client.call_async(SetParameters.Request(parameters=[Parameter(name, value=value).to_parameter_msg()]))
        deadline = time.monotonic() + timeout
        while not future.done() and time.monotonic() < deadline:
            time.sleep(0.005)
        return future.result().results[0] if future.done() else None

    def _wait(self, future: Any, timeout: float) -> Any:
        deadline = time.monotonic() + timeout
        while not future.done() and time.monotonic() < deadline:
            time.sleep(0.005)
        return future.result() if future.done() else None

    def moveit_call(self, srv_type: Any, name: str, request: Any, timeout: float) -> Any:
        """A move_group service's response (None: no answer within ``timeout``)."""
        client = self._moveit_clients.get(name)
        if client is None:
            client = self._moveit_clients[name] = self.node.create_client(srv_type, name)
        if not client.wait_for_service(timeout_sec=timeout):
            return None
        return self._wait(client.call_async(request), timeout)

    def moveit_goal(self, action_type: Any, name: str, goal: Any, timeout: float) -> tuple[str, Any]:
        """("rejected", None), ("done", get_result response) or ("hang", what did not come)."""
        from rclpy.qos import QoSProfile

        from interfaces_py.action_client import ActionClient

        client = self._moveit_clients.get(name)
        if client is None:
            deep = {f"{k}_service_qos_profile": QoSProfile(depth=100) for k in ("goal", "result", "cancel")}
            client = self._moveit_clients[name] = ActionClient(self.node, action_type, name, **deep)
        if not client.wait_for_server(timeout_sec=timeout):
            return "hang", "the action server is not there"
        handle = self._wait(client.send_goal_async(goal), timeout)
        if handle is None:
            return "hang", "no goal response"
        if not handle.accepted:
            return "rejected", None
        result = self._wait(handle.get_result_async(), timeout)
        return ("done", result) if result is not None else ("hang", "no result")

    def publish_trajectory(self, controller: str, data: dict) -> None:
        from builtin_interfaces.msg import Duration
        from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

        msg = JointTrajectory(joint_names=data["joint_names"])
        for p in data["points"]:
            t = p["time_from_start"]
            sec = math.floor(t)
            point = JointTrajectoryPoint(positions=[float(v) for v in p["positions"]],
                                         time_from_start=Duration(sec=int(sec), nanosec=int((t - sec) * 1e9)))
            if p.get("velocities"):
                point.velocities = [float(v) for v in p["velocities"]]
            msg.points.append(point)
        self.controllers[controller].publish(msg)

    def close(self) -> None:
        import rclpy

        self.spinner.stop()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def _problem_text(text: str) -> str | None:
    """Why an answer's text is not a clear refusal, or None."""
    if not text or not text.strip():
        return "the answer gives no reason"
    leaked = [w for w in INTERNAL_WORDS if w in text]
    if leaked:
        return f"the answer leaks internals ({leaked[0]}): {text[:200]}"
    return None


class Runner:
    """Runs cases against live nodes and judges each (see the module docstring)."""

    def __init__(self, prober: Prober, processes: dict[str, Any], log: Callable[[str], str]) -> None:
        self.prober = prober
        self.processes = processes  # name -> subprocess.Popen
        self.log = log  # node name -> its log so far

    def _dead(self) -> str | None:
        dead = [name for name, proc in self.processes.items() if proc.poll() is not None]
        return f"{', '.join(dead)} died" if dead else None

    def snapshot(self) -> tuple[Any, dict[str, float]]:
        answer = self.prober.call("get_planning_scene", {}, 20.0)
        scene = answer["result"]
        world = sorted((o["id"], json.dumps(o, sort_keys=True)) for o in scene["world"]["collision_objects"])
        attached = sorted(a["object"]["id"] for a in scene["robot_state"]["attached_collision_objects"])
        acm = json.dumps(scene["allowed_collision_matrix"], sort_keys=True)
        with self.prober.lock:
            joints = dict(self.prober.joints)
        return (world, attached, acm), joints

    def _changed(self, before: tuple[Any, dict[str, float]]) -> tuple[str, str] | None:
        """(verdict, what) when a refused input left something behind: the scene changed
        (half_applied) or the robot moved (unsafe_motion)."""
        scene, joints = self.snapshot()
        if scene != before[0]:
            return "half_applied", "the planning scene changed"
        moved = [n for n in ARM_JOINTS + ["gripper_controller"]
                 if n in joints and abs(joints[n] - before[1].get(n, joints[n])) > 1e-4]
        return ("unsafe_motion", f"the robot moved ({moved})") if moved else None

    def judge(self, case: Case) -> Outcome:
        before = self.snapshot()
        started = time.monotonic()
        verdict, detail = self._send(case)
        if verdict == "refused" and case.interface in ("controller", "topic", "moveit"):
            time.sleep(0.3)  # let a wrongly accepted command show its effect
        dead = self._dead()
        if dead is not None:
            return Outcome(case, "crash", dead)
        if verdict != "refused":
            return Outcome(case, verdict, detail)
        try:
            changed = self._changed(before)
        except (TimeoutError, KeyError, TypeError) as exc:
            return Outcome(case, "hang", f"the planning_server stopped answering: {exc}")
        if changed is not None:
            return Outcome(case, changed[0], f"{changed[1]}; answer: {detail}")
        return Outcome(case, "refused", f"{detail} ({time.monotonic() - started:.2f} s)")

    def _send(self, case: Case) -> tuple[str, str]:
        p = self.prober
        if case.interface == "rpc":
            try:
                answer = p.call(case.target, case.payload, case.timeout)
            except TimeoutError as exc:
                return "hang", str(exc)
            return self._judge_rpc(answer)
        if case.interface == "rpc_raw" and case.logged:
            seen = self.log("planning_server").count(case.logged)
            from std_msgs.msg import String

            p.requests.publish(String(data=case.payload))
            deadline = time.monotonic() + case.timeout
            while time.monotonic() < deadline:
                if self.log("planning_server").count(case.logged) > seen:
                    return "refused", f"logged '{case.logged}' (no id to answer to)"
                time.sleep(0.02)
            return "hang", f"the planning_server neither answered nor logged '{case.logged}'"
        if case.interface == "rpc_raw":
            request_id = uuid.uuid4().hex
            answer = p.send_raw(case.payload.replace("RID", request_id), request_id, case.timeout)
            if answer is None:
                return "hang", "no answer"
            return self._judge_rpc(answer)
        if case.interface == "topic":
            from std_msgs.msg import String

            p.topics[case.target].publish(String(data=case.payload))
            time.sleep(0.2)
            return "refused", "no answer expected on a topic"
        if case.interface == "controller":
            p.publish_trajectory(case.target, case.payload)
            return "refused", "no answer expected on a topic"
        if case.interface == "param":
            name, value = case.payload
            result = p.set_param(case.target, name, value)
            if result is None:
                return "hang", f"{case.target} did not answer set_parameters"
            if result.successful:
                return "accepted_bad", "Set parameter successful"
            problem = _problem_text(result.reason)
            return ("accepted_bad", problem) if problem else ("refused", result.reason)
        if case.interface == "moveit":
            return self._send_moveit(case)
        raise ValueError(f"unknown interface {case.interface}")

    def _send_moveit(self, case: Case) -> tuple[str, str]:
        given, p = case.payload, self.prober
        if given.kind == "planner_params":
            from moveit_msgs.srv import GetPlannerParams

            ask = GetPlannerParams.Request(pipeline_id="ompl", planner_config="RRTkConfigDefault")
            before = p.moveit_call(GetPlannerParams, "/get_planner_params", ask, case.timeout)
            if p.moveit_call(given.type, given.name, given.build(), case.timeout) is None:
                return "hang", "set_planner_params did not answer"
            after = p.moveit_call(GetPlannerParams, "/get_planner_params", ask, case.timeout)
            if before is None or after is None:
                return "hang", "get_planner_params did not answer"
            unchanged = (list(before.params.keys), list(before.params.values)) == \
                (list(after.params.keys), list(after.params.values))
            return ("refused", "the parameters are unchanged") if unchanged else \
                ("half_applied", f"the parameters changed: {dict(zip(after.params.keys, after.params.values))}")
        if given.kind == "action":
            from action_msgs.msg import GoalStatus

            state, answer = p.moveit_goal(given.type, given.name, given.build(), case.timeout)
            if state == "rejected":
                return "refused", "goal rejected"
            if state == "hang":
                return "hang", answer
            if hasattr(answer.result, "error_string"):  # control_msgs/FollowJointTrajectory
                if answer.status == GoalStatus.STATUS_SUCCEEDED or answer.result.error_code == 0:
                    return "accepted_bad", f"the controller's goal succeeded: {answer.result.error_string[:120]}"
                problem = _problem_text(answer.result.error_string)
                return ("accepted_bad", problem) if problem else \
                    ("refused", f"{answer.result.error_code}: {answer.result.error_string}")
            if answer.status == GoalStatus.STATUS_SUCCEEDED:
                return "accepted_bad", f"the goal succeeded: {answer.result.error_code.message[:120]}"
            return self._judge_code(answer.result.error_code)
        response = p.moveit_call(given.type, given.name, given.build(), case.timeout)
        if response is None:
            return "hang", f"{given.name} did not answer"
        if hasattr(response, "motion_plan_response"):
            return self._judge_code(response.motion_plan_response.error_code)
        if hasattr(response, "error_code"):
            return self._judge_code(response.error_code)
        if hasattr(response, "valid"):
            return ("accepted_bad", "answered valid") if response.valid else ("refused", "valid: false")
        if hasattr(response, "success"):
            return ("accepted_bad", "answered success") if response.success else ("refused", "success: false")
        return "accepted_bad", f"no way to tell a refusal from {type(response).__name__}"

    @staticmethod
    def _judge_code(code: Any) -> tuple[str, str]:
        """A moveit_msgs/MoveItErrorCodes: a refusal is a value other than SUCCESS with a clear
        message; an internal error (the face's catch-all) is no refusal."""
        message = str(code.message)
        if code.val == 1:
            return "accepted_bad", f"answered SUCCESS: {message[:120]}"
        problem = _problem_text(message)
        if problem is None and "internal error" in message:
            problem = f"an internal error, not a refusal: {message[:120]}"
        return ("accepted_bad", problem) if problem else ("refused", f"{code.val}: {message}")

    @staticmethod
    def _judge_rpc(answer: dict) -> tuple[str, str]:
        if not answer.get("ok"):
            message = str((answer.get("error") or {}).get("message", ""))
            problem = _problem_text(message)
            return ("accepted_bad", problem) if problem else ("refused", message)
        result = answer.get("result") or {}
        code = result.get("error_code") if isinstance(result, dict) else None
        if isinstance(code, dict) and code.get("val") != 1:
            message = str(code.get("message", ""))
            problem = _problem_text(message)
            return ("accepted_bad", problem) if problem else ("refused", message)
        return "accepted_bad", f"answered as a success: {json.dumps(result)[:200]}"

    def run(self, cases: list[Case], progress: Callable[[int, Outcome], None] | None = None) -> Report:
        report = Report()
        for k, case in enumerate(cases):
            outcome = self.judge(case)
            report.outcomes.append(outcome)
            if progress is not None:
                progress(k, outcome)
            if outcome.verdict == "crash":
                break  # the rest would only repeat it
        return report


class RobustnessSystem:
    """mock_controllers + planning_server + mtc_node (its start-up plan done) and a Prober."""

    def __init__(self, domain: int) -> None:
        self.processes = RobotProcesses(domain, extra_nodes={
            "mtc_node": (["--ros-args", "-p", "max_solutions:=1"], "MTC pick and place completed")})
        self.prober: Prober | None = None

    def __enter__(self) -> "RobustnessSystem":
        self.processes.__enter__()
        try:
            self.prober = Prober()
            self.prober.wait_ready()
        except BaseException:
            self.close()
            raise
        return self

    def runner(self) -> Runner:
        assert self.prober is not None
        return Runner(self.prober, self.processes.procs, self.processes.log)

    def close(self) -> None:
        if self.prober is not None:
            self.prober.close()
        self.processes.close()

    def __exit__(self, *exc: Any) -> None:
        self.close()


def bench_robustness(repeat: int, seed: int) -> None:
    """Every case once per repeat; the summary counts the verdicts (all but refused must be 0)."""
    cases = all_cases()
    totals: dict[str, int] = {}
    failing: list[str] = []
    with RobustnessSystem(bench_domain_id()) as system:
        runner = system.runner()
        for index in range(repeat):
            started = time.perf_counter()
            report = runner.run(cases)
            summary = report.summary()
            emit({"scenario": "robustness", "repeat": index, "seconds": round(time.perf_counter() - started, 2),
                  **{k: v for k, v in summary.items() if k != "failing_cases"}})
            for key in ("inputs", "refused", "accepted_bad", "crashes", "hangs", "half_applied", "unsafe_motions"):
                totals[key] = totals.get(key, 0) + summary[key]
            failing += [f for f in summary["failing_cases"] if f not in failing]
    emit({"scenario": "robustness", "summary": True, **totals, "failing_cases": failing[:20], **machine()})
