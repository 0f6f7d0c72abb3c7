"""Tests of the OMPL adapter on synthetic joint spaces (2-D and 6-D) with box obstacles.

Every path a planner returns is re-checked here, independently of OMPL: densely (every 2 mrad
along each segment) against the *exact* obstacles. The planner is given obstacles inflated by
one validity-checking step (longest_valid_segment_fraction x extent), so a path OMPL validated
at its resolution is provably clear of the exact obstacles; a dense-check failure is a real bug
(edges not checked, wrong resolution, path corrupted on the way out), not discretisation luck.
"""
from __future__ import annotations

import faulthandler
import math
import subprocess
import sys
import textwrap
import threading
from dataclasses import dataclass, field

import numpy as np
import pytest
from ompl import base as ob
from ompl import geometric as og

from mycobot_planning.core.planners.ompl import (
    UNAVAILABLE_MOVEIT_PLANNERS,
    OmplConfigError,
    available_planners,
    canonical_planner_type,
    load_ompl_config,
    parse_projection_evaluator,
    plan_joint_space,
    resolve_planner_id,
)
from mycobot_planning.core.planners.ompl.planners import apply_params, validate_params
from mycobot_planning.paths import config_file

from file_checks import assert_file_refused

LVSF = 0.005
INF = math.inf
DENSE_STEP = 0.002


# --------------------------------------------------------------------------------------------
# Synthetic worlds
# --------------------------------------------------------------------------------------------


@dataclass
class Solid:
    """Axis-aligned box (infinite sides allowed) minus axis-aligned holes."""

    lo: np.ndarray
    hi: np.ndarray
    holes: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)


def box(dim: int, **ranges: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """box(6, q0=(-1, 1)) -> bounds that are infinite in every dimension not named."""
    lo, hi = np.full(dim, -INF), np.full(dim, INF)
    for name, (a, b) in ranges.items():
        lo[int(name[1:])], hi[int(name[1:])] = a, b
    return lo, hi


class World:
    def __init__(self, dim: int, solids: list[Solid]):
        self.dim = dim
        self.lower = np.full(dim, -np.pi)
        self.upper = np.full(dim, np.pi)
        self.solids = solids
        # The spacing at which OMPL checks edges (MoveIt's definition).
        self.resolution = LVSF * float(np.linalg.norm(self.upper - self.lower))

    def planner_validity(self):
        """Scalar, pure-Python check against obstacles inflated by one checking step."""
        m = self.resolution
        solids = [
            (list(s.lo - m), list(s.hi + m), [(list(a + m), list(b - m)) for a, b in s.holes]) for s in self.solids
        ]

        def inside(q, lo, hi):
            return all(lo_i < x < hi_i for x, lo_i, hi_i in zip(q, lo, hi))

        def is_valid(q: np.ndarray) -> bool:
            for lo, hi, holes in solids:
                if inside(q, lo, hi) and not any(inside(q, a, b) for a, b in holes):
                    return False
            return True

        return is_valid

    def collides(self, pts: np.ndarray) -> np.ndarray:
        """Vectorised check against the exact obstacles (the test's own, independent checker)."""
        hit = np.zeros(len(pts), dtype=bool)
        for s in self.solids:
            inside = np.all((pts > s.lo) & (pts < s.hi), axis=1)
            for a, b in s.holes:
                inside &= ~np.all((pts > a) & (pts < b), axis=1)
            hit |= inside
        return hit

    def assert_valid_path(self, result, start, goals) -> None:
        assert result.success, f"{result.planner}: {result.status} {result.message}"
        assert result.status == "EXACT_SOLUTION"
        path = result.path
        assert path.ndim == 2 and path.shape[1] == self.dim and len(path) >= 2
        assert np.allclose(path[0], start, rtol=0, atol=1e-9), "path must begin at the start state"
        reached = [i for i, g in enumerate(goals) if np.allclose(path[-1], g, rtol=0, atol=1e-9)]
        assert reached, f"path ends at {path[-1]}, which is none of the goals"
        assert result.goal_index in reached
        assert np.all(path >= self.lower - 1e-9) and np.all(path <= self.upper + 1e-9)
        for a, b in zip(path, path[1:]):
            n = max(2, int(math.ceil(np.linalg.norm(b - a) / DENSE_STEP)) + 1)
            pts = a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)
            assert not self.collides(pts).any(), f"segment {a} -> {b} passes through an obstacle"


def easy_world(dim: int) -> tuple[World, np.ndarray, np.ndarray]:
    """A block across the straight line from start to goal; easy to go around in q1."""
    world = World(dim, [Solid(*box(dim, q0=(-0.4, 0.4), q1=(-1.0, 1.0)))])
    start = np.array([-2.0, 0.0, 0.3, -0.3, 0.5, 0.0][:dim])
    goal = np.array([2.0, 0.2, -0.3, 0.3, -0.5, 0.1][:dim])
    return world, start, goal


def sealed_goal_world(dim: int) -> tuple[World, np.ndarray, np.ndarray, np.ndarray]:
    """easy_world plus a closed shell around a valid configuration (a goal no path reaches)."""
    world, start, goal = easy_world(dim)
    c = np.full(dim, 2.0)
    world.solids.append(Solid(c - 0.6, c + 0.6, holes=[(c - 0.4, c + 0.4)]))
    return world, start, goal, c


def narrow_passage_world() -> tuple[World, np.ndarray, np.ndarray]:
    """6-D: a wall across q0 with one cubic window in (q1, q2, q3) of half-width 0.35 rad, off
    the straight line (0.27 after the planner's inflation: 0.07 % of the wall's 5-D area)."""
    dim = 6
    window = box(dim, q1=(0.65, 1.35), q2=(-0.85, -0.15), q3=(0.35, 1.05))
    world = World(dim, [Solid(*box(dim, q0=(-0.3, 0.3)), holes=[window])])
    return world, np.array([-2.0, 0, 0, 0, 0, 0]), np.array([2.0, 0, 0, 0, 0, 0])


@pytest.fixture(autouse=True)
def _hang_guard():
    """A planner deadlock (PRM + several goals + Python callback, see ompl_interface) would hang
    the run forever; dump the stacks and exit instead."""
    faulthandler.dump_traceback_later(300, exit=True)
    yield
    faulthandler.cancel_dump_traceback_later()


@pytest.fixture(scope="module")
def bundled():
    return load_ompl_config(config_file("ompl_planning.yaml"))


BUNDLED_CONFIG_NAMES = sorted(load_ompl_config(config_file("ompl_planning.yaml")).planner_configs)


# --------------------------------------------------------------------------------------------
# Registry and bundled config
# --------------------------------------------------------------------------------------------


def test_available_planners_are_the_wheels_classes():
    avail = available_planners()
    assert "geometric::RRTConnect" in avail and "geometric::KPIECE" in avail
    for t in avail:
        assert canonical_planner_type(t) == t
    # MoveIt's KPIECE names and OMPL's class names resolve to the same planner.
    assert canonical_planner_type("KPIECE1") == canonical_planner_type("geometric::KPIECE") == "geometric::KPIECE"
    for missing in UNAVAILABLE_MOVEIT_PLANNERS:
        assert not hasattr(og, missing.split("::")[1])
        with pytest.raises(OmplConfigError, match="not provided by the ompl"):
            canonical_planner_type(missing)


def test_bundled_config_covers_every_available_planner(bundled):
    assert {c.type for c in bundled.planner_configs.values()} == set(available_planners())
    assert set(bundled.groups) >= {"arm", "gripper", "arm_with_gripper"}
    for name in ("arm", "gripper", "arm_with_gripper"):
        g = bundled.group(name)
        assert g.default_planner_config == "RRTConnectkConfigDefault"
        assert g.longest_valid_segment_fraction == pytest.approx(0.005)
        assert set(g.planner_configs) == set(bundled.planner_configs)
    assert bundled.planner_configs["RRTstarkConfigDefault"].params["delay_collision_checking"] is True
    assert bundled.planner_configs["FMTkConfigDefault"].params["num_samples"] == 1000
    assert "planning_plugins" in bundled.pipeline
    assert parse_projection_evaluator(bundled.group("arm").projection_evaluator) == (
        "joints",
        ("link1_to_link2", "link2_to_link3"),
    )


def _declared_params(planner) -> set[str]:
    text = planner.printSettings()
    return {line.split("=")[0].strip() for line in text.splitlines() if "=" in line}


@pytest.mark.parametrize("ptype", available_planners())
def test_param_table_matches_what_ompl_declares(ptype):
    """Our name->setter table must cover OMPL's declared parameters (printSettings lists them,
    ParamSet is not bound) and every setter it names must exist on the class."""
    from mycobot_planning.core.planners.ompl.planners import PLANNERS

    spec = PLANNERS[ptype]
    space = ob.RealVectorStateSpace(3)
    space.setBounds(-1.0, 1.0)
    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(ob.AllValidStateValidityChecker(si))
    si.setup()
    planner = getattr(og, spec.cls_name)(si)
    setup = og.SimpleSetup(si)
    setup.setPlanner(planner)
    setup.setup()  # AORRTC must be set up before it is destroyed
    declared = _declared_params(planner)
    assert declared <= set(spec.params), f"OMPL declares {sorted(declared - set(spec.params))} we do not handle"
    for name, p in spec.params.items():
        if p.setter is not None:
            assert hasattr(planner, p.setter), f"{ptype}.{name}: no method {p.setter}"


def test_params_reach_the_planner():
    space = ob.RealVectorStateSpace(2)
    space.setBounds(-1.0, 1.0)
    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(ob.AllValidStateValidityChecker(si))
    si.setup()
    cases = {
        "geometric::RRTConnect": ({"range": "0.25"}, "getRange", 0.25),
        "geometric::RRTstar": ({"delay_collision_checking": 0, "goal_bias": 0.2}, "getGoalBias", 0.2),
        "geometric::KPIECE": ({"border_fraction": 0.7}, "getBorderFraction", 0.7),
        "geometric::FMT": ({"num_samples": "250", "nearest_k": "false"}, "getNumSamples", 250),
        "geometric::PRM": ({"max_nearest_neighbors": 7.0}, "getMaxNearestNeighbors", 7),
    }
    for ptype, (raw, getter, expected) in cases.items():
        planner = getattr(og, ptype.split("::")[1].replace("KPIECE", "KPIECE1"))(si)
        apply_params(planner, ptype, validate_params(ptype, raw, "test"))
        assert getattr(planner, getter)() == pytest.approx(expected)
    fmt = og.FMT(si)
    apply_params(fmt, "geometric::FMT", validate_params("geometric::FMT", {"nearest_k": 0}, "test"))
    assert fmt.getNearestK() is False
    rrtstar = og.RRTstar(si)
    apply_params(rrtstar, "geometric::RRTstar", {"delay_collision_checking": False})
    assert rrtstar.getDelayCC() is False


# --------------------------------------------------------------------------------------------
# Every configured planner finds a valid path
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("dim", [2, 6])
@pytest.mark.parametrize("config_name", BUNDLED_CONFIG_NAMES)
def test_every_configured_planner_solves_easy_problem(bundled, config_name, dim):
    world, start, goal = easy_world(dim)
    r = resolve_planner_id(bundled, "arm", config_name)
    result = plan_joint_space(
        world.lower,
        world.upper,
        world.planner_validity(),
        start,
        [goal],
        r.type,
        r.params,
        timeout=10.0,
        longest_valid_segment_fraction=r.longest_valid_segment_fraction,
        seed=11,
        stop_on_first_solution=True,
    )
    world.assert_valid_path(result, start, [goal])
    assert result.planner == r.type
    assert result.validity_checks > 0


@pytest.mark.parametrize("ptype", available_planners())
def test_multi_goal_with_sealed_first_goal(ptype):
    """The first goal is valid but sealed in a shell. Regression for three wheel hazards: PRM
    deadlocking on the GIL with several goals, BFMT segfaulting, and bidirectional planners
    never sampling the second goal."""
    world, start, goal, sealed = sealed_goal_world(6)
    validity = world.planner_validity()
    assert validity(sealed)  # the sealed goal itself is a valid state
    result = plan_joint_space(
        world.lower, world.upper, validity, start, [sealed, goal], ptype, {}, timeout=10.0, seed=3,
        stop_on_first_solution=True,
    )
    world.assert_valid_path(result, start, [sealed, goal])
    assert result.goal_index == 1


def test_rrtconnect_solves_narrow_passage():
    world, start, goal = narrow_passage_world()
    result = plan_joint_space(
        world.lower, world.upper, world.planner_validity(), start, [goal], "RRTConnect", {}, timeout=30.0, seed=5
    )
    world.assert_valid_path(result, start, [goal])
    # The path must go through the window: some waypoint-to-waypoint segment crosses q0 = 0.
    crossing = [(a, b) for a, b in zip(result.path, result.path[1:]) if a[0] <= 0 <= b[0] or b[0] <= 0 <= a[0]]
    assert crossing


def test_kpiece_with_explicit_projection_dims():
    world, start, goal = easy_world(6)
    result = plan_joint_space(
        world.lower, world.upper, world.planner_validity(), start, [goal], "KPIECE", {}, timeout=10.0, seed=2,
        projection_dims=[1, 0, 2],
    )
    world.assert_valid_path(result, start, [goal])


def test_one_dimensional_gripper_group(bundled):
    r = resolve_planner_id(bundled, "gripper", "")
    result = plan_joint_space([-0.7], [0.15], lambda q: True, [0.1], [[-0.5]], r.type, r.params, timeout=5.0)
    assert result.success and result.path.shape[1] == 1
    assert result.path[0, 0] == pytest.approx(0.1) and result.path[-1, 0] == pytest.approx(-0.5)


# --------------------------------------------------------------------------------------------
# Statuses
# --------------------------------------------------------------------------------------------


def test_invalid_start():
    world, start, goal = easy_world(6)
    inside_block = np.array([0.0, 0.0, 0, 0, 0, 0])
    for bad_start in (inside_block, np.array([4.0, 0, 0, 0, 0, 0])):  # in collision; out of bounds
        result = plan_joint_space(world.lower, world.upper, world.planner_validity(), bad_start, [goal], "RRTConnect", {}, 5.0)
        assert not result.success and result.status == "INVALID_START"
        assert result.path.shape == (0, 6)


def test_invalid_goals():
    world, start, goal = easy_world(6)
    inside_block = np.array([0.0, 0.0, 0, 0, 0, 0])
    out_of_bounds = np.array([0.0, 0, 0, 0, 0, 3.5])
    result = plan_joint_space(
        world.lower, world.upper, world.planner_validity(), start, [inside_block, out_of_bounds], "RRTConnect", {}, 5.0
    )
    assert not result.success and result.status == "INVALID_GOAL"
    # An invalid goal among valid ones is just dropped.
    result = plan_joint_space(
        world.lower, world.upper, world.planner_validity(), start, [inside_block, goal], "RRTConnect", {}, 5.0
    )
    world.assert_valid_path(result, start, [inside_block, goal])
    assert result.goal_index == 1


@pytest.mark.parametrize("ptype", ["RRTConnect", "PRM", "BFMT", "FMT"])
def test_impossible_problem_times_out(ptype):
    """Goal(s) sealed off: failure, reported as TIMEOUT (approximate solutions are failures)."""
    world, start, _, sealed = sealed_goal_world(6)
    result = plan_joint_space(
        world.lower, world.upper, world.planner_validity(), start, [sealed, sealed + 0.05], ptype, {}, timeout=0.5
    )
    assert not result.success
    assert result.status == "TIMEOUT"
    assert result.path.shape == (0, 6)


def test_trivial_problem():
    result = plan_joint_space([-1, -1], [1, 1], lambda q: True, [0.2, 0.3], [[0.2, 0.3]], "InformedRRTstar", {}, 1.0)
    assert result.success and result.path.shape == (2, 2) and result.goal_index == 0


# --------------------------------------------------------------------------------------------
# Reproducibility, path post-processing, callback bridge
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "ptype", ["RRTConnect", "RRT", "KPIECE", "BKPIECE", "LBKPIECE", "FMT", "BFMT", "RRTstar", "BITstar"]
)
def test_same_seed_same_path(ptype):
    world, start, goal = easy_world(6)

    def run():
        return plan_joint_space(
            world.lower, world.upper, world.planner_validity(), start, [goal, goal + 0.05], ptype, {}, 10.0, seed=42,
            stop_on_first_solution=True,
        )

    first, second = run(), run()
    assert first.success and second.success
    assert np.array_equal(first.path, second.path)


def test_edge_validator_checks_the_same_states_as_ompls(monkeypatch):
    """RRTConnect's edges are checked by our _EdgeValidator: the same states in the same order
    as OMPL's DiscreteMotionValidator, so the same seed gives the same path; edges and end
    states it has decided before are not checked again, so it needs fewer checks."""
    import mycobot_planning.core.planners.ompl.planners as ompl_interface

    world, start, goal = narrow_passage_world()
    spec = ompl_interface.PLANNERS["geometric::RRTConnect"]
    assert spec.plain_motion_checks

    def run():
        return plan_joint_space(world.lower, world.upper, world.planner_validity(), start, [goal], "RRTConnect",
                                {}, timeout=30.0, seed=11, interpolate_states=0)

    ours = run()
    monkeypatch.setitem(ompl_interface.PLANNERS, "geometric::RRTConnect",
                        ompl_interface.PlannerSpec(**{**spec.__dict__, "plain_motion_checks": False}))
    theirs = run()
    world.assert_valid_path(ours, start, [goal])
    assert ours.validity_checks < theirs.validity_checks
    assert np.array_equal(ours.path, theirs.path)


def test_interpolation_and_simplification_options():
    world, start, goal = easy_world(6)
    common = dict(timeout=10.0, seed=9)
    raw = plan_joint_space(world.lower, world.upper, world.planner_validity(), start, [goal], "RRT", {}, simplify=False, **common)
    world.assert_valid_path(raw, start, [goal])
    dense = plan_joint_space(world.lower, world.upper, world.planner_validity(), start, [goal], "RRT", {}, interpolate_states=0, **common)
    world.assert_valid_path(dense, start, [goal])
    steps = np.linalg.norm(np.diff(dense.path, axis=0), axis=1)
    assert steps.max() <= world.resolution + 1e-9  # MoveIt's interpolate(): states at the checking resolution
    many = plan_joint_space(world.lower, world.upper, world.planner_validity(), start, [goal], "RRT", {}, interpolate_states=2000, **common)
    world.assert_valid_path(many, start, [goal])
    assert len(many.path) >= 2000
    limited = plan_joint_space(
        world.lower, world.upper, world.planner_validity(), start, [goal], "RRT", {}, simplify_max_time=0.5, **common
    )
    world.assert_valid_path(limited, start, [goal])


def test_callback_receives_fresh_float_arrays():
    seen = []

    def check(q):
        seen.append(q)
        assert isinstance(q, np.ndarray) and q.dtype == np.float64 and q.shape == (3,)
        q[0] = 99.0  # mutating it must not affect the planner
        return True

    result = plan_joint_space([-1] * 3, [1] * 3, check, [-0.5, 0, 0], [[0.5, 0, 0]], "RRTConnect", {}, 2.0)
    assert result.success and np.all(np.abs(result.path) <= 1.0)
    assert len({id(q) for q in seen}) == len(seen) >= 2


class _Boom(Exception):
    pass


@pytest.mark.parametrize("ptype", ["RRTConnect", "PRM", "BFMT", "BITstar"])
def test_callback_exception_stops_planner_and_propagates(ptype):
    calls = [0]

    def check(q):
        calls[0] += 1
        if calls[0] > 50:
            raise _Boom("collision checker failed")
        return abs(q[0]) > 0.1 or q[1] > 0.8

    with pytest.raises(_Boom, match="collision checker failed"):
        plan_joint_space([-1] * 2, [1] * 2, check, [-0.5, 0], [[0.5, 0], [0.5, 0.1]], ptype, {}, 5.0)
    assert calls[0] == 51  # no call after the failure reached the user function


def test_cancel_stops_planning():
    """A cancel request (an Event another thread sets) ends the solve with ABORT; here the
    validity callback sets it itself, so the test needs no threads or timing."""
    world, start, _, sealed = sealed_goal_world(6)  # impossible: would run the full 60 s otherwise
    cancel = threading.Event()
    validity = world.planner_validity()
    calls = [0]

    def check(q):
        calls[0] += 1
        if calls[0] == 2000:
            cancel.set()
        return validity(q)

    for ptype in ("RRTConnect", "PRM", "BFMT"):
        calls[0] = 0
        cancel.clear()
        result = plan_joint_space(
            world.lower, world.upper, check, start, [sealed, sealed + 0.05], ptype, {}, 60.0, cancel=cancel
        )
        assert (result.success, result.status) == (False, "ABORT")
        assert calls[0] == 2000  # the user function is not called after the cancel was seen
    cancel.set()
    assert plan_joint_space([-1], [1], lambda q: True, [0], [[0.5]], cancel=cancel).status == "ABORT"


def test_no_nanobind_leak_report_at_exit():
    """Plan at module level with a callback that sees module globals (the pattern that leaks
    when OMPL objects form a cycle with a Python callable); nanobind must report nothing."""
    script = textwrap.dedent(
        """
        import numpy as np
        from mycobot_planning.core.planners.ompl import plan_joint_space
        obstacle = 0.1
        def valid(q):
            return abs(q[0]) > obstacle or q[1] > 0.8
        goals = [[0.5, 0.0], [0.5, 0.2]]
        results = [plan_joint_space([-1, -1], [1, 1], valid, [-0.5, 0], goals, p, {}, 1.0, seed=1,
                                    stop_on_first_solution=True)
                   for p in ("RRTConnect", "PRM", "BFMT", "KPIECE", "AORRTC")]
        assert all(r.success for r in results), [r.status for r in results]
        def bad(q):
            raise RuntimeError("x")
        try:
            plan_joint_space([-1, -1], [1, 1], lambda q: bad(q) if q[0] > 0 else True, [-0.5, 0], goals, "RRTConnect", {}, 1.0)
        except RuntimeError:
            pass
        print("ok")
        """
    )
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "ok"
    assert "leaked" not in proc.stderr, proc.stderr


# --------------------------------------------------------------------------------------------
# Input validation
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(goals=[[0.5, 0, 0]]), "goals\\[0\\] must be length 2"),
        (dict(start=[math.nan, 0]), "start contains NaN"),
        (dict(lower=[-1, 1]), "lower must be < upper.*\\[1\\]"),
        (dict(goals=[]), "goals is empty"),
        (dict(goals=np.array([0.5, 0.0])), "list of goal vectors"),
        (dict(timeout=0), "timeout must be a positive"),
        (dict(planner_type="Dijkstra"), "unknown planner type 'Dijkstra'"),
        (dict(planner_type="SBL"), "not provided by the ompl"),
        (dict(planner_params={"rang": 0.1}), "unknown parameter 'rang'.*known: intermediate_states, range"),
        (dict(planner_params={"range": -1}), "'range' = -1 must be >= 0"),
        (dict(planner_params={"range": "far"}), "'range' = 'far'"),
        (dict(planner_type="BFMT", planner_params={"balanced": 1}), "'balanced'.*cannot be changed"),
        (dict(seed=0), "seed must be"),
        (dict(longest_valid_segment_fraction=0), "longest_valid_segment_fraction"),
        (dict(projection_dims=[0, 0]), "projection_dims"),
        (dict(interpolate_states=-1), "interpolate_states"),
        (dict(is_state_valid=None), "must be callable"),
        (dict(cancel=True), "cancel must be"),
    ],
)
def test_bad_planning_input_raises(kwargs, match):
    args = dict(
        lower=[-1, -1], upper=[1, 1], is_state_valid=lambda q: True, start=[-0.5, 0], goals=[[0.5, 0]],
        planner_type="RRTConnect", planner_params={}, timeout=1.0,
    )
    args.update(kwargs)
    with pytest.raises(OmplConfigError, match=match):
        plan_joint_space(**args)


# --------------------------------------------------------------------------------------------
# Config loading and planner id resolution
# --------------------------------------------------------------------------------------------


def _cfg(**extra):
    data = {
        "planner_configs": {
            "RRTConnectkConfigDefault": {"type": "geometric::RRTConnect", "range": 0.0},
            "KPIECEkConfigDefault": {"type": "geometric::KPIECE", "goal_bias": 0.05},
            "FastRRTConnect": {"type": "geometric::RRTConnect", "range": 0.5, "longest_valid_segment_fraction": 0.02},
        },
        "arm": {
            "planner_configs": ["RRTConnectkConfigDefault", "KPIECEkConfigDefault", "FastRRTConnect"],
            "default_planner_config": "RRTConnectkConfigDefault",
            "longest_valid_segment_fraction": 0.01,
            "projection_evaluator": "joints(j1, j2)",
        },
    }
    for k, v in extra.items():
        data[k] = v
    return data


@pytest.mark.parametrize(
    "mutate, match",
    [
        (lambda d: d["planner_configs"].update(X={"type": "geometric::Teleport"}), "planner_configs.X: unknown planner type"),
        (lambda d: d["planner_configs"].update(X={"type": "geometric::SBL"}), "planner_configs.X: .*not provided by the ompl"),
        (lambda d: d["planner_configs"].update(X={"type": "geometric::RRT", "speed": 1}), "planner_configs.X: unknown parameter 'speed'"),
        (lambda d: d["planner_configs"].update(X={"type": "geometric::RRT", "goal_bias": 2}), "'goal_bias' = 2 must be in \\[0, 1\\]"),
        (lambda d: d["planner_configs"].update(X={"range": 0.1}), "planner_configs.X: missing 'type'"),
        (lambda d: d["planner_configs"].update(X="RRT"), "planner_configs.X: must be a mapping"),
        (lambda d: d["planner_configs"].update(X={"type": "RRT", "longest_valid_segment_fraction": 2}), "longest_valid_segment_fraction"),
        (lambda d: d["arm"]["planner_configs"].append("Nope"), "group 'arm': planner config 'Nope' is not defined"),
        (lambda d: d["arm"].update(default_planner_config="Nope"), "default_planner_config 'Nope' is not defined"),
        (lambda d: d["arm"].update(longest_valid_segment_fraction=0), "group 'arm': longest_valid_segment_fraction"),
        (lambda d: d["arm"].update(projection_evaluator="first_two"), "malformed projection_evaluator"),
        (lambda d: d["arm"].update(planners=["RRT"]), "group 'arm': unknown key\\(s\\) 'planners'"),
        (lambda d: d["arm"].update(planner_configs="RRTConnectkConfigDefault"), "must be a list"),
    ],
)
def test_config_errors(mutate, match):
    data = _cfg()
    mutate(data)
    with pytest.raises(OmplConfigError, match=match):
        load_ompl_config(data)


@pytest.mark.parametrize("name, text, match", [
    ("missing.yaml", None, "not found"),
    ("bad.yaml", "planner_configs: [unclosed\n", "invalid YAML"),
    ("bad.yaml", "- just\n- a list\n", "mapping at the top level"),
])
def test_config_file_errors(tmp_path, name, text, match):
    assert_file_refused(load_ompl_config, OmplConfigError, tmp_path / name, text, match)


def test_stock_moveit_file_loads_with_skip_unavailable():
    data = _cfg()
    data["planner_configs"]["SBLkConfigDefault"] = {"type": "geometric::SBL", "range": 0.0}
    data["arm"]["planner_configs"].append("SBLkConfigDefault")
    with pytest.raises(OmplConfigError, match="SBLkConfigDefault"):
        load_ompl_config(data)
    cfg = load_ompl_config(data, skip_unavailable=True)
    assert cfg.skipped_configs == ("SBLkConfigDefault",)
    assert "SBLkConfigDefault" not in cfg.group("arm").planner_configs


def test_resolve_planner_id_forms():
    cfg = load_ompl_config(_cfg())
    default = resolve_planner_id(cfg, "arm", "")
    assert (default.config_name, default.type, default.planner_id) == (
        "RRTConnectkConfigDefault",
        "geometric::RRTConnect",
        "arm[RRTConnectkConfigDefault]",
    )
    assert resolve_planner_id(cfg, "arm", None) == default
    assert resolve_planner_id(cfg, "arm", "RRTConnectkConfigDefault") == default
    assert resolve_planner_id(cfg, "arm", "arm[RRTConnectkConfigDefault]") == default
    # A planner type picks the group's <Type>kConfigDefault even when another config has the type.
    assert resolve_planner_id(cfg, "arm", "RRTConnect") == default
    assert resolve_planner_id(cfg, "arm", "geometric::RRTConnect") == default
    assert resolve_planner_id(cfg, "arm", "KPIECE1").config_name == "KPIECEkConfigDefault"
    # A type with no config: OMPL defaults.
    bit = resolve_planner_id(cfg, "arm", "BITstar")
    assert (bit.type, bit.params, bit.config_name) == ("geometric::BITstar", {}, "BITstar")
    # Group settings apply; a config's own longest_valid_segment_fraction wins.
    assert default.longest_valid_segment_fraction == 0.01
    assert default.projection_evaluator == "joints(j1, j2)"
    fast = resolve_planner_id(cfg, "arm", "FastRRTConnect")
    assert fast.longest_valid_segment_fraction == 0.02 and fast.params == {"range": 0.5}


def test_resolve_planner_id_errors_and_fallbacks():
    cfg = load_ompl_config(_cfg(gripper={"longest_valid_segment_fraction": 0.005}, hand={"planner_configs": ["KPIECEkConfigDefault"]}))
    with pytest.raises(OmplConfigError, match="unknown planner id 'Teleport'.*RRTConnectkConfigDefault"):
        resolve_planner_id(cfg, "arm", "Teleport")
    with pytest.raises(OmplConfigError, match="for group 'gripper', but the request is for group 'arm'"):
        resolve_planner_id(cfg, "arm", "gripper[RRTConnectkConfigDefault]")
    with pytest.raises(OmplConfigError, match="no OMPL configuration for planning group 'leg'"):
        resolve_planner_id(cfg, "leg", "")
    # No default: first listed config. Nothing listed: RRTConnect with OMPL defaults (MoveIt's fallback).
    assert resolve_planner_id(cfg, "hand", "").config_name == "KPIECEkConfigDefault"
    fallback = resolve_planner_id(cfg, "gripper", "")
    assert (fallback.type, fallback.params, fallback.planner_id) == ("geometric::RRTConnect", {}, "gripper[RRTConnect]")


def test_parse_projection_evaluator():
    assert parse_projection_evaluator("joints(a,b)") == ("joints", ("a", "b"))
    assert parse_projection_evaluator(" joints( a , b , c ) ") == ("joints", ("a", "b", "c"))
    assert parse_projection_evaluator("link(tool0)") == ("link", ("tool0",))
    for bad in ("joints()", "joints(a,,b)", "link(a, b)", "pose(a)", "joints(a"):
        with pytest.raises(OmplConfigError):
            parse_projection_evaluator(bad)


def test_try_direct_returns_the_straight_motion_when_it_is_valid_and_plans_otherwise():
    """try_direct: a free straight edge is the answer at once (checked as the planner checks an
    edge, interpolated as asked); a blocked one leaves the problem to the planner."""
    _, start, goal = easy_world(6)
    world = World(6, [])  # nothing in the way
    direct = plan_joint_space(world.lower, world.upper, world.planner_validity(), start, [goal], "RRTConnect", {},
                              timeout=10.0, seed=3, interpolate_states=0, try_direct=True)
    world.assert_valid_path(direct, start, [goal])
    assert direct.direct and direct.simplify_time == 0.0 and "straight" in direct.message
    steps = np.linalg.norm(np.diff(direct.path, axis=0), axis=1)
    assert steps.max() <= world.resolution + 1e-9 and np.allclose(steps, steps[0])
    many = plan_joint_space(world.lower, world.upper, world.planner_validity(), start, [goal], "RRTConnect", {},
                            timeout=10.0, seed=3, interpolate_states=500, try_direct=True)
    assert many.direct and len(many.path) == 500
    world, start, goal = easy_world(6)  # the block is across the straight line
    around = plan_joint_space(world.lower, world.upper, world.planner_validity(), start, [goal], "RRTConnect", {},
                              timeout=10.0, seed=3, interpolate_states=0, try_direct=True)
    world.assert_valid_path(around, start, [goal])
    assert not around.direct
    world, start, goal = narrow_passage_world()
    blocked = plan_joint_space(world.lower, world.upper, world.planner_validity(), start, [goal], "RRTConnect", {},
                               timeout=30.0, seed=11, interpolate_states=0, try_direct=True)
    world.assert_valid_path(blocked, start, [goal])
    assert not blocked.direct and len(blocked.path) > 2
