"""ROSCon 2024 exercise 1-1 on the myCobot: plan to a pick pose, attach, plan to a place pose, detach.

The full story: docs/nodes.md, section mycobot_planning.ros.demos.move_group_exercise_1_1.
"""
from __future__ import annotations


import numpy as np

from interfaces_py.clients import MoveGroupClient, RpcError
from interfaces_py.msgs import CollisionObject
from mycobot_planning.ros.node_runtime import ParameterSpec
from mycobot_planning.demos.seed_scenarios import HotDogScenario
from mycobot_planning.ros.workflow_runtime import PLANNING_SPECS, WorkflowFailed, WorkflowNode

NODE_NAME = "move_group_exercise_1_1"
_DEFAULT = HotDogScenario()


def scenario_specs() -> list[ParameterSpec]:
    """The hot dog scene's parameters (shared with exercise 1-2)."""
    return [
        ParameterSpec("pick_position", list(_DEFAULT.pick_position),
                      "centre of the sausage on the table, where it is picked (m, world frame)", array_size=3),
        ParameterSpec("bun_position", list(_DEFAULT.bun_position), "centre of the bun (m, world frame)",
                      array_size=3),
        ParameterSpec("grasp_height", _DEFAULT.grasp_height,
                      "height of the flange above the sausage's centre when picking and placing (m)",
                      range=(0.01, 0.5)),
        ParameterSpec("drop_height", _DEFAULT.drop_height,
                      "the place pose is this much above the final place: the detached sausage drops into the "
                      "bun (m)", range=(0.0, 0.1)),
        ParameterSpec("tool_yaw", _DEFAULT.yaw, "yaw of the downward-pointing tool at pick and place (rad)",
                      range=(-3.1416, 3.1416)),
        ParameterSpec("reset_scene", True, "remove the scenario's objects left by an earlier run before starting"),
    ]


def scenario_from(params) -> HotDogScenario:
    return HotDogScenario(
        pick_position=tuple(float(v) for v in params.get("pick_position")),
        bun_position=tuple(float(v) for v in params.get("bun_position")),
        grasp_height=float(params.get("grasp_height")),
        drop_height=float(params.get("drop_height")),
        yaw=float(params.get("tool_yaw")),
    )


def reset_objects(arm: MoveGroupClient, ids: list[str], log) -> None:
    """Detach and remove objects with these ids (left by an earlier run), so a run starts clean."""
    scene = arm.scene
    for object_id in scene.get_attached_objects(ids):
        scene.detach_object(object_id)
        log.info(f"detached '{object_id}' left attached by an earlier run")
    present = list(scene.get_objects(ids))
    if present:
        scene.apply_collision_objects([CollisionObject(id=i, operation=CollisionObject.REMOVE) for i in present])
        log.info(f"removed {present} left by an earlier run")


class Exercise11(WorkflowNode):
    """See docs/nodes.md (mycobot_planning.ros.demos.move_group_exercise_1_1)."""

    def __init__(self) -> None:
        super().__init__(NODE_NAME, PLANNING_SPECS + scenario_specs())
        try:
            self.scenario = scenario_from(self.params)
        except ValueError as exc:
            raise ValueError(f"invalid scenario parameters: {exc}") from None

    def run(self) -> None:
        log = self.get_logger()
        sc = self.scenario
        arm = self.move_group()
        scene = arm.scene
        try:
            if self.params.get("reset_scene"):
                reset_objects(arm, [sc.sausage_id, sc.bun_id, sc.mustard_id, sc.bottle_id], log)
            scene.apply_collision_objects([sc.sausage(), sc.bun()])
        except RpcError as exc:
            raise WorkflowFailed(f"setting up the scene failed: {exc}") from None
        log.info(f"scene: '{sc.sausage_id}' at {np.round(sc.pick_position, 3).tolist()}, "
                 f"'{sc.bun_id}' at {np.round(sc.bun_position, 3).tolist()}")

        # pick: move above the sausage
        pick = sc.pick_pose()
        log.info(f"pick pose: {np.round(pick.position, 3).tolist()} (tool pointing down)")
        arm.set_pose_target(pick)
        self.execute(arm, self.plan(arm, "the pick motion"), "the pick motion")

        # attach the sausage, then plan to the place pose carrying it
        try:
            attached = scene.attach_object(sc.sausage_id)
        except RpcError as exc:
            raise WorkflowFailed(f"attaching '{sc.sausage_id}' failed: {exc}") from None
        log.info(f"attached '{sc.sausage_id}' to '{attached['link_name']}'")
        place = sc.place_pose()
        log.info(f"place pose: {np.round(place.position, 3).tolist()} (tool pointing down)")
        arm.set_pose_target(place)
        failure: WorkflowFailed | None = None
        try:
            self.execute(arm, self.plan(arm, "the place motion"), "the place motion")
        except WorkflowFailed as exc:
            failure = exc

        # detach in any case (as the seed does); drop it into the bun only if it got there
        try:
            scene.detach_object(sc.sausage_id)
            log.info(f"detached '{sc.sausage_id}'")
            if failure is not None:
                raise failure
            carried = scene.get_objects([sc.sausage_id])[sc.sausage_id].pose
            dropped = sc.dropped_sausage_pose(carried)
            scene.move_object(sc.sausage_id, dropped)
        except RpcError as exc:
            raise WorkflowFailed(f"placing '{sc.sausage_id}' failed: {exc}") from None
        log.info(f"dropped '{sc.sausage_id}' into the bun at {np.round(dropped.position, 4).tolist()}")
