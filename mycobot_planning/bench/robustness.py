"""Robustness: hundreds of bad inputs over every interface of our nodes, as a careless or hostile
client would send them (issue 13). Shared by the ``robustness`` bench and test/test_robustness.py.

The cases (robustness_cases.py) are generated systematically from a few good requests: each field of a good request
gets the values that are wrong for it (wrong types, missing and extra fields, non-finite and
extreme numbers, odd strings: empty, NUL, control characters, lone surrogates, oversized), plus
protocol-level garbage (not JSON, deep nesting, oversized payloads), bad trajectories on the
controllers' topics and bad ``ros2 param set`` values on every node; and (issue 27) MoveIt's
face: real moveit_msgs / control_msgs requests and goals to move_group's services and actions
and to the controllers' FollowJointTrajectory actions (robustness_moveit.py).

Summary keys: inputs, refused, accepted_bad, crashes, hangs, half_applied (a refused input left
the scene or a planner's parameters changed), unsafe_motions (the robot moved); all but
refused must be 0.

For each case the runner checks what a user relies on:
* the node answers it (a hang is a case that got no answer within its timeout),
* the answer refuses it and names the problem (RPC ``ok: false`` with a message, a MoveIt error
  code other than SUCCESS with a message, a parameter refusal with a reason); an answer that
  leaks Python internals (``Traceback``, ``IndexError`` ...) counts as accepted_bad,
* the planning scene and the robot are unchanged afterwards (else half_applied, unsafe_motion),
  and every node is still alive: looked at SETTLE_S after the answer for what reaches the
  controllers or goes without an answer (action goals, topics), at once after move_group's
  services, which command no motion and answer once their scene change is in place. The robot
  is watched the whole run (every joint_states message against the position the case began
  at), and each case's scene is compared with the one the case before left, so a motion or a
  scene change that comes later than that is still seen, in the case it shows up in (its
  detail says so), and after the last case the runner waits LATE_S and looks once more.

Inputs without an answer (topics) are refused when the node stays alive and nothing changed.
"""
from __future__ import annotations

import json
import math
import os
import threading
import time
import uuid
from dataclasses import dataclass, field
from typing import Any, Callable

from .common import emit, machine
from .robustness_cases import Case
from .robustness_cases import all_cases as all_cases  # re-exported: its public path before the split
from .ros_scenarios import ARM_JOINTS, RobotProcesses, bench_domain_id

SETTLE_S = 0.1  # after an answer to what may act later: a wrong motion shows up in this case
LATE_S = 0.3  # after the last case: what a wrongly accepted input did late still shows up
WATCHED_JOINTS = ARM_JOINTS + ["gripper_controller"]
INTERNAL_WORDS = ("Traceback", "IndexError", "KeyError", "TypeError:", "AttributeError", "ZeroDivisionError",
                  "RecursionError", "UnicodeEncodeError", "NoneType")


@dataclass
class Outcome:
    case: Case
    verdict: str  # refused, accepted_bad, half_applied, unsafe_motion, crash, hang
    detail: str = ""


@dataclass
class Report:
    outcomes: list[Outcome] = field(default_factory=list)

    def count(self, verdict: str) -> int:
        return sum(1 for o in self.outcomes if o.verdict == verdict)

    def failures(self) -> list[Outcome]:
        return [o for o in self.outcomes if o.verdict != "refused"]

    def summary(self) -> dict[str, Any]:
        return {"inputs": len(self.outcomes), "refused": self.count("refused"),
                "accepted_bad": self.count("accepted_bad"), "crashes": self.count("crash"),
                "hangs": self.count("hang"), "half_applied": self.count("half_applied"),
                "unsafe_motions": self.count("unsafe_motion"),
                "failing_cases": [f"{o.case.interface}:{o.case.name}: {o.verdict} ({o.detail[:160]})"
                                  for o in self.failures()[:20]]}


# ---------------------------------------------------------------------------- the runner
class Prober:
    """One private rclpy node that sends every kind of input and reads the answers."""

    def __init__(self) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState
        from std_msgs.msg import String
        from trajectory_msgs.msg import JointTrajectory
        from interfaces_py.background_spin import BackgroundSpin

        from interfaces_py.json_rpc import RPC_QOS

        self.context = Context()
        rclpy.init(context=self.context)
        self.node = Node(f"robustness_prober_{os.getpid()}", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.lock = threading.Lock()
        self.answers: dict[str, dict] = {}
        self.joints: dict[str, float] = {}
        self._rest: dict[str, float] | None = None  # what watch() compares every joint_states message with
        self._moved: list[str] | None = None  # the joints the first message off _rest had moved
        self.requests = self.node.create_publisher(String, "/planning_server/requests", RPC_QOS)
        self.node.create_subscription(String, "/planning_server/responses", self._on_answer, RPC_QOS)
        self.node.create_subscription(JointState, "/joint_states", self._on_joints, 10)
        self.topics = {t: self.node.create_publisher(String, t, QoSProfile(
            depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE))
            for t in ("/planning_server/collision_object", "/planning_server/attached_collision_object", "/planning_server/planning_scene")}
        self.controllers = {c: self.node.create_publisher(JointTrajectory, f"/{c}/joint_trajectory", 10)
                            for c in ("arm_controller", "grip_action_controller")}
        self._param_clients: dict[str, Any] = {}
        self._moveit_clients: dict[str, Any] = {}
        self.spinner = BackgroundSpin(self.executor, name="robustness probe")

    def _on_answer(self, msg: Any) -> None:
        try:
            envelope = json.loads(msg.data)
        except ValueError:
            return
        if isinstance(envelope, dict) and isinstance(envelope.get("id"), str):
            with self.lock:
                self.answers[envelope["id"]] = envelope

    def _on_joints(self, msg: Any) -> None:
        with self.lock:
            self.joints = dict(zip(msg.name, msg.position))
            if self._rest is not None and self._moved is None:
                self._moved = moved_joints(self._rest, self.joints) or None

    def watch(self, rest: dict[str, float]) -> None:
        """From now on, note the first joint_states message in which the robot is off ``rest``."""
        with self.lock:
            self._rest, self._moved = dict(rest), None

    def motion(self) -> list[str] | None:
        """The joints that had moved off watch()'s position in the first message that showed it."""
        with self.lock:
            return self._moved

    def wait_ready(self, timeout: float = 60.0) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if (self.requests.get_subscription_count() > 0 and self.node.count_publishers("/planning_server/responses")
                    and self.joints and all(p.get_subscription_count() > 0 for p in self.topics.values())
                    and all(p.get_subscription_count() > 0 for p in self.controllers.values())):
                try:
                    self.call("get_state", {}, 10.0)
                    return
                except TimeoutError:
                    pass
            time.sleep(0.1)
        raise RuntimeError("the nodes do not answer")

    def send_raw(self, text: str, request_id: str, timeout: float) -> dict | None:
        from std_msgs.msg import String

        self.requests.publish(String(data=text))
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self.lock:
                if request_id in self.answers:
                    return self.answers.pop(request_id)
            time.sleep(0.005)
        return None

    def call(self, method: str, params: Any, timeout: float = 15.0) -> dict:
        request_id = uuid.uuid4().hex
        text = json.dumps({"id": request_id, "method": method, "params": params})
        answer = self.send_raw(text, request_id, timeout)
        if answer is None:
            raise TimeoutError(f"{method}: no answer within {timeout} s")
        return answer

    def set_param(self, node: str, name: str, value: Any, timeout: float = 10.0) -> Any:
        from rcl_interfaces.srv import SetParameters
        from rclpy.parameter import Parameter

        client = self._param_clients.get(node)
        if client is None:
            client = self._param_clients[node] = self.node.create_client(SetParameters, f"/{node}/set_parameters")
        if not client.wait_for_service(timeout_sec=timeout):
            return None
        future = client.call_async(SetParameters.Request(parameters=[Parameter(name, value=value).to_parameter_msg()]))
        deadline = time.monotonic() + timeout
        while not future.done() and time.monotonic() < deadline:
            time.sleep(0.005)
        return future.result().results[0] if future.done() else None

    def _wait(self, future: Any, timeout: float) -> Any:
        deadline = time.monotonic() + timeout
        while not future.done() and time.monotonic() < deadline:
            time.sleep(0.005)
        return future.result() if future.done() else None

    def moveit_call(self, srv_type: Any, name: str, request: Any, timeout: float) -> Any:
        """A move_group service's response (None: no answer within ``timeout``)."""
        client = self._moveit_clients.get(name)
        if client is None:
            client = self._moveit_clients[name] = self.node.create_client(srv_type, name)
        if not client.wait_for_service(timeout_sec=timeout):
            return None
        return self._wait(client.call_async(request), timeout)

    def moveit_goal(self, action_type: Any, name: str, goal: Any, timeout: float) -> tuple[str, Any]:
        """("rejected", None), ("done", get_result response) or ("hang", what did not come)."""
        from rclpy.qos import QoSProfile

        from interfaces_py.action_client import ActionClient

        client = self._moveit_clients.get(name)
        if client is None:
            deep = {f"{k}_service_qos_profile": QoSProfile(depth=100) for k in ("goal", "result", "cancel")}
            client = self._moveit_clients[name] = ActionClient(self.node, action_type, name, **deep)
        if not client.wait_for_server(timeout_sec=timeout):
            return "hang", "the action server is not there"
        handle = self._wait(client.send_goal_async(goal), timeout)
        if handle is None:
            return "hang", "no goal response"
        if not handle.accepted:
            return "rejected", None
        result = self._wait(handle.get_result_async(), timeout)
        return ("done", result) if result is not None else ("hang", "no result")

    def publish_trajectory(self, controller: str, data: dict) -> None:
        from builtin_interfaces.msg import Duration
        from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

        msg = JointTrajectory(joint_names=data["joint_names"])
        for p in data["points"]:
            t = p["time_from_start"]
            sec = math.floor(t)
            point = JointTrajectoryPoint(positions=[float(v) for v in p["positions"]],
                                         time_from_start=Duration(sec=int(sec), nanosec=int((t - sec) * 1e9)))
            if p.get("velocities"):
                point.velocities = [float(v) for v in p["velocities"]]
            msg.points.append(point)
        self.controllers[controller].publish(msg)

    def close(self) -> None:
        import rclpy

        self.spinner.stop()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def moved_joints(before: dict[str, float], now: dict[str, float]) -> list[str]:
    """The watched joints of ``now`` more than 1e-4 off their position in ``before``."""
    return [n for n in WATCHED_JOINTS if n in now and abs(now[n] - before.get(n, now[n])) > 1e-4]


def _problem_text(text: str) -> str | None:
    """Why an answer's text is not a clear refusal, or None."""
    if not text or not text.strip():
        return "the answer gives no reason"
    leaked = [w for w in INTERNAL_WORDS if w in text]
    if leaked:
        return f"the answer leaks internals ({leaked[0]}): {text[:200]}"
    return None


class Runner:
    """Runs cases against live nodes and judges each (see the module docstring)."""

    def __init__(self, prober: Prober, processes: dict[str, Any], log: Callable[[str], str]) -> None:
        self.prober = prober
        self.processes = processes  # name -> subprocess.Popen
        self.log = log  # node name -> its log so far
        self._left: tuple[Any, dict[str, float]] | None = None  # what the last refused case left

    def _dead(self) -> str | None:
        dead = [name for name, proc in self.processes.items() if proc.poll() is not None]
        return f"{', '.join(dead)} died" if dead else None

    def snapshot(self) -> tuple[Any, dict[str, float]]:
        answer = self.prober.call("get_planning_scene", {}, 20.0)
        scene = answer["result"]
        world = sorted((o["id"], json.dumps(o, sort_keys=True)) for o in scene["world"]["collision_objects"])
        attached = sorted(a["object"]["id"] for a in scene["robot_state"]["attached_collision_objects"])
        acm = json.dumps(scene["allowed_collision_matrix"], sort_keys=True)
        with self.prober.lock:
            joints = dict(self.prober.joints)
        return (world, attached, acm), joints

    def _changed(self, before: tuple[Any, dict[str, float]]
                 ) -> tuple[tuple[str, str] | None, tuple[Any, dict[str, float]]]:
        """((verdict, what) or None, the snapshot now): what a refused input left behind, the
        scene changed (half_applied) or the robot moved (unsafe_motion), now or in any
        joint_states message since watch()."""
        now = self.snapshot()
        if now[0] != before[0]:
            return ("half_applied", "the planning scene changed"), now
        moved = self.prober.motion() or moved_joints(before[1], now[1])
        return (("unsafe_motion", f"the robot moved ({moved})") if moved else None), now

    def judge(self, case: Case) -> Outcome:
        # compared with what the case before left (unless it failed), so that an earlier input's
        # late change shows up here instead of falling between two snapshots
        before, self._left = self._left or self.snapshot(), None
        self.prober.watch(before[1])
        started = time.monotonic()
        verdict, detail = self._send(case)
        if verdict == "refused" and self._may_act_later(case):
            time.sleep(SETTLE_S)  # let a wrongly accepted command show its effect in this case
        dead = self._dead()
        if dead is not None:
            return Outcome(case, "crash", dead)
        if verdict != "refused":
            return Outcome(case, verdict, detail)
        try:
            changed, now = self._changed(before)
        except (TimeoutError, KeyError, TypeError) as exc:
            return Outcome(case, "hang", f"the planning_server stopped answering: {exc}")
        if changed is not None:
            return Outcome(case, changed[0], f"{changed[1]} (in this case, or late after an earlier one); "
                                             f"answer: {detail}")
        self._left = now
        return Outcome(case, "refused", f"{detail} ({time.monotonic() - started:.2f} s)")

    @staticmethod
    def _may_act_later(case: Case) -> bool:
        """Whether a refused input could still show its effect after its answer: what reaches the
        controllers (their topics, move_group's and the controllers' action goals) or the scene
        without an answer (topics). A move_group service (plan, IK, FK, validity, Cartesian path,
        scene apply, planner parameters) commands no motion, and its scene change, if any, is in
        place when it answers, so the check right after it is the whole check (saves SETTLE_S on
        each of ~490 cases)."""
        if case.interface in ("controller", "topic"):
            return True
        return case.interface == "moveit" and case.payload.kind == "action"

    def _send(self, case: Case) -> tuple[str, str]:
        p = self.prober
        if case.interface == "rpc":
            try:
                answer = p.call(case.target, case.payload, case.timeout)
            except TimeoutError as exc:
                return "hang", str(exc)
            return self._judge_rpc(answer)
        if case.interface == "rpc_raw" and case.logged:
            seen = self.log("planning_server").count(case.logged)
            from std_msgs.msg import String

            p.requests.publish(String(data=case.payload))
            deadline = time.monotonic() + case.timeout
            while time.monotonic() < deadline:
                if self.log("planning_server").count(case.logged) > seen:
                    return "refused", f"logged '{case.logged}' (no id to answer to)"
                time.sleep(0.02)
            return "hang", f"the planning_server neither answered nor logged '{case.logged}'"
        if case.interface == "rpc_raw":
            request_id = uuid.uuid4().hex
            answer = p.send_raw(case.payload.replace("RID", request_id), request_id, case.timeout)
            if answer is None:
                return "hang", "no answer"
            return self._judge_rpc(answer)
        if case.interface == "topic":
            from std_msgs.msg import String

            p.topics[case.target].publish(String(data=case.payload))
            time.sleep(0.2)
            return "refused", "no answer expected on a topic"
        if case.interface == "controller":
            p.publish_trajectory(case.target, case.payload)
            return "refused", "no answer expected on a topic"
        if case.interface == "param":
            name, value = case.payload
            result = p.set_param(case.target, name, value)
            if result is None:
                return "hang", f"{case.target} did not answer set_parameters"
            if result.successful:
                return "accepted_bad", "Set parameter successful"
            problem = _problem_text(result.reason)
            return ("accepted_bad", problem) if problem else ("refused", result.reason)
        if case.interface == "moveit":
            return self._send_moveit(case)
        raise ValueError(f"unknown interface {case.interface}")

    def _send_moveit(self, case: Case) -> tuple[str, str]:
        given, p = case.payload, self.prober
        if given.kind == "planner_params":
            from moveit_msgs.srv import GetPlannerParams

            ask = GetPlannerParams.Request(pipeline_id="ompl", planner_config="RRTkConfigDefault")
            before = p.moveit_call(GetPlannerParams, "/get_planner_params", ask, case.timeout)
            if p.moveit_call(given.type, given.name, given.build(), case.timeout) is None:
                return "hang", "set_planner_params did not answer"
            after = p.moveit_call(GetPlannerParams, "/get_planner_params", ask, case.timeout)
            if before is None or after is None:
                return "hang", "get_planner_params did not answer"
            unchanged = (list(before.params.keys), list(before.params.values)) == \
                (list(after.params.keys), list(after.params.values))
            return ("refused", "the parameters are unchanged") if unchanged else \
                ("half_applied", f"the parameters changed: {dict(zip(after.params.keys, after.params.values))}")
        if given.kind == "action":
            from action_msgs.msg import GoalStatus

            state, answer = p.moveit_goal(given.type, given.name, given.build(), case.timeout)
            if state == "rejected":
                return "refused", "goal rejected"
            if state == "hang":
                return "hang", answer
            if hasattr(answer.result, "error_string"):  # control_msgs/FollowJointTrajectory
                if answer.status == GoalStatus.STATUS_SUCCEEDED or answer.result.error_code == 0:
                    return "accepted_bad", f"the controller's goal succeeded: {answer.result.error_string[:120]}"
                problem = _problem_text(answer.result.error_string)
                return ("accepted_bad", problem) if problem else \
                    ("refused", f"{answer.result.error_code}: {answer.result.error_string}")
            if answer.status == GoalStatus.STATUS_SUCCEEDED:
                return "accepted_bad", f"the goal succeeded: {answer.result.error_code.message[:120]}"
            return self._judge_code(answer.result.error_code)
        response = p.moveit_call(given.type, given.name, given.build(), case.timeout)
        if response is None:
            return "hang", f"{given.name} did not answer"
        if hasattr(response, "motion_plan_response"):
            return self._judge_code(response.motion_plan_response.error_code)
        if hasattr(response, "error_code"):
            return self._judge_code(response.error_code)
        if hasattr(response, "valid"):
            return ("accepted_bad", "answered valid") if response.valid else ("refused", "valid: false")
        if hasattr(response, "success"):
            return ("accepted_bad", "answered success") if response.success else ("refused", "success: false")
        return "accepted_bad", f"no way to tell a refusal from {type(response).__name__}"

    @staticmethod
    def _judge_code(code: Any) -> tuple[str, str]:
        """A moveit_msgs/MoveItErrorCodes: a refusal is a value other than SUCCESS with a clear
        message; an internal error (the face's catch-all) is no refusal."""
        message = str(code.message)
        if code.val == 1:
            return "accepted_bad", f"answered SUCCESS: {message[:120]}"
        problem = _problem_text(message)
        if problem is None and "internal error" in message:
            problem = f"an internal error, not a refusal: {message[:120]}"
        return ("accepted_bad", problem) if problem else ("refused", f"{code.val}: {message}")

    @staticmethod
    def _judge_rpc(answer: dict) -> tuple[str, str]:
        if not answer.get("ok"):
            message = str((answer.get("error") or {}).get("message", ""))
            problem = _problem_text(message)
            return ("accepted_bad", problem) if problem else ("refused", message)
        result = answer.get("result") or {}
        code = result.get("error_code") if isinstance(result, dict) else None
        if isinstance(code, dict) and code.get("val") != 1:
            message = str(code.get("message", ""))
            problem = _problem_text(message)
            return ("accepted_bad", problem) if problem else ("refused", message)
        return "accepted_bad", f"answered as a success: {json.dumps(result)[:200]}"

    def run(self, cases: list[Case], progress: Callable[[int, Outcome], None] | None = None) -> Report:
        report = Report()
        for k, case in enumerate(cases):
            outcome = self.judge(case)
            report.outcomes.append(outcome)
            if progress is not None:
                progress(k, outcome)
            if outcome.verdict == "crash":
                break  # the rest would only repeat it
        last = report.outcomes[-1] if report.outcomes else None
        if last is not None and last.verdict == "refused" and self._left is not None:
            time.sleep(LATE_S)  # what the last input did late has no next case to show up in
            changed, _ = self._changed(self._left)
            if changed is not None:
                report.outcomes[-1] = Outcome(last.case, changed[0], f"{changed[1]} after the answer; {last.detail}")
        return report


class RobustnessSystem:
    """mock_controllers + planning_server + mtc_node (its start-up plan done) and a Prober."""

    def __init__(self, domain: int) -> None:
        self.processes = RobotProcesses(domain, extra_nodes={
            "mtc_node": (["--ros-args", "-p", "max_solutions:=1"], "MTC pick and place completed")})
        self.prober: Prober | None = None

    def __enter__(self) -> "RobustnessSystem":
        self.processes.__enter__()
        try:
            self.prober = Prober()
            self.prober.wait_ready()
        except BaseException:
            self.close()
            raise
        return self

    def runner(self) -> Runner:
        assert self.prober is not None
        return Runner(self.prober, self.processes.procs, self.processes.log)

    def close(self) -> None:
        if self.prober is not None:
            self.prober.close()
        self.processes.close()

    def __exit__(self, *exc: Any) -> None:
        self.close()


def bench_robustness(repeat: int, seed: int) -> None:
    """Every case once per repeat; the summary counts the verdicts (all but refused must be 0)."""
    cases = all_cases()
    totals: dict[str, int] = {}
    failing: list[str] = []
    with RobustnessSystem(bench_domain_id()) as system:
        runner = system.runner()
        for index in range(repeat):
            started = time.perf_counter()
            report = runner.run(cases)
            summary = report.summary()
            emit({"scenario": "robustness", "repeat": index, "seconds": round(time.perf_counter() - started, 2),
                  **{k: v for k, v in summary.items() if k != "failing_cases"}})
            for key in ("inputs", "refused", "accepted_bad", "crashes", "hangs", "half_applied", "unsafe_motions"):
                totals[key] = totals.get(key, 0) + summary[key]
            failing += [f for f in summary["failing_cases"] if f not in failing]
    emit({"scenario": "robustness", "summary": True, **totals, "failing_cases": failing[:20], **machine()})
