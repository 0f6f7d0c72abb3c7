"""MTC's execute_task_solution: sub-trajectories with planning-scene diffs before and after each.

The whole solution is checked first (trajectories, controllers, continuity, and a dry run of every
scene diff on a copy of the scene); an "after" diff is applied only once its trajectory
succeeded, so a failure never leaves a half-applied attach or detach behind.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, Callable, Mapping, Sequence

from interfaces_py.msgs import JointTrajectory, MessageError, MoveItErrorCode
from interfaces_py.msgs import PlanningScene as PlanningSceneMsg
from interfaces_py.msgs import RobotState as RobotStateMsg

from ..moveit_error_code import ErrorCodeResult
from ..errors import PlanningError, SceneError
from ..planning_scene.planning_scene import PlanningScene
from .controller_manager import select_controllers
from .monitor import ExecutionResult
from .settings import ExecutionError
from .settings import error_code as _code
from .trajectory_preparation import parse_trajectory, prepare_trajectory

if TYPE_CHECKING:  # pragma: no cover
    from .manager import TrajectoryExecutionManager

@dataclass
class SolutionStep:
    """One sub-trajectory of a task solution with the scene changes around it."""

    name: str
    group: str = ""
    trajectory: JointTrajectory | None = None  # None (or no points): a scene-change-only step
    controllers: tuple[str, ...] | None = None
    scene_diff_before: PlanningSceneMsg | None = None
    scene_diff_after: PlanningSceneMsg | None = None

    @property
    def moves(self) -> bool:
        return self.trajectory is not None and len(self.trajectory.points) > 0



_STEP_KEYS = {"name", "group", "trajectory", "controller", "controller_names", "controllers",
              "scene_diff_before", "scene_diff_after", "scene_diff", "execution_info"}
_IGNORED_STEP_KEYS = {"info", "id", "cost", "comment", "stage_id", "stage"}


def as_scene_diff(value: Any, what: str) -> PlanningSceneMsg:
    """A planning-scene diff for applying during execution.

    Always applied as a diff (is_diff forced, so an omitted flag can never wipe the world), and the
    robot_state's joint positions are dropped: during execution the robot's real state comes from
    /joint_states, a planned state in a diff would only fight it. Attached objects are kept.
    """
    try:
        msg = value if isinstance(value, PlanningSceneMsg) else (
            PlanningSceneMsg.from_json(value) if isinstance(value, (str, bytes, bytearray)) else PlanningSceneMsg.from_dict(value)
        )
    except MessageError as exc:
        raise ExecutionError(MoveItErrorCode.INVALID_MOTION_PLAN, f"{what}: {exc}") from None
    state = RobotStateMsg(attached_collision_objects=list(msg.robot_state.attached_collision_objects), is_diff=True)
    return replace(msg, robot_state=state, is_diff=True)


def parse_task_solution(data: Any) -> list[SolutionStep]:
    """Solution steps from ``{"steps": [...]}``, ``{"sub_trajectory": [...]}`` (MTC) or a list.

    Each step: ``trajectory`` (RobotTrajectory or JointTrajectory; optional), ``group``, ``name``,
    ``controller`` / ``controller_names`` (or MTC's ``execution_info.controller_names``),
    ``scene_diff_before`` and ``scene_diff_after`` (``scene_diff`` is MTC's name for the latter).
    Everything is validated here; ExecutionError(INVALID_MOTION_PLAN) names the step and field.
    """
    bad = MoveItErrorCode.INVALID_MOTION_PLAN
    if isinstance(data, Mapping):
        raw = data.get("steps", data.get("sub_trajectory"))
        if raw is None:
            raise ExecutionError(bad, "task solution needs a 'steps' list")
    else:
        raw = data
    if not isinstance(raw, list) or not raw:
        raise ExecutionError(bad, "task solution 'steps' must be a non-empty list")
    steps = []
    for k, entry in enumerate(raw):
        where = f"step {k}"
        if not isinstance(entry, Mapping):
            raise ExecutionError(bad, f"{where} must be an object, got {type(entry).__name__}")
        unknown = sorted(set(entry) - _STEP_KEYS - _IGNORED_STEP_KEYS)
        if unknown:
            raise ExecutionError(bad, f"{where}: unknown keys {unknown}; known: {sorted(_STEP_KEYS)}")
        name = entry.get("name", "")
        if not name and isinstance(entry.get("info"), Mapping):
            name = entry["info"].get("stage_name", "")  # MTC-style sub_trajectory: the stage's name
        if not isinstance(name, str):
            raise ExecutionError(bad, f"{where}: 'name' must be a string")
        where = f"step {k}" + (f" ('{name}')" if name else "")
        trajectory, group = None, entry.get("group", "")
        if not isinstance(group, str):
            raise ExecutionError(bad, f"{where}: 'group' must be a string")
        if entry.get("trajectory") is not None:
            trajectory, traj_group = parse_trajectory(entry["trajectory"], f"{where} trajectory")
            group = group or traj_group
        controllers = _step_controllers(entry, where)
        before = entry.get("scene_diff_before")
        after = entry.get("scene_diff_after")
        if entry.get("scene_diff") is not None:
            if after is not None:
                raise ExecutionError(bad, f"{where}: give scene_diff or scene_diff_after, not both")
            after = entry["scene_diff"]
        steps.append(SolutionStep(
            name=name or f"step {k}",
            group=group,
            trajectory=trajectory,
            controllers=controllers,
            scene_diff_before=as_scene_diff(before, f"{where} scene_diff_before") if before is not None else None,
            scene_diff_after=as_scene_diff(after, f"{where} scene_diff_after") if after is not None else None,
        ))
    return steps


def _step_controllers(entry: Mapping, where: str) -> tuple[str, ...] | None:
    bad = MoveItErrorCode.INVALID_MOTION_PLAN
    value = entry.get("controller_names", entry.get("controllers", entry.get("controller")))
    info = entry.get("execution_info")
    if value is None and isinstance(info, Mapping):
        value = info.get("controller_names")
    if value is None or value == "" or value == []:
        return None
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        raise ExecutionError(bad, f"{where}: controller names must be a string or a list of strings")
    return tuple(value)


@dataclass
class SolutionResult(ErrorCodeResult):
    """The outcome of a task solution: which steps ran and which scene changes were applied."""

    error_code: MoveItErrorCode
    steps_completed: int = 0
    failed_step: int | None = None
    applied: list[str] = field(default_factory=list)
    step_results: list[dict[str, Any]] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {
            "error_code": self.error_code.to_dict(),
            "steps_completed": self.steps_completed,
            "failed_step": self.failed_step,
            "applied_scene_diffs": list(self.applied),
            "steps": list(self.step_results),
        }



def check_solution(manager: "TrajectoryExecutionManager", steps: Sequence[SolutionStep], scene: PlanningScene,
                   current: Mapping[str, float] | None = None) -> None:
    """Validate a whole solution before the first motion (ExecutionError naming the step).

    Trajectories and controllers are checked, consecutive steps must join within the start
    tolerance, and every scene diff is applied on a copy of ``scene`` with the robot placed
    where the previous steps leave it: a diff that would fail at run time fails here instead.
    """
    staged = scene.copy()
    tolerance = manager.settings.allowed_start_tolerance
    expected: dict[str, float] = dict(current or {})
    for k, step in enumerate(steps):
        where = f"step {k} ('{step.name}')"
        if step.scene_diff_before is not None:
            _stage_scene_diff(staged, step.scene_diff_before, where, "scene_diff_before")
        if step.moves:
            try:
                prepared = prepare_trajectory(manager.model, step.trajectory,
                                              limit_tolerance=manager.settings.limit_tolerance,
                                              max_waypoint_distance=manager.settings.max_waypoint_distance)
                select_controllers(prepared.joint_names, manager.controllers, step.controllers)
            except ExecutionError as exc:
                raise ExecutionError(exc.code, f"{where}: {exc.message}") from None
            if k > 0 and tolerance > 0:
                for name, value in zip(prepared.joint_names, prepared.points[0].positions):
                    if name in expected and abs(value - expected[name]) > tolerance:
                        raise ExecutionError(
                            MoveItErrorCode.INVALID_MOTION_PLAN,
                            f"{where} starts at {name}={value:.4f} but the previous steps end at "
                            f"{expected[name]:.4f} (allowed_start_tolerance {tolerance})",
                        )
            end = dict(zip(prepared.joint_names, prepared.points[-1].positions))
            expected.update(end)
            try:
                staged.set_current_state(end)
            except (ValueError, PlanningError) as exc:
                raise ExecutionError(MoveItErrorCode.INVALID_MOTION_PLAN, f"{where}: end state: {exc}") from None
        if step.scene_diff_after is not None:
            _stage_scene_diff(staged, step.scene_diff_after, where, "scene_diff_after")

def _stage_scene_diff(staged: PlanningScene, diff: PlanningSceneMsg, where: str, label: str) -> None:
    """Apply one of a step's scene diffs on the staged scene copy (ExecutionError when it cannot)."""
    try:
        staged.apply_planning_scene_msg(diff)
    except (SceneError, MessageError) as exc:
        raise ExecutionError(MoveItErrorCode.INVALID_MOTION_PLAN, f"{where}: {label} cannot be applied: {exc}") from None


def execute_solution(
    manager: "TrajectoryExecutionManager",
    steps: Sequence[SolutionStep],
    apply_diff: Callable[[PlanningSceneMsg], None],
    scene: PlanningScene | None = None,
) -> SolutionResult:
    """Execute a task solution step by step (blocking), applying scene diffs as it goes.

    ``apply_diff`` applies a diff to the live scene (raising SceneError leaves it unchanged).
    ``scene`` (a snapshot of the live scene) enables the dry run of :func:`check_solution`.
    """
    refused = manager._begin(f"task solution of {len(steps)} steps")
    if refused is not None:
        return SolutionResult(refused)
    result = SolutionResult(_code(MoveItErrorCode.FAILURE, "not executed"))
    try:
        result = _execute_solution(manager, steps, apply_diff, scene)
    except ExecutionError as exc:
        result = SolutionResult(exc.error_code(), failed_step=None)
    except Exception as exc:
        result = SolutionResult(_code(MoveItErrorCode.FAILURE, f"execution failed: {type(exc).__name__}: {exc}"))
    finally:
        manager._end(result.to_dict())
    return result

def _execute_solution(manager: "TrajectoryExecutionManager", steps: Sequence[SolutionStep], apply_diff: Callable[[PlanningSceneMsg], None],
                      scene: PlanningScene | None) -> SolutionResult:
    if scene is not None:
        positions, _ = manager._current_positions()
        check_solution(manager, steps, scene, positions)
    result = SolutionResult(_code(MoveItErrorCode.SUCCESS, ""))
    for k, step in enumerate(steps):
        where = f"step {k} ('{step.name}')"
        with manager._state_lock:
            stopped = manager._stop_requested
        if stopped:
            return _fail(manager, result, k, _code(MoveItErrorCode.PREEMPTED, f"execution stopped on request before {where}"))
        if step.scene_diff_before is not None:
            failed = _apply_scene_diff(manager, result, k, where, "scene_diff_before", step.scene_diff_before, apply_diff)
            if failed is not None:
                return failed
        step_record: dict[str, Any] = {"name": step.name, "group": step.group}
        if step.moves:
            try:
                outcome = manager._execute(step.trajectory, step.controllers, where)
            except ExecutionError as exc:
                manager._log("warning", f"execution of {where} refused: {exc.message}")
                outcome = ExecutionResult(exc.error_code())
            step_record.update(outcome.to_dict())
            result.step_results.append(step_record)
            if not outcome:
                code = outcome.error_code
                tail = (" Its scene_diff_after was not applied." if step.scene_diff_after is not None else "")
                return _fail(manager, result, k, _code(code.val, f"{where} failed: {code.message.rstrip('.')}.{tail}"))
        else:
            result.step_results.append(step_record)
        if step.scene_diff_after is not None:
            failed = _apply_scene_diff(manager, result, k, where, "scene_diff_after", step.scene_diff_after, apply_diff)
            if failed is not None:
                return failed
        result.steps_completed = k + 1
    result.error_code = _code(MoveItErrorCode.SUCCESS, f"{len(steps)} steps executed")
    return result


def _apply_scene_diff(manager: "TrajectoryExecutionManager", result: SolutionResult, step: int, where: str, label: str,
                      diff: PlanningSceneMsg, apply_diff: Callable[[PlanningSceneMsg], None]) -> SolutionResult | None:
    """Apply one of a step's scene diffs and note it in ``result.applied``; the failed result
    (see _fail) when it cannot be applied, None when it was."""
    try:
        apply_diff(diff)
    except (SceneError, MessageError, ValueError) as exc:
        return _fail(manager, result, step, _code(MoveItErrorCode.FAILURE, f"{where}: {label} could not be applied: {exc}"))
    result.applied.append(f"{where}: {label}")
    return None


def _fail(manager: "TrajectoryExecutionManager", result: SolutionResult, step: int, code: MoveItErrorCode) -> SolutionResult:
    applied = ("Applied scene diffs: " + ", ".join(result.applied) + "." if result.applied
               else "No scene diff was applied.")
    text = code.message.rstrip()
    result.error_code = _code(code.val, f"{text}{'' if text.endswith('.') else '.'} {applied}")
    result.failed_step = step
    manager._log("warning" if code.val == MoveItErrorCode.PREEMPTED else "error",
              f"task solution stopped at step {step}: {result.error_code.message}")
    return result
