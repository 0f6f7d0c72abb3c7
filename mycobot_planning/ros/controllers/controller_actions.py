"""ros2_control's controller actions of the controller manager's controllers: what a MoveIt controller manager
(moveit_simple_controller_manager) or any ros2_control client sends to a real arm.

* JointTrajectoryController: ``/<name>/follow_joint_trajectory`` (control_msgs/action/
  FollowJointTrajectory, with path_tolerance, goal_tolerance and goal_time_tolerance as JTC reads
  them) and ``/<name>/controller_state`` (control_msgs/msg/JointTrajectoryControllerState).
* GripperActionController: ``/<name>/gripper_cmd`` (control_msgs/action/GripperCommand:
  position and max_effort in; position, effort, stalled, reached_goal out).

Both drive the same follower as the ``joint_trajectory`` topic, through the public calls of
``controller_manager.Controller`` (submit, state, stop), so a goal sent by action preempts one
sent by topic and the other way round, as in ros2_control.
"""
from __future__ import annotations

import math
import time
import uuid
from typing import TYPE_CHECKING, Any

import numpy as np
from control_msgs.action import FollowJointTrajectory, GripperCommand
from control_msgs.msg import JointTrajectoryControllerState
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from trajectory_msgs.msg import JointTrajectoryPoint

from interfaces_py.ros_conversions import duration_to_seconds, seconds_to_duration
from mycobot_planning.ros.action_servers import ACTION_SERVER_OPTIONS, end_goal
from mycobot_planning.ros.stamped_cdr import StampedCdr
from mycobot_planning.mock_control.joint_trajectory_follower import ControllerStatus, FollowerState, TrajectoryCommand

if TYPE_CHECKING:  # pragma: no cover
    from rclpy.node import Node

    from mycobot_planning.ros.controllers.controller_manager import Controller

#: s between two checks of a running goal (and two feedback messages): the controller rate is
#: 100 Hz; feedback at 50 Hz is what JTC's default action_monitor_rate (20 Hz) allows and more.
POLL_PERIOD = 0.02
#: rad/s of a gripper move when the joint has no velocity limit
DEFAULT_GRIPPER_SPEED = 0.5
FJT = FollowJointTrajectory.Result


def _point(positions: np.ndarray, velocities: np.ndarray, accelerations: np.ndarray,
           t: float) -> JointTrajectoryPoint:
    point = JointTrajectoryPoint()
    point.positions = positions.tolist()
    point.velocities = velocities.tolist()
    point.accelerations = accelerations.tolist()
    point.time_from_start = seconds_to_duration(t)
    return point


def _state_points(state: FollowerState) -> tuple[JointTrajectoryPoint, JointTrajectoryPoint, JointTrajectoryPoint]:
    t = state.time_from_start
    desired = _point(state.desired_positions, state.desired_velocities, state.desired_accelerations, t)
    actual = _point(state.actual_positions, state.actual_velocities, state.actual_accelerations, t)
    error = _point(state.desired_positions - state.actual_positions,
                   state.desired_velocities - state.actual_velocities,
                   state.desired_accelerations - state.actual_accelerations, t)
    return desired, actual, error


def _tolerance_problem(goal: Any, joints: tuple[str, ...]) -> str | None:
    """Why a goal's path or goal tolerances cannot be read (a joint this controller does not
    have, a NaN value), or None: JTC refuses such a goal, it never drops the entry silently."""
    for what, entries in (("path_tolerance", goal.path_tolerance), ("goal_tolerance", goal.goal_tolerance)):
        for entry in entries:
            if entry.name not in joints:
                return f"{what} names joint {entry.name!r}, which this controller does not drive ({list(joints)})"
            if any(math.isnan(v) for v in (entry.position, entry.velocity, entry.acceleration)):
                return f"{what} of joint {entry.name!r} holds NaN"
    return None


def _tolerances(entries: Any, joints: tuple[str, ...]) -> np.ndarray:
    """Per-joint position tolerances from control_msgs/JointTolerance[] (0 or absent: unchecked;
    JTC reads a negative value as "no limit" too)."""
    limits = np.full(len(joints), math.inf)
    for entry in entries:
        if entry.name in joints and entry.position > 0:
            limits[joints.index(entry.name)] = entry.position
    return limits


class ControllerActions:
    """The action servers and the controller_state publisher of one controller."""

    def __init__(self, manager: "Node", controller: "Controller") -> None:
        self._manager = manager
        self._c = controller
        name = controller.config.name
        self._group = ReentrantCallbackGroup()
        self.is_gripper = controller.config.type.endswith("GripperActionController")
        if self.is_gripper:
            self.server = ActionServer(manager, GripperCommand, f"/{name}/gripper_cmd", self._execute_gripper,
                                       goal_callback=self._accept_gripper, cancel_callback=self._cancel,
                                       callback_group=self._group, **ACTION_SERVER_OPTIONS)
        else:
            self.server = ActionServer(manager, FollowJointTrajectory, f"/{name}/follow_joint_trajectory",
                                       self._execute_trajectory, goal_callback=self._accept_trajectory,
                                       cancel_callback=self._cancel, callback_group=self._group,
                                       **ACTION_SERVER_OPTIONS)
        self.state_pub = manager.create_publisher(JointTrajectoryControllerState, f"/{name}/controller_state", 10)
        self._state_msg = JointTrajectoryControllerState()
        self._state_msg.joint_names = list(controller.config.joints)
        self._state_points = (JointTrajectoryPoint(), JointTrajectoryPoint(), JointTrajectoryPoint())
        self._state_key: tuple = ()  # what the points hold (time and arrays of the last state published)
        self._state_cdr = StampedCdr()
        self._closing = False

    def destroy(self) -> None:
        self._closing = True
        self.server.destroy()

    def _going_down(self) -> bool:
        """SIGINT/SIGTERM or destroy(): the action server is going away, nothing can be reported."""
        return self._closing or not self._manager.context.ok()

    # ------------------------------------------------------------------ controller_state
    def publish_state(self, state: FollowerState, stamp: Any) -> None:
        """controller_state at every update, as JTC does: the message's points are reused and
        filled in place (this runs at the controller rate: building three new points with exact
        Duration arithmetic each time was most of the idle node's cost)."""
        msg = self._state_msg
        msg.header.stamp = stamp
        t = state.time_from_start
        key = (t, *(a.tobytes() for a in (state.desired_positions, state.desired_velocities, state.desired_accelerations,
                                          state.actual_positions, state.actual_velocities, state.actual_accelerations)))
        if key == self._state_key:  # holding still: the serialized message already says so
            self._state_cdr.publish(self.state_pub, stamp.sec, stamp.nanosec)
            return
        self._state_key = key
        sec = math.floor(t) if math.isfinite(t) else 0
        nanosec = min(999_999_999, max(0, int(round((t - sec) * 1e9)))) if math.isfinite(t) else 0
        for point, (p, v, a) in zip(self._state_points, (
                (state.desired_positions, state.desired_velocities, state.desired_accelerations),
                (state.actual_positions, state.actual_velocities, state.actual_accelerations),
                (state.desired_positions - state.actual_positions, state.desired_velocities - state.actual_velocities,
                 state.desired_accelerations - state.actual_accelerations))):
            point.positions = p.tolist()
            point.velocities = v.tolist()
            point.accelerations = a.tolist()
            point.time_from_start.sec, point.time_from_start.nanosec = int(sec), nanosec
        msg.reference, msg.feedback, msg.error = self._state_points
        msg.output = msg.reference
        self._state_cdr.update(msg)
        self._state_cdr.publish(self.state_pub, stamp.sec, stamp.nanosec)

    # ------------------------------------------------------------------ shared
    def _log(self) -> Any:
        return self._manager.get_logger()

    def _cancel(self, goal_handle: Any) -> CancelResponse:
        """Decelerate to a stop along the goal's path within the joint acceleration limits (JTC
        holds position at once; an arm moving at speed cannot, and the issue 29 contract is a stop
        within the deceleration limits); the goal ends canceled once the joints are at rest."""
        running = self._c.running_goal()
        if running and running.endswith(str(uuid.UUID(bytes=bytes(goal_handle.goal_id.uuid)))):
            self._c.stop(f"goal {running} canceled by its client", smooth=True)
        return CancelResponse.ACCEPT

    def _follow(self, goal_handle: Any, command: TrajectoryCommand, feedback: Any | None,
                path_limits: np.ndarray | None, goal_time_tolerance: float) -> tuple[str, str, FollowerState]:
        """Submit and follow one goal until it ends: (outcome, message, last state) with outcome
        one of succeeded, rejected, canceled, preempted, path, failed, stalled, or shutdown (the
        node is going down: nothing can be reported any more)."""
        result = self._c.submit(command)
        if not result.accepted:
            return "rejected", result.reason, self._c.state()
        goal_id = result.goal_id
        end = command.times[-1] if command.times else 0.0
        while True:
            time.sleep(POLL_PERIOD)
            state = self._c.state()
            if self._going_down():
                return "shutdown", "the node is shutting down", state
            if state.goal_id != goal_id:
                return "preempted", f"goal {goal_id} was preempted by goal {state.goal_id}", state
            if goal_handle.is_cancel_requested:
                self._c.stop(f"goal {goal_id} canceled by its client", smooth=True)
                state = self._c.state()
                if state.goal_id == goal_id and state.status not in ControllerStatus.TERMINAL:
                    continue  # still decelerating: answer once at rest
                return "canceled", f"goal {goal_id} canceled", state
            if feedback is not None and not self._send_feedback(goal_handle, feedback, state):
                return "shutdown", "the node is shutting down", state
            if state.status == ControllerStatus.SUCCEEDED:
                return "succeeded", state.message, state
            if state.status in ControllerStatus.TERMINAL:
                return state.status, state.message, state
            if path_limits is not None:
                error = np.abs(state.desired_positions - state.actual_positions)
                over = np.nonzero(error > path_limits)[0]
                if over.size:
                    j = int(over[0])
                    self._c.stop("path tolerance violated")
                    return "path", (f"path tolerance violated: joint {self._c.config.joints[j]} is {error[j]:.4f} "
                                    f"from the desired position (tolerance {path_limits[j]:g})"), state
            if (state.status == ControllerStatus.STALLED and goal_time_tolerance > 0
                    and state.time_from_start > end + goal_time_tolerance):
                self._c.stop("goal time tolerance exceeded")
                return "stalled", state.message + f"; goal_time_tolerance {goal_time_tolerance:g} s exceeded", state

    def _send_feedback(self, goal_handle: Any, feedback: Any, state: FollowerState) -> bool:
        """Publish one feedback message; False when the node went down since the last check (the
        context can be shut down between that check and this publish: rcl then calls the feedback
        publisher invalid). Any other failure to publish is logged and the goal goes on."""
        if isinstance(feedback, FollowJointTrajectory.Feedback):
            feedback.header.stamp = self._manager.get_clock().now().to_msg()
            feedback.desired, feedback.actual, feedback.error = _state_points(state)
        else:
            feedback.position = float(state.actual_positions[0])
            feedback.effort = 0.0
            feedback.stalled = state.status == ControllerStatus.STALLED
            feedback.reached_goal = False
        try:
            goal_handle.publish_feedback(feedback)
        except Exception as exc:  # rclpy's RCLError / InvalidHandle: no public exception type for either
            if self._going_down():
                return False
            self._log().warning(f"{self._c.config.name}: could not publish feedback: {exc}")
        return True

    # ------------------------------------------------------------------ FollowJointTrajectory
    def _command(self, trajectory: Any, goal_id: str) -> TrajectoryCommand:
        stamp = trajectory.header.stamp
        start = None if stamp.sec == 0 and stamp.nanosec == 0 else stamp.sec + stamp.nanosec * 1e-9
        return TrajectoryCommand(
            joint_names=list(trajectory.joint_names),
            times=[duration_to_seconds(p.time_from_start) for p in trajectory.points],
            positions=[list(p.positions) for p in trajectory.points],
            velocities=[list(p.velocities) for p in trajectory.points],
            accelerations=[list(p.accelerations) for p in trajectory.points],
            start_time=start, goal_id=goal_id)

    def _accept_trajectory(self, goal: FollowJointTrajectory.Goal) -> GoalResponse:
        """JTC refuses a goal it cannot follow before accepting it; so do we (same checks as the
        topic: joints, sizes, limits, start tolerance are checked again when it starts)."""
        if len(goal.multi_dof_trajectory.points):
            self._log().warning(f"{self._c.config.name}: rejected a goal with a multi-DOF trajectory "
                                "(this controller drives single-DOF joints only)")
            return GoalResponse.REJECT
        problem = self._c.validate(self._command(goal.trajectory, "")) or _tolerance_problem(goal, self._c.config.joints)
        if problem is not None:
            self._log().warning(f"{self._c.config.name}: rejected a FollowJointTrajectory goal: {problem}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _execute_trajectory(self, goal_handle: Any) -> FollowJointTrajectory.Result:
        goal = goal_handle.request
        result = FollowJointTrajectory.Result()
        goal_id = f"{self._c.config.name}/follow_joint_trajectory/{uuid.UUID(bytes=bytes(goal_handle.goal_id.uuid))}"
        path_limits = _tolerances(goal.path_tolerance, self._c.config.joints)
        outcome, message, state = self._follow(
            goal_handle, self._command(goal.trajectory, goal_id), FollowJointTrajectory.Feedback(),
            path_limits if np.isfinite(path_limits).any() else None, duration_to_seconds(goal.goal_time_tolerance))
        if outcome == "shutdown":  # nothing can reach the client any more
            return result
        if outcome == "succeeded":
            limits = _tolerances(goal.goal_tolerance, self._c.config.joints)
            target = np.array(goal.trajectory.points[-1].positions, dtype=float) if goal.trajectory.points else None
            if target is not None and len(target) == len(self._c.config.joints):
                order = [list(goal.trajectory.joint_names).index(j) for j in self._c.config.joints]
                error = np.abs(state.actual_positions - target[order])
                over = np.nonzero(error > limits)[0]
                if over.size:
                    j = int(over[0])
                    outcome, message = "goal", (f"goal tolerance violated: joint {self._c.config.joints[j]} ended "
                                                f"{error[j]:.4f} from the goal (tolerance {limits[j]:g})")
        codes = {"succeeded": FJT.SUCCESSFUL, "rejected": FJT.INVALID_GOAL, "path": FJT.PATH_TOLERANCE_VIOLATED,
                 "goal": FJT.GOAL_TOLERANCE_VIOLATED, "stalled": FJT.GOAL_TOLERANCE_VIOLATED}
        result.error_code = codes.get(outcome, FJT.PATH_TOLERANCE_VIOLATED)
        result.error_string = "" if outcome == "succeeded" else message
        end_goal(goal_handle, outcome, self._log(),
                 f"{self._c.config.name}: FollowJointTrajectory goal ended: {message}")
        return result

    # ------------------------------------------------------------------ GripperCommand
    def _gripper_target(self, goal: GripperCommand.Goal) -> tuple[float | None, str]:
        position = float(goal.command.position)
        lower, upper = self._c.lower[0], self._c.upper[0]
        if not math.isfinite(position):
            return None, f"position must be a finite number, got {position}"
        if not lower - 1e-9 <= position <= upper + 1e-9:
            return None, (f"position {position:g} is outside the limits [{lower:g}, {upper:g}] of joint "
                          f"{self._c.config.joints[0]}")
        return min(max(position, lower), upper), ""

    def _accept_gripper(self, goal: GripperCommand.Goal) -> GoalResponse:
        target, problem = self._gripper_target(goal)
        if target is None:
            self._log().warning(f"{self._c.config.name}: rejected a GripperCommand goal: {problem}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _execute_gripper(self, goal_handle: Any) -> GripperCommand.Result:
        """A gripper move is a two-point trajectory from where the finger is to the commanded
        position at the joint's velocity limit; there are no dynamics, so it never stalls on an
        object (effort stays 0) unless stall_after is injected."""
        target, problem = self._gripper_target(goal_handle.request)
        result = GripperCommand.Result()
        if target is None:
            goal_handle.abort()
            return result
        start = float(self._c.state().actual_positions[0])
        speed = float(self._c.velocity_limits[0])
        speed = speed if math.isfinite(speed) and speed > 0 else DEFAULT_GRIPPER_SPEED
        duration = max(abs(target - start) / speed, 0.05)
        goal_id = f"{self._c.config.name}/gripper_cmd/{uuid.UUID(bytes=bytes(goal_handle.goal_id.uuid))}"
        command = TrajectoryCommand(list(self._c.config.joints), [0.0, duration], [[start], [target]],
                                    [[0.0], [0.0]], goal_id=goal_id)
        outcome, message, state = self._follow(goal_handle, command, GripperCommand.Feedback(), None, 0.0)
        if outcome == "shutdown":  # nothing can reach the client any more
            return result
        result.position = float(state.actual_positions[0])
        result.effort = 0.0
        result.stalled = outcome == "stalled" or state.status == ControllerStatus.STALLED
        result.reached_goal = outcome == "succeeded"
        end_goal(goal_handle, outcome, self._log(), f"{self._c.config.name}: GripperCommand goal ended: {message}")
        return result

