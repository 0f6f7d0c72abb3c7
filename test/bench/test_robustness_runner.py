"""The robustness runner's watch, without ROS: what a wrongly accepted input does after its case
was judged (a motion that comes back to rest, a scene change) still fails the run, in the case it
shows up in or after the last case. A fake prober stands for the nodes; the "late" effects are
scripted on the calls the runner makes, so nothing here depends on timing."""
from __future__ import annotations

import threading
import time
from types import SimpleNamespace
from typing import Any, Callable

import pytest

from mycobot_planning.bench import robustness
from mycobot_planning.bench.robustness import LATE_S, WATCHED_JOINTS, Case, Prober, Runner

REST = dict.fromkeys(WATCHED_JOINTS, 0.0)


class FakeNodes(Prober):
    """The scene, joint_states and the planning_server's answers, as the test scripts them:
    ``on_plan[k]`` runs while the k-th ``plan`` request (from 0) is being answered,
    ``after_scene[k]`` right after the k-th scene was sent."""

    def __init__(self) -> None:  # no ROS: only what the runner reads
        self.lock = threading.Lock()
        self.joints = dict(REST)
        self._rest: dict[str, float] | None = None
        self._moved: list[str] | None = None
        self.objects: list[dict[str, Any]] = []
        self.on_plan: dict[int, Callable[[], None]] = {}
        self.after_scene: dict[int, Callable[[], None]] = {}
        self.plans = self.scenes = 0

    def publish(self, joints: dict[str, float]) -> None:
        """One joint_states message."""
        self._on_joints(SimpleNamespace(name=list(joints), position=list(joints.values())))

    def call(self, method: str, params: Any, timeout: float = 15.0) -> dict:
        if method == "get_planning_scene":
            scene = {"world": {"collision_objects": list(self.objects)},
                     "robot_state": {"attached_collision_objects": []}, "allowed_collision_matrix": {}}
            self.after_scene.get(self.scenes, lambda: None)()
            self.scenes += 1
            return {"ok": True, "result": scene}
        assert method == "plan"
        self.on_plan.get(self.plans, lambda: None)()
        self.plans += 1
        return {"ok": False, "error": {"code": -1001, "message": "goal: unknown named state"}}

    def publish_trajectory(self, controller: str, data: dict) -> None:
        pass  # what the controller does with it, the test scripts


def _cases(kinds: str) -> list[Case]:
    """c: a bad trajectory on the arm controller's topic; p: a bad plan request."""
    return [Case("controller", f"trajectory {k}", {"joint_names": [], "points": []}, "arm_controller")
            if kind == "c" else Case("rpc", f"plan {k}", {"goal": {"named": "nowhere"}}, "plan")
            for k, kind in enumerate(kinds)]


@pytest.fixture
def late_sleep(monkeypatch: pytest.MonkeyPatch) -> dict[float, Callable[[], None]]:
    """The runner's sleeps return at once; one of LATE_S first runs what the test put here."""
    actions: dict[float, Callable[[], None]] = {}

    def sleep(seconds: float) -> None:
        actions.pop(seconds, lambda: None)()

    monkeypatch.setattr(robustness, "time", SimpleNamespace(sleep=sleep, monotonic=time.monotonic))
    return actions


def _run(nodes: FakeNodes, kinds: str) -> list[robustness.Outcome]:
    return Runner(nodes, {}, lambda name: "").run(_cases(kinds)).outcomes


def test_inputs_that_change_nothing_are_all_refused(late_sleep):
    outcomes = _run(FakeNodes(), "ccppp")
    assert [o.verdict for o in outcomes] == ["refused"] * 5, outcomes


def test_a_motion_back_to_rest_after_its_case_fails_the_case_it_shows_up_in(late_sleep):
    nodes = FakeNodes()
    moved = dict(REST, link2_to_link3=0.02)
    nodes.on_plan[1] = lambda: (nodes.publish(moved), nodes.publish(REST))  # the arm is back at rest
    outcomes = _run(nodes, "cppp")
    assert [o.verdict for o in outcomes] == ["refused", "refused", "unsafe_motion", "refused"], outcomes
    assert "link2_to_link3" in outcomes[2].detail and "late after an earlier one" in outcomes[2].detail
    assert nodes.joints == REST  # a look at the joints after each case alone would have missed it


def test_a_scene_change_between_two_cases_fails_the_next_one(late_sleep):
    nodes = FakeNodes()
    # right after the scene that closed the first case (a look before each case would miss it)
    nodes.after_scene[1] = lambda: nodes.objects.append({"id": "ghost", "primitives": []})
    outcomes = _run(nodes, "cpp")
    assert [o.verdict for o in outcomes] == ["refused", "half_applied", "refused"], outcomes


def test_a_motion_after_the_last_answer_is_seen_by_the_last_look(late_sleep):
    nodes = FakeNodes()
    late_sleep[LATE_S] = lambda: nodes.publish(dict(REST, link1_to_link2=-0.01))
    outcomes = _run(nodes, "pc")
    assert [o.verdict for o in outcomes] == ["refused", "unsafe_motion"], outcomes
    assert "after the answer" in outcomes[1].detail
    assert not late_sleep  # the last look was taken
