"""Benchmark ``sim``: the MuJoCo twin (mycobot_planning.simulation), ROS-free.

Per repeat, on the seeds' world (config/mujoco_scene.yaml, config/mujoco_sim.yaml):

- ``step_us``: wall time of one physics step as the simulator takes it (servo targets, MuJoCo's
  step with its contacts and noslip pass, the gripper's goal rules), camera off; the median of
  20 batches of 500 steps while the arm follows a planned trajectory.
- ``real_time_factor``: simulated seconds per wall second stepping as fast as the CPU allows
  with the depth camera rendering a 640x480 frame every 0.1 s of simulated time (in its own
  thread; no frame is dropped, so a slow camera slows the simulation): the arm follows the
  home -> ready -> home motions for 4 simulated seconds. >= 1 means the twin can run in real
  time with the camera at 10 Hz.
- ``camera_hz``: depth frames per wall second while running in real time (speed factor 1,
  camera at 10 Hz) for 3 s; ``camera_frame_ms`` the median time to render and back-project a
  frame, ``realtime_behind`` whether that run fell behind real time.

Then, once (seeded by --seed): ``pick_place_success`` of ``PICK_PLACE_RUNS`` (10) runs of the
seeds' pick and place, the cylinder placed uniformly at random on the seeds' table (10 x 20 cm
at (0.22, 0.12); wholly on it), each planned as mtc_node plans (max_solutions 10, the best
executed) and executed in physics (demos/sim_pick_place.py); ``place_error_mm`` median and max
over the runs that placed, ``slip_mm`` max over the runs that carried the cylinder.

Summary keys (a contract, keep them stable): real_time_factor, step_us, camera_hz,
pick_place_success, pick_place_runs, place_error_mm_median, place_error_mm_max, slip_mm_max,
plus camera_frame_ms, realtime_behind, the same two speeds in process CPU time (step_cpu_us,
real_time_factor_cpu: all our threads, the camera's and Mesa's included, so less sensitive to
other load on the machine; on an idle machine the camera renders beside the physics and the
wall-clock factor is higher), the 1-minute load average while measuring, the failures'
messages, the spread of per-repeat medians and the machine.

Register in scenarios.SCENARIOS as "sim".
"""
from __future__ import annotations

import math
import os
import time

import numpy as np

from mycobot_planning.simulation import MujocoSimulator  # first: sets MUJOCO_GL before mujoco loads
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.planning_interface import MotionPlanRequest, NamedGoal
from mycobot_planning.core import PlanningPipeline
from mycobot_planning.demos.pick_place import PickPlaceParameters
from mycobot_planning.demos.sim_pick_place import run_sim_pick_place

from .common import emit, machine, spread

PICK_PLACE_RUNS = 10
#: the seeds' table (mtc_node_params.yaml: table_dimensions, table_pose)
TABLE_CENTRE = (0.22, 0.12)
TABLE_SIZE = (0.10, 0.20)


def _motions(model: RobotModel) -> list:
    """home -> ready and ready -> home, planned by the core's pipeline."""
    out = []
    for start, goal in (("home", "ready"), ("ready", "home")):
        state = RobotState(model)
        state.set_named(start)
        scene = PlanningScene(model)
        scene.set_current_state(state)
        response = PlanningPipeline().plan(scene, MotionPlanRequest("arm", NamedGoal(goal), seed=1))
        if not response.success:
            raise RuntimeError(f"could not plan {start} -> {goal}: {response.message}")
        out.append(response.trajectory)
    return out


def _follow(sim: MujocoSimulator, motions: list, duration: float, batch: int | None = None) -> list[tuple[float, float]]:
    """Follow the motions in turn for ``duration`` simulated seconds; (wall, process CPU) time of
    every ``batch`` steps (or of the whole when None)."""
    times: list[tuple[float, float]] = []
    end = sim.time + duration
    k = 0
    started, cpu = time.perf_counter(), time.process_time()
    while sim.time < end - 1e-9:
        if not sim.trajectory_active:
            sim.follow_trajectory(motions[k % len(motions)])
            k += 1
        if batch is None:
            sim.step(10)
            continue
        t0, c0 = time.perf_counter(), time.process_time()
        sim.step(batch)
        times.append((time.perf_counter() - t0, time.process_time() - c0))
    if batch is None:
        sim.wait_for_frame()
        times.append((time.perf_counter() - started, time.process_time() - cpu))
    return times


def _measure_speed(model: RobotModel, motions: list) -> dict[str, float]:
    with MujocoSimulator(model, camera=False) as sim:
        batches = np.array(_follow(sim, motions, 10.0, batch=500))
        step_us, step_cpu_us = np.median(batches, axis=0) / 500 * 1e6
    with MujocoSimulator(model) as sim:
        sim.set_camera_rate(10.0)
        sim.capture()  # the camera thread's start-up (GL context, shaders) is not what we measure
        duration = 4.0
        wall, cpu = _follow(sim, motions, duration)[0]
        rtf, rtf_cpu = duration / wall, duration / cpu
    with MujocoSimulator(model) as sim:
        sim.set_camera_rate(10.0)
        frames0 = sim.status().camera_frames
        started = time.perf_counter()
        sim.run_realtime(3.0)
        sim.wait_for_frame()
        wall = time.perf_counter() - started
        status = sim.status()
        camera_hz = (status.camera_frames - frames0) / wall
        frame_ms = status.camera_frame_time * 1e3
    return {"step_us": round(float(step_us), 2), "real_time_factor": round(rtf, 3), "camera_hz": round(camera_hz, 2),
            "camera_frame_ms": round(frame_ms, 1), "realtime_behind": bool(status.behind_real_time),
            "step_cpu_us": round(float(step_cpu_us), 2), "real_time_factor_cpu": round(rtf_cpu, 3),
            "load_average": round(os.getloadavg()[0], 2)}


def _pick_place_runs(model: RobotModel, seed: int) -> list[dict]:
    rng = np.random.default_rng(seed)
    radius = PickPlaceParameters().object_dimensions[1]
    half = np.array(TABLE_SIZE) / 2 - radius
    runs = []
    for k in range(PICK_PLACE_RUNS):
        x, y = np.array(TABLE_CENTRE) + rng.uniform(-half, half)
        params = PickPlaceParameters(object_pose=[float(x), float(y), 0.0, 0.0, 0.0, 0.0])
        started = time.perf_counter()
        result = run_sim_pick_place(model, params, seed=seed * 1000 + k, camera=False)
        outcome = result.outcome
        record = {"scenario": "sim", "run": k, "object_xy": [round(float(x), 4), round(float(y), 4)],
                  "success": result.success, "wall_s": round(time.perf_counter() - started, 2),
                  "message": result.message}
        if outcome is not None:
            record.update(outcome.figures())
        emit(record)
        runs.append(record)
    return runs


def bench_sim(repeat: int, seed: int) -> None:
    """The twin's speed and the seeds' pick and place in physics (see the module docstring)."""
    model = RobotModel.mycobot()
    motions = _motions(model)
    speeds = []
    for index in range(repeat):
        figures = _measure_speed(model, motions)
        emit({"scenario": "sim", "repeat": index, **figures})
        speeds.append(figures)
    runs = _pick_place_runs(model, seed)
    placed = [r["place_error_mm"] for r in runs if r["success"]]
    slips = [r["slip_mm"] for r in runs if isinstance(r.get("slip_mm"), float) and math.isfinite(r["slip_mm"])]
    rtf = [s["real_time_factor"] for s in speeds]
    summary = {
        "scenario": "sim",
        "summary": True,
        "real_time_factor": round(float(np.median(rtf)), 3),
        "step_us": round(float(np.median([s["step_us"] for s in speeds])), 2),
        "camera_hz": round(float(np.median([s["camera_hz"] for s in speeds])), 2),
        "pick_place_success": sum(1 for r in runs if r["success"]),
        "pick_place_runs": len(runs),
        "place_error_mm_median": round(float(np.median(placed)), 2) if placed else None,
        "place_error_mm_max": round(float(np.max(placed)), 2) if placed else None,
        "slip_mm_max": round(float(np.max(slips)), 2) if slips else None,
        "camera_frame_ms": round(float(np.median([s["camera_frame_ms"] for s in speeds])), 1),
        "step_cpu_us": round(float(np.median([s["step_cpu_us"] for s in speeds])), 2),
        "real_time_factor_cpu": round(float(np.median([s["real_time_factor_cpu"] for s in speeds])), 3),
        "load_average": round(float(np.median([s["load_average"] for s in speeds])), 2),
        "realtime_behind": any(s["realtime_behind"] for s in speeds),
        "failures": [f"run {r['run']} at {r['object_xy']}: {r['message']}" for r in runs if not r["success"]],
    }
    emit({**summary, **spread(rtf), **machine()})


SIM_SCENARIOS = {"sim": bench_sim}
