"""PNG pictures of trajectories and scenes, for reports and CI artefacts (matplotlib, no display).

* ``plot_trajectory``: one row per moved joint, columns position / velocity / acceleration over
  time, the joint's limits dashed, waypoints beyond a limit marked red, the task's steps shaded
  and named. What a reviewer checks first: does anything touch a limit, where are the steps.
* ``plot_scene``: one 3D view per chosen state — the robot's collision shapes among the scene
  objects (attached objects in purple) — e.g. start, grasp, release, end.

Both write the number of subplots and each subplot's pixel box into the PNG's text chunks
(``mycobot_planning:subplots``, ``mycobot_planning:axes``), so a test or a script can read the
picture back and check its layout without guessing from pixels. Figures are built with the
object-oriented API (no pyplot state), so plotting is safe from any thread and never opens a
window.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from ..core.robot_model.robot_model import RobotModel
from ..core.robot_state.robot_state import RobotState
from .geometry import object_shapes, robot_link_shapes, transform_points
from .playback import SceneObjects, Timeline

__all__ = ["PlotInfo", "SnapshotState", "plot_scene", "plot_trajectory", "read_plot_info", "snapshot_states"]

ROBOT_COLOUR = (0.55, 0.62, 0.75)
ATTACHED_COLOUR = (0.6, 0.3, 0.8)
OBJECT_COLOURS = [(0.85, 0.6, 0.3), (0.3, 0.7, 0.4), (0.35, 0.55, 0.9), (0.9, 0.4, 0.45), (0.5, 0.75, 0.8),
                  (0.8, 0.75, 0.3)]
JOINT_COLOURS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22"]
META_SUBPLOTS = "mycobot_planning:subplots"
META_AXES = "mycobot_planning:axes"
META_KIND = "mycobot_planning:kind"


@dataclass
class PlotInfo:
    """What was written: file, pixel size, and each subplot's title and pixel box
    (x0, y0, x1, y1 from the top-left corner)."""

    path: Path
    width: int
    height: int
    kind: str
    titles: list[str] = field(default_factory=list)
    boxes: list[tuple[int, int, int, int]] = field(default_factory=list)

    @property
    def subplots(self) -> int:
        return len(self.boxes)


@dataclass(frozen=True)
class SnapshotState:
    """A robot state to draw, with the objects as they are at that moment."""

    label: str
    positions: np.ndarray
    objects: SceneObjects


def _figure(width_in: float, height_in: float):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in))
    FigureCanvasAgg(fig)
    return fig


def _save(fig, path: str | Path, kind: str, axes: Sequence, titles: Sequence[str], dpi: int) -> PlotInfo:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.set_dpi(dpi)
    fig.canvas.draw()
    width, height = (int(round(v)) for v in fig.canvas.get_width_height())
    boxes = []
    for ax in axes:
        x0, y0, x1, y1 = ax.get_window_extent().extents
        boxes.append((int(math.floor(x0)), int(math.floor(height - y1)), int(math.ceil(x1)), int(math.ceil(height - y0))))
    metadata = {META_KIND: kind, META_SUBPLOTS: str(len(boxes)),
                META_AXES: json.dumps([{"title": t, "box": b} for t, b in zip(titles, boxes)])}
    fig.savefig(path, format="png", dpi=dpi, metadata=metadata)
    return PlotInfo(path, width, height, kind, list(titles), boxes)


def read_plot_info(path: str | Path) -> PlotInfo:
    """PlotInfo of a PNG written by this module, from its pixels' size and its text chunks."""
    from PIL import Image

    with Image.open(path) as image:
        width, height = image.size
        text = dict(getattr(image, "text", {}) or image.info)
    if META_AXES not in text:
        raise ValueError(f"{path}: not a mycobot_planning plot (no '{META_AXES}' text chunk)")
    axes = json.loads(text[META_AXES])
    return PlotInfo(Path(path), width, height, text.get(META_KIND, ""), [a["title"] for a in axes],
                    [tuple(a["box"]) for a in axes])


# ------------------------------------------------------------------------------ trajectory
def _limits(model: RobotModel, name: str) -> tuple[tuple[float, float], float, float]:
    info = model.joint(name)
    velocity = info.max_velocity if info.max_velocity and math.isfinite(info.max_velocity) else math.inf
    acceleration = (info.max_acceleration if info.max_acceleration and math.isfinite(info.max_acceleration)
                    else math.inf)
    return (info.lower, info.upper), velocity, acceleration


def plot_trajectory(timeline: Timeline, path: str | Path, *, title: str | None = None, dpi: int = 100,
                    joints: Sequence[str] | None = None) -> PlotInfo:
    """Positions, velocities and accelerations of every moved joint over time (one row per
    joint), limits dashed, out-of-limit waypoints red, steps shaded. Raises ValueError when
    the timeline has no waypoint (a solution made only of scene changes)."""
    times, names, positions, velocities, accelerations = timeline.dense()
    if joints is not None:
        unknown = [j for j in joints if j not in names]
        if unknown:
            raise ValueError(f"joint(s) {', '.join(unknown)} not moved by this trajectory; moved: {', '.join(names)}")
        keep = [names.index(j) for j in joints]
        names = list(joints)
        positions, velocities, accelerations = positions[:, keep], velocities[:, keep], accelerations[:, keep]
    if len(times) == 0 or not names:
        raise ValueError("nothing to plot: the trajectory has no waypoints")
    rows = len(names)
    fig = _figure(12.0, 1.9 * rows + 1.0)
    grid = fig.subplots(rows, 3, sharex=True, squeeze=False)
    columns = (("position", positions, "rad or m"), ("velocity", velocities, "/s"), ("acceleration", accelerations, "/s²"))
    spans = [(s.start_time, s.end_time, s.label) for s in timeline.segments if s.duration > 0]
    axes, titles = [], []
    for r, name in enumerate(names):
        (low, high), vmax, amax = _limits(timeline.model, name)
        bounds = {"position": (low, high), "velocity": (-vmax, vmax), "acceleration": (-amax, amax)}
        colour = JOINT_COLOURS[r % len(JOINT_COLOURS)]
        for c, (what, values, unit) in enumerate(columns):
            ax = grid[r][c]
            for k, (t0, t1, _label) in enumerate(spans):
                if k % 2:
                    ax.axvspan(t0, t1, color="0.93", zorder=0, lw=0)
            ax.plot(times, values[:, r], color=colour, lw=1.2)
            lo, hi = bounds[what]
            for bound in (lo, hi):
                if math.isfinite(bound):
                    ax.axhline(bound, color=colour, ls="--", lw=0.9, alpha=0.8)
            outside = (values[:, r] < lo - 1e-9 * max(1.0, abs(lo))) | (values[:, r] > hi + 1e-9 * max(1.0, abs(hi)))
            if np.any(outside):
                ax.plot(times[outside], values[outside, r], "o", color="red", ms=3)
            ax.grid(True, lw=0.3, alpha=0.5)
            ax.tick_params(labelsize=7)
            if r == 0:  # above the step names written over the first row
                ax.set_title(what, fontsize=10, pad=70 if len(spans) > 1 else 6)
            if c == 0:
                ax.set_ylabel(name, fontsize=8)
            if r == rows - 1:
                ax.set_xlabel("time [s]", fontsize=8)
            axes.append(ax)
            titles.append(f"{name} {what}")
    if spans and len(spans) > 1:
        top = grid[0][0]
        for t0, t1, label in spans:
            top.text(0.5 * (t0 + t1), 1.02, label, transform=top.get_xaxis_transform(), fontsize=6, rotation=60,
                     ha="left", va="bottom", clip_on=False)
    heading = title if title is not None else (f"{timeline.title} — {timeline.duration:.2f} s" if timeline.title
                                               else f"trajectory — {timeline.duration:.2f} s")
    fig.suptitle(heading, fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.98))
    return _save(fig, path, "trajectory", axes, titles, dpi)


# ------------------------------------------------------------------------------ scene
def snapshot_states(timeline: Timeline, at: Sequence[str | float] | None = None, max_default: int = 4,
                    ) -> list[SnapshotState]:
    """The states to draw. ``at`` items: "start", "end", a time in seconds (number or numeric
    string), or a stage name (the state at the end of that stage's first step, with its scene
    change applied). Default: start, every step that attaches or detaches an object, end (at
    most ``max_default``). Raises ValueError naming an item that matches nothing."""
    if at is None:
        picks: list[str | float] = ["start"]
        for segment in timeline.segments:
            if set(segment.objects.attached) != set(segment.objects_after.attached):
                picks.append(segment.label)
        picks.append("end")
        if len(picks) > max_default:
            picks = picks[: max_default - 1] + ["end"]
        at = picks
    out = []
    for item in at:
        out.append(_snapshot(timeline, item))
    return out


def _snapshot(timeline: Timeline, item: str | float) -> SnapshotState:
    if isinstance(item, (int, float)) and not isinstance(item, bool):
        sample = timeline.sample(float(item))
        return SnapshotState(f"t = {float(item):.2f} s", sample.positions, sample.objects)
    text = str(item).strip()
    if text == "start":
        return SnapshotState("start", timeline.start_positions.copy(), timeline.start_objects)
    if text == "end":
        return SnapshotState(f"end (t = {timeline.duration:.2f} s)", timeline.end_positions, timeline.end_objects)
    try:
        return _snapshot(timeline, float(text))
    except ValueError:
        pass
    for segment in timeline.segments:
        if segment.label == text:
            return SnapshotState(f"{text} (t = {segment.end_time:.2f} s)", segment.end_positions, segment.objects_after)
    known = sorted({s.label for s in timeline.segments if s.label})
    raise ValueError(f"'{text}' is neither start, end, a time in seconds nor a stage of this solution"
                     + (f" (stages: {', '.join(known)})" if known else ""))


def _object_colours(ids: Sequence[str]) -> dict[str, tuple[float, float, float]]:
    return {object_id: OBJECT_COLOURS[k % len(OBJECT_COLOURS)] for k, object_id in enumerate(sorted(ids))}


def plot_scene(model: RobotModel, states: Sequence[SnapshotState], path: str | Path, *, title: str | None = None,
               dpi: int = 100, elev: float = 25.0, azim: float = -50.0, package_dirs: Sequence = ()) -> PlotInfo:
    """One 3D view per state: the robot's collision shapes and the scene objects."""
    if not states:
        raise ValueError("no state to draw")
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    links = robot_link_shapes(model, segments=16)
    link_names = sorted({s.link for s in links} | set().union(*(s.objects.links() for s in states)))
    all_ids = sorted(set().union(*(set(s.objects.ids) for s in states)))
    colours = _object_colours(all_ids)
    cols = min(len(states), 3) if len(states) != 4 else 2
    rows = math.ceil(len(states) / cols)
    fig = _figure(4.6 * cols, 4.4 * rows + 0.5)
    axes, titles = [], []
    shape_cache: dict[str, list] = {}
    lows, highs = [], []
    for k, snap in enumerate(states):
        ax = fig.add_subplot(rows, cols, k + 1, projection="3d")
        state = RobotState(model, snap.positions)
        poses = state.frame_poses(link_names)
        for shape in links:
            verts = transform_points(poses[shape.link] @ shape.pose, shape.mesh.vertices)
            ax.add_collection3d(Poly3DCollection(verts[shape.mesh.faces], facecolor=ROBOT_COLOUR, edgecolor=(0, 0, 0, 0.08),
                                                 linewidths=0.2, alpha=1.0))
            lows.append(verts.min(axis=0))
            highs.append(verts.max(axis=0))
        object_poses = snap.objects.poses(poses)
        for object_id in snap.objects.ids:
            obj = snap.objects.object(object_id)
            key = snap.objects.shape_signature(object_id)
            if key not in shape_cache:
                shape_cache[key] = object_shapes(obj, package_dirs, segments=24)
            colour = ATTACHED_COLOUR if object_id in snap.objects.attached else colours[object_id]
            for shape in shape_cache[key]:
                verts = transform_points(object_poses[object_id] @ shape.pose, shape.mesh.vertices)
                ax.add_collection3d(Poly3DCollection(verts[shape.mesh.faces], facecolor=colour,
                                                     edgecolor=(0, 0, 0, 0.1), linewidths=0.2, alpha=0.9))
                lows.append(verts.min(axis=0))
                highs.append(verts.max(axis=0))
        ax.set_title(snap.label, fontsize=9)
        ax.view_init(elev=elev, azim=azim)
        ax.tick_params(labelsize=6)
        ax.set_xlabel("x", fontsize=7)
        ax.set_ylabel("y", fontsize=7)
        ax.set_zlabel("z", fontsize=7)
        axes.append(ax)
        titles.append(snap.label)
    low, high = np.min(lows, axis=0), np.max(highs, axis=0)
    centre, half = 0.5 * (low + high), 0.5 * float(np.max(high - low)) * 1.05
    for ax in axes:
        ax.set_xlim(centre[0] - half, centre[0] + half)
        ax.set_ylim(centre[1] - half, centre[1] + half)
        ax.set_zlim(max(centre[2] - half, low[2] - 0.02), max(centre[2] - half, low[2] - 0.02) + 2 * half)
        ax.set_box_aspect((1, 1, 1))
    if all_ids:
        from matplotlib.patches import Patch

        handles = [Patch(color=ROBOT_COLOUR, label=model.name)]
        handles += [Patch(color=colours[i], label=i) for i in all_ids]
        if any(s.objects.attached for s in states):
            handles.append(Patch(color=ATTACHED_COLOUR, label="attached"))
        fig.legend(handles=handles, loc="lower center", ncol=min(len(handles), 6), fontsize=8, frameon=False)
    fig.suptitle(title or "scene", fontsize=11)
    fig.tight_layout(rect=(0, 0.05 if all_ids else 0, 1, 0.96))
    return _save(fig, path, "scene", axes, titles, dpi)
