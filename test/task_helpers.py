"""Shared helpers for the task-constructor tests (scenes, validation of whole solutions)."""
from __future__ import annotations

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
    stage = stages.MoveTo("open gripper", interpolation)
    stage.setGroup("gripper")
    stage.setGoal("open")
    stage.setTrajectoryExecutionInfo(CONTROLLERS)
    task.add(stage)
    stage = stages.Connect("move to pick", [("arm", ompl), ("gripper", interpolation)])
    stage.setTimeout(5.0)
    stage.properties.configureInitFrom(Stage.PARENT)
    task.add(stage)

    grasp = SerialContainer("pick object")
    task.properties.exposeTo(grasp.properties, ["eef", "group", "ik_frame"])
    grasp.properties.configureInitFrom(Stage.PARENT, ["eef", "group", "ik_frame"])
    stage = stages.MoveRelative("approach object", cartesian)
    stage.properties.configureInitFrom(Stage.PARENT, ["group"])
    stage.setMinMaxDistance(0.0015, 0.3)
    stage.setDirection(Vector3Stamped(GRIPPER_FRAME, [0.0, 0.0, 1.0]))
    grasp.insert(stage)
    generator = stages.GenerateGraspPose("generate grasp pose")
    generator.properties.configureInitFrom(Stage.PARENT)
    generator.setPreGraspPose("open")
    generator.setObject("object")
    generator.setAngleDelta(0.2618)  # the seed's grasp_pose_angle_delta
    generator.setMonitoredStage(current)
    ik = stages.ComputeIK("grasp pose IK", generator)
    ik.setMaxIKSolutions(8)
    ik.setMinSolutionDistance(1.0)
    ik.setTimeout(0.2)  # robust under load; the search usually saturates well before
    ik.setIKFrame(GRASP_FRAME, GRIPPER_FRAME)
    ik.properties.configureInitFrom(Stage.PARENT, ["eef", "group"])
    ik.properties.configureInitFrom(Stage.INTERFACE, ["target_pose"])
    grasp.insert(ik)
    stage = stages.ModifyPlanningScene("allow collision (gripper,object)")
    stage.allowCollisions("object", model.group("gripper"), True)
    grasp.insert(stage)
    stage = stages.MoveTo("close gripper", interpolation)
    stage.setGroup("gripper")
    stage.setGoal("half_closed")
    grasp.insert(stage)
    attach = stages.ModifyPlanningScene("attach object")
    attach.attachObject("object", GRIPPER_FRAME)
    grasp.insert(attach)
    stage = stages.ModifyPlanningScene("allow collision (object,support)")
    stage.allowCollisions(["object"], ["table"], True)
    grasp.insert(stage)
    stage = stages.MoveRelative("lift object", cartesian)
    stage.properties.configureInitFrom(Stage.PARENT, ["group"])
    stage.setMinMaxDistance(0.005, 0.3)
    stage.setIKFrame(GRIPPER_FRAME)
    stage.setDirection(Vector3Stamped("base_link", [0.0, 0.0, 1.0]))
    grasp.insert(stage)
    stage = stages.ModifyPlanningScene("forbid collision (object,surface)")
    stage.allowCollisions(["object"], ["table"], False)
    grasp.insert(stage)
    task.add(grasp)

    stage = stages.Connect("move to place", [("arm", ompl), ("gripper", interpolation)])
    stage.setTimeout(10.0)
    stage.properties.configureInitFrom(Stage.PARENT)
    task.add(stage)

    place = SerialContainer("place object")
    task.properties.exposeTo(place.properties, ["eef", "group", "ik_frame"])
    place.properties.configureInitFrom(Stage.PARENT, ["eef", "group", "ik_frame"])
    stage = stages.MoveRelative("lower object", cartesian)
    stage.properties.configureInitFrom(Stage.PARENT, ["group"])
    stage.setMinMaxDistance(0.005, 0.4)
    stage.setDirection(Vector3Stamped("base_link", [0.0, 0.0, -1.0]))
    place.insert(stage)
    generator = stages.GeneratePlacePose("generate place pose")
    generator.properties.configureInitFrom(Stage.PARENT, ["ik_frame"])
    generator.setObject("object")
    generator.setPose(PoseStamped("base_link", PLACE))
    generator.setMonitoredStage(attach)
    ik = stages.ComputeIK("place pose IK", generator)
    ik.setMaxIKSolutions(2)
    ik.setIKFrame(GRASP_FRAME, GRIPPER_FRAME)
    ik.properties.configureInitFrom(Stage.PARENT, ["eef", "group"])
    ik.properties.configureInitFrom(Stage.INTERFACE, ["target_pose"])
    place.insert(ik)
    stage = stages.MoveTo("open gripper", interpolation)
    stage.setGroup("gripper")
    stage.setGoal("open")
    place.insert(stage)
    stage = stages.ModifyPlanningScene("forbid collision (gripper,object)")
    stage.allowCollisions("object", model.group("gripper"), False)
    place.insert(stage)
    stage = stages.ModifyPlanningScene("detach object")
    stage.detachObject("object", GRIPPER_FRAME)
    place.insert(stage)
    stage = stages.MoveRelative("retreat after place", cartesian)
    stage.properties.configureInitFrom(Stage.PARENT, ["group"])
    stage.setMinMaxDistance(0.025, 0.25)
    stage.setIKFrame(GRIPPER_FRAME)
    stage.setDirection(Vector3Stamped(GRIPPER_FRAME, [0.0, 0.0, -1.0]))
    place.insert(stage)
    task.add(place)

    stage = stages.MoveTo("move home", ompl)
    stage.properties.configureInitFrom(Stage.PARENT, ["group"])
    stage.setGoal("home")
    task.add(stage)
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
