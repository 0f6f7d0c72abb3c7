"""Robustness cases for MoveIt's face (issue 27): bad inputs built with the real moveit_msgs
types and sent to move_group's services and actions, as a MoveIt client would send them.

Each case is a :class:`MoveItInput`: which service or action, and how to build the request (a
good request with one field made wrong). The runner (robustness.Runner, interface "moveit")
sends it and judges the answer: a MoveItErrorCodes value other than SUCCESS with a message free
of Python internals (services with no error code: ``valid`` false, ``success`` false; for
SetPlannerParams, which answers nothing, the planner's parameters unchanged); an action goal
must end ABORTED/CANCELED with such a code. Afterwards the scene must be unchanged (else
``half_applied``) and the robot must not have moved (else ``unsafe_motion``).

Accepted on purpose, because MoveIt accepts them too (so they are no cases here):
* an all-zero quaternion in a collision object's or a constraint region's pose: MoveIt's
  PlanningScene reads it as the identity ("Empty quaternion found in pose message. Setting to
  neutral orientation."), and so do we;
* a quaternion of any other non-zero norm: MoveIt normalizes it (poseMsgToEigen); both our faces
  normalize it too, with a warning in the log (interfaces_py.pose_conversion);
* a zero or negative IK timeout: MoveIt's RobotState::setFromIK uses the group's default
  timeout for a timeout below epsilon, and so do we;
* in a task solution (ExecuteTaskSolution), a sub-trajectory without points (MTC's stages that
  only change the scene send them) and a scene diff whose collision matrix names objects that
  are gone (MTC's solutions carry the task's whole matrix): executed, the latter with a warning;
  the joint values of a task solution's scene-diff robot state are not read at all (MTC's
  capability clears them: the joints move only through the trajectories);
* a NUL inside a string field: ROS strings end at the first NUL, so the server receives what
  comes before it ("a\x00b" arrives as "a", "0.5\x00" as "0.5") and judges that.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

NAN, INF = float("nan"), float("inf")
ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6",
       "link6_to_link6_flange"]
GOAL = [0.3, -0.3, 0.5, 0.2, 0.1, 0.2]
ODD_NAMES = ["", "legs", "bad\x00name", "bell\x07\x1b[2J", "x" * 5000, "t\u00e9\u4e2d"]


@dataclass(frozen=True)
class MoveItInput:
    kind: str  # "service", "action", "planner_params"
    type: Any  # the srv or action class
    name: str  # the service or action name
    build: Callable[[], Any]  # the request (or goal), built fresh for each send


Mutation = tuple[str, Callable[[Any], None]]


def _pose(x: float = 0.15, y: float = 0.0, z: float = 0.2, q: tuple[float, float, float, float] = (0, 0, 0, 1)) -> Any:
    from geometry_msgs.msg import Pose

    pose = Pose()
    pose.position.x, pose.position.y, pose.position.z = x, y, z
    pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = (float(v) for v in q)
    return pose


def _joint_goal(r: Any) -> None:
    from moveit_msgs.msg import Constraints, JointConstraint

    r.group_name = "arm"
    r.allowed_planning_time = 5.0
    r.num_planning_attempts = 1
    r.goal_constraints = [Constraints(joint_constraints=[JointConstraint(
        joint_name=j, position=v, tolerance_above=1e-3, tolerance_below=1e-3, weight=1.0) for j, v in zip(ARM, GOAL)])]


def _pose_goal(r: Any, primitives: list[tuple[int, list[float]]] | None = None, poses: int = 1,
               orientation_tolerance: float = 0.1, link: str = "link6_flange", pose: Any = None) -> None:
    from moveit_msgs.msg import Constraints, OrientationConstraint, PositionConstraint
    from shape_msgs.msg import SolidPrimitive

    _joint_goal(r)
    pc = PositionConstraint(link_name=link)
    pc.header.frame_id = "world"
    pc.constraint_region.primitives = [SolidPrimitive(type=t, dimensions=d)
                                       for t, d in (primitives if primitives is not None else [(2, [0.01])])]
    pc.constraint_region.primitive_poses = [pose or _pose() for _ in range(poses)]
    oc = OrientationConstraint(link_name=link, absolute_x_axis_tolerance=orientation_tolerance,
                               absolute_y_axis_tolerance=0.1, absolute_z_axis_tolerance=0.1, weight=1.0)
    oc.header.frame_id = "world"
    oc.orientation.w = 1.0
    r.goal_constraints = [Constraints(position_constraints=[pc], orientation_constraints=[oc])]


def _set(path: str, value: Any) -> Callable[[Any], None]:
    def apply(r: Any) -> None:
        target = r
        parts = path.split(".")
        for part in parts[:-1]:
            target = target[int(part)] if part.isdigit() else getattr(target, part)
        setattr(target, parts[-1], value)
    return apply


def _plan_mutations() -> list[Mutation]:
    """What is wrong with a motion plan request, one field at a time (the request's
    goal_constraints start as a good joint goal)."""
    from moveit_msgs.msg import Constraints, JointConstraint

    out: list[Mutation] = []
    for name in ODD_NAMES:
        out.append((f"group_name={name[:12]!r}", _set("group_name", name)))
    for key, values in (("allowed_planning_time", [-1.0, NAN, INF, 1e9]),
                        ("max_velocity_scaling_factor", [-1.0, NAN, INF, 2.0]),
                        ("max_acceleration_scaling_factor", [-0.5, NAN, 5.0]),
                        ("num_planning_attempts", [2_000_000_000])):
        out += [(f"{key}={v}", _set(key, v)) for v in values]
    out += [(f"planner_id={v[:12]!r}", _set("planner_id", v)) for v in ("Magic", "\x1b[2J", "x" * 5000)]
    out += [(f"pipeline_id={v[:12]!r}", _set("pipeline_id", v)) for v in ("magic", "bad\x00")]

    def ptp_on_lines(r: Any) -> None:
        r.pipeline_id, r.planner_id = "joint_interpolation", "PTP"
    out.append(("planner PTP on joint_interpolation", ptp_on_lines))
    for field, values in (("position", [NAN, INF, 1e308, 100.0]), ("tolerance_above", [NAN, -0.1, INF]),
                          ("tolerance_below", [NAN, -0.1]), ("joint_name", ["nojoint", "", "bad\x00"])):
        out += [(f"joint goal {field}={v!r:.14}", _set(f"goal_constraints.0.joint_constraints.0.{field}", v))
                for v in values]

    def twice(r: Any) -> None:
        c = r.goal_constraints[0].joint_constraints
        c.append(JointConstraint(joint_name=c[0].joint_name, position=c[0].position - 1.0, tolerance_above=1e-3,
                                 tolerance_below=1e-3, weight=1.0))
    out.append(("one joint constrained twice", twice))
    out.append(("no goal_constraints", _set("goal_constraints", [])))
    out.append(("empty goal constraints", _set("goal_constraints", [Constraints()])))

    def trajectory_constraints(r: Any) -> None:
        r.trajectory_constraints.constraints = [r.goal_constraints[0]]
    out.append(("trajectory_constraints", trajectory_constraints))
    pose_goals: list[tuple[str, dict[str, Any]]] = [
        ("box region with a negative side", {"primitives": [(1, [0.1, -0.1, 0.1])]}),
        ("sphere region without dimensions", {"primitives": [(2, [])]}),
        ("region without primitive", {"primitives": [], "poses": 0}),
        ("2 primitives 1 pose", {"primitives": [(2, [0.01]), (2, [0.02])], "poses": 1}),
        ("NaN sphere radius", {"primitives": [(2, [NAN])]}),
        ("unknown primitive type", {"primitives": [(9, [0.1])]}),
        ("orientation tolerance NaN", {"orientation_tolerance": NAN}),
        ("orientation tolerance -0.1", {"orientation_tolerance": -0.1}),
        ("unknown link", {"link": "nolink"}),
        ("NaN region pose", {"pose": _pose(NAN)}),
    ]
    for label, kwargs in pose_goals:
        out.append((f"pose goal {label}", lambda r, kw=kwargs: _pose_goal(r, **kw)))
    for label, names, positions in (("unknown joint", ["nojoint"], [0.0]), ("NaN", ARM, [NAN] + [0.0] * 5),
                                    ("5 positions for 6 names", ARM, [0.0] * 5), ("beyond limits", ARM, [9.0] * 6)):
        def start(r: Any, names: list[str] = names, positions: list[float] = positions) -> None:
            r.start_state.joint_state.name = list(names)
            r.start_state.joint_state.position = list(positions)
        out.append((f"start_state {label}", start))
    for label, joint, tolerance in (("NaN tolerance", ARM[0], NAN), ("unknown joint", "nojoint", 0.1),
                                    ("negative tolerance", ARM[0], -1.0)):
        def path(r: Any, joint: str = joint, tolerance: float = tolerance) -> None:
            r.path_constraints.joint_constraints = [JointConstraint(joint_name=joint, position=0.0,
                                                                    tolerance_above=tolerance,
                                                                    tolerance_below=0.1, weight=1.0)]
        out.append((f"path constraint {label}", path))
    return out


def _plan_request(mutate: Callable[[Any], None]) -> Callable[[], Any]:
    def build() -> Any:
        from moveit_msgs.srv import GetMotionPlan

        request = GetMotionPlan.Request()
        _joint_goal(request.motion_plan_request)
        mutate(request.motion_plan_request)
        return request
    return build


def _move_goal(mutate: Callable[[Any], None], plan_only: bool = False) -> Callable[[], Any]:
    """A move_action goal (plan and execute, or plan only) with a scene diff adding a box: the bad
    request must leave the box out of the live scene and the robot where it is."""
    def build() -> Any:
        from moveit_msgs.action import MoveGroup
        from moveit_msgs.msg import CollisionObject
        from shape_msgs.msg import SolidPrimitive

        goal = MoveGroup.Goal()
        _joint_goal(goal.request)
        mutate(goal.request)
        diff = goal.planning_options.planning_scene_diff
        diff.is_diff = diff.robot_state.is_diff = True
        box = CollisionObject(id="half_applied_box", operation=CollisionObject.ADD)
        box.header.frame_id = "world"
        box.primitives = [SolidPrimitive(type=SolidPrimitive.BOX, dimensions=[0.05, 0.05, 0.05])]
        box.primitive_poses = [_pose(0.3, 0.3, 0.3)]
        diff.world.collision_objects = [box]
        goal.planning_options.plan_only = plan_only
        return goal
    return build


class _SceneHolder:
    """What a scene case mutates (``.scene``), over another message's PlanningScene field."""

    def __init__(self, scene: Any) -> None:
        self.scene = scene


def _move_goal_with_diff(mutate: Callable[[Any], None]) -> Callable[[], Any]:
    """A good move_action joint goal whose planning_scene_diff is a bad scene (a scene case):
    refused, and neither the live scene nor the robot changes (MoveIt plans on a copy)."""
    def build() -> Any:
        from moveit_msgs.action import MoveGroup

        goal = MoveGroup.Goal()
        _joint_goal(goal.request)
        diff = goal.planning_options.planning_scene_diff
        diff.is_diff = diff.robot_state.is_diff = True
        mutate(_SceneHolder(diff))
        return goal
    return build


def _task_solution(build: Callable[[], Any] | None = None,
                   scene_mutate: Callable[[Any], None] | None = None) -> Callable[[], Any]:
    """An MTC solution (moveit_task_constructor_msgs) of one sub-trajectory: a bad trajectory
    (an execute case's) or a good one with a bad scene diff (a scene case's), as mtc_node's
    execute() sends it to move_group's execute_task_solution."""
    def goal() -> Any:
        from moveit_task_constructor_msgs.action import ExecuteTaskSolution
        from moveit_task_constructor_msgs.msg import SubTrajectory

        sub = SubTrajectory()
        sub.info.id = 1
        sub.trajectory.joint_trajectory = (build or _execute_goal(
            [([0.0] * 6, [], [], 0.0), ([0.0] * 6, [], [], 1.0)]))().trajectory.joint_trajectory
        sub.scene_diff.is_diff = sub.scene_diff.robot_state.is_diff = True
        if scene_mutate is not None:
            scene_mutate(_SceneHolder(sub.scene_diff))
        out = ExecuteTaskSolution.Goal()
        out.solution.sub_trajectory = [sub]
        return out
    return goal


def _ik_cases() -> list[tuple[str, Callable[[Any], None]]]:
    from moveit_msgs.msg import Constraints, JointConstraint

    def constraint(value: float) -> Callable[[Any], None]:
        def apply(r: Any) -> None:
            r.ik_request.constraints = Constraints(joint_constraints=[JointConstraint(
                joint_name=ARM[0], position=value, tolerance_above=0.1, tolerance_below=0.1, weight=1.0)])
        return apply

    def stamped_vector(r: Any) -> None:
        from geometry_msgs.msg import PoseStamped

        r.ik_request.pose_stamped_vector = [PoseStamped(pose=_pose())]

    def robot_state(names: list[str], positions: list[float]) -> Callable[[Any], None]:
        return lambda r: (setattr(r.ik_request.robot_state.joint_state, "name", names),
                          setattr(r.ik_request.robot_state.joint_state, "position", positions))
    return [("timeout 2^31-1 s", _set("ik_request.timeout.sec", 2 ** 31 - 1)),
            *[(f"group {n[:12]!r}", _set("ik_request.group_name", n)) for n in ODD_NAMES],
            ("ik_link_name nolink", _set("ik_request.ik_link_name", "nolink")),
            ("NaN pose", _set("ik_request.pose_stamped.pose", _pose(NAN))),
            ("frame mars", _set("ik_request.pose_stamped.header.frame_id", "mars")),
            ("seed naming nojoint", robot_state(["nojoint"], [0.0])),
            ("seed 1e308", robot_state([ARM[0]], [1e308])),
            ("seed NaN", robot_state(list(ARM), [NAN] + [0.0] * 5)),
            ("seed infinite", robot_state(list(ARM), [0.0] * 5 + [INF])),
            ("seed 5 positions for 6 names", robot_state(list(ARM), [0.0] * 5)),
            ("seed beyond limits", robot_state(list(ARM), [9.0] * 6)),
            ("NaN constraint", constraint(NAN)),
            ("constraint beyond the joint limits", constraint(4.0)),  # no state can meet it
            ("pose_stamped_vector", stamped_vector)]


def _ik_request(mutate: Callable[[Any], None]) -> Callable[[], Any]:
    def build() -> Any:
        from moveit_msgs.srv import GetPositionIK

        request = GetPositionIK.Request()
        request.ik_request.group_name = "arm"
        request.ik_request.pose_stamped.header.frame_id = "world"
        request.ik_request.pose_stamped.pose = _pose()
        request.ik_request.timeout.nanosec = 200_000_000
        mutate(request)
        return request
    return build


def _validity_cases() -> list[tuple[str, Callable[[Any], None]]]:
    from moveit_msgs.msg import Constraints, JointConstraint

    def state(names: list[str], positions: list[float]) -> Callable[[Any], None]:
        return lambda r: (setattr(r.robot_state.joint_state, "name", names),
                          setattr(r.robot_state.joint_state, "position", positions))

    def constraint(joint: str, value: float) -> Callable[[Any], None]:
        def apply(r: Any) -> None:
            state(list(ARM), [0.0] * 6)(r)
            r.constraints = Constraints(joint_constraints=[JointConstraint(
                joint_name=joint, position=value, tolerance_above=0.1, tolerance_below=0.1, weight=1.0)])
        return apply
    return [("nojoint", state(["nojoint"], [0.0])), ("NaN", state(list(ARM), [NAN] + [0.0] * 5)),
            ("5 positions", state(list(ARM), [0.0] * 5)), ("beyond limits", state(list(ARM), [9.0] * 6)),
            ("group legs", lambda r: (state(list(ARM), [0.0] * 6)(r), setattr(r, "group_name", "legs"))),
            ("violated constraint", constraint(ARM[0], 1.0)), ("NaN constraint", constraint(ARM[0], NAN)),
            ("constraint on nojoint", constraint("nojoint", 0.0)),
            *[(f"group {n[:12]!r}", lambda r, n=n: (state(list(ARM), [0.0] * 6)(r), setattr(r, "group_name", n)))
              for n in ODD_NAMES if n]]


def _cartesian_cases() -> list[tuple[str, Callable[[Any], None]]]:
    return [*[(f"max_step={v}", _set("max_step", v)) for v in (0.0, -0.01, NAN, INF)],
            ("no waypoints", _set("waypoints", [])), ("NaN waypoint", _set("waypoints", [_pose(NAN)])),
            ("zero quaternion waypoint", _set("waypoints", [_pose(q=(0, 0, 0, 0))])),
            ("20001 waypoints", _set("waypoints", [_pose()] * 20001)),
            ("link_name nolink", _set("link_name", "nolink")), ("group legs", _set("group_name", "legs")),
            ("jump_threshold NaN", _set("jump_threshold", NAN)), ("jump_threshold -1", _set("jump_threshold", -1.0)),
            ("frame mars", _set("header.frame_id", "mars")),
            ("velocity scaling NaN", _set("max_velocity_scaling_factor", NAN)),
            *[(f"start_state {label}", lambda r, names=names, positions=positions: (
                setattr(r.start_state.joint_state, "name", names),
                setattr(r.start_state.joint_state, "position", positions)))
              for label, names, positions in (("nojoint", ["nojoint"], [0.0]), ("NaN", list(ARM), [NAN] + [0.0] * 5),
                                              ("5 positions", list(ARM), [0.0] * 5),
                                              ("beyond limits", list(ARM), [9.0] * 6))],
            *[(f"group {n[:12]!r}", _set("group_name", n)) for n in ODD_NAMES if n and n != "legs"]]


def _cartesian_request(mutate: Callable[[Any], None]) -> Callable[[], Any]:
    def build() -> Any:
        from moveit_msgs.srv import GetCartesianPath

        request = GetCartesianPath.Request(group_name="arm", max_step=0.01)
        request.header.frame_id = "world"
        request.waypoints = [_pose(0.15, 0.0, 0.2), _pose(0.15, 0.05, 0.2)]
        mutate(request)
        return request
    return build


def _scene_cases() -> list[tuple[str, Callable[[Any], None]]]:
    from moveit_msgs.msg import AttachedCollisionObject, CollisionObject, LinkPadding, LinkScale
    from shape_msgs.msg import SolidPrimitive

    def obj(dims: list[float] | None = None, pose: Any = None, poses: int = 1, operation: int = 0, oid: str = "bad",
            ptype: int = SolidPrimitive.BOX) -> Callable[[Any], None]:
        def apply(r: Any) -> None:
            o = CollisionObject(id=oid, operation=bytes([operation]))  # a byte field
            o.header.frame_id = "world"
            o.primitives = [SolidPrimitive(type=ptype, dimensions=dims if dims is not None else [0.05, 0.05, 0.05])]
            o.primitive_poses = [pose or _pose(0.3, 0.3, 0.3) for _ in range(poses)]
            r.scene.world.collision_objects = [o]
        return apply

    def acm(names: list[str]) -> Callable[[Any], None]:
        def apply(r: Any) -> None:
            r.scene.allowed_collision_matrix.entry_names = names
            r.scene.allowed_collision_matrix.entry_values = []
            from moveit_msgs.msg import AllowedCollisionEntry

            r.scene.allowed_collision_matrix.entry_values = [
                AllowedCollisionEntry(enabled=[True] * len(names)) for _ in names]
        return apply

    def attached(link: str) -> Callable[[Any], None]:
        def apply(r: Any) -> None:
            a = AttachedCollisionObject(link_name=link)
            obj()(r)
            a.object = r.scene.world.collision_objects[0]
            r.scene.world.collision_objects = []
            r.scene.robot_state.attached_collision_objects = [a]
        return apply
    return [("box with a negative side", obj([0.1, -0.1, 0.1])), ("box NaN side", obj([NAN, 0.1, 0.1])),
            ("box zero side", obj([0.0, 0.1, 0.1])), ("box 2 dimensions", obj([0.1, 0.1])),
            ("sphere 1e308", obj([1e308], ptype=SolidPrimitive.SPHERE)), ("NaN pose", obj(pose=_pose(NAN))),
            ("1 primitive 2 poses", obj(poses=2)),
            ("operation 9", obj(operation=9)), ("empty id", obj(oid="")), ("escape in id", obj(oid="a\x1b[2Jb")),
            ("remove an unknown object", obj(operation=CollisionObject.REMOVE[0], oid="ghost")),
            ("ACM naming a ghost", acm(["ghost", "link1"])),
            ("padding for nolink", lambda r: setattr(r.scene, "link_padding", [LinkPadding(link_name="nolink",
                                                                                          padding=0.01)])),
            ("padding NaN", lambda r: setattr(r.scene, "link_padding", [LinkPadding(link_name="link2", padding=NAN)])),
            ("scale -1", lambda r: setattr(r.scene, "link_scale", [LinkScale(link_name="link2", scale=-1.0)])),
            ("robot_state nojoint", lambda r: (setattr(r.scene.robot_state.joint_state, "name", ["nojoint"]),
                                               setattr(r.scene.robot_state.joint_state, "position", [0.0]))),
            ("robot_state beyond limits", lambda r: (setattr(r.scene.robot_state.joint_state, "name", [ARM[1]]),
                                                     setattr(r.scene.robot_state.joint_state, "position", [9.0]))),
            ("attached to nolink", attached("nolink")),
            ("octomap", lambda r: setattr(r.scene.world.octomap.octomap, "data", [1, 2, 3]))]


def _scene_request(mutate: Callable[[Any], None]) -> Callable[[], Any]:
    def build() -> Any:
        from moveit_msgs.srv import ApplyPlanningScene

        request = ApplyPlanningScene.Request()
        request.scene.is_diff = request.scene.robot_state.is_diff = True
        mutate(request)
        return request
    return build


def _planner_params(keys: list[str], values: list[str], pipeline_id: str = "ompl") -> Callable[[], Any]:
    def build() -> Any:
        from moveit_msgs.msg import PlannerParams
        from moveit_msgs.srv import SetPlannerParams

        return SetPlannerParams.Request(pipeline_id=pipeline_id, planner_config="RRTkConfigDefault",
                                        params=PlannerParams(keys=keys, values=values))
    return build


def _execute_goal(points: list[tuple[list[float], list[float], list[float], float]],
                  names: list[str] | None = None, multi_dof: bool = False) -> Callable[[], Any]:
    def build() -> Any:
        from builtin_interfaces.msg import Duration
        from moveit_msgs.action import ExecuteTrajectory
        from trajectory_msgs.msg import JointTrajectoryPoint, MultiDOFJointTrajectoryPoint

        goal = ExecuteTrajectory.Goal()
        jt = goal.trajectory.joint_trajectory
        jt.joint_names = list(names or ARM)
        for positions, velocities, accelerations, t in points:
            sec = math.floor(t) if math.isfinite(t) else 0
            jt.points.append(JointTrajectoryPoint(
                positions=positions, velocities=velocities, accelerations=accelerations,
                time_from_start=Duration(sec=int(sec), nanosec=int((t - sec) * 1e9) if math.isfinite(t) else 0)))
        if multi_dof:
            goal.trajectory.multi_dof_joint_trajectory.points = [MultiDOFJointTrajectoryPoint()]
        return goal
    return build


def _execute_cases() -> list[tuple[str, Callable[[], Any]]]:
    home, whip = [0.0] * 6, [0.0, 1.5, 0.0, 0.0, 0.0, 0.0]
    zero: list[float] = []
    return [
        ("whip 1.5 rad in 1 ms", _execute_goal([(home, zero, zero, 0.0), (whip, zero, zero, 0.001)])),
        ("accelerations without velocities", _execute_goal([(home, zero, [0.0] * 6, 0.0),
                                                            ([0.0, 0.05, 0, 0, 0, 0], zero, [0.0] * 6, 2.0)])),
        ("stated overspeed", _execute_goal([(home, [0.0] * 6, zero, 0.0),
                                            ([0.0, 0.05, 0, 0, 0, 0], [0, 50.0, 0, 0, 0, 0], zero, 1.0)])),
        ("unknown joint", _execute_goal([(home, zero, zero, 0.0), (home, zero, zero, 1.0)],
                                        names=ARM[:5] + ["elbow_of_mars"])),
        ("duplicate joint", _execute_goal([(home, zero, zero, 0.0), (home, zero, zero, 1.0)],
                                          names=ARM[:5] + [ARM[0]])),
        ("5 positions", _execute_goal([([0.0] * 5, zero, zero, 0.0), ([0.0] * 5, zero, zero, 1.0)])),
        ("NaN position", _execute_goal([(home, zero, zero, 0.0), ([NAN] + [0.0] * 5, zero, zero, 1.0)])),
        ("beyond joint limits", _execute_goal([(home, zero, zero, 0.0), ([0.0, 9.0, 0, 0, 0, 0], zero, zero, 20.0)])),
        ("times not increasing", _execute_goal([(home, zero, zero, 0.0), ([0.0, 0.1, 0, 0, 0, 0], zero, zero, 1.0),
                                                (home, zero, zero, 0.5)])),
        ("far from the start", _execute_goal([([0.0, 1.0, 0, 0, 0, 0], zero, zero, 0.0),
                                              ([0.0, 1.1, 0, 0, 0, 0], zero, zero, 1.0)])),
        ("no points", _execute_goal([])),
        ("multi-DOF", _execute_goal([(home, zero, zero, 0.0)], multi_dof=True)),
    ]


def _controller_goal(build: Callable[[], Any], tolerance_joint: str = "") -> Callable[[], Any]:
    """The same bad trajectory as a control_msgs/FollowJointTrajectory goal to the arm's
    controller (what moveit_simple_controller_manager sends)."""
    def goal() -> Any:
        from control_msgs.action import FollowJointTrajectory
        from control_msgs.msg import JointTolerance

        fjt = FollowJointTrajectory.Goal(trajectory=build().trajectory.joint_trajectory)
        if tolerance_joint:
            fjt.goal_tolerance = [JointTolerance(name=tolerance_joint, position=0.01)]
        return fjt
    return goal


def moveit_inputs() -> list[tuple[str, MoveItInput]]:
    """Every moveit_msgs case: (name, input)."""
    from moveit_msgs.action import ExecuteTrajectory, MoveGroup
    from moveit_task_constructor_msgs.action import ExecuteTaskSolution
    from moveit_msgs.srv import (
        ApplyPlanningScene,
        GetCartesianPath,
        GetMotionPlan,
        GetPositionFK,
        GetPositionIK,
        GetStateValidity,
        SetPlannerParams,
    )

    out: list[tuple[str, MoveItInput]] = []
    for label, mutate in _plan_mutations():
        out.append((f"plan_kinematic_path {label}", MoveItInput("service", GetMotionPlan, "/plan_kinematic_path",
                                                                _plan_request(mutate))))
        out.append((f"move_action {label}", MoveItInput("action", MoveGroup, "/move_action", _move_goal(mutate))))
        out.append((f"move_action plan_only {label}", MoveItInput("action", MoveGroup, "/move_action",
                                                                  _move_goal(mutate, plan_only=True))))
    for label, mutate in _ik_cases():
        out.append((f"compute_ik {label}", MoveItInput("service", GetPositionIK, "/compute_ik", _ik_request(mutate))))
    fk_cases = [("no links", [], "world", None), ("nolink", ["nolink"], "world", None),
                ("NUL link", ["a\x00b"], "world", None), ("frame mars", ["link2"], "mars", None),
                *[(f"link {n[:12]!r}", [n], "world", None) for n in ODD_NAMES if n not in ("", "bad\x00name")],
                *[(f"robot_state {label}", ["link2"], "world", (names, positions))
                  for label, names, positions in (("nojoint", ["nojoint"], [0.0]), ("NaN", list(ARM), [NAN] + [0.0] * 5),
                                                  ("5 positions", list(ARM), [0.0] * 5),
                                                  ("beyond limits", list(ARM), [9.0] * 6))]]
    for label, links, frame, state in fk_cases:
        def fk(links: list[str] = links, frame: str = frame, state: Any = state) -> Any:
            request = GetPositionFK.Request(fk_link_names=links)
            request.header.frame_id = frame
            if state is not None:
                request.robot_state.joint_state.name, request.robot_state.joint_state.position = state
            return request
        out.append((f"compute_fk {label}", MoveItInput("service", GetPositionFK, "/compute_fk", fk)))
    for label, mutate in _validity_cases():
        def validity(mutate: Callable[[Any], None] = mutate) -> Any:
            request = GetStateValidity.Request(group_name="arm")
            mutate(request)
            return request
        out.append((f"check_state_validity {label}", MoveItInput("service", GetStateValidity, "/check_state_validity",
                                                                 validity)))
    for label, mutate in _cartesian_cases():
        out.append((f"compute_cartesian_path {label}", MoveItInput("service", GetCartesianPath,
                                                                   "/compute_cartesian_path",
                                                                   _cartesian_request(mutate))))
    for label, mutate in _scene_cases():
        out.append((f"apply_planning_scene {label}", MoveItInput("service", ApplyPlanningScene,
                                                                 "/apply_planning_scene", _scene_request(mutate))))
        out.append((f"move_action planning_scene_diff {label}", MoveItInput("action", MoveGroup, "/move_action",
                                                                            _move_goal_with_diff(mutate))))
        if label in ("ACM naming a ghost", "robot_state nojoint", "robot_state beyond limits"):
            continue  # accepted in task solutions on purpose (see the module docstring)
        out.append((f"execute_task_solution action scene_diff {label}", MoveItInput(
            "action", ExecuteTaskSolution, "/execute_task_solution", _task_solution(scene_mutate=mutate))))
    for label, keys, values in (("range,goal_bias,foo", ["range", "goal_bias", "foo"], ["0.5", "0.1", "1"]),
                                ("range NaN", ["range"], ["NaN"]), ("range -1", ["range"], ["-1"]),
                                ("goal_bias banana", ["goal_bias"], ["banana"]),
                                ("escape in key", ["range\x1b[2J"], ["0.5"]), ("bell in value", ["range"], ["0.5\x07"]),
                                ("100000 digits", ["range"], ["9" * 100_000]), ("1e400", ["range"], ["1e400"]),
                                ("2 keys 1 value", ["range", "goal_bias"], ["0.5"]),
                                ("type PRM", ["type"], ["geometric::PRM"])):
        out.append((f"set_planner_params {label}", MoveItInput("planner_params", SetPlannerParams,
                                                               "/set_planner_params", _planner_params(keys, values))))
    # a good key beside a bad one (all or nothing), and a good key for a pipeline that is not there
    for name in ODD_NAMES:
        out.append((f"set_planner_params range and key {name[:12]!r}", MoveItInput(
            "planner_params", SetPlannerParams, "/set_planner_params", _planner_params(["range", name], ["0.7", "1"]))))
    for pipeline in (" ompl", "magic", "bad\x00", "\x1b[2J"):  # "" is the default pipeline, as for plans
        out.append((f"set_planner_params range on pipeline {pipeline!r}", MoveItInput(
            "planner_params", SetPlannerParams, "/set_planner_params", _planner_params(["range"], ["0.7"], pipeline))))
    from control_msgs.action import FollowJointTrajectory

    controller = "/arm_controller/follow_joint_trajectory"
    for label, build in _execute_cases():
        out.append((f"execute_trajectory {label}", MoveItInput("action", ExecuteTrajectory, "/execute_trajectory",
                                                               build)))
        if label not in ("multi-DOF", "no points"):  # MTC's scene-only stages send no points
            out.append((f"execute_task_solution action {label}", MoveItInput("action", ExecuteTaskSolution,
                                                                      "/execute_task_solution", _task_solution(build))))
        if label not in ("multi-DOF",):
            out.append((f"follow_joint_trajectory {label}", MoveItInput("action", FollowJointTrajectory, controller,
                                                                        _controller_goal(build))))
    still = _execute_goal([([0.0] * 6, [], [], 0.0), ([0.0] * 6, [], [], 1.0)])
    out.append(("follow_joint_trajectory goal_tolerance for nojoint",
                MoveItInput("action", FollowJointTrajectory, controller, _controller_goal(still, "nojoint"))))
    return out
