"""The viewer's Teleoperate panel fed from servo_node, the gripper controller and the
planning_server: jogs out as servo commands (JointJog / TwistStamped, each stamped as it is sent,
at 50 Hz while the page's button is held), the servo's ~/status in; Stop ends the jog and stops
move_group's execution (MoveIt's "stop" on /trajectory_execution_event), and a button still held
when Stop is pressed jogs no more until it is pressed again; the gripper through its
GripperCommand action to the SRDF's "open" / "closed" states; the joint sliders as the
planning_server's plan_and_execute to the joint positions (planned collision-free within the
limits, executed like any move: never a jump), one at a time, the newest slider positions next;
waypoints through the planning_server's JSON methods (list_waypoints, save_waypoint,
rename_waypoint, erase_waypoint, move_to_waypoint; docs/waypoints.md).

Nothing here blocks a ROS callback: service answers come back as futures, the planning_server's
methods run on worker threads and report to the panel when they answer."""
from __future__ import annotations

import threading
import time
from typing import Any

from control_msgs.action import GripperCommand
from control_msgs.msg import JointJog
from geometry_msgs.msg import TwistStamped
from moveit_msgs.msg import ServoStatus
from moveit_msgs.srv import ServoCommandType
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from std_msgs.msg import String
from std_srvs.srv import SetBool

from interfaces_py import names
from interfaces_py.action_client import ActionClient
from interfaces_py.json_rpc import JsonRpcClient, RpcError
from interfaces_py.msgs import MoveItErrorCode
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.visualization.teleop_panel import TeleopActions, TeleopPanel

#: s a jog goes on after the page's last repeat of a held button (it repeats at HOLD_HZ, 20 Hz)
HOLD_GRACE = 0.15
#: s between two servo commands while a button is held (the servo's timeout is 0.1 s)
STREAM_PERIOD = 0.02
#: s: a jog button held when Stop was pressed jogs again only after a pause this long in its
#: repeats (it was let go and pressed again)
STOP_LATCH_GAP = 0.5
STATUS_NAMES = {getattr(ServoStatus, n): n for n in dir(ServoStatus) if n.isupper() and isinstance(getattr(ServoStatus, n), int)}


class TeleopView:
    """Connects a viewer's TeleopPanel to the servo ``servo`` (e.g. /servo_node)."""

    def __init__(self, node: Node, model: RobotModel, servo: str = "/servo_node",
                 planning_server: str = "/planning_server",
                 gripper_action: str = "/grip_action_controller/gripper_cmd",
                 group: str = "arm", gripper_group: str = "gripper",
                 base_frame: str = "", tool_frame: str = "", poll_period: float = 2.0) -> None:
        self.node = node
        self.servo = servo.rstrip("/")
        self.panel: TeleopPanel | None = None
        self.group = group
        self.joint_names = list(model.group(group).joint_names)
        bounds = {n: (float(lo), float(hi)) for n, lo, hi in zip(model.variable_names, model.lower_limits,
                                                                 model.upper_limits)}
        #: {joint: (lower, upper)} of the group's joints (the sliders' ranges)
        self.joint_limits = {n: bounds[n] for n in self.joint_names if n in bounds}
        base = base_frame or ("base_link" if model.has_link("base_link") else model.root_link)
        self.frames = {"base": base, "tool": tool_frame or self._tip(model, group)}
        self._gripper_states = self._gripper_targets(model, gripper_group)
        callbacks = MutuallyExclusiveCallbackGroup()
        self._twist = node.create_publisher(TwistStamped, f"{self.servo}/delta_twist_cmds", 10)
        self._jog = node.create_publisher(JointJog, f"{self.servo}/delta_joint_cmds", 10)
        self._switch = node.create_client(ServoCommandType, f"{self.servo}/switch_command_type",
                                          callback_group=callbacks)
        self._pause = node.create_client(SetBool, f"{self.servo}/pause_servo", callback_group=callbacks)
        node.create_subscription(ServoStatus, f"{self.servo}/status", self._on_status, 10, callback_group=callbacks)
        self._events = node.create_publisher(String, names.TRAJECTORY_EXECUTION_EVENT, 10)
        self._gripper = ActionClient(node, GripperCommand, gripper_action, callback_group=callbacks)
        self._rpc = JsonRpcClient(node, planning_server)
        self._lock = threading.Lock()
        self._held: tuple[str, Any, Any, float] | None = None  # (kind, target, value, until)
        self._mode: int | None = None  # the command type the servo has confirmed
        self._switching: int | None = None
        self._stop_latch: tuple[Any, float] | None = None  # (the jog held at Stop, its last repeat)
        self._joint_goal: dict[str, float] | None = None  # the sliders' next move
        self._joint_mover = False  # a thread is moving the arm to the sliders' positions
        self.sent = 0
        node.create_timer(STREAM_PERIOD, self._tick, callback_group=callbacks)
        self._listing = threading.Event()  # set while a list_waypoints call is out
        node.create_timer(poll_period, lambda: self.refresh_waypoints(), callback_group=callbacks)

    @staticmethod
    def _tip(model: RobotModel, group: str) -> str:
        try:
            return model.group(group).tip_link
        except Exception:
            return model.link_names[-1]

    @staticmethod
    def _gripper_targets(model: RobotModel, group: str) -> dict[bool, float]:
        """{True: open position, False: closed position} of the gripper group's first joint,
        from the SRDF's named states ("open", "closed"/"close")."""
        targets: dict[bool, float] = {}
        for opened, state_names in ((True, ("open",)), (False, ("closed", "close"))):
            for state in state_names:
                try:
                    values = model.named_state(state, group)
                except Exception:
                    continue
                if values:
                    targets[opened] = float(next(iter(values.values())))
                    break
        return targets

    def actions(self) -> TeleopActions:
        return TeleopActions(jog=self.jog, stop=self.stop, gripper=self.gripper, save_waypoint=self.save_waypoint,
                             move_to_waypoint=self.move_to_waypoint, refresh_waypoints=self.refresh_waypoints,
                             move_joints=self.move_joints, rename_waypoint=self.rename_waypoint,
                             erase_waypoint=self.erase_waypoint)

    def attach(self, panel: TeleopPanel) -> None:
        self.panel = panel
        self.refresh_waypoints()

    def _say(self, text: str) -> None:
        if self.panel is not None:
            self.panel.on_message(text)

    # -- jogging --------------------------------------------------------------------------
    def jog(self, kind: str, target: Any, value: Any) -> None:
        """One repeat of a held jog button: go on jogging for HOLD_GRACE from now."""
        mode = ServoCommandType.Request.JOINT_JOG if kind == "joint" else ServoCommandType.Request.TWIST
        now = time.monotonic()
        with self._lock:
            if self._stop_latch is not None:
                key, last = self._stop_latch
                if key == (kind, target, value) and now - last < STOP_LATCH_GAP:
                    self._stop_latch = (key, now)  # still held since Stop: no jog
                    return
                self._stop_latch = None
            self._held = (kind, target, value, time.monotonic() + HOLD_GRACE)
            need_switch = self._mode != mode and self._switching != mode
            if need_switch:
                self._switching = mode
        if need_switch:
            self._request_mode(mode)

    def _request_mode(self, mode: int) -> None:
        if not (self._switch.service_is_ready() and self._pause.service_is_ready()):
            with self._lock:
                self._switching = None
            self._say(f"{self.servo} is not available: is servo_node running?")
            return
        self._pause.call_async(SetBool.Request(data=False))  # resumed (and queued before the switch)
        future = self._switch.call_async(ServoCommandType.Request(command_type=mode))

        def done(f: Any) -> None:
            ok = f.exception() is None and f.result().success
            with self._lock:
                self._switching = None
                if ok:
                    self._mode = mode
        future.add_done_callback(done)

    def _tick(self) -> None:
        with self._lock:
            held, mode = self._held, self._mode
        if held is None:
            return
        kind, target, value, until = held
        if time.monotonic() > until:
            with self._lock:
                if self._held is held:
                    self._held = None
            return
        wanted = ServoCommandType.Request.JOINT_JOG if kind == "joint" else ServoCommandType.Request.TWIST
        if mode != wanted:
            return  # the switch has not been confirmed yet
        stamp = self.node.get_clock().now().to_msg()
        if kind == "joint":
            msg = JointJog()
            msg.header.stamp = stamp
            msg.joint_names, msg.velocities = [str(target)], [float(value)]
            self._jog.publish(msg)
        else:
            linear, angular = value
            msg = TwistStamped()
            msg.header.stamp, msg.header.frame_id = stamp, self.frames.get(str(target), self.frames["base"])
            msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z = (float(v) for v in linear)
            msg.twist.angular.x, msg.twist.angular.y, msg.twist.angular.z = (float(v) for v in angular)
            self._twist.publish(msg)
        self.sent += 1

    def stop(self) -> None:
        """Stop whatever moves the arm: the jog (the servo halts within its command timeout; the
        button held now jogs again only once let go and pressed again), the sliders' next move and
        move_group's execution."""
        with self._lock:
            held, self._held = self._held, None
            self._stop_latch = (held[:3] if held is not None else None, time.monotonic())
            self._joint_goal = None
        self._events.publish(String(data="stop"))
        self._say("stopped")

    def _on_status(self, msg: ServoStatus) -> None:
        if self.panel is not None:
            self.panel.on_servo_status(STATUS_NAMES.get(msg.code, str(msg.code)))

    # -- gripper --------------------------------------------------------------------------
    def gripper(self, opened: bool) -> None:
        if opened not in self._gripper_states:
            self._say("the robot's SRDF names no gripper 'open' / 'closed' states")
            return
        if not self._gripper.server_is_ready():
            self._say("the gripper controller's action is not available")
            return
        goal = GripperCommand.Goal()
        goal.command.position = self._gripper_states[opened]
        goal.command.max_effort = 0.0
        self._gripper.send_goal_async(goal)
        self._say("opening the gripper" if opened else "closing the gripper")

    # -- waypoints (planning_server's JSON methods, on worker threads) ----------------------
    def _in_background(self, name: str, work) -> None:
        def guarded() -> None:
            try:
                work()
            except Exception as exc:  # the node shutting down under a call, or a malformed answer
                if self.node.context.ok():
                    self._say(f"{name} failed: {type(exc).__name__}: {exc}")
        threading.Thread(target=guarded, name=f"teleop {name}", daemon=True).start()

    def refresh_waypoints(self, select: str | None = None) -> None:
        """List the planning_server's waypoints into the panel (polled, and after a save)."""
        if self.panel is None or (select is None and self._listing.is_set()):
            return
        self._listing.set()

        def work() -> None:
            try:
                if not self._rpc.wait_for_server(0.1):
                    return  # no planning_server (yet): the next poll looks again, without waiting
                listed = self._rpc.call("list_waypoints", {}, timeout=10.0)
            except RpcError:
                return  # no planning_server (yet): the next poll tries again
            finally:
                self._listing.clear()
            if self.panel is not None:
                self.panel.on_waypoints([w["name"] for w in listed.get("waypoints", [])], select)
        self._in_background("list", work)

    def save_waypoint(self, name: str) -> None:
        self._waypoint_call("save", "save_waypoint", {"name": name, "group": self.group},
                            f"waypoint '{name}' not saved", f"saved waypoint '{name}'", name)

    def rename_waypoint(self, old: str, new: str) -> None:
        self._waypoint_call("rename", "rename_waypoint", {"old_name": old, "new_name": new},
                            f"waypoint '{old}' not renamed", f"renamed waypoint '{old}' to '{new}'", new)

    def erase_waypoint(self, name: str) -> None:
        self._waypoint_call("erase", "erase_waypoint", {"name": name},
                            f"waypoint '{name}' not erased", f"erased waypoint '{name}'", "")

    def _waypoint_call(self, what: str, method: str, params: dict, failed: str, done: str, select: str) -> None:
        """One waypoint method of the planning_server in the background: its refusal or its
        success said in the page, then the list refreshed with ``select`` selected."""
        def work() -> None:
            try:
                self._rpc.call(method, params, timeout=10.0)
            except RpcError as exc:
                self._say(f"{failed}: {exc}")
                return
            self._say(done)
            self.refresh_waypoints(select=select)
        self._in_background(what, work)

    @staticmethod
    def outcome(result: Any) -> str | None:
        """None when a plan_and_execute answer is a success, else its error code, e.g.
        "PREEMPTED: execution stopped"."""
        code = (result or {}).get("error_code") if isinstance(result, dict) else None
        if not isinstance(code, dict) or code.get("val", 1) == 1:
            return None
        val = code.get("val")
        name = MoveItErrorCode(val).name if isinstance(val, int) and MoveItErrorCode.is_known(val) else str(val)
        return f"{name}: {code['message']}" if code.get("message") else name

    def move_to_waypoint(self, name: str) -> None:
        def work() -> None:
            self._say(f"moving to waypoint '{name}'")
            try:
                result = self._rpc.call("move_to_waypoint", {"name": name, "wait": True}, timeout=120.0)
            except RpcError as exc:
                self._say(f"move to waypoint '{name}' failed: {exc}")
                return
            problem = self.outcome(result)
            self._say(f"at waypoint '{name}'" if problem is None else f"move to waypoint '{name}' ended {problem}")
        self._in_background("move", work)

    # -- joint sliders (a planned move; one at a time, the newest positions next) ------------
    def move_joints(self, goal: dict[str, float]) -> None:
        with self._lock:
            self._joint_goal = {str(k): float(v) for k, v in goal.items()}
            if self._joint_mover:
                return  # the running move's thread takes it next
            self._joint_mover = True
        threading.Thread(target=self._move_joints_loop, name="teleop sliders move", daemon=True).start()

    def _move_joints_loop(self) -> None:
        done = False
        try:
            while True:
                with self._lock:
                    goal, self._joint_goal = self._joint_goal, None
                    if goal is None:
                        self._joint_mover, done = False, True
                        break
                self._move_to_joints(goal)
        finally:
            if not done:
                with self._lock:
                    self._joint_mover = False
            if self.panel is not None:
                self.panel.on_joint_moves_idle()

    def _move_to_joints(self, goal: dict[str, float]) -> None:
        self._say("moving to the sliders' positions")
        try:
            result = self._rpc.call("plan_and_execute", {"group": self.group, "goal": {"joints": goal},
                                                         "wait": True}, timeout=120.0)
        except RpcError as exc:
            self._say(f"move to the sliders' positions failed: {exc}")
            return
        except Exception as exc:  # the node shutting down under the call
            if self.node.context.ok():
                self._say(f"move to the sliders' positions failed: {type(exc).__name__}: {exc}")
            return
        problem = self.outcome(result)
        self._say("at the sliders' positions" if problem is None else f"move to the sliders' positions ended {problem}")
