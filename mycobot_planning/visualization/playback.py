"""Trajectories as something to show: a timeline of robot states and scene objects over time.

A task solution is a sequence of sub-trajectories, each followed by a scene change (attach,
detach, allowed collisions). To animate it — in the browser viewer or in a PNG — we need, at
any time ``t``, the full joint vector and where every object is, attached ones following their
link. ``Timeline`` precomputes that once from a ``TaskSolution`` (or a bare
``JointTrajectory``): the core ``PlanningScene`` applies the start scene and each step's
``scene_diff`` exactly as the executor does, and ``sample(t)`` interpolates the waypoints.

Zero-length steps (pure scene changes such as "attach object", or an IK state) occupy an
instant: they are kept as segments so that selecting one shows the robot at that step, with the
scene after its change.
"""
from __future__ import annotations

import bisect
import dataclasses
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from interfaces_py.msgs import CollisionObject, JointTrajectory, PlanningScene as PlanningSceneMsg, TaskSolution

from ..core.planning_scene.planning_scene import PlanningScene
from ..core.robot_model.robot_model import RobotModel
from ..core.robot_state.robot_state import RobotState

_EMPTY_DIFF = PlanningSceneMsg(is_diff=True).to_dict()

__all__ = ["SceneObjects", "Segment", "Timeline", "TimelineSample", "joint_vector"]


@dataclass(frozen=True)
class SceneObjects:
    """The collision objects of a scene, as a display needs them: world objects posed in the
    world frame, attached objects posed in the frame of the link that carries them."""

    world: Mapping[str, CollisionObject] = field(default_factory=dict)
    attached: Mapping[str, tuple[str, CollisionObject]] = field(default_factory=dict)

    @classmethod
    def from_scene(cls, scene: PlanningScene) -> "SceneObjects":
        world = {object_id: scene.get_object(object_id) for object_id in scene.world_object_ids()}
        attached = {}
        for object_id in scene.attached_object_ids():
            msg = scene.get_attached_object(object_id)
            attached[object_id] = (msg.link_name, msg.object)
        return cls(world, attached)

    @classmethod
    def from_msg(cls, model: RobotModel, msg: PlanningSceneMsg | str) -> "SceneObjects":
        """From a full PlanningScene message (/monitored_planning_scene); raises SceneError or
        MessageError for a message that does not fit the model."""
        scene = PlanningScene(model)
        scene.apply_planning_scene_msg(msg)
        return cls.from_scene(scene)

    @property
    def ids(self) -> list[str]:
        return list(self.world) + list(self.attached)

    def links(self) -> set[str]:
        return {link for link, _ in self.attached.values()}

    def object(self, object_id: str) -> CollisionObject:
        if object_id in self.world:
            return self.world[object_id]
        return self.attached[object_id][1]

    def poses(self, link_poses: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """World pose of every object, attached ones at the given link poses."""
        out = {object_id: obj.pose.to_matrix() for object_id, obj in self.world.items()}
        for object_id, (link, obj) in self.attached.items():
            out[object_id] = np.asarray(link_poses[link]) @ obj.pose.to_matrix()
        return out

    def signature(self) -> tuple:
        """Changes when an object appears, vanishes, changes shape, moves (world objects) or
        changes link; a viewer rebuilds its object meshes only then."""
        world = tuple(sorted((i, o.to_json()) for i, o in self.world.items()))
        attached = tuple(sorted((i, link, o.to_json()) for i, (link, o) in self.attached.items()))
        return world, attached

    def shape_signature(self, object_id: str) -> str:
        """The object's shapes without its pose: a viewer re-creates meshes only when this changes."""
        obj = self.object(object_id)
        data = obj.to_dict()
        data.pop("pose", None)
        data.pop("frame_id", None)
        data.pop("operation", None)
        return repr(data)


def joint_vector(model: RobotModel, base: np.ndarray, names: Sequence[str], values: Sequence[float]) -> np.ndarray:
    """``base`` (over model.variable_names) with the named joints set; names the model does not
    have as active joints (mimic joints in /joint_states) are ignored."""
    out = np.array(base, dtype=float, copy=True)
    known = set(model.variable_names)
    for name, value in zip(names, values):
        if name in known:
            out[model.variable_index(name)] = value
    return out


@dataclass
class Segment:
    """One step of the timeline: the waypoints of one (sub-)trajectory over ``joint_names``,
    starting at ``start_time``, with the scene objects during it (``objects``) and after its
    scene change (``objects_after``)."""

    label: str
    stage_id: int
    solution_id: int
    start_time: float
    times: np.ndarray
    joint_names: list[str]
    columns: np.ndarray  # indices into model.variable_names
    positions: np.ndarray  # len(times) x len(joint_names)
    velocities: np.ndarray
    accelerations: np.ndarray
    start_positions: np.ndarray  # full variable vector at the segment start
    objects: SceneObjects
    objects_after: SceneObjects
    cost: float = 0.0
    comment: str = ""

    @property
    def duration(self) -> float:
        return float(self.times[-1]) if len(self.times) else 0.0

    @property
    def end_time(self) -> float:
        return self.start_time + self.duration

    def positions_at(self, t_local: float) -> np.ndarray:
        full = self.start_positions.copy()
        if len(self.times) == 0:
            return full
        if t_local <= self.times[0]:
            row = self.positions[0]
        elif t_local >= self.times[-1]:
            row = self.positions[-1]
        else:
            k = int(np.searchsorted(self.times, t_local, side="right")) - 1
            t0, t1 = self.times[k], self.times[k + 1]
            w = 0.0 if t1 <= t0 else (t_local - t0) / (t1 - t0)
            row = (1.0 - w) * self.positions[k] + w * self.positions[k + 1]
        full[self.columns] = row
        return full

    @property
    def end_positions(self) -> np.ndarray:
        return self.positions_at(self.duration)


@dataclass(frozen=True)
class TimelineSample:
    """What to show at one time: the joint vector, the objects and the step that is playing."""

    time: float
    positions: np.ndarray
    objects: SceneObjects
    segment: int
    label: str


class Timeline:
    """Robot states and scene objects over time for a task solution or a trajectory."""

    def __init__(self, model: RobotModel, segments: list[Segment], start_positions: np.ndarray,
                 start_objects: SceneObjects, title: str = "") -> None:
        self.model = model
        self.segments = segments
        self.start_positions = np.asarray(start_positions, dtype=float)
        self.start_objects = start_objects
        self.title = title
        self._starts = [s.start_time for s in segments]

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_task_solution(cls, model: RobotModel, solution: TaskSolution | str,
                           steps: Sequence[int] | None = None) -> "Timeline":
        """The solution's steps (default all; else the given sub_trajectory indices, in order)
        timed back to back from t = 0. The scene is replayed from ``start_scene`` through every
        earlier step's diff, so a slice starts with the objects where they really are."""
        if isinstance(solution, str):
            solution = TaskSolution.from_json(solution)
        scene = PlanningScene(model)
        scene.apply_planning_scene_msg(solution.start_scene)
        wanted = None if steps is None else list(steps)
        if wanted is not None:
            for k in wanted:
                if not 0 <= k < len(solution.sub_trajectory):
                    raise ValueError(f"step {k} out of range: the solution has {len(solution.sub_trajectory)} steps")
        positions = scene.current_state.positions.copy()
        every: list[Segment] = []
        t = 0.0
        for sub in solution.sub_trajectory:
            objects = SceneObjects.from_scene(scene)
            if sub.scene_diff.to_dict() != _EMPTY_DIFF:
                scene.apply_planning_scene_msg(sub.scene_diff)
                objects_after = SceneObjects.from_scene(scene)
            else:
                objects_after = objects
            segment = _segment(model, sub.trajectory.joint_trajectory, positions, objects, objects_after, t,
                               label=sub.info.stage_name, stage_id=sub.info.stage_id, solution_id=sub.info.id,
                               cost=sub.info.cost, comment=sub.info.comment)
            every.append(segment)
            t += segment.duration
            positions = segment.end_positions
        if wanted is None:
            segments = every
        else:  # retimed back to back from 0
            segments, t = [], 0.0
            for k in wanted:
                segments.append(dataclasses.replace(every[k], start_time=t))
                t += every[k].duration
        if segments:
            first_positions, first_objects = segments[0].start_positions, segments[0].objects
        else:
            first_positions, first_objects = positions, SceneObjects.from_scene(scene)
        return cls(model, segments, first_positions, first_objects, title=solution.task_id)

    @classmethod
    def from_joint_trajectory(cls, model: RobotModel, trajectory: JointTrajectory | str,
                              start_positions: np.ndarray | None = None, scene: PlanningScene | None = None,
                              label: str = "trajectory") -> "Timeline":
        """A single trajectory; joints it does not name stay at ``start_positions`` (default:
        the scene's current state, else the model's default positions)."""
        if isinstance(trajectory, str):
            trajectory = JointTrajectory.from_json(trajectory)
        if start_positions is None:
            start_positions = scene.current_state.positions if scene is not None else model.default_positions()
        objects = SceneObjects.from_scene(scene) if scene is not None else SceneObjects()
        segment = _segment(model, trajectory, np.asarray(start_positions, dtype=float), objects, objects, 0.0,
                           label=label, stage_id=0, solution_id=0)
        return cls(model, [segment], segment.start_positions, objects, title=label)

    # ------------------------------------------------------------------ queries
    @property
    def duration(self) -> float:
        return self.segments[-1].end_time if self.segments else 0.0

    @property
    def end_positions(self) -> np.ndarray:
        return self.segments[-1].end_positions if self.segments else self.start_positions

    @property
    def end_objects(self) -> SceneObjects:
        return self.segments[-1].objects_after if self.segments else self.start_objects

    def segment_index(self, t: float) -> int:
        """The step playing at time ``t`` (the last one starting at or before it)."""
        if not self.segments:
            return -1
        k = bisect.bisect_right(self._starts, t) - 1
        return min(max(k, 0), len(self.segments) - 1)

    def sample(self, t: float) -> TimelineSample:
        """Joint vector and objects at time ``t`` (clamped into [0, duration]). At the very end
        the last step's scene change is applied (an attach step shows the object attached)."""
        if not self.segments:
            return TimelineSample(0.0, self.start_positions.copy(), self.start_objects, -1, "")
        t = min(max(float(t), 0.0), self.duration)
        if t >= self.duration:
            last = self.segments[-1]
            return TimelineSample(t, last.end_positions, last.objects_after, len(self.segments) - 1, last.label)
        k = self.segment_index(t)
        segment = self.segments[k]
        return TimelineSample(t, segment.positions_at(t - segment.start_time), segment.objects, k, segment.label)

    def dense(self, period: float = 0.01) -> tuple[np.ndarray, list[str], np.ndarray, np.ndarray, np.ndarray]:
        """(times, joint names, positions, velocities, accelerations) over every joint that
        any step moves, for plotting: the waypoints themselves (no resampling, so limits are
        checked where the planner put them), steps concatenated in time. Velocities and
        accelerations come from the waypoints when given, else from finite differences."""
        names = [n for n in self.model.variable_names if any(n in s.joint_names for s in self.segments)]
        index = {n: i for i, n in enumerate(names)}
        rows_t, rows_p, rows_v, rows_a = [], [], [], []
        for segment in self.segments:
            if len(segment.times) == 0:
                continue
            base = np.array([segment.start_positions[self.model.variable_index(n)] for n in names])
            cols = np.array([index[n] for n in segment.joint_names], dtype=int)
            for k in range(len(segment.times)):
                p = base.copy()
                p[cols] = segment.positions[k]
                v = np.zeros(len(names))
                a = np.zeros(len(names))
                v[cols] = segment.velocities[k]
                a[cols] = segment.accelerations[k]
                rows_t.append(segment.start_time + float(segment.times[k]))
                rows_p.append(p)
                rows_v.append(v)
                rows_a.append(a)
        if not rows_t:
            empty = np.zeros((0, len(names)))
            return np.zeros(0), names, empty, empty.copy(), empty.copy()
        return np.asarray(rows_t), names, np.asarray(rows_p), np.asarray(rows_v), np.asarray(rows_a)

    def state(self, positions: np.ndarray) -> RobotState:
        return RobotState(self.model, positions)


def _derivative(times: np.ndarray, values: np.ndarray) -> np.ndarray:
    if len(times) < 2:
        return np.zeros_like(values)
    return np.gradient(values, times, axis=0, edge_order=1)


def _segment(model: RobotModel, trajectory: JointTrajectory, start: np.ndarray, objects: SceneObjects,
             objects_after: SceneObjects, start_time: float, *, label: str, stage_id: int, solution_id: int,
             cost: float = 0.0, comment: str = "") -> Segment:
    known = set(model.variable_names)  # mimic joints are derived from their source joint
    names = [n for n in trajectory.joint_names if n in known]
    columns = [model.variable_index(n) for n in names]
    keep = [trajectory.joint_names.index(n) for n in names]
    points = trajectory.points
    times = np.array([p.time_from_start for p in points], dtype=float)
    if len(times):
        times = times - times[0]
    positions = np.array([[p.positions[i] for i in keep] for p in points], dtype=float).reshape(len(points), len(keep))
    if points and all(p.velocities for p in points):
        velocities = np.array([[p.velocities[i] for i in keep] for p in points], dtype=float)
    else:
        velocities = _derivative(times, positions) if len(points) else positions.copy()
    if points and all(p.accelerations for p in points):
        accelerations = np.array([[p.accelerations[i] for i in keep] for p in points], dtype=float)
    else:
        accelerations = _derivative(times, velocities) if len(points) else positions.copy()
    if len(times) > 1 and np.any(np.diff(times) <= 0):  # repeated stamps: keep the last of each
        keep_rows = np.append(np.diff(times) > 0, True)
        times, positions = times[keep_rows], positions[keep_rows]
        velocities, accelerations = velocities[keep_rows], accelerations[keep_rows]
    return Segment(label=label, stage_id=stage_id, solution_id=solution_id, start_time=start_time, times=times,
                   joint_names=names, columns=np.asarray(columns, dtype=int), positions=positions,
                   velocities=velocities, accelerations=accelerations, start_positions=np.asarray(start, dtype=float),
                   objects=objects, objects_after=objects_after, cost=cost, comment=comment)


def timeline_from_json(model: RobotModel, text: str, scene: PlanningSceneMsg | str | None = None,
                       label: str = "trajectory") -> Timeline:
    """A Timeline from the JSON of a TaskSolution, a RobotTrajectory or a JointTrajectory (what
    ``ros2 topic echo`` users save and the task constructor exports), recognised by its keys.
    ``scene`` (a full PlanningScene) places a bare trajectory among objects and gives its start
    state. Raises ValueError (MessageError) naming what is wrong."""
    import json

    from interfaces_py.msgs import MessageError, RobotTrajectory

    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise MessageError("input", f"not JSON: {exc}") from None
    if not isinstance(data, dict):
        raise MessageError("input", "expected a JSON object (TaskSolution, RobotTrajectory or JointTrajectory)")
    if "sub_trajectory" in data or "start_scene" in data:
        return Timeline.from_task_solution(model, TaskSolution.from_dict(data))
    if "joint_trajectory" in data:
        trajectory = RobotTrajectory.from_dict(data).joint_trajectory
    elif "points" in data and "joint_names" in data:
        trajectory = JointTrajectory.from_dict(data)
    else:
        raise MessageError("input", "not a TaskSolution (sub_trajectory), RobotTrajectory (joint_trajectory) or "
                           f"JointTrajectory (joint_names, points); keys: {', '.join(sorted(data)) or 'none'}")
    unknown = [n for n in trajectory.joint_names if n not in model.variable_names and n not in model.mimic_joint_names]
    if unknown:
        raise MessageError("JointTrajectory.joint_names",
                           f"joint(s) {', '.join(unknown)} are not joints of robot '{model.name}'")
    start_scene = None
    if scene is not None:
        start_scene = PlanningScene(model)
        start_scene.apply_planning_scene_msg(scene)
    return Timeline.from_joint_trajectory(model, trajectory, scene=start_scene, label=label)
