"""The MuJoCo twin as a plant of the controller manager (hardware_interface.plant): the
controllers' followers measure the simulated joints (``read``), and each control period the arm
servos get the trajectory's desired position and velocity as ros2_control's position and
velocity command interfaces (``write``); a gripper goal becomes the simulator's GripperCommand,
whose contact decides where the fingers stop (a stall on an object counts as success, as
GripperActionController's allow_stalling). Physics runs in the simulator's own real-time thread.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from ..core.trajectory_execution.controllers_config import ControllerConfig
from ..hardware.follower import MeasuredTrajectoryFollower
from ..hardware_interface.plant import ControllerSpec, Plant, PlantHost
from .grasp_monitor import GraspWatch
from .simulator import MujocoSimulator


@dataclass(frozen=True)
class SimTracking:
    """How goals are judged against the simulated joints: ``path_tolerance`` (rad; inf: not
    checked) and ``goal_time`` (s after a trajectory's end to come within goal tolerance)."""

    path_tolerance: float = 0.2
    goal_time: float = 1.0
    gripper_goal_time: float = 3.0


class MujocoPlant(Plant):
    """``simulator``'s arm joints are driven by the one controller that names them, its gripper
    joint by a gripper controller (ValueError when the controllers do not match the model).
    ``own_simulator``: close the simulator with the plant. ``hand_link``: watch which object
    the gripper holds and how much it slips in this link's frame (``grasp``, sampled at every
    ``read``); empty: not watched. ``stop_on_lost_grasp``: a held object leaving the hand aborts
    the arm's goal (the arm holds where it is), as a grasp check on a real cell would."""

    def __init__(self, variable_names: Sequence[str], default_positions: np.ndarray, simulator: MujocoSimulator,
                 controllers: Sequence[ControllerConfig], tracking: SimTracking = SimTracking(),
                 own_simulator: bool = False, hand_link: str = "", stop_on_lost_grasp: bool = False) -> None:
        super().__init__(variable_names, default_positions)
        self.sim = simulator
        self.hand_link = hand_link
        self.stop_on_lost_grasp = stop_on_lost_grasp
        # open: where the gripper starts (the model's initial positions hold it open)
        self.grasp = GraspWatch(open_position=simulator.joint_states().as_dict()[simulator.gripper_joint])
        self._host: PlantHost | None = None
        if hand_link:
            try:
                simulator.link_pose(hand_link)  # an unknown link is refused here, before anything starts
            except KeyError as exc:
                raise ValueError(f"hand_link: {exc.args[0]}") from None
        self.tracking = tracking
        self.own_simulator = own_simulator
        arm = [c for c in controllers if set(c.joints) == set(simulator.arm_joints)]
        gripper = [c for c in controllers if c.joints == (simulator.gripper_joint,)]
        if len(arm) != 1:
            raise ValueError(f"the simulation needs one controller of the arm joints {list(simulator.arm_joints)}; "
                             f"the controllers are {[(c.name, list(c.joints)) for c in controllers]}")
        self.arm_controller = arm[0].name
        self.gripper_controller = gripper[0].name if gripper else None
        self._arm_was_active = False
        self._clock_offset: float | None = None  # follower_time's anchor
        self._order: np.ndarray | None = None  # simulator arm joint -> arm follower column
        self._gripper_target: float | None = None
        self._index = {name: i for i, name in enumerate(self.variable_names)}

    def create_follower(self, spec: ControllerSpec) -> MeasuredTrajectoryFollower:
        c, t = spec.config, self.tracking
        if c.name == self.gripper_controller:
            tolerance, goal_time, stalling = math.inf, t.gripper_goal_time, True
        elif c.name == self.arm_controller:
            tolerance, goal_time, stalling = t.path_tolerance, t.goal_time, False
        else:
            raise ValueError(f"the simulation drives no joints of controller {c.name} ({list(c.joints)})")
        start = self.sim.joint_states().as_dict()
        return MeasuredTrajectoryFollower(
            c.joints, spec.lower, spec.upper, np.clip([start[j] for j in c.joints], spec.lower, spec.upper),
            goal_tolerance=c.goal_tolerance, start_tolerance=c.start_tolerance, name=c.name,
            velocity_limits=spec.velocity_limits, acceleration_limits=spec.acceleration_limits,
            limit_tolerance=spec.limit_tolerance, path_tolerance=tolerance, goal_time=goal_time,
            allow_stalling=stalling)

    def start(self, host: PlantHost) -> None:
        super().start(host)
        self._host = host
        self.sim.start()

    def follower_time(self, now: float) -> float:
        """While a goal runs, the simulation's clock (over the speed factor, which cannot change
        then), anchored to the manager's clock whenever no goal runs. A physics thread that falls
        behind real time (a loaded machine), stalls, or drops its debt (simulator.MAX_LAG) then
        delays the whole motion, its path tolerance and goal_time included, as use_sim_time
        would: the arm is never judged against a trajectory the physics has not had time to
        follow. (Before, the manager's clock less the simulator's latest lag: a stalled physics
        thread left it stale, a dropped debt made it jump ahead, and the arm failed its path
        tolerance.)"""
        scaled = self.sim.time / self.sim.speed_factor
        if self._clock_offset is None or not any(f.active for f, _ in self.followers.values()):
            self._clock_offset = now - scaled
        return scaled + self._clock_offset

    def _ahead(self, arm: MeasuredTrajectoryFollower,
               now: float) -> Callable[[float], tuple[np.ndarray, np.ndarray] | None]:
        """The arm's trajectory as the physics samples it between two controller cycles:
        simulation time -> arm-order desired (positions, velocities), the followers' clock
        (``now``, as follower_time gives it) advancing with the simulation's. The follower's own
        spline, read at each call: a stop or a new goal takes effect at the next physics step."""
        order = self._arm_order(arm)
        speed = self.sim.speed_factor
        offset = now - self.sim.time / speed

        def ahead(sim_time: float) -> tuple[np.ndarray, np.ndarray] | None:
            desired = arm.desired_state_at(sim_time / speed + offset)
            return None if desired is None else (desired[0][order], desired[1][order])
        return ahead

    def _arm_order(self, arm: MeasuredTrajectoryFollower) -> np.ndarray:
        if self._order is None:
            names = list(arm.joint_names)
            self._order = np.array([names.index(j) for j in self.sim.arm_joints], dtype=int)
        return self._order

    def read(self, now: float) -> None:
        state = self.sim.joint_states()
        position = dict(zip(state.names, state.positions))
        velocity = dict(zip(state.names, state.velocities))
        for follower, _ in self.followers.values():
            follower.measure([position[j] for j in follower.joint_names],
                             [velocity[j] for j in follower.joint_names], now)
        if self.hand_link:
            sim = self.sim
            ended = self.grasp.sample(sim.time, sim.gripper_state(), sim.link_pose(self.hand_link), sim.object_poses(),
                                      sim.objects_between_pads)
            if ended is not None and ended.ended == "lost":
                self._lost(ended, now)

    def _lost(self, hold, now: float) -> None:
        text = (f"the held object '{hold.object}' left the hand ({hold.slip * 1000:.0f} mm from where it was "
                "held)")
        arm = self.followers[self.arm_controller][0]
        if self.stop_on_lost_grasp and arm.active and self._host is not None:
            for state in arm.abort(now, text):
                self._host.report(arm, state)
        elif self._host is not None:
            self._host.log("warning", text)

    def write(self, now: float) -> None:
        arm = self.followers[self.arm_controller][0]
        if arm.active:
            desired = arm.desired_state_at(now)
            if desired is None:
                state = arm.state()
                desired = state.desired_positions, state.desired_velocities
            self.sim.set_arm_command(dict(zip(arm.joint_names, desired[0])), dict(zip(arm.joint_names, desired[1])),
                                     ahead=self._ahead(arm, now))
        elif self._arm_was_active:
            self.sim.stop_arm()  # the goal ended (succeeded, stopped, aborted): hold where the arm is
        self._arm_was_active = arm.active
        if self.gripper_controller is not None:
            gripper = self.followers[self.gripper_controller][0]
            target = float(gripper.final_positions[0]) if gripper.active else None
            if target is not None and target != self._gripper_target:
                self.sim.command_gripper(target)
            self._gripper_target = target

    def reset_world(self) -> None:
        """The simulation back to its scene file and initial positions, and a fresh grasp watch
        (a new episode). Under the lock, while no controller follows a goal."""
        self.sim.reset()
        self.grasp = GraspWatch(open_position=self.sim.joint_states().as_dict()[self.sim.gripper_joint])
        self._gripper_target = None

    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        state = self.sim.joint_states()
        for name, q, qd in zip(state.names, state.positions, state.velocities):
            i = self._index.get(name)
            if i is not None:
                self.positions[i], self.velocities[i] = q, qd
        return self.positions, self.velocities

    def description(self) -> str:
        return (f"MuJoCo twin, physics step {self.sim.timestep * 1000:g} ms, speed factor "
                f"{self.sim.speed_factor:g}")

    def state_source(self) -> str:
        return " from the simulation"

    def stats(self) -> dict:
        status = self.sim.status()
        return {"time": status.time, "real_time_factor": status.real_time_factor,
                "behind_real_time": status.behind_real_time, "message": status.message}

    def close(self) -> None:
        self.sim.stop()
        if self.own_simulator:
            self.sim.close()
