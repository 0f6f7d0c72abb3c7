"""Reacting while moving (issue 29): objects appearing on the path of a running motion, and stops.

Real processes (mock controllers, planning_server) on a domain of the bench's own. Each
intrusion: the arm moves to a random valid start, a move_action goal to a random valid goal runs
with replanning (replan, 3 attempts, velocity and acceleration scaling 0.5); the plan is read from
/planned_path and a 4 cm box is published on /collision_object where the flange will be at a
random 50-85 % of the plan (the start and the goal kept 2 cm clear of it), 0.6 s before the
plan would first touch it (counted from the stamp of the first /joint_states message that left the
start). Every time here is a /joint_states stamp or the wall clock, never this client's arrival
time: under load its executor runs late, and arrival times then published the box with a fraction
of its lead and counted states from before the box as after it. A run in which the box still went
out with less than half its lead (the client itself too late) is reported ``late`` and left out of
the clearance: it tests this client, not the stop. Then:

* ``reaction_ms``: from the box's arrival at move_group (the scene change) to the stop command
  sent to the controllers, as move_group measures it (``get_state``: last_reaction_ms);
* ``min_clearance_m``: the smallest distance between the box and the robot over every
  /joint_states state recorded from the box's publication to the replan (the reaction and the
  stop), in every run (> 0: never touched); ``replanned_min_clearance_m`` the same over the
  replanned motions (the planner's own clearance: plans are checked at the validator's
  resolution, with no padding, as MoveIt's);
* ``replan_success_rate``: runs that ended SUCCESS at the goal (after stopping and replanning);
* ``stop_latency_ms``: separate runs: a "stop" on /trajectory_execution_event 30-60 % into a
  motion at full speed, to the first /joint_states message after which the arm stays still for
  two more (the controllers publish at 100 Hz: up to 20 ms late); ``stop_decel_ms`` is the stop's
  own deceleration time (from the result message) and ``stop_overhead_ms`` the difference.

Summary keys (a contract, keep them stable): reaction_ms (median), reaction_p90_ms,
min_clearance_m, replanned_min_clearance_m, replan_success_rate, stop_latency_ms (median), stop_decel_ms, stop_overhead_ms
(medians), intrusions, late_intrusions, invalidated, plus the spread of per-repeat reaction medians and the machine.

Register in scenarios.SCENARIOS as "react".
"""
from __future__ import annotations

import re
import time
from typing import Any

import numpy as np

from .common import emit, machine, rest_time, spread

INTRUSIONS = 20
#: s between the box's publication and the plan's first contact with it
LEAD = 0.6
STOPS = 10
BOX_SIZE = 0.04
REST_THRESHOLD = 1e-6


def _random_pair(model: Any, scene: Any, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A valid start and goal 1-2.5 rad apart (joint 1 turning most), flange above the table."""
    from mycobot_planning.core import RobotState

    group = model.group("arm")
    low, high = model.lower_limits[group.variable_indices], model.upper_limits[group.variable_indices]
    while True:
        start = rng.uniform(low * 0.6, high * 0.6)
        goal = rng.uniform(low * 0.6, high * 0.6)
        goal[0] = start[0] + rng.choice([-1.0, 1.0]) * rng.uniform(1.0, 2.5)
        if not low[0] * 0.9 < goal[0] < high[0] * 0.9:
            continue
        ok = True
        for values in (start, goal):
            state = RobotState(model)
            state.set_group_positions("arm", values)
            if scene.is_state_colliding(state):
                ok = False
            if state.frame_pose("link6_flange")[2, 3] < 0.12:
                ok = False
        if ok:
            return start, goal


def _intrusion(model: Any, trajectory: Any, goal: np.ndarray, rng: np.random.Generator
               ) -> tuple[np.ndarray, float] | None:
    """Where to put the box (the flange's position at a random 50-85 % of the plan, keeping the
    goal and the start free and 2 cm clear) and when the plan first touches it (s from its start);
    None when 50 tries find no such place."""
    from interfaces_py.msgs import CollisionObject as SceneObject
    from mycobot_planning.core import PlanningScene, RobotState
    from mycobot_planning.core.trajectory_execution.path_ahead import PathAhead
    from mycobot_planning.core.transforms import make_pose
    from mycobot_planning.ros.demos.react_demo import ARM

    path = PathAhead(model, trajectory)
    for _ in range(50):
        q = trajectory.sample(trajectory.times[0] + rng.uniform(0.5, 0.85) * trajectory.duration)[0]
        state = RobotState(model)
        state.set_joint_positions(dict(zip(trajectory.joint_names, q)))
        where = state.frame_pose("link6_flange")[:3, 3]
        scene = PlanningScene(model)
        scene.add_object(SceneObject.box("probe", [BOX_SIZE] * 3, make_pose(where)))
        ends = []
        for values in (trajectory.positions[0], goal):
            end = RobotState(model)
            end.set_joint_positions(dict(zip(ARM, values)))
            ends.append(scene.distance(end, include_self=False).min_distance)
        hit = path.first_collision(scene, 0.0)
        if hit is not None and min(ends) > 0.02 and hit.time > LEAD + 0.3:
            return where, hit.time
    return None


def bench_react(repeat: int, seed: int) -> None:
    """See the module docstring."""
    from interfaces_py.clients import MoveGroupClient
    from mycobot_planning.core import PlanningScene, RobotModel
    from mycobot_planning.core.robot_trajectory.robot_trajectory import joint_trajectory_to_timed
    from interfaces_py.ros_conversions import joint_trajectory_from_msg
    from std_msgs.msg import String

    from mycobot_planning.ros.demos.react_demo import (ReactProbe, box_msg, clearances, joint_goal, run_goal,
                                                       send_goal, wait_for)

    from .ros_scenarios import RobotProcesses, bench_domain_id, robot_ready

    rng = np.random.default_rng(seed)
    model = RobotModel.mycobot()
    free = PlanningScene(model)
    per_repeat = max(1, -(-INTRUSIONS // repeat))
    reactions: list[float] = []
    medians: list[float] = []
    stop_clearances: list[float] = []
    replanned_clearances: list[float] = []
    outcomes: list[bool] = []
    invalidated = 0
    late_runs = 0
    latencies, decels = [], []
    with RobotProcesses(bench_domain_id()):
        probe = ReactProbe()
        server = MoveGroupClient("arm", node=probe.node, timeout=15.0)
        try:
            robot_ready(server, lambda: len(probe.history) > 0)
            run = 0
            for index in range(repeat):
                repeat_reactions = []
                while len(outcomes) < (index + 1) * per_repeat:
                    run += 1
                    start, goal = _random_pair(model, free, rng)
                    if run_goal(probe, joint_goal(start, 1.0, False)).error_code.val != 1:
                        raise RuntimeError("could not move to the start")
                    with probe.lock:
                        probe.plans.clear()
                        probe.plan_times.clear()
                    before = server.call("get_state")["execution"]["invalidations"]
                    sent = probe.now()
                    future = send_goal(probe, joint_goal(goal, 0.5, True))
                    wait_for(lambda: probe.plans, 30.0, "the plan on /planned_path")
                    with probe.lock:
                        plan_msg = probe.plans[0]
                    trajectory = joint_trajectory_to_timed(joint_trajectory_from_msg(plan_msg))
                    found = _intrusion(model, trajectory, goal, rng)
                    if found is None:  # no place on this plan: let it finish, take another pair
                        wait_for(future.done, 90.0, "the goal's result")
                        run -= 1
                        continue
                    where, t_contact = found
                    object_id = f"intruder{run}"
                    # the motion starts when the arm leaves the start (the stamp of that /joint_states)
                    wait_for(lambda: future.done() or probe.left(start, sent) is not None, 30.0, "the motion")
                    moved = probe.left(start, sent)
                    contact_at = (moved if moved is not None else probe.now()) + t_contact
                    wait_for(lambda: probe.now() >= contact_at - LEAD or future.done(), 60.0, "the intrusion time")
                    published = probe.now()
                    probe.objects.publish(box_msg(object_id, where, BOX_SIZE))
                    lead = contact_at - published
                    wait_for(future.done, 90.0, "the goal's result")
                    code = future.result().result.error_code
                    status = server.call("get_state")["execution"]
                    if status["invalidations"] > before:
                        invalidated += 1
                        reactions.append(status["last_reaction_ms"])
                        repeat_reactions.append(status["last_reaction_ms"])
                    time.sleep(0.05)
                    with probe.lock:  # the replanned motion begins with the second plan
                        replanned_at = probe.plan_times[1] if len(probe.plan_times) > 1 else float("inf")
                    recorded = probe.since(published)
                    distances = clearances(model, [p for _, p in recorded], object_id, where, BOX_SIZE)
                    stopping = [d for (t, _), d in zip(recorded, distances) if t < replanned_at]
                    moving_on = [d for (t, _), d in zip(recorded, distances) if t >= replanned_at]
                    clearance = float(min(stopping)) if stopping else float("nan")
                    late = lead < LEAD / 2
                    if late:  # this client ran too late to give the box its lead: no test of a stop
                        late_runs += 1
                    else:
                        stop_clearances.append(clearance)
                    if moving_on:
                        replanned_clearances.append(float(min(moving_on)))
                    arrived = code.val == 1 and np.max(np.abs(probe.arm() - goal)) < 0.02
                    outcomes.append(bool(arrived))
                    emit({"scenario": "react", "run": run, "code": int(code.val), "arrived": bool(arrived),
                          "lead_s": round(lead, 3), "late": late, "min_clearance_m": round(clearance, 4),
                          "replanned_min_clearance_m": round(min(moving_on), 4) if moving_on else None,
                          "reaction_ms": status["last_reaction_ms"] if status["invalidations"] > before else None,
                          "message": code.message[:160]})
                    probe.objects.publish(box_msg(object_id, None, BOX_SIZE, remove=True))
                    wait_for(lambda: object_id not in server.call("get_objects").get("objects", {}), 10.0,
                          "the box's removal")
                if repeat_reactions:
                    medians.append(float(np.median(repeat_reactions)))
            for _ in range(STOPS):
                start, goal = _random_pair(model, free, rng)
                if run_goal(probe, joint_goal(start, 1.0, False)).error_code.val != 1:
                    raise RuntimeError("could not move to the start")
                with probe.lock:
                    probe.plans.clear()
                future = send_goal(probe, joint_goal(goal, 1.0, False))
                wait_for(lambda: probe.plans, 30.0, "the plan on /planned_path")
                with probe.lock:
                    duration = joint_trajectory_to_timed(joint_trajectory_from_msg(probe.plans[0])).duration
                time.sleep(rng.uniform(0.3, 0.6) * duration)
                asked = probe.now()
                probe.events.publish(String(data="stop"))
                wait_for(future.done, 60.0, "the stopped goal's result")
                wait_for(lambda: rest_time(probe.since(asked), asked, REST_THRESHOLD) is not None, 10.0,
                         "the arm at rest on /joint_states after the stop")
                latencies.append((rest_time(probe.since(asked), asked, REST_THRESHOLD) - asked) * 1e3)
                found = re.search(r"after a ([0-9.]+) s stop", future.result().result.error_code.message)
                decels.append(float(found.group(1)) * 1e3 if found else float("nan"))
                emit({"scenario": "react", "stop": len(latencies), "stop_latency_ms": round(latencies[-1], 2),
                      "stop_decel_ms": decels[-1], "message": future.result().result.error_code.message[:160]})
        finally:
            server.close()
            probe.close()
    overhead = [lat - dec for lat, dec in zip(latencies, decels)]
    emit({"scenario": "react", "summary": True,
          "reaction_ms": round(float(np.median(reactions)), 3) if reactions else None,
          "reaction_p90_ms": round(float(np.percentile(reactions, 90)), 3) if reactions else None,
          "min_clearance_m": round(float(np.nanmin(stop_clearances)), 4) if stop_clearances else None,
          "replanned_min_clearance_m": round(float(min(replanned_clearances)), 4) if replanned_clearances else None,
          "replan_success_rate": round(float(np.mean(outcomes)), 3) if outcomes else None,
          "stop_latency_ms": round(float(np.median(latencies)), 2) if latencies else None,
          "stop_decel_ms": round(float(np.nanmedian(decels)), 2) if decels else None,
          "stop_overhead_ms": round(float(np.nanmedian(overhead)), 2) if overhead else None,
          "intrusions": len(outcomes), "late_intrusions": late_runs, "invalidated": invalidated, **spread(medians), **machine()})


REACT_SCENARIOS = {"react": bench_react}
