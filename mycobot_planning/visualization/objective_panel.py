"""The viewer's Objectives panel (MoveIt Pro's Objectives view, in the browser): the objective
library with Run and Stop, the running tree drawn with each node's live status, the root
blackboard, and the operator prompt with Continue, Fail and a move to a saved waypoint.

ROS-free like the rest of the page: ``on_*`` inputs take plain data (what the objective_server
publishes), the buttons call the ``actions`` the ROS side gives (send /do_objective, call
/cancel_objective, answer the prompt). ``state()`` reports what the panel shows, for tests.
"""
from __future__ import annotations

import html
import threading
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

#: node status -> colour (BT.CPP's Groot2 colours: running orange, success green, failure red)
STATUS_COLOURS = {"IDLE": "#888888", "RUNNING": "#e8900c", "SUCCESS": "#2e9e44", "FAILURE": "#d33a2c",
                  "SKIPPED": "#3a7bd5"}
NO_OBJECTIVES = "(no objective_server)"
NO_WAYPOINTS = "(no waypoints)"


@dataclass
class ObjectiveActions:
    """What the panel's buttons do (each returns at once; results arrive as inputs)."""

    run: Callable[[str], None]
    stop: Callable[[], None]
    answer: Callable[[int, str, str], None]  # (prompt_id, "continue" | "fail" | "waypoint", waypoint name)


def tree_lines(xml: str, statuses: Mapping[str, str],
               last: Mapping[str, str] | None = None) -> list[tuple[int, str, str, str]]:
    """(depth, label, status, last completed status) per node of a running tree's XML (``_uid``
    attributes, as write_tree_to_xml writes them), SubTrees expanded in place. ``last`` keeps
    what a node answered before it was reset to IDLE (Groot2 shows it faded)."""
    last = last or {}
    if not xml:
        return []
    root = ET.fromstring(xml)
    trees = {t.get("_fullpath", t.get("ID", "")): t for t in root.findall("BehaviorTree")}
    first = root.find("BehaviorTree")
    lines: list[tuple[int, str, str, str]] = []

    def walk(element: ET.Element, depth: int, prefix: str) -> None:
        for child in element:
            if child.tag in ("TreeNodesModel", "MetadataFields"):
                continue
            uid = child.get("_uid", "")
            name = child.get("name")
            kind = child.get("ID") if child.tag == "SubTree" else child.tag
            label = kind if not name or name == kind else f"{name} ({kind})"
            lines.append((depth, label, statuses.get(uid, "IDLE"), last.get(uid, "")))
            if child.tag == "SubTree":
                path = child.get("_fullpath", "")
                sub = trees.get(path)
                if sub is not None:
                    walk(sub, depth + 1, path)
            else:
                walk(child, depth + 1, prefix)

    if first is not None:
        walk(first, 0, "")
    return lines


def tree_html(lines: Sequence[tuple[int, str, str, str]]) -> str:
    if not lines:
        return "<p><i>no objective has run yet</i></p>"
    rows = []
    for depth, label, status, last in lines:
        shown = last if status == "IDLE" and last else status
        colour = STATUS_COLOURS.get(shown, "#888888")
        fade = ";opacity:0.5" if shown != status else ""
        rows.append(f'<div style="margin-left:{depth * 14}px;white-space:nowrap{fade}">'
                    f'<span style="color:{colour};font-weight:bold">●</span> {html.escape(label)}'
                    f' <span style="color:{colour};font-size:smaller">{shown.lower()}</span></div>')
    return "".join(rows)


def blackboard_html(entries: Mapping[str, Any]) -> str:
    if not entries:
        return "<p><i>blackboard empty</i></p>"
    rows = "".join(f"<tr><td><b>{html.escape(str(k))}</b></td><td>{html.escape(_short(v))}</td></tr>"
                   for k, v in sorted(entries.items()))
    return f'<table style="font-size:smaller">{rows}</table>'


def _short(value: Any, limit: int = 120) -> str:
    text = str(value)
    return text if len(text) <= limit else text[:limit] + "…"


class ObjectivePanel:
    """The panel in a viser GUI; inputs from any thread, buttons call ``actions``."""

    def __init__(self, gui: Any, actions: ObjectiveActions) -> None:
        self._actions = actions
        self._lock = threading.Lock()
        self._objectives: list[str] = []
        self._waypoints: list[str] = []
        self._status = ("", "Idle", "")
        self._lines: list[tuple[int, str, str, str]] = []
        self._blackboard: dict[str, Any] = {}
        self._prompt: dict[str, Any] | None = None
        with gui.add_folder("Objectives"):
            self._dropdown = gui.add_dropdown("Objective", (NO_OBJECTIVES,))
            self._run_button = gui.add_button("Run", disabled=True)
            self._stop_button = gui.add_button("Stop")
            self._status_md = gui.add_markdown("objective_server: **Idle**")
            self._prompt_md = gui.add_markdown("")
            self._waypoint_dropdown = gui.add_dropdown("Waypoint", (NO_WAYPOINTS,), visible=False)
            self._move_button = gui.add_button("Move to waypoint", visible=False)
            self._continue_button = gui.add_button("Continue", visible=False)
            self._fail_button = gui.add_button("Fail", visible=False)
            self._tree_html = gui.add_html(tree_html([]))
            self._blackboard_html = gui.add_html(blackboard_html({}))
        self._run_button.on_click(lambda _: self.click_run())
        self._stop_button.on_click(lambda _: self.click_stop())
        self._continue_button.on_click(lambda _: self.click_answer("continue"))
        self._fail_button.on_click(lambda _: self.click_answer("fail"))
        self._move_button.on_click(lambda _: self.click_answer("waypoint"))

    # -- buttons (viser's threads, or tests) ---------------------------------------------------
    def click_run(self, name: str | None = None) -> None:
        name = name or self._dropdown.value
        if name and name != NO_OBJECTIVES:
            self._actions.run(name)

    def click_stop(self) -> None:
        self._actions.stop()

    def click_answer(self, answer: str, waypoint: str | None = None) -> None:
        with self._lock:
            prompt = self._prompt
        if prompt is None:
            return
        self._actions.answer(int(prompt.get("prompt_id", 0)), answer, waypoint or self._waypoint_dropdown.value)

    # -- inputs (ROS callbacks) ---------------------------------------------------------------
    def on_library(self, objectives: Sequence[str], waypoints: Sequence[str]) -> None:
        with self._lock:
            if list(objectives) != self._objectives:
                self._objectives = list(objectives)
                self._dropdown.options = tuple(self._objectives) or (NO_OBJECTIVES,)
                self._run_button.disabled = not self._objectives
            if list(waypoints) != self._waypoints:
                self._waypoints = list(waypoints)
                self._waypoint_dropdown.options = tuple(self._waypoints) or (NO_WAYPOINTS,)

    def on_status(self, objective: str, status: str, message: str = "") -> None:
        with self._lock:
            self._status = (objective, status, message)
            text = f"objective_server: **{status}**" + (f" — {objective}" if objective else "")
            if message:
                text += f"  \n{message}"
            self._status_md.content = text

    def on_tree_state(self, state: Mapping[str, Any]) -> None:
        lines = tree_lines(str(state.get("xml") or ""), {str(k): v for k, v in (state.get("nodes") or {}).items()},
                           {str(k): v for k, v in (state.get("last") or {}).items()})
        with self._lock:
            self._lines = lines
            self._blackboard = dict(state.get("blackboard") or {})
            self._tree_html.content = tree_html(lines)
            self._blackboard_html.content = blackboard_html(self._blackboard)

    def on_prompt(self, prompt: Mapping[str, Any] | None) -> None:
        """The open operator prompt (None or ``active`` false: none)."""
        active = bool(prompt and prompt.get("active"))
        with self._lock:
            self._prompt = dict(prompt) if active else None
            self._prompt_md.content = (f"**Operator:** {html.escape(str(prompt.get('prompt') or 'Continue or Fail?'))}"
                                       f"  \n({html.escape(str(prompt.get('node_path', '')))})" if active else "")
            if active and prompt.get("waypoint_names"):
                self._waypoints = list(prompt["waypoint_names"])
                self._waypoint_dropdown.options = tuple(self._waypoints)
            for widget in (self._continue_button, self._fail_button, self._waypoint_dropdown, self._move_button):
                widget.visible = active

    def state(self) -> dict[str, Any]:
        with self._lock:
            return {"objectives": list(self._objectives), "waypoints": list(self._waypoints),
                    "status": {"objective": self._status[0], "status": self._status[1], "message": self._status[2]},
                    "tree": [{"depth": d, "label": label, "status": s, "last": last}
                             for d, label, s, last in self._lines],
                    "blackboard": dict(self._blackboard), "prompt": dict(self._prompt) if self._prompt else None}
