"""The seeds' task-constructor demos, ROS-free: modular, fallbacks_move_to, ik_clearance_cost.

Each builder returns a Task ready to ``plan()``; the demo nodes wrap them (scene from the
planning_server, parameters from YAML, solutions published and executed). Stage names, tree
shapes and solver settings follow the tutorials exactly, so printState reads the same.

* ``build_modular_task``: "Reusable Containers": current → move to ready (joint interpolation)
  → five "Cartesian Path" modules (x +0.05, y -0.02, rz -18° with a CartesianPath solver,
  moveTo ready with joint interpolation; group inherited from the module) → move to home.
* ``build_fallbacks_move_to_task``: "fallback strategies in MoveTo": an Alternatives of three
  initial states ("90 degree offset from target goal", "directly reachable without
  collision", "getting to target requires collision avoidance" with a thin box) and a
  Fallbacks "move to other side" of MoveTo stages with a Cartesian (jump threshold 2.0), an
  industrial PTP and an OMPL RRTConnect planner, all to 'ready' with link1_to_link2 = +tau/8.
* ``build_ik_clearance_cost_task``: "clearance IK": ComputeIK "IK" (up to 100 solutions,
  timeout 1 s) wrapping FixedState "initial state" (arm 'ready' beside a sphere obstacle),
  target (-0.183, 0.0175, 0.15) rotated 45° about x, ranked by a Clearance cost term.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping

import yaml

from interfaces_py.msgs import CollisionObject

from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.core.transforms import make_pose
from mycobot_planning.task.containers import Alternatives, Fallbacks, SerialContainer
from mycobot_planning.task.cost_terms import Clearance
from mycobot_planning.task.geometry import PoseStamped, TwistStamped, Vector3Stamped
from mycobot_planning.task.solvers import CartesianPath, JointInterpolationPlanner, PipelinePlanner
from mycobot_planning.paths import config_dir
from mycobot_planning.task.stage import Stage
from mycobot_planning.task.stages import ComputeIK, CurrentState, FixedState, MoveRelative, MoveTo
from mycobot_planning.task.task import Task

__all__ = [
    "IK_CLEARANCE_COST_PARAMETERS",
    "build_fallbacks_move_to_task",
    "build_ik_clearance_cost_task",
    "build_modular_task",
    "fallbacks_initial_cases",
    "fallbacks_initial_scene",
    "fallbacks_target_state",
    "ik_clearance_cost_scene",
    "load_ik_clearance_cost_parameters",
]

TAU = 2.0 * math.pi


# ---------------------------------------------------------------------------- modular
def _create_module(group: str) -> SerialContainer:
    """The tutorial's reusable "Cartesian Path" module (createModule)."""
    c = SerialContainer("Cartesian Path")
    c.setProperty("group", group)
    cartesian = CartesianPath()
    joint_interpolation = JointInterpolationPlanner()

    stage = MoveRelative("x +0.05", cartesian)
    stage.properties.configureInitFrom(Stage.PARENT, ["group"])
    stage.setDirection(Vector3Stamped("base_link", [0.05, 0.0, 0.0]))
    c.insert(stage)

    stage = MoveRelative("y -0.02", cartesian)
    stage.properties.configureInitFrom(Stage.PARENT)
    stage.setDirection(Vector3Stamped("base_link", [0.0, -0.02, 0.0]))
    c.insert(stage)

    stage = MoveRelative("rz -18°", cartesian)
    stage.properties.configureInitFrom(Stage.PARENT)
    stage.setDirection(TwistStamped("base_link", linear=[0.0, 0.0, 0.0], angular=[0.0, 0.0, -math.pi / 10.0]))
    c.insert(stage)

    stage = MoveTo("moveTo ready", joint_interpolation)
    stage.properties.configureInitFrom(Stage.PARENT)
    stage.setGoal("ready")
    c.insert(stage)
    return c


def build_modular_task(model: RobotModel, scene: PlanningScene | None = None, *, group: str = "arm",
                       modules: int = 5, seed: int | None = 0) -> Task:
    """The seed's modular demo ("Reusable Containers"); ``scene`` is the current scene."""
    task = Task("Reusable Containers", model, scene, seed=seed)
    task.add(CurrentState("current"))
    stage = MoveTo("move to ready", JointInterpolationPlanner())
    stage.setGroup(group)
    stage.setGoal("ready")
    task.add(stage)
    for _ in range(modules):
        task.add(_create_module(group))
    stage = MoveTo("move to home", JointInterpolationPlanner())
    stage.setGroup(group)
    stage.setGoal("home")
    task.add(stage)
    return task


# ---------------------------------------------------------------------------- fallbacks_move_to
def fallbacks_initial_scene(model: RobotModel, base: PlanningScene | None = None) -> PlanningScene:
    """The seed's initial scene: ``base`` (or an empty scene) with the arm in 'ready'."""
    scene = base.copy() if base is not None else PlanningScene(model)
    state = scene.current_state.copy()
    state.set_named("ready", "arm")
    scene.set_current_state(state)
    return scene


def fallbacks_target_state(model: RobotModel) -> dict[str, float]:
    """The seed's goal of "move to other side": arm 'ready' with link1_to_link2 at +TAU/8."""
    target_state = dict(model.named_state("ready", "arm"))
    target_state["link1_to_link2"] = +TAU / 8
    return target_state


def fallbacks_initial_cases(model: RobotModel, scene_for_initial_state: PlanningScene | None = None
                            ) -> list[tuple[str, PlanningScene]]:
    """The seed's three initial states (a, b, c), each a diff of the initial scene: (a) 90 degrees
    from the target, (b) directly reachable, (c) the target behind a thin box (collision avoidance)."""
    initial_scene = fallbacks_initial_scene(model, scene_for_initial_state)
    cases = []
    scene = initial_scene.diff()
    scene.set_current_state({"link1_to_link2": -TAU / 8})
    cases.append(("90 degree offset from target goal", scene))
    scene = initial_scene.diff()
    scene.set_current_state({"link1_to_link2": +TAU / 8, "link3_to_link4": 0.0})
    cases.append(("directly reachable without collision", scene))
    scene = initial_scene.diff()
    scene.set_current_state({"link1_to_link2": -TAU / 8})
    scene.apply_collision_object(CollisionObject.box("box", [0.005, 0.1, 0.32], make_pose([0.02, -0.20, 0.32 / 2]),
                                                     frame_id="base_link"))
    cases.append(("getting to target requires collision avoidance", scene))
    return cases


def build_fallbacks_move_to_task(model: RobotModel, scene_for_initial_state: PlanningScene | None = None, *,
                                 seed: int | None = 0, pipeline=None) -> Task:
    """The seed's fallbacks_move_to demo ("fallback strategies in MoveTo")."""
    task = Task("fallback strategies in MoveTo", model, seed=seed, pipeline=pipeline)

    cartesian = CartesianPath()
    cartesian.setJumpThreshold(2.0)
    pilz_planner = PipelinePlanner({"pilz_industrial_motion_planner": "PTP"})
    ompl_planner = PipelinePlanner({"ompl": "arm[RRTConnectkConfigDefault]"})

    target_state = fallbacks_target_state(model)

    initial_alternatives = Alternatives("initial states")
    for name, scene in fallbacks_initial_cases(model, scene_for_initial_state):
        fixed = FixedState(name)
        fixed.setState(scene)
        initial_alternatives.add(fixed)
    task.add(initial_alternatives)

    fallbacks = Fallbacks("move to other side")
    for solver, name in ((cartesian, "Cartesian path"), (pilz_planner, "Pilz path"), (ompl_planner, "OMPL path")):
        move_to = MoveTo(name, solver)
        move_to.setGroup("arm")
        move_to.setGoal(dict(target_state))
        fallbacks.add(move_to)
    task.add(fallbacks)
    return task


# ---------------------------------------------------------------------------- ik_clearance_cost
#: Defaults of config/ik_clearance_cost_parameters.yaml (the seed's parameter file).
IK_CLEARANCE_COST_PARAMETERS: dict[str, bool] = {"cumulative": False, "with_world": True}


def load_ik_clearance_cost_parameters(path: str | Path | None = None) -> dict[str, bool]:
    """``cumulative`` and ``with_world`` from the YAML file (ros__parameters format; default:
    config/ik_clearance_cost_parameters.yaml). Raises ValueError naming a bad or unknown key."""
    if path is None:
        path = Path(config_dir()) / "ik_clearance_cost_parameters.yaml"
    with open(path, encoding="utf-8") as handle:
        data = yaml.safe_load(handle) or {}
    params: Mapping[str, Any] = data
    if len(data) == 1 and isinstance(next(iter(data.values())), Mapping):
        params = next(iter(data.values()))  # node name
    if "ros__parameters" in params:
        params = params["ros__parameters"] or {}
    out = dict(IK_CLEARANCE_COST_PARAMETERS)
    for key, value in params.items():
        if key not in out:
            raise ValueError(f"{path}: unknown parameter '{key}' (known: {', '.join(out)})")
        if not isinstance(value, bool):
            raise ValueError(f"{path}: parameter '{key}' must be true or false, got {value!r}")
        out[key] = value
    return out


def ik_clearance_cost_scene(model: RobotModel, base: PlanningScene | None = None) -> PlanningScene:
    """The seed's scene: default state, arm 'ready', sphere 'obstacle' r=0.1 at (-0.183, -0.14,
    0.15) in the model frame."""
    scene = base.copy() if base is not None else PlanningScene(model)
    state = RobotState(model)
    state.set_named("ready", "arm")
    scene.set_current_state(state)
    scene.apply_collision_object(CollisionObject.sphere("obstacle", 0.1, make_pose([-0.183, -0.14, 0.15])))
    return scene


def build_ik_clearance_cost_task(model: RobotModel, scene: PlanningScene | None = None, cumulative: bool = False,
                                 with_world: bool = True, *, seed: int | None = 0) -> Task:
    """The seed's ik_clearance_cost demo ("clearance IK"); ``scene`` defaults to
    :func:`ik_clearance_cost_scene`."""
    if scene is None:
        scene = ik_clearance_cost_scene(model)
    task = Task("clearance IK", model, seed=seed)

    initial = FixedState("initial state")
    initial.setState(scene)
    initial.setIgnoreCollisions(True)

    ik = ComputeIK("IK", initial)
    ik.setGroup("arm")
    ik.setTargetPose(PoseStamped("", make_pose([-0.183, 0.0175, 0.15], rpy=[math.pi / 4, 0.0, 0.0])))
    ik.setTimeout(1.0)
    ik.setMaxIKSolutions(100)

    cost = Clearance()
    cost.cumulative = bool(cumulative)
    cost.with_world = bool(with_world)
    ik.setCostTerm(cost)

    task.add(ik)
    return task
