"""The task schedule: a SerialContainer computes one child per step, the one with the most
promising pending work (deepest partial solution first), and states made by a monitoring
generator inherit the depth of the partial solution they derive from (see task/stage.py)."""
from __future__ import annotations

from mycobot_planning.task import Generator, InterfaceState, Task, stages
from mycobot_planning.demos.pick_place import PickPlaceParameters, build_pick_place_task, pick_place_scene
from mycobot_planning.task.stage import GENERATOR_KEY, Priority, schedule_key
from task_helpers import scene_at


class ThreeStates(Generator):
    """Spawns three states of the given scene in one compute (as a grasp IK target does)."""

    def __init__(self, name: str, scene) -> None:
        super().__init__(name)
        self._scene = scene
        self._done = False

    def reset(self) -> None:
        super().reset()
        self._done = False

    def canCompute(self) -> bool:
        return not self._done

    def compute(self) -> None:
        self._done = True
        for cost in (0.0, 1.0, 2.0):
            self.spawn(InterfaceState(self._scene.diff()), cost)


def _chain_task(mycobot, log: list[str]) -> Task:
    """b2 ← b1 ← gen → f1 → f2 → f3: two backward and three forward no-op propagators."""
    scene = scene_at(mycobot, "home")
    task = Task("chain", mycobot, scene)
    names = ["b2", "b1", "gen", "f1", "f2", "f3"]
    for name in names:
        stage = ThreeStates(name, scene) if name == "gen" else stages.ModifyPlanningScene(name)
        stage.addSolutionCallback(lambda solution, name=name: log.append(name))
        task.add(stage)
    return task


def test_the_deepest_branch_is_finished_first(mycobot):
    log: list[str] = []
    steps: list[int] = []
    task = _chain_task(mycobot, log)
    task.addTaskCallback(lambda t: steps.append(t.numSolutions()))
    assert task.plan(max_solutions=1)
    # One stage per step. After the generator, the cheapest state is carried to both ends before
    # any other state moves: 6 computes. (MTC's rounds run gen, f1, f2, f3, then b1 and f1, f2, f3
    # on the second state, then b2: the solution comes with the 9th compute.)
    assert steps == [0, 0, 0, 0, 0, 1]
    assert log == ["gen", "gen", "gen", "b1", "b2", "f1", "f2", "f3"]
    assert task.solutions[0].cost == 0.0


def test_planning_to_exhaustion_still_processes_every_state(mycobot):
    log: list[str] = []
    task = _chain_task(mycobot, log)
    assert task.plan()
    assert task.numSolutions() == 3
    assert [s.cost for s in task.solutions] == [0.0, 1.0, 2.0]
    for name in ("b2", "b1", "f1", "f2", "f3"):
        assert log.count(name) == 3, name
    assert not task._root._can_compute()


def test_schedule_key_orders_like_mtc_priority_without_lineage():
    priorities = [Priority(3, 5.0), Priority(3, 1.0), Priority(1, 0.0), Priority(2, float("inf")), Priority(0, 0.0)]
    assert sorted(priorities, key=schedule_key) == sorted(priorities, key=Priority.key)
    # a lineage counts as depth, but a state's own depth breaks the tie
    assert schedule_key(Priority(1, 0.0), lineage_depth=5) < schedule_key(Priority(4, 0.0))
    assert schedule_key(Priority(5, 9.0)) < schedule_key(Priority(1, 0.0), lineage_depth=5)
    # work that derives from no state comes after every finite-cost state, before failures
    assert schedule_key(Priority(0, 1e9)) < GENERATOR_KEY < schedule_key(Priority(9, float("inf")))


def test_place_states_inherit_the_depth_of_the_grasp_they_come_from(mycobot):
    params = PickPlaceParameters()
    task = build_pick_place_task(mycobot, params, pick_place_scene(mycobot, params), seed=3)
    assert task.plan(max_solutions=1)
    generator = task.findChild("place object").findChild("place pose IK").wrapped
    monitored = generator.monitored_stage
    assert monitored is not None and generator.solutions
    for solution in generator.solutions:
        # "generate place pose" reads the lifted grasp: at least current state ... forbid collision
        assert solution.start.lineage_depth >= 8
    lineages = {s.start.lineage_depth for s in generator.solutions}
    place_ik = task.findChild("place object").findChild("place pose IK")
    assert place_ik.solutions
    # the IK solutions and the states propagated from them keep that lineage
    assert all(s.end.lineage_depth in lineages for s in place_ik.solutions)
    lower = task.findChild("place object").findChild("lower object")
    assert lower.solutions and all(s.start.lineage_depth in lineages for s in lower.solutions)
