"""Mock ros2_control: the controller manager over the mock's kinematic plant (joints exactly
where they are commanded, with fault injection and settable initial positions).

The full story: docs/nodes.md, section mycobot_planning.ros.controllers.mock_controllers.
"""
from __future__ import annotations

import math
from typing import Any

from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.trajectory_execution.controllers_config import ControllerManagerConfig
from mycobot_planning.mock_control.mock_plant import FAULTS, MockPlant
from mycobot_planning.ros.controllers.controller_manager import ControllerManager
from mycobot_planning.ros.node_runtime import Parameters, ParameterSpec

NODE_NAME = "controller_manager"


# Numeric parameters use dynamic typing so that `ros2 param set ... 1` (an integer) works too.
def _finite(name: str):
    def check(value: Any) -> str | None:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            return f"{name} must be a finite number of seconds (negative disables), got {value!r}"
        return None

    return check


def load_mock_plant(node: ControllerManager, model: RobotModel, config: ControllerManagerConfig) -> MockPlant:
    """The mock's plant with its parameters on ``node``: fault injection per controller
    (``<controller>.fail_after``, ``<controller>.stall_after``) and ``initial_positions.<joint>``."""
    owner = {j: c.name for c in config.controllers for j in c.joints}
    defaults = model.default_positions()
    plant: MockPlant | None = None

    def initial_position_check(joint: str, index: int, controller: str | None):
        lower, upper = model.lower_limits[index], model.upper_limits[index]

        def check(value: Any) -> str | None:
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                return f"initial_positions.{joint} must be a finite number, got {value!r}"
            if not lower <= value <= upper:
                return f"initial_positions.{joint} = {value} is outside the joint's limits [{lower}, {upper}]"
            goal = plant.executing_goal(controller) if plant is not None and controller else ""
            if goal:
                return f"{controller} is executing goal {goal}; stop it before setting initial_positions.{joint}"
            return None

        return check

    specs = []
    for c in config.controllers:
        specs.append(ParameterSpec(
            f"{c.name}.fail_after", -1.0,
            f"fault injection: {c.name} aborts each goal with status 'failed' this many seconds after it "
            "starts (negative disables)", validator=_finite(f"{c.name}.fail_after"), dynamic_typing=True))
        specs.append(ParameterSpec(
            f"{c.name}.stall_after", -1.0,
            f"fault injection: {c.name}'s joints stop moving this many seconds after a goal starts while it "
            "keeps reporting 'executing' (negative disables)", validator=_finite(f"{c.name}.stall_after"),
            dynamic_typing=True))
    for i, joint in enumerate(model.variable_names):
        controller = owner.get(joint)
        specs.append(ParameterSpec(
            f"initial_positions.{joint}", float(defaults[i]),
            f"position of {joint} at start-up (rad or m); setting it later moves the joint there at once "
            f"while {controller or 'nothing'} is not executing a goal",
            validator=initial_position_check(joint, i, controller), dynamic_typing=True))
    params = Parameters(node, specs)
    plant = MockPlant(model.variable_names, defaults,
                      {j: float(params.get(f"initial_positions.{j}")) for j in model.variable_names},
                      {c.name: {f: float(params.get(f"{c.name}.{f}")) for f in FAULTS} for c in config.controllers})
    log = node.get_logger()

    def on_change(changed: dict[str, Any]) -> None:
        moved: dict[str, float] = {}
        for name, value in changed.items():
            prefix, _, key = name.partition(".")
            if prefix == "initial_positions":
                moved[key] = float(value)
                continue
            plant.set_fault(prefix, key, float(value))
            log.info(f"{prefix}: {key} = {value}" + (" (disabled)" if value < 0 else ""))
        if moved:
            plant.move_joints(moved)
            log.info(f"joints moved to {moved}")

    params.on_change(on_change)
    return plant


def mock_controller_manager() -> ControllerManager:
    """The node ``controller_manager`` of ``ros2 run mycobot_planning mock_controllers``."""
    return ControllerManager(NODE_NAME, load_mock_plant)
