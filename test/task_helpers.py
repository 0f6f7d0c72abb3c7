"""Shared helpers for the task-constructor tests (scenes, validation of whole solutions)."""
from __future__ import annotations

from typing import Any

import numpy as np

from interfaces_py.msgs import CollisionObject, TaskSolution
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.robot_trajectory.robot_trajectory import joint_trajectory_to_timed
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory
from mycobot_planning.core.transforms import make_pose
from mycobot_planning.task import (
    CartesianPath,
    JointInterpolationPlanner,
    PipelinePlanner,
    PoseStamped,
    SerialContainer,
    Stage,
    Task,
    Vector3Stamped,
    stages,
)


def scene_at(model: RobotModel, named: str = "ready", **joints: float) -> PlanningScene:
    scene = PlanningScene(model)
    state = RobotState(model)
    state.set_named(named, "arm")
    if joints:
        state.set_joint_positions(joints)
    scene.set_current_state(state)
    return scene


def current_state_task(model: RobotModel, name: str, named: str = "home") -> Task:
    """A task that starts from the current state ("current") of the arm at ``named``."""
    task = Task(name, model, scene_at(model, named))
    task.add(stages.CurrentState("current"))
    return task


def panda_start_scene(model: RobotModel, arm: str = "panda_arm", hand: str = "hand") -> PlanningScene:
    """The start of MTC's Panda demos: the arm at 'ready', the hand 'open'."""
    scene = PlanningScene(model)
    state = scene.current_state.copy()
    state.set_named("ready", arm)
    state.set_named("open", hand)
    scene.set_current_state(state)
    return scene


def table_scene(model: RobotModel, named: str = "home") -> PlanningScene:
    """The seeds' pick-and-place table (0.10 x 0.20 x 0.03, top at z=0, centred (0.22, 0.12))
    with the cylinder 'object' (h 0.35, r 0.0125) standing on it."""
    scene = scene_at(model, named)
    scene.add_object(CollisionObject.box("table", [0.10, 0.20, 0.03], make_pose([0.22, 0.12, -0.015]), frame_id="base_link"))
    scene.add_object(CollisionObject.cylinder("object", 0.35, 0.0125, make_pose([0.22, 0.12, 0.175]), frame_id="base_link"))
    return scene


def assert_solution_valid(solution) -> int:
    """Every sub-trajectory passes the core validator in the scene it starts from (attached
    objects and allowed collisions included) and starts where its start state is. Returns how
    many trajectories were checked."""
    checked = 0
    for sub in solution.sub_trajectories():
        if sub.trajectory is None:
            continue
        scene = sub.start.scene
        report = validate_trajectory(scene, sub.trajectory, sub.group, scene.current_state)
        assert report.valid, f"{sub.creator.path}: {report.problems}"
        end = sub.end.scene.current_state.group_positions(sub.group)
        assert np.allclose(sub.trajectory.positions[-1], end, atol=1e-6), f"{sub.creator.path}: does not end at its end state"
        checked += 1
    return checked


#: MTC's JointInterpolationPlanner max_step: the largest joint motion between two waypoints
MAX_WAYPOINT_GAP = 0.1


def waypoint_spacing(solution) -> list[dict]:
    """For every sub-trajectory with motion: its stage path, the largest joint motion between
    consecutive waypoints and, when a CartesianPath planned it, the largest ik-frame translation
    between consecutive waypoints and the planner's step_size."""
    from mycobot_planning.task import CartesianPath
    from mycobot_planning.task.geometry import robot_tip_for_frame

    out = []
    for sub in solution.sub_trajectories():
        traj = sub.trajectory
        if traj is None or len(traj) < 2:
            continue
        entry = {"stage": sub.creator.path, "points": len(traj),
                 "max_joint_gap": float(np.max(np.abs(np.diff(traj.positions, axis=0))))}
        planner = getattr(sub.creator, "planner", None)
        if isinstance(planner, CartesianPath):
            scene = sub.start.scene
            link, ik_pose = robot_tip_for_frame(sub.creator.properties.get("ik_frame"), scene, sub.group)
            offset = np.linalg.solve(scene.current_state.frame_pose(link), ik_pose)
            state = scene.current_state.copy()
            indices = [scene.robot_model.variable_index(n) for n in traj.joint_names]
            points = []
            for row in traj.positions:
                values = np.array(state.positions)
                values[indices] = row
                state.set_positions(values)
                points.append((state.frame_pose(link) @ offset)[:3, 3])
            entry["max_cartesian_step"] = float(np.max(np.linalg.norm(np.diff(points, axis=0), axis=1)))
            entry["step_size"] = float(planner.properties["step_size"])
        out.append(entry)
    return out


def spacing_problems(spacing: list[dict], max_gap: float = MAX_WAYPOINT_GAP) -> list[str]:
    """The sub-trajectories of waypoint_spacing() whose waypoints are too far apart."""
    problems = [f"{e['stage']}: joint gap {e['max_joint_gap']:.4f} > {max_gap}" for e in spacing
                if e["max_joint_gap"] > max_gap + 1e-9]
    problems += [f"{e['stage']}: Cartesian step {e['max_cartesian_step']:.5f} > step_size {e['step_size']}"
                 for e in spacing if "step_size" in e and e["max_cartesian_step"] > e["step_size"] + 1e-6]
    return problems


def chain_is_continuous(solution) -> None:
    """Consecutive steps meet: each step starts where the previous one ended (joint values)."""
    subs = solution.sub_trajectories()
    for previous, current in zip(subs, subs[1:]):
        a = previous.end.scene.current_state.positions
        b = current.start.scene.current_state.positions
        assert np.allclose(a, b, atol=1e-6), f"{previous.creator.path} -> {current.creator.path}: {a} != {b}"


GRIPPER_FRAME = "link6_flange"
GRASP_FRAME = make_pose([0.0, 0.0, 0.096], rpy=[1.5708, 0.0, 0.0])  # the seed's grasp_frame_transform
PLACE = make_pose([-0.183, -0.14, 0.185])
CONTROLLERS = ["arm_controller", "grip_action_controller"]


def _arm_container(task: Task, name: str) -> SerialContainer:
    """A serial container that takes the task's eef, group and ik_frame (the seed's pick and place)."""
    container = SerialContainer(name)
    task.properties.exposeTo(container.properties, ["eef", "group", "ik_frame"])
    container.properties.configureInitFrom(Stage.PARENT, ["eef", "group", "ik_frame"])
    return container


def _cartesian_move(name: str, planner: CartesianPath, min_distance: float, max_distance: float,
                    direction: Vector3Stamped, ik_frame: str | None = None) -> stages.MoveRelative:
    """A MoveRelative of the parent's group along ``direction`` (of the ik frame, when given)."""
    stage = stages.MoveRelative(name, planner)
    stage.properties.configureInitFrom(Stage.PARENT, ["group"])
    stage.setMinMaxDistance(min_distance, max_distance)
    if ik_frame is not None:
        stage.setIKFrame(ik_frame)
    stage.setDirection(direction)
    return stage


def _connect(name: str, ompl: PipelinePlanner, interpolation: JointInterpolationPlanner, timeout: float) -> stages.Connect:
    """A Connect that plans the arm with OMPL and the gripper by interpolation, properties from the parent."""
    stage = stages.Connect(name, [("arm", ompl), ("gripper", interpolation)])
    stage.setTimeout(timeout)
    stage.properties.configureInitFrom(Stage.PARENT)
    return stage


def _gripper_move(name: str, planner: JointInterpolationPlanner, goal: str) -> stages.MoveTo:
    """A MoveTo of the gripper to its named state ``goal``."""
    stage = stages.MoveTo(name, planner)
    stage.setGroup("gripper")
    stage.setGoal(goal)
    return stage


def _collisions(name: str, first: Any, second: Any, allow: bool) -> stages.ModifyPlanningScene:
    """A ModifyPlanningScene that allows (or forbids) collisions between ``first`` and ``second``."""
    stage = stages.ModifyPlanningScene(name)
    stage.allowCollisions(first, second, allow)
    return stage


def _grasp_frame_ik(name: str, generator: Stage, max_solutions: int) -> stages.ComputeIK:
    """IK of the grasp frame for the poses of ``generator``, eef and group from the parent."""
    ik = stages.ComputeIK(name, generator)
    ik.setMaxIKSolutions(max_solutions)
    ik.setIKFrame(GRASP_FRAME, GRIPPER_FRAME)
    ik.properties.configureInitFrom(Stage.PARENT, ["eef", "group"])
    ik.properties.configureInitFrom(Stage.INTERFACE, ["target_pose"])
    return ik


def build_pick_place(model) -> Task:
    task = Task("pick_place_task", model, table_scene(model), seed=3)
    ompl = PipelinePlanner({"ompl": "arm[RRTConnectkConfigDefault]"})
    interpolation = JointInterpolationPlanner()
    cartesian = CartesianPath()
    cartesian.setStepSize(0.0025)
    task.setProperty("trajectory_execution_info", CONTROLLERS)
    task.setProperty("group", "arm")
    task.setProperty("eef", "gripper")
    task.setProperty("ik_frame", GRIPPER_FRAME)

    current = stages.CurrentState("current state")
    task.add(current)
    stage = _gripper_move("open gripper", interpolation, "open")
    stage.setTrajectoryExecutionInfo(CONTROLLERS)
    task.add(stage)
    task.add(_connect("move to pick", ompl, interpolation, 5.0))

    grasp = _arm_container(task, "pick object")
    grasp.insert(_cartesian_move("approach object", cartesian, 0.0015, 0.3, Vector3Stamped(GRIPPER_FRAME, [0.0, 0.0, 1.0])))
    generator = stages.GenerateGraspPose("generate grasp pose")
    generator.properties.configureInitFrom(Stage.PARENT)
    generator.setPreGraspPose("open")
    generator.setObject("object")
    generator.setAngleDelta(0.2618)  # the seed's grasp_pose_angle_delta
    generator.setMonitoredStage(current)
    ik = _grasp_frame_ik("grasp pose IK", generator, 8)
    ik.setMinSolutionDistance(1.0)
    ik.setTimeout(0.2)  # robust under load; the search usually saturates well before
    grasp.insert(ik)
    grasp.insert(_collisions("allow collision (gripper,object)", "object", model.group("gripper"), True))
    grasp.insert(_gripper_move("close gripper", interpolation, "half_closed"))
    attach = stages.ModifyPlanningScene("attach object")
    attach.attachObject("object", GRIPPER_FRAME)
    grasp.insert(attach)
    grasp.insert(_collisions("allow collision (object,support)", ["object"], ["table"], True))
    grasp.insert(_cartesian_move("lift object", cartesian, 0.005, 0.3, Vector3Stamped("base_link", [0.0, 0.0, 1.0]),
                                 GRIPPER_FRAME))
    grasp.insert(_collisions("forbid collision (object,surface)", ["object"], ["table"], False))
    task.add(grasp)

    task.add(_connect("move to place", ompl, interpolation, 10.0))

    place = _arm_container(task, "place object")
    place.insert(_cartesian_move("lower object", cartesian, 0.005, 0.4, Vector3Stamped("base_link", [0.0, 0.0, -1.0])))
    generator = stages.GeneratePlacePose("generate place pose")
    generator.properties.configureInitFrom(Stage.PARENT, ["ik_frame"])
    generator.setObject("object")
    generator.setPose(PoseStamped("base_link", PLACE))
    generator.setMonitoredStage(attach)
    place.insert(_grasp_frame_ik("place pose IK", generator, 2))
    place.insert(_gripper_move("open gripper", interpolation, "open"))
    place.insert(_collisions("forbid collision (gripper,object)", "object", model.group("gripper"), False))
    stage = stages.ModifyPlanningScene("detach object")
    stage.detachObject("object", GRIPPER_FRAME)
    place.insert(stage)
    place.insert(_cartesian_move("retreat after place", cartesian, 0.025, 0.25,
                                 Vector3Stamped(GRIPPER_FRAME, [0.0, 0.0, -1.0]), GRIPPER_FRAME))
    task.add(place)

    stage = stages.MoveTo("move home", ompl)
    stage.properties.configureInitFrom(Stage.PARENT, ["group"])
    stage.setGoal("home")
    task.add(stage)
    return task


def planned_pick_place(model) -> Task:
    """:func:`build_pick_place` planned to one solution; asserts it planned (the message is MTC's
    explanation of the failure)."""
    task = build_pick_place(model)
    assert task.plan(max_solutions=1), task.explainFailure(stream=None)
    return task


def replay_task_solution(model: RobotModel, msg: TaskSolution, check_limits: bool = True) -> tuple[PlanningScene, int]:
    """Replay a TaskSolution as the planning_server executes it (each step's trajectory, then its
    scene diff): every trajectory must pass the core validator in the scene it runs in, starting
    where the robot is. Returns the final scene and how many steps moved. ``check_limits``: also
    the velocity and acceleration limits."""
    scene = PlanningScene.from_msg(model, msg.start_scene)
    moved = 0
    for k, sub in enumerate(msg.sub_trajectory):
        jt = sub.trajectory.joint_trajectory
        if jt.points:
            timed = joint_trajectory_to_timed(jt)
            # MTC's SubTrajectory message carries no group name: the group of exactly these joints
            group = sub.trajectory.group_name or next(
                g for g in model.group_names if set(model.group(g).joint_names) == set(jt.joint_names))
            report = validate_trajectory(scene, timed, group, scene.current_state, check_limits=check_limits)
            assert report.valid, f"step {k} ({sub.info.stage_name}): {report.problems}"
            state = scene.current_state.copy()
            state.set_joint_positions(dict(zip(jt.joint_names, jt.points[-1].positions)))
            scene.set_current_state(state)
            moved += 1
        scene.apply_planning_scene_msg(sub.scene_diff)
    return scene, moved


def float_bits(value) -> list[str]:
    """Every float in a to_dict() tree, in order, as hex: a bit-exact fingerprint of a message."""
    def floats(v):
        if isinstance(v, float):
            yield v
        elif isinstance(v, dict):
            for item in v.values():
                yield from floats(item)
        elif isinstance(v, list):
            for item in v:
                yield from floats(item)
    return [f.hex() for f in floats(value)]
