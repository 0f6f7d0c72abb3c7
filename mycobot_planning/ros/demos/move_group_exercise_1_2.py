"""ROSCon 2024 exercise 1-2 on the myCobot: a zig-zag of straight Cartesian moves over the hot dog.

The full story: docs/nodes.md, section mycobot_planning.ros.demos.move_group_exercise_1_2.
"""
from __future__ import annotations


import numpy as np

from interfaces_py.clients import RpcError
from mycobot_planning.ros.demos.move_group_exercise_1_1 import reset_objects, scenario_specs
from mycobot_planning.ros.node_runtime import ParameterSpec
from mycobot_planning.demos.seed_scenarios import HotDogScenario
from mycobot_planning.ros.workflow_runtime import PLANNING_SPECS, WorkflowFailed, WorkflowNode

NODE_NAME = "move_group_exercise_1_2"
_DEFAULT = HotDogScenario()


def _specs() -> list[ParameterSpec]:
    scene = [s for s in scenario_specs() if s.name in ("bun_position", "tool_yaw", "reset_scene")]
    return PLANNING_SPECS + scene + [
        ParameterSpec("start_height", _DEFAULT.mustard_start_height,
                      "height of the flange above the sausage's centre where the zig-zag starts (m)",
                      range=(0.02, 0.5)),
        ParameterSpec("zigzag_length", _DEFAULT.mustard_length, "length of the zig-zag along the sausage (m)",
                      range=(0.001, 0.5)),
        ParameterSpec("zigzag_amplitude", _DEFAULT.mustard_amplitude,
                      "sideways offset of the zig-zag's corners (m)", range=(0.0, 0.1)),
        ParameterSpec("zigzag_strokes", _DEFAULT.mustard_strokes, "straight segments of the zig-zag",
                      range=(1, 100)),
        ParameterSpec("eef_step", 0.002, "largest end-effector translation between path points (m)",
                      range=(0.0001, 0.1)),
        ParameterSpec("jump_threshold", 1.5, "MoveIt's relative joint-space jump test (0 disables it)",
                      range=(0.0, 100.0)),
        ParameterSpec("avoid_collisions", True, "stop the Cartesian path before a collision"),
        ParameterSpec("min_fraction", 0.0, "fail unless the Cartesian path's fraction is above this "
                      "(the seed executes any fraction above 0)", range=(0.0, 1.0)),
        ParameterSpec("hold_bottle", True, "the gripper holds a mustard bottle (an attached object), as in "
                      "the seed"),
    ]


class Exercise12(WorkflowNode):
    """See docs/nodes.md (mycobot_planning.ros.demos.move_group_exercise_1_2)."""

    def __init__(self) -> None:
        super().__init__(NODE_NAME, _specs())
        p = self.params
        try:
            self.scenario = HotDogScenario(
                bun_position=tuple(float(v) for v in p.get("bun_position")),
                yaw=float(p.get("tool_yaw")),
                mustard_start_height=float(p.get("start_height")),
                mustard_length=float(p.get("zigzag_length")),
                mustard_amplitude=float(p.get("zigzag_amplitude")),
                mustard_strokes=int(p.get("zigzag_strokes")),
            )
        except ValueError as exc:
            raise ValueError(f"invalid scenario parameters: {exc}") from None

    def run(self) -> None:
        log = self.get_logger()
        p = self.params
        sc = self.scenario
        arm = self.move_group()
        scene = arm.scene
        try:
            if p.get("reset_scene"):
                reset_objects(arm, [sc.sausage_id, sc.bun_id, sc.mustard_id, sc.bottle_id], log)
            scene.apply_collision_objects([sc.bun(), sc.sausage(sc.place_position())])
            if p.get("hold_bottle"):
                scene.attach_collision_object(sc.mustard_bottle())
        except RpcError as exc:
            raise WorkflowFailed(f"setting up the scene failed: {exc}") from None
        log.info(f"scene: hot dog at {np.round(sc.place_position(), 3).tolist()}"
                 + (f", '{sc.bottle_id}' held by the gripper" if p.get("hold_bottle") else ""))

        # 1. a pose just above the hot dog
        start = sc.mustard_start_pose()
        log.info(f"start pose: {np.round(start.position, 3).tolist()} (tool pointing down)")
        arm.set_pose_target(start)
        self.execute(arm, self.plan(arm, "the motion to the start pose"), "the motion to the start pose")

        # 2.-3. the zig-zag as straight Cartesian segments from where the robot now is
        waypoints = sc.mustard_waypoints(start)
        eef_step, jump = float(p.get("eef_step")), float(p.get("jump_threshold"))
        trajectory, fraction = arm.compute_cartesian_path(waypoints, eef_step=eef_step, jump_threshold=jump,
                                                          avoid_collisions=bool(p.get("avoid_collisions")))
        result = arm.last_result or {}
        if fraction < 0:
            raise WorkflowFailed(f"the Cartesian path request failed: {result.get('error_code')}")
        points = len(trajectory.joint_trajectory.points) if trajectory is not None else 0
        log.info(f"Cartesian path: fraction {fraction:.4f} of {len(waypoints)} waypoints with eef_step {eef_step} "
                 f"and jump_threshold {jump} ({points} points, stop reason: {result.get('stop_reason', 'n/a')})")
        if fraction <= 0 or trajectory is None:
            raise WorkflowFailed("no part of the Cartesian path could be planned (fraction 0): nothing to execute")
        if fraction < float(p.get("min_fraction")):
            raise WorkflowFailed(f"the Cartesian path covers only {fraction:.4f} of the zig-zag "
                                 f"(min_fraction {p.get('min_fraction')})")

        # 4. execute it and show the mustard
        self.execute(arm, trajectory, "the Cartesian zig-zag")
        try:
            scene.add_object(sc.mustard_stripe())
        except RpcError as exc:
            raise WorkflowFailed(f"adding the mustard to the scene failed: {exc}") from None
        log.info(f"mustard applied ('{sc.mustard_id}' on the hot dog)")
