"""The task viewer's page: a viser 3D scene plus a side panel, fed by plain Python calls.

What RViz gives MoveIt users, in a browser: the robot (its collision shapes) following the live
joint states among the planning scene objects; the Motion Planning Tasks panel — every task's
stage tree with ✓/✗, solution and failure counts, time, cost and comment — where selecting a
stage's solution shows it and animates it (play / pause / scrub); and the planned path
animation of ``/planned_path``.

This module is ROS-free: ``mycobot_planning.ros.task.task_viewer`` feeds it from topics; tests and
scripts can feed it directly. Threading: inputs (``on_*`` calls from ROS callbacks) and the
page's widgets (viser's callback threads) only store the newest data or queue a command and
wake one display thread, which alone touches the 3D scene. So a burst of joint states never
queues up: the display applies the newest one, and the lag is measured from its stamp.

Colours: the live robot is blue, a previewed solution or planned path is an orange robot, world
objects take colours in order of appearance (green, magenta, cyan, yellow, red), attached
objects are purple. ``state()`` reports all of it, so tests can read the page's content.
"""
from __future__ import annotations

import html
import queue
import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from interfaces_py.msgs import JointTrajectory, PlanningScene as PlanningSceneMsg
from interfaces_py.msgs import TaskDescription, TaskSolution, TaskStatistics

from ..core.robot_model.robot_model import RobotModel
from ..core.robot_state.robot_state import RobotState
from .displays import ATTACHED_COLOUR, ObjectsDisplay, RobotDisplay
from .objective_panel import ObjectiveActions, ObjectivePanel
from .pose_target import PoseTargetActions, PoseTargetPanel
from .teleop_panel import TeleopActions, TeleopPanel
from .playback import SceneObjects, Timeline, joint_vector
from .task_tree import TaskRegistry, TaskTree

__all__ = ["TaskViewer", "LIVE_COLOUR", "PREVIEW_COLOUR", "ATTACHED_COLOUR", "OBJECT_COLOURS"]

LIVE_COLOUR = (70, 120, 215)
PREVIEW_COLOUR = (245, 135, 25)
OBJECT_COLOURS = [(50, 175, 75), (205, 50, 170), (30, 180, 195), (225, 200, 30), (215, 55, 55)]
#: the simulated world's objects (at their true poses) when the simulator gives no colour
SIM_COLOUR = (160, 160, 160)
SPEEDS = {"0.25×": 0.25, "0.5×": 0.5, "1×": 1.0, "2×": 2.0, "4×": 4.0}
NO_TASK = "(no task published yet)"
NO_SOLUTION = "(no published solution)"
LAG_WINDOW = 20000  # joint-state display lags kept for statistics


# ---------------------------------------------------------------------------- viewer
@dataclass
class _Preview:
    source: str  # "task" or "planned_path"
    timeline: Timeline
    label: str
    task_key: str = ""
    stage_id: int = 0
    stage_name: str = ""
    solution_label: str = ""
    time: float = 0.0
    playing: bool = True


class TaskViewer:
    """The viewer: a viser server on ``host:port`` (default localhost only) and its display thread.

    ``port=0`` takes any free port; a busy port makes viser try the next ones, so read ``url``.
    """

    def __init__(self, model: RobotModel, host: str = "127.0.0.1", port: int = 8080, *,
                 max_update_rate: float = 100.0, speed: float = 1.0, loop: bool = True,
                 auto_play_planned_path: bool = True, package_dirs: Sequence[Any] = (),
                 log: Callable[[str], None] | None = None, objective_actions: ObjectiveActions | None = None,
                 teleop_actions: TeleopActions | None = None, teleop_joints: Sequence[str] = (),
                 teleop_limits: Mapping[str, tuple[float, float]] | None = None,
                 pose_target_actions: PoseTargetActions | None = None, pose_target_link: str = "") -> None:
        import viser

        if max_update_rate <= 0:
            raise ValueError(f"max_update_rate must be > 0, got {max_update_rate}")
        self.model = model
        self._log = log or (lambda _msg: None)
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._commands: "queue.Queue[tuple[str, tuple]]" = queue.Queue()
        self._stop = threading.Event()
        self.max_update_rate = float(max_update_rate)
        self.loop = bool(loop)
        self.speed = float(speed)
        self.auto_play_planned_path = bool(auto_play_planned_path)

        # newest inputs (written by any thread, read by the display thread)
        self._joint_msg: tuple[Sequence[str], Sequence[float], float | None, float] | None = None
        self._scene_msg: PlanningSceneMsg | None = None
        self._tasks_dirty = False
        self.registry = TaskRegistry()
        self._received = 0
        self._applied = 0
        self._lags: deque[float] = deque(maxlen=LAG_WINDOW)
        self._last_apply = 0.0
        self._retry_at: float | None = None

        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        self.host = host
        self.port = self.server.get_port()
        self.server.gui.configure_theme(control_width="large", show_logo=False, show_share_button=False)
        self.server.scene.set_up_direction("+z")
        self.server.scene.add_grid("/grid", width=1.0, height=1.0, cell_size=0.05, section_size=0.25,
                                   plane="xy", position=(0.0, 0.0, -0.0005))
        self._colour_of: dict[str, tuple[int, int, int]] = {}
        self.live = RobotDisplay(self.server, model, "/live_robot", LIVE_COLOUR)
        self.preview_robot = RobotDisplay(self.server, model, "/preview_robot", PREVIEW_COLOUR, visible=False)
        self.live_objects = ObjectsDisplay(self.server, "/scene", self._colour, package_dirs)
        self.preview_objects = ObjectsDisplay(self.server, "/preview_scene", self._colour, package_dirs)
        #: the simulated world (a physics twin's objects at their true poses), beside the planning scene
        self._sim_colours: dict[str, tuple[int, int, int]] = {}
        self.sim_objects = ObjectsDisplay(self.server, "/sim_world", lambda i: self._sim_colours.get(i, SIM_COLOUR))
        self._sim_msg: SceneObjects | None = None
        self.preview_objects.visible = False
        self._live_scene = SceneObjects()
        self._live_positions = model.default_positions()
        self._live_link_poses = self.live.set_positions(self._live_positions)
        self.live_objects.update(self._live_scene, self._live_link_poses)
        self._live_stamp: float | None = None
        self._preview: _Preview | None = None
        self._planned_path: JointTrajectory | None = None
        self._selected_task: str | None = None
        self._selected_stage: int | None = None
        self._stage_options: dict[str, int] = {}
        self._solution_options: dict[str, Any] = {}
        self._shown_tree_version: tuple = ()
        self._last_slider_update = 0.0
        self._last_status = 0.0
        self._set_camera()
        self._build_gui()
        #: the Objectives panel (MoveIt Pro's objectives view), when an objective_server is served
        self.objectives = ObjectivePanel(self.server.gui, objective_actions) if objective_actions else None
        #: the Teleoperate panel (MoveIt Pro's teleoperation view), when a servo_node is served
        self.teleop = TeleopPanel(self.server.gui, teleop_actions, teleop_joints, teleop_limits) \
            if teleop_actions else None
        #: the Pose target panel (a draggable goal for ``pose_target_link``, planned, previewed, approved)
        self.pose_target = PoseTargetPanel(self.server.gui, self.server.scene, pose_target_actions,
                                           lambda: self._live_frame_pose(pose_target_link), pose_target_link) \
            if pose_target_actions and pose_target_link else None
        self._thread = threading.Thread(target=self._run, name="task_viewer display", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ set-up
    @property
    def url(self) -> str:
        host = self.host if self.host not in ("0.0.0.0", "::", "") else "127.0.0.1"
        return f"http://{host}:{self.port}/"

    def _set_camera(self) -> None:
        poses = self.live.link_poses(self._live_positions)
        points = np.array([T[:3, 3] for T in poses.values()])
        reach = max(0.25, float(np.max(np.linalg.norm(points[:, :2], axis=1))) + 0.2, float(points[:, 2].max()))
        target = np.array([0.05, 0.05, 0.35 * reach])
        self.server.initial_camera.look_at = tuple(target)
        self.server.initial_camera.position = tuple(target + reach * np.array([1.1, -1.3, 0.8]))
        self.server.initial_camera.up = (0.0, 0.0, 1.0)

    def _colour(self, object_id: str) -> tuple[int, int, int]:
        if object_id not in self._colour_of:
            self._colour_of[object_id] = OBJECT_COLOURS[len(self._colour_of) % len(OBJECT_COLOURS)]
        return self._colour_of[object_id]

    def _build_gui(self) -> None:
        gui = self.server.gui
        # Controls first, the (long) stage tree last: everything one clicks stays in view.
        with gui.add_folder("Playback"):
            self._now_showing = gui.add_markdown("showing: live robot")
            self._play_button = gui.add_button("Pause", icon=None)
            self._time_slider = gui.add_slider("Time [s]", min=0.0, max=1.0, step=0.01, initial_value=0.0)
            self._speed_dropdown = gui.add_dropdown("Speed", tuple(SPEEDS), initial_value=self._speed_label())
            self._loop_checkbox = gui.add_checkbox("Loop", self.loop)
            self._live_button = gui.add_button("Show live robot only")
            self._planned_button = gui.add_button("Play planned path", disabled=True)
        with gui.add_folder("Tasks"):
            self._task_dropdown = gui.add_dropdown("Task", (NO_TASK,))
            self._stage_dropdown = gui.add_dropdown("Stage", ("-",), hint="the stage whose solutions to show")
            self._solution_dropdown = gui.add_dropdown("Solution", (NO_SOLUTION,),
                                                       hint="the stage's part of a published solution")
            self._tree_html = gui.add_html("<p><i>no task yet: task nodes publish /&lt;node&gt;/task/*</i></p>")
        with gui.add_folder("Display"):
            self._live_checkbox = gui.add_checkbox("Live robot", True)
            self._objects_checkbox = gui.add_checkbox("Scene objects", True)
            self._sim_checkbox = gui.add_checkbox("Simulated world", True,
                                                  hint="a physics twin's objects where its simulation has them "
                                                       "(mujoco_sim: their true poses), drawn in their own colours")
            # last: its text changes as data arrives, and nothing below it may move
            self._status = gui.add_markdown("waiting for joint states")

        def user(event: Any) -> bool:
            return getattr(event, "client", None) is not None

        self._task_dropdown.on_update(lambda e: user(e) and self._command("select_task", e.target.value))
        self._stage_dropdown.on_update(lambda e: user(e) and self._command("select_stage", e.target.value))
        self._solution_dropdown.on_update(lambda e: user(e) and self._command("select_solution", e.target.value))
        self._play_button.on_click(lambda e: self._command("toggle_play"))
        self._time_slider.on_update(lambda e: user(e) and self._command("seek", float(e.target.value)))
        self._speed_dropdown.on_update(lambda e: user(e) and self._command("speed", SPEEDS[e.target.value]))
        self._loop_checkbox.on_update(lambda e: user(e) and self._command("loop", bool(e.target.value)))
        self._live_button.on_click(lambda e: self._command("show_live"))
        self._planned_button.on_click(lambda e: self._command("play_planned_path"))
        self._live_checkbox.on_update(lambda e: user(e) and self._command("live_visible", bool(e.target.value)))
        self._objects_checkbox.on_update(lambda e: user(e) and self._command("objects_visible", bool(e.target.value)))
        self._sim_checkbox.on_update(lambda e: user(e) and self._command("sim_visible", bool(e.target.value)))

    def _live_frame_pose(self, frame: str) -> np.ndarray | None:
        """``frame``'s world pose in the live robot's state (any thread: a state of its own)."""
        with self._lock:
            positions = np.array(self._live_positions, dtype=float)
        return RobotState(self.model, positions).frame_pose(frame)

    def _speed_label(self) -> str:
        return min(SPEEDS, key=lambda k: abs(SPEEDS[k] - self.speed))

    # ------------------------------------------------------------------ inputs (any thread)
    def on_joint_state(self, names: Sequence[str], positions: Sequence[float], stamp: float | None = None) -> None:
        """Newest joint state (stamp: seconds since the epoch, for the display-lag figure)."""
        with self._lock:
            self._joint_msg = (list(names), list(positions), stamp, time.time())
            self._received += 1
        self._wake.set()

    def on_scene(self, msg: PlanningSceneMsg | str) -> None:
        """A full planning scene (/planning_server/monitored_planning_scene)."""
        if isinstance(msg, str):
            msg = PlanningSceneMsg.from_json(msg)
        with self._lock:
            self._scene_msg = msg
        self._wake.set()

    def on_sim_world(self, objects: Mapping[str, Any], colours: Mapping[str, tuple[int, int, int]] | None = None
                     ) -> None:
        """A simulator's objects at their true poses ({id: CollisionObject posed in the world}),
        optional {id: RGB 0-255}; the newest is drawn."""
        with self._lock:
            self._sim_msg = SceneObjects(world=dict(objects))
            if colours:
                self._sim_colours.update(colours)
        self._wake.set()

    def on_task_description(self, source: str, msg: TaskDescription) -> None:
        self._on_task_message(self.registry.on_description, source, msg)

    def on_task_statistics(self, source: str, msg: TaskStatistics) -> None:
        self._on_task_message(self.registry.on_statistics, source, msg)

    def on_task_solution(self, source: str, msg: TaskSolution) -> None:
        self._on_task_message(self.registry.on_solution, source, msg)

    def _on_task_message(self, update: Callable[[str, Any], None], source: str, msg: Any) -> None:
        """Hand one task message to the registry (``update``) under the lock and wake the loop."""
        with self._lock:
            update(source, msg)
            self._tasks_dirty = True
        self._wake.set()

    def on_planned_path(self, trajectory: JointTrajectory) -> None:
        """A planned trajectory (/planned_path): animated from the live state."""
        self._command("planned_path", trajectory)

    # ------------------------------------------------------------------ commands (any thread)
    def select(self, task: str | None = None, stage: str | int | None = None, solution: int = 0) -> None:
        """Show a solution: of ``task`` (its key, "/node: task_id"; default the selected one),
        of ``stage`` (name, path or id; default the root), the ``solution``-th cheapest.
        Raises ValueError at once for a task, stage or solution that does not exist."""
        with self._lock:
            key = task if task is not None else (self._selected_task or next(iter(self.registry.keys()), None))
            tree = self.registry.get(key) if key is not None else None
            if tree is None:
                raise ValueError(f"unknown task {task!r}; known: {', '.join(self.registry.keys()) or 'none yet'}"
                                 if task is not None else "no task has been published yet")
            rows = tree.rows()
            match = rows[:1] if stage is None else [r for r in rows if stage in (r.id, r.name, r.path)]
            if not match:
                raise ValueError(f"task '{tree.key}' has no stage {stage!r}")
            count = len(tree.solutions_of(match[0].id))
            if not 0 <= solution < count:
                raise ValueError(f"stage '{match[0].name}' has {count} published solution(s); "
                                 f"no solution index {solution}")
        self._command("select", key, match[0].id, solution)

    def play(self) -> None:
        self._command("play", True)

    def pause(self) -> None:
        self._command("play", False)

    def seek(self, t: float) -> None:
        self._command("seek", float(t))

    def show_live(self) -> None:
        self._command("show_live")

    def _command(self, name: str, *args: Any) -> None:
        self._commands.put((name, args))
        self._wake.set()

    def wait_idle(self, timeout: float = 5.0) -> bool:
        """True once every queued command and input has been applied (for scripts and tests)."""
        marker = threading.Event()
        self._command("_mark", marker)
        return marker.wait(timeout)

    # ------------------------------------------------------------------ queries
    def display_lags(self, reset: bool = False) -> list[float]:
        """Seconds from each applied joint state's stamp to the display having it."""
        with self._lock:
            lags = list(self._lags)
            if reset:
                self._lags.clear()
        return lags

    def state(self) -> dict[str, Any]:
        """What the page shows, as JSON-able data."""
        with self._lock:
            lags = np.asarray(self._lags, dtype=float) * 1000.0
            received, applied = self._received, self._applied
            trees = [t.to_dict() for t in sorted(self.registry.tasks.values(), key=lambda t: t.key)]
        preview = self._preview
        names = self.model.variable_names
        out: dict[str, Any] = {
            "url": self.url,
            "clients": len(self.server.get_clients()),
            "robot": {"name": self.model.name, "links": list(self.live.links)},
            "live": {"visible": self.live.visible,
                     "positions": dict(zip(names, [round(float(v), 6) for v in self._live_positions])),
                     "stamp": self._live_stamp, "objects": self.live_objects.shown,
                     "objects_visible": self.live_objects.visible, "object_errors": dict(self.live_objects.errors)},
            "preview": None,
            "tasks": trees,
            "selected": {"task": self._selected_task, "stage_id": self._selected_stage},
            "joint_states": {"received": received, "applied": applied,
                             "lag_ms": ({"median": round(float(np.median(lags)), 3),
                                         "p90": round(float(np.percentile(lags, 90)), 3),
                                         "max": round(float(lags.max()), 3)} if len(lags) else None)},
            "colours": {"live_robot": list(LIVE_COLOUR), "preview_robot": list(PREVIEW_COLOUR),
                        "attached": list(ATTACHED_COLOUR), "objects": {k: list(v) for k, v in self._colour_of.items()}},
            "objectives": self.objectives.state() if self.objectives is not None else None,
            "teleop": self.teleop.state() if self.teleop is not None else None,
            "pose_target": self.pose_target.state() if self.pose_target is not None else None,
            "sim_world": {"visible": self.sim_objects.visible, "objects": self.sim_objects.shown},
        }
        if preview is not None:
            positions = self.preview_robot.positions
            out["preview"] = {
                "source": preview.source, "label": preview.label, "task": preview.task_key,
                "stage_id": preview.stage_id, "stage": preview.stage_name, "solution": preview.solution_label,
                "time": round(preview.time, 4), "duration": round(preview.timeline.duration, 4),
                "playing": preview.playing, "visible": self.preview_robot.visible,
                "steps": [s.label for s in preview.timeline.segments],
                "positions": dict(zip(names, [round(float(v), 6) for v in positions])) if positions is not None else {},
                "objects": self.preview_objects.shown,
            }
        return out

    # ------------------------------------------------------------------ display thread
    def close(self) -> None:
        self._stop.set()
        self._wake.set()
        self._thread.join(timeout=5.0)
        self.server.stop()

    def _run(self) -> None:
        period = 1.0 / 60.0  # animation frame period
        last_frame = time.monotonic()
        while not self._stop.is_set():
            playing = self._preview is not None and self._preview.playing
            timeout = period if playing else 0.5
            if self._retry_at is not None:
                timeout = max(0.0, min(timeout, self._retry_at - time.monotonic()))
                self._retry_at = None
            self._wake.wait(timeout=timeout)
            self._wake.clear()
            if self._stop.is_set():
                break
            try:
                self._drain_commands()
                self._apply_inputs()
                now = time.monotonic()
                if self._preview is not None and self._preview.playing:
                    self._advance(now - last_frame)
                last_frame = now
            except Exception as exc:  # never let one bad input stop the display
                self._log(f"display update failed: {type(exc).__name__}: {exc}")

    def _apply_inputs(self) -> None:
        with self._lock:
            joint_msg, self._joint_msg = self._joint_msg, None
            scene_msg, self._scene_msg = self._scene_msg, None
            sim_msg, self._sim_msg = self._sim_msg, None
            tasks_dirty, self._tasks_dirty = self._tasks_dirty, False
        if sim_msg is not None:
            self.sim_objects.update(sim_msg, {})
        if scene_msg is not None:
            try:
                self._live_scene = SceneObjects.from_msg(self.model, scene_msg)
            except Exception as exc:
                self._log(f"ignored a planning scene that does not fit robot '{self.model.name}': {exc}")
            else:
                self.live_objects.update(self._live_scene, self._live_link_poses)
        if joint_msg is not None:
            wait = self._last_apply + 1.0 / self.max_update_rate - time.monotonic()
            if wait > 0:  # over the rate cap: keep the newest for the next round
                with self._lock:
                    if self._joint_msg is None:
                        self._joint_msg = joint_msg
                self._retry_at = time.monotonic() + wait  # the display loop wakes up then
            else:
                names, positions, stamp, _received_at = joint_msg
                self._live_positions = joint_vector(self.model, self._live_positions, names, positions)
                links = self._live_scene.links()
                with self.server.atomic():
                    self._live_link_poses = self.live.set_positions(self._live_positions, tuple(links))
                    if links:
                        self.live_objects.update(self._live_scene, self._live_link_poses)
                self._last_apply = time.monotonic()
                with self._lock:
                    self._applied += 1
                    if stamp is not None:
                        self._lags.append(time.time() - stamp)
                self._live_stamp = stamp
                if self.teleop is not None:
                    self.teleop.on_joint_positions(names, positions)
        if tasks_dirty:
            self._refresh_tasks()
        self._refresh_status()

    def _refresh_status(self) -> None:
        # At most twice a second: each change re-renders the page's panel, and a joint-state
        # counter changing at 100 Hz would keep a browser busy for nothing.
        now = time.monotonic()
        if now - self._last_status < 0.5:
            return
        self._last_status = now
        with self._lock:
            received = self._received
        tasks = len(self.registry.tasks)
        objects = len(self._live_scene.ids)
        text = (f"robot `{self.model.name}` · joint states {received} · "
                f"{objects} scene object{'s' if objects != 1 else ''} · {tasks} task{'s' if tasks != 1 else ''}")
        if self._status.content != text:
            self._status.content = text

    def _drain_commands(self) -> None:
        while True:
            try:
                name, args = self._commands.get_nowait()
            except queue.Empty:
                return
            try:
                getattr(self, f"_do_{name.lstrip('_')}")(*args)
            except Exception as exc:
                self._log(f"'{name}' failed: {type(exc).__name__}: {exc}")

    # ------------------------------------------------------------------ commands (display thread)
    def _do_mark(self, event: threading.Event) -> None:
        self._apply_inputs()
        event.set()

    def _do_select_task(self, key: str) -> None:
        if key == NO_TASK or self.registry.get(key) is None:
            return
        self._selected_task = key
        self._selected_stage = None
        self._refresh_tasks(force=True)

    def _do_select_stage(self, label: str) -> None:
        stage_id = self._stage_options.get(label)
        if stage_id is None:
            return
        self._selected_stage = stage_id
        self._refresh_tasks(force=True)
        self._show_entry(0)

    def _do_select_solution(self, label: str) -> None:
        index = self._solution_options.get(label)
        if index is not None:
            self._show_entry(index)

    def _do_select(self, task: str | None, stage: str | int | None, solution: int) -> None:
        if task is not None:
            if self.registry.get(task) is None:
                raise ValueError(f"unknown task '{task}'; known: {', '.join(self.registry.keys()) or 'none'}")
            self._selected_task = task
        tree = self._tree()
        if tree is None:
            raise ValueError("no task to select from")
        rows = tree.rows()
        if stage is None:
            stage_id = rows[0].id if rows else None
        else:
            match = [r for r in rows if stage in (r.id, r.name, r.path)]
            if not match:
                raise ValueError(f"task '{tree.key}' has no stage {stage!r}")
            stage_id = match[0].id
        self._selected_stage = stage_id
        self._refresh_tasks(force=True)
        self._show_entry(solution)

    def _do_toggle_play(self) -> None:
        if self._preview is None:
            return
        self._do_play(not self._preview.playing)

    def _do_play(self, playing: bool) -> None:
        if self._preview is None:
            return
        if playing and self._preview.time >= self._preview.timeline.duration:
            self._preview.time = 0.0
        self._preview.playing = bool(playing)
        self._play_button.label = "Pause" if playing else "Play"

    def _do_seek(self, t: float) -> None:
        if self._preview is None:
            return
        self._preview.time = min(max(t, 0.0), self._preview.timeline.duration)
        self._show_time()

    def _do_speed(self, speed: float) -> None:
        self.speed = speed

    def _do_loop(self, loop: bool) -> None:
        self.loop = loop

    def _do_live_visible(self, visible: bool) -> None:
        self.live.visible = visible

    def _do_sim_visible(self, visible: bool) -> None:
        self.sim_objects.visible = visible

    def set_sim_visible(self, visible: bool) -> None:
        """Show or hide the simulated world (the "Simulated world" checkbox)."""
        self._sim_checkbox.value = bool(visible)
        self._command("sim_visible", bool(visible))

    def _do_objects_visible(self, visible: bool) -> None:
        self.live_objects.visible = visible and self._preview is None
        self.preview_objects.visible = visible and self._preview is not None

    def _do_show_live(self) -> None:
        self._preview = None
        self.preview_robot.visible = False
        self.preview_objects.visible = False
        self.live_objects.visible = bool(self._objects_checkbox.value)
        self._now_showing.content = "showing: live robot"

    def _do_planned_path(self, trajectory: JointTrajectory) -> None:
        self._planned_path = trajectory
        self._planned_button.disabled = False
        if self.auto_play_planned_path:
            self._do_play_planned_path()

    def _do_play_planned_path(self) -> None:
        if self._planned_path is None:
            return
        timeline = Timeline.from_joint_trajectory(self.model, self._planned_path, self._live_positions,
                                                  label="planned path")
        timeline.start_objects = self._live_scene
        for segment in timeline.segments:
            segment.objects = segment.objects_after = self._live_scene
        self._start_preview(_Preview("planned_path", timeline, "planned path (/planned_path)"))

    # ------------------------------------------------------------------ tasks panel
    def _tree(self) -> TaskTree | None:
        if self._selected_task is not None:
            tree = self.registry.get(self._selected_task)
            if tree is not None:
                return tree
        keys = self.registry.keys()
        if not keys:
            return None
        self._selected_task = keys[0]
        return self.registry.get(keys[0])

    def _refresh_tasks(self, force: bool = False) -> None:
        tree = self._tree()
        keys = self.registry.keys()
        version = (tuple(keys), self._selected_task, self._selected_stage, tree.version if tree else -1)
        if version == self._shown_tree_version and not force:
            return
        self._shown_tree_version = version
        if not keys:
            return
        self._task_dropdown.options = tuple(keys)
        self._task_dropdown.value = self._selected_task
        rows = tree.rows()
        self._tree_html.content = tree.html_table(self._selected_stage)
        options: dict[str, int] = {}
        for row in rows:
            label = "\u00a0\u00a0" * row.depth + row.name
            while label in options:
                label += f" [{row.id}]"
            options[label] = row.id
        self._stage_options = options
        if options:
            self._stage_dropdown.options = tuple(options)
            if self._selected_stage not in options.values():
                self._selected_stage = rows[0].id
            self._stage_dropdown.value = next(k for k, v in options.items() if v == self._selected_stage)
        entries = tree.solutions_of(self._selected_stage) if self._selected_stage is not None else []
        self._solution_options = {}
        for k, entry in enumerate(entries):
            self._solution_options[f"{k + 1}. {entry.label}"] = k
        self._solution_dropdown.options = tuple(self._solution_options) or (NO_SOLUTION,)
        if self._preview is None and entries and self._selected_stage == rows[0].id:
            self._show_entry(0)  # first complete solution of a task: show it, as the MTC panel does

    def _show_entry(self, index: int) -> None:
        tree = self._tree()
        if tree is None or self._selected_stage is None:
            return
        entries = tree.solutions_of(self._selected_stage)
        if not entries:
            return
        if not 0 <= index < len(entries):
            raise ValueError(f"solution index {index} out of range: the stage has {len(entries)} published")
        entry = entries[index]
        solution = tree.solutions[entry.solution_index]
        timeline = Timeline.from_task_solution(self.model, solution, entry.steps)
        row = next(r for r in tree.rows() if r.id == entry.stage_id)
        label = next((k for k, v in self._solution_options.items() if v == index), entry.label)
        self._solution_dropdown.value = label if label in self._solution_dropdown.options else \
            self._solution_dropdown.options[0]
        self._start_preview(_Preview("task", timeline, f"{tree.key} · {row.name} · {entry.label}", tree.key,
                                     row.id, row.name, entry.label))

    # ------------------------------------------------------------------ playback
    def _start_preview(self, preview: _Preview) -> None:
        self._preview = preview
        self.preview_robot.visible = True
        show_objects = bool(self._objects_checkbox.value)
        self.live_objects.visible = False
        self.preview_objects.visible = show_objects
        self._time_slider.max = max(preview.timeline.duration, 0.01)
        self._do_play(preview.timeline.duration > 0)
        self._show_time(force_slider=True)

    def _advance(self, dt: float) -> None:
        preview = self._preview
        assert preview is not None
        duration = preview.timeline.duration
        preview.time += dt * self.speed
        if preview.time >= duration:
            if self.loop and duration > 0:
                preview.time = preview.time % duration if preview.time < 2 * duration else 0.0
            else:
                preview.time = duration
                self._do_play(False)
        self._show_time()

    def _show_time(self, force_slider: bool = False) -> None:
        preview = self._preview
        assert preview is not None
        sample = preview.timeline.sample(preview.time)
        with self.server.atomic():
            link_poses = self.preview_robot.set_positions(sample.positions, tuple(sample.objects.links()))
            self.preview_objects.update(sample.objects, link_poses)
        now = time.monotonic()
        if force_slider or now - self._last_slider_update > 0.1 or not preview.playing:
            self._time_slider.value = round(preview.time, 2)
            self._last_slider_update = now
            step = html.escape(sample.label or "-")
            self._now_showing.content = (f"showing: **{html.escape(preview.label)}**  \n"
                                         f"step: {step} · t = {preview.time:.2f} / {preview.timeline.duration:.2f} s")
