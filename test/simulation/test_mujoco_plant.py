"""The MuJoCo twin as a plant of the controller manager: the controllers' followers, driven by the
plant's read/write around their update exactly as the manager's loop does (here stepped by hand
on the simulation's clock), move the simulated arm and gripper."""
from __future__ import annotations

import numpy as np
import pytest

from mycobot_planning.simulation import MujocoSimulator  # noqa: F401 - first: sets MUJOCO_GL
from mycobot_planning.core.trajectory_execution.controllers_config import load_controllers_config
from mycobot_planning.hardware_interface.plant import ControllerSpec, PlantHost
from mycobot_planning.mock_control.joint_trajectory_follower import ControllerStatus, TrajectoryCommand
from mycobot_planning.paths import config_file
from mycobot_planning.simulation.mujoco_plant import MujocoPlant

PERIOD = 0.01  # s: the controller manager's loop (100 Hz)


@pytest.fixture
def plant(sim, mycobot):
    config = load_controllers_config(config_file("controllers.yaml"), mycobot.variable_names)
    plant = MujocoPlant(mycobot.variable_names, mycobot.default_positions(), sim, config.controllers)
    defaults = mycobot.default_positions()
    for c in config.controllers:
        idx = np.array([mycobot.variable_index(j) for j in c.joints])
        plant.make_follower(ControllerSpec(c, idx, mycobot.lower_limits[idx], mycobot.upper_limits[idx],
                                           mycobot.velocity_limits[idx], mycobot.acceleration_limits[idx],
                                           defaults[idx], 0.05))
    plant.host = PlantHost(clock=lambda: sim.time)  # stepped by hand: no real-time thread
    return plant


def run(plant, sim, until, seconds: float) -> None:
    """The manager's loop on the simulation's clock: read, update every follower, write, step."""
    end = sim.time + seconds
    while sim.time < end and not until():
        now = sim.time
        plant.read(now)
        for follower, _ in plant.followers.values():
            follower.update(now)
        plant.write(now)
        sim.advance(PERIOD)


def move(follower, target, duration):
    start = follower.positions.copy()
    times = np.linspace(0.0, duration, 21)
    s = times / duration
    blend = 10 * s**3 - 15 * s**4 + 6 * s**5  # rest to rest
    rate = (30 * s**2 - 60 * s**3 + 30 * s**4) / duration
    accel = (60 * s - 180 * s**2 + 120 * s**3) / duration**2
    delta = np.asarray(target) - start
    return TrajectoryCommand.from_arrays(follower.joint_names, times, start + np.outer(blend, delta),
                                         np.outer(rate, delta), np.outer(accel, delta))


def test_the_arm_follows_a_trajectory_and_the_goal_succeeds_on_the_simulated_joints(plant, sim):
    arm = plant.followers["arm_controller"][0]
    target = [0.3, -0.2, 0.4, 0.1, 0.2, 0.0]
    result = arm.submit(move(arm, target, 2.0), sim.time)
    assert result.accepted, result.reason
    run(plant, sim, lambda: arm.status in ControllerStatus.TERMINAL, 5.0)
    assert arm.status == ControllerStatus.SUCCEEDED, arm.state().message
    state = sim.joint_states().as_dict()
    reached = np.array([state[j] for j in arm.joint_names])
    assert np.abs(reached - target).max() <= arm.goal_tolerance
    positions, _ = plant.joint_state()  # what the broadcaster publishes: the simulated joints
    assert np.allclose(positions[plant.followers["arm_controller"][1]], reached)


def test_a_stopped_goal_holds_the_arm_where_it_is(plant, sim):
    arm = plant.followers["arm_controller"][0]
    assert arm.submit(move(arm, [0.8, 0.0, 0.0, 0.0, 0.0, 0.0], 2.0), sim.time).accepted
    run(plant, sim, lambda: False, 0.8)
    arm.stop(sim.time, "test")
    run(plant, sim, lambda: False, 0.3)  # the servos settle on the hold command
    held = sim.arm_positions().copy()
    assert 0.05 < held[0] < 0.75  # stopped on the way
    run(plant, sim, lambda: False, 1.0)
    assert np.abs(sim.arm_positions() - held).max() < 0.01


def test_a_gripper_goal_moves_the_simulated_fingers(plant, sim):
    gripper = plant.followers["grip_action_controller"][0]
    start = float(gripper.positions[0])
    target = -0.3
    command = TrajectoryCommand(list(gripper.joint_names), [0.0, 1.0], [[start], [target]], [[0.0], [0.0]])
    assert gripper.submit(command, sim.time).accepted
    run(plant, sim, lambda: gripper.status in ControllerStatus.TERMINAL, 6.0)
    assert gripper.status == ControllerStatus.SUCCEEDED, gripper.state().message
    assert abs(sim.gripper_state().position - target) < 0.05


def test_controllers_that_do_not_match_the_model_are_refused(sim, mycobot):
    config = load_controllers_config(config_file("controllers.yaml"), mycobot.variable_names)
    with pytest.raises(ValueError, match="one controller of the arm joints"):
        MujocoPlant(mycobot.variable_names, mycobot.default_positions(), sim,
                    [c for c in config.controllers if c.name != "arm_controller"])


def run_behind(plant, sim, until, seconds: float, behind) -> None:
    """The manager's loop on its own clock while the physics does not keep up: ``behind(t)`` is
    how much of each period the simulation advances at manager time t (0: stalled, 0.5: at half
    speed), as a physics thread on a loaded machine does."""
    now = 100.0  # the manager's clock: unrelated to the simulation's
    end = now + seconds
    while now < end and not until():
        t = plant.follower_time(now)
        plant.read(t)
        for follower, _ in plant.followers.values():
            follower.update(t)
        plant.write(t)
        share = behind(now - 100.0)
        if share > 0:
            sim.advance(PERIOD * share)
        now += PERIOD


def test_a_physics_that_stalls_and_falls_behind_delays_the_motion_instead_of_failing_it(plant, sim):
    """The followers run on the simulation's clock while a goal runs (as use_sim_time would): a
    0.6 s stall in the middle of the motion and a phase at half speed leave the arm on its
    trajectory and the goal succeeds. On the manager's clock (Plant.follower_time, the base rule)
    the same run fails its path tolerance: the failure a fresh-clone run showed on a loaded
    machine (0.32 rad from the desired position, tolerance 0.2)."""
    arm = plant.followers["arm_controller"][0]
    target = [0.8, -0.3, 0.4, 0.1, 0.2, 0.0]

    def behind(t: float) -> float:
        return 0.0 if 0.5 <= t < 1.1 else 0.5 if 1.1 <= t < 1.6 else 1.0

    assert arm.submit(move(arm, target, 2.0), plant.follower_time(100.0)).accepted
    run_behind(plant, sim, lambda: arm.status in ControllerStatus.TERMINAL, 8.0, behind)
    assert arm.status == ControllerStatus.SUCCEEDED, arm.state().message
    reached = np.array([sim.joint_states().as_dict()[j] for j in arm.joint_names])
    assert np.abs(reached - target).max() <= arm.goal_tolerance
    # between goals the followers' clock is the manager's again
    assert plant.follower_time(250.0) == 250.0


def test_on_the_managers_clock_the_same_stall_fails_the_path_tolerance(plant, sim, monkeypatch):
    from mycobot_planning.hardware_interface.plant import Plant

    monkeypatch.setattr(type(plant), "follower_time", Plant.follower_time)
    arm = plant.followers["arm_controller"][0]
    assert arm.submit(move(arm, [0.8, -0.3, 0.4, 0.1, 0.2, 0.0], 2.0), 100.0).accepted
    run_behind(plant, sim, lambda: arm.status in ControllerStatus.TERMINAL, 8.0,
               lambda t: 0.0 if 0.5 <= t < 1.1 else 1.0)
    assert arm.status == ControllerStatus.FAILED and "path tolerance violated" in arm.state().message


def run_starved(plant, sim, until, seconds: float, starved) -> None:
    """The manager's loop on the simulation's clock, skipping its cycles while ``starved(t)``
    (a controller thread that gets no CPU for a while) as the physics goes on."""
    end = sim.time + seconds
    start = sim.time
    while sim.time < end and not until():
        now = sim.time
        if not starved(now - start):
            t = plant.follower_time(now)
            plant.read(t)
            for follower, _ in plant.followers.values():
                follower.update(t)
            plant.write(t)
        sim.advance(PERIOD)


@pytest.mark.parametrize("lookahead", [True, False], ids=["trajectory_ahead", "last_point_only"])
def test_a_starved_controller_loop_leaves_the_arm_on_its_trajectory(plant, sim, monkeypatch, lookahead):
    """The controller loop gets no CPU for 0.45 s in mid-motion while the physics runs on. The
    physics samples the goal's trajectory itself between two cycles (set_arm_command's
    ``ahead``), so the arm stays on it and the goal succeeds. With the last commanded point only
    (held after COMMAND_HOLD) the arm stops while the trajectory goes on, and the goal fails its
    path tolerance: what a loaded machine did to the twin's pick and place."""
    if not lookahead:
        monkeypatch.setattr(type(plant), "_ahead", lambda self, arm, now: None)
    arm = plant.followers["arm_controller"][0]
    assert arm.submit(move(arm, [0.8, -0.3, 0.4, 0.1, 0.2, 0.0], 2.0), plant.follower_time(sim.time)).accepted
    run_starved(plant, sim, lambda: arm.status in ControllerStatus.TERMINAL, 6.0, lambda t: 0.6 <= t < 1.05)
    if lookahead:
        assert arm.status == ControllerStatus.SUCCEEDED, arm.state().message
    else:
        assert arm.status == ControllerStatus.FAILED and "path tolerance violated" in arm.state().message
