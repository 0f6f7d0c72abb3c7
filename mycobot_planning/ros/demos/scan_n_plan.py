"""Scan-N-Plan's application node: ask the vision node where the part is, move the tool there.

The full story: docs/nodes.md, section mycobot_planning.ros.demos.scan_n_plan.
"""
from __future__ import annotations

import json
import time
from dataclasses import replace

from std_srvs.srv import Trigger

from interfaces_py.msgs import MessageError, Pose
from mycobot_planning.ros.node_runtime import ParameterSpec
from mycobot_planning.ros.workflow_runtime import PLANNING_SPECS, WorkflowFailed, WorkflowNode

NODE_NAME = "scan_n_plan"
# The seed's plan_request_params, as defaults (each still a parameter of this node).
SEED_DEFAULTS = {"planning_time": 10.0, "planning_attempts": 3, "max_velocity_scaling_factor": 0.5,
                 "max_acceleration_scaling_factor": 0.5}


def _specs() -> list[ParameterSpec]:
    specs = [replace(s, default=SEED_DEFAULTS[s.name]) if s.name in SEED_DEFAULTS else s for s in PLANNING_SPECS]
    return specs + [
        ParameterSpec("base_frame", "world", "frame of the part pose (the planning frame)", non_empty=True),
        ParameterSpec("tool_frame", "", "link moved to the part (empty: the group's tip link)"),
        ParameterSpec("localizer", "/part_localizer", "the vision node offering localize_part", non_empty=True),
        ParameterSpec("localize_timeout", 10.0, "seconds to keep asking the vision node while it has no marker",
                      range=(0.1, 3600.0)),
    ]


class ScanNPlan(WorkflowNode):
    """See docs/nodes.md (mycobot_planning.ros.demos.scan_n_plan)."""

    def __init__(self) -> None:
        super().__init__(NODE_NAME, _specs())
        service = self.params.get("localizer").rstrip("/") + "/localize_part"
        self._localize_client = self.create_client(Trigger, service)
        self._service = service

    def localize_part(self) -> Pose:
        """The part's pose from the vision node, in ``base_frame``."""
        log = self.get_logger()
        timeout = float(self.params.get("localize_timeout"))
        deadline = time.monotonic() + timeout
        log.info(f"waiting for {self._service}")
        if not self._localize_client.wait_for_service(timeout_sec=timeout):
            raise WorkflowFailed(f"the vision node's service {self._service} is not available after {timeout:g} s: "
                                 "is part_localizer running?")
        reason = ""
        while True:
            future = self._localize_client.call_async(Trigger.Request())
            while not future.done() and time.monotonic() < deadline + 5.0:
                time.sleep(0.01)
            if not future.done():
                raise WorkflowFailed(f"{self._service} did not answer")
            response = future.result()
            if response.success:
                break
            reason = response.message
            if time.monotonic() > deadline:
                raise WorkflowFailed(f"the vision node could not localize the part within {timeout:g} s: {reason}")
            log.info(f"part not localized yet ({reason}); asking again", throttle_duration_sec=2.0)
            time.sleep(0.2)
        try:
            answer = json.loads(response.message)
            pose = Pose.from_dict(answer["pose"])
            frame = answer["frame_id"]
        except (ValueError, KeyError, TypeError, MessageError) as exc:
            raise WorkflowFailed(f"the vision node answered something that is not a part pose: {exc}") from None
        if frame != self.params.get("base_frame"):
            raise WorkflowFailed(f"the vision node reports the part in '{frame}', but planning needs it in "
                                 f"'{self.params.get('base_frame')}': set part_localizer's base_frame")
        log.info(f"part localized at {[round(v, 4) for v in pose.position]} in '{frame}' "
                 f"(orientation {[round(v, 4) for v in pose.orientation]})")
        return pose

    def run(self) -> None:
        part = self.localize_part()
        arm = self.move_group()
        tool = self.params.get("tool_frame") or None
        if self.params.get("base_frame") != arm.get_planning_frame():
            raise WorkflowFailed(f"base_frame '{self.params.get('base_frame')}' is not the planning frame "
                                 f"'{arm.get_planning_frame()}'")
        arm.set_pose_target(part, end_effector_link=tool)
        what = f"the motion of {tool or 'the tip link'} to the part"
        self.execute(arm, self.plan(arm, what), what)
