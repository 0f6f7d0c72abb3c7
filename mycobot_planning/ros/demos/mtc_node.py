"""mtc_node: the seed's pick and place as a node (``ros2 run mycobot_planning mtc_node``).

    ros2 run mycobot_planning mtc_node --ros-args --params-file config/mtc_node_params.yaml

Declares every parameter of the seed's mtc_node (config/mtc_node_params.yaml; descriptions with
``ros2 param describe /mtc_node <name>``), puts the table (unless ``spawn_table`` is false,
which removes one left by an earlier run) and the cylinder into the planning_server's scene as
the seed computes them, plans "pick_place_task" for ``max_solutions`` solutions from the
planning_server's current state, logs printState and the stage summary, publishes the best
solution (``/mtc_node/task/solution``, ``/planned_path``, MTC's ``/solution``), executes it when ``execute``
is true, and keeps running. ``ros2 param set /mtc_node execute true`` executes the best solution
later; the Trigger services ``/mtc_node/plan`` (plan again; a changed table or object
parameter re-does the scene first) and ``/mtc_node/execute`` do what they say. A bad value is
refused with the reason (array sizes, empty names, ranges, a minimum above its maximum) and the
node keeps running. Node plumbing (parameters every task node has, topics, services, exit codes
with ``exit_when_done``): ros/task/task_node.py. The task itself: mycobot_planning.demos.pick_place.
"""
from __future__ import annotations

from typing import Any, Sequence

from interfaces_py.clients import RpcError
from mycobot_planning.core.trajectory_execution import load_controllers
from mycobot_planning.ros.node_runtime import ParameterSpec
from mycobot_planning.ros.perception.perception_object_source import PerceptionObjectSource, perception_parameter_specs
from mycobot_planning.ros.task.task_node import TaskNode
from mycobot_planning.task import Task
from mycobot_planning.demos.pick_place import (
    MTC_NODE_PARAMETER_NAMES,
    PARAMETERS,
    PickPlaceParameters,
    build_pick_place_task,
    seed_scene_objects,
)

NODE_NAME = "mtc_node"
#: Declared by the TaskNode base (same names and defaults as the seed's).
_BASE_NAMES = ("execute", "max_solutions")
#: Pairs checked on set: the minimum must not exceed the maximum.
_PARTNERS = {
    "approach_object_min_dist": ("approach_object_max_dist", "max"),
    "approach_object_max_dist": ("approach_object_min_dist", "min"),
    "lift_object_min_dist": ("lift_object_max_dist", "max"),
    "lift_object_max_dist": ("lift_object_min_dist", "min"),
    "lower_object_min_dist": ("lower_object_max_dist", "max"),
    "lower_object_max_dist": ("lower_object_min_dist", "min"),
    "retreat_min_distance": ("retreat_max_distance", "max"),
    "retreat_max_distance": ("retreat_min_distance", "min"),
}
#: Parameters that name something of the robot, checked against its model when set.
_GROUPS = ("arm_group_name", "gripper_group_name")
_LINKS = ("gripper_frame", "world_frame", "table_reference_frame", "object_reference_frame")
_NAMED_STATES = {"arm_home_pose": "arm_group_name", "gripper_open_pose": "gripper_group_name",
                 "gripper_close_pose": "gripper_group_name"}
#: What the scene set-up depends on: when one of them changed, a re-plan sets the scene up again.
_SCENE_NAMES = ("spawn_table", "table_name", "table_reference_frame", "table_dimensions", "table_pose", "object_name",
                "object_reference_frame", "object_dimensions", "object_pose", "place_pose_z_offset_factor")


def _controller_names() -> list[str]:
    """The controllers the planning_server executes through (config/controllers.yaml)."""
    return [c.name for c in load_controllers(None)]


def _default(name: str) -> Any:
    value = getattr(PickPlaceParameters(), name)
    if name in ("eef_name", "surface_link"):
        return {"eef_name": "gripper", "surface_link": "table"}[name]  # Example 1's defaults
    return list(value) if isinstance(value, tuple) else value


class PickPlaceTaskNode(TaskNode):
    """The pick-and-place task node; ``names`` are the task parameters it declares."""

    #: The seed's own log lines (mtc_node.cpp) after planning and execution, besides the base's.
    PLANNED, NOT_PLANNED = "Task planning succeeded", "Task planning failed"
    EXECUTED, NOT_EXECUTED = "Task executed successfully", "Task execution failed with error code: {val}"

    def __init__(self, node_name: str = NODE_NAME, names: Sequence[str] = MTC_NODE_PARAMETER_NAMES,
                 title: str = "MTC pick and place") -> None:
        self._task_names = [n for n in names if n not in _BASE_NAMES]
        specs = [self._spec(name) for name in self._task_names] + perception_parameter_specs()
        super().__init__(node_name, title=title, parameters=specs, max_solutions=10, seed=0)
        self._scene_key: tuple | None = None
        self._spawned_table: str | None = None
        # use_perception:=true takes the cylinder from the perception_server instead of object_pose.
        self.perception = PerceptionObjectSource(self)
        self.info("All parameters have been declared with descriptions")

    def _spec(self, name: str) -> ParameterSpec:
        info = PARAMETERS[name]
        partner = _PARTNERS.get(name)

        def validator(value: Any) -> str | None:
            if info.check is not None:
                problem = info.check(name, value)
                if problem:
                    return problem
            problem = self._robot_problem(name, value)
            if problem:
                return problem
            if partner is not None:
                other, role = partner
                if self.has_parameter(other):
                    bound = self.get_parameter(other).value
                    if (role == "max" and value > bound) or (role == "min" and value < bound):
                        word = "exceed" if role == "max" else "be below"
                        return f"{name} ({value:g}) must not {word} {other} ({bound:g}); set {other} first"
            return None

        return ParameterSpec(name, _default(name), info.description, range=info.range, array_size=info.array_size,
                             non_empty=info.non_empty, validator=validator)

    def _current(self, name: str) -> Any:
        return self.get_parameter(name).value if self.has_parameter(name) else _default(name)

    def _robot_problem(self, name: str, value: Any) -> str | None:
        """Why ``value`` names nothing of the robot or its controllers, or None."""
        model = self.model
        if name in _GROUPS and not model.has_group(value):
            return f"{name}: unknown planning group '{value}'; robot '{model.name}' has {list(model.group_names)}"
        if name in _LINKS and value != "world" and not model.has_link(value):
            return f"{name}: unknown frame '{value}': neither 'world' nor a link of robot '{model.name}'"
        if name in _NAMED_STATES:
            group = self._current(_NAMED_STATES[name])
            known = model.named_state_names(group) if model.has_group(group) else []
            if value not in known:
                return f"{name}: unknown named state '{value}' of group '{group}'; known: {list(known)}"
        if name == "controller_names":
            unknown = [c for c in value if c not in _controller_names()]
            if unknown:
                return (f"controller_names: unknown controllers {unknown}; config/controllers.yaml has "
                        f"{_controller_names()}")
        return None

    # ------------------------------------------------------------------ the seed's log lines
    def plan(self) -> bool:
        solved = super().plan()
        if solved:
            self.info(self.PLANNED)
        else:
            self.error(self.NOT_PLANNED)
        return solved

    def execute(self):
        code = super().execute()
        if code:
            self.info(self.EXECUTED)
        else:
            self.error(self.NOT_EXECUTED.format(val=code.val))
        return code

    # ------------------------------------------------------------------ the task
    def task_parameters(self) -> PickPlaceParameters:
        """The node's current values as validated task parameters (ValueError naming problems)."""
        values = {name: self.params.get(name) for name in (*_BASE_NAMES, *self._task_names)}
        return PickPlaceParameters.from_mapping(values)

    def build_task(self) -> Task:
        params = self.task_parameters()
        if self.perception.enabled:
            params = self.perception.setup_planning_scene(params)
            self._scene_key = None  # perception replaced the seed's objects: redo them if switched off
        else:
            self.setup_planning_scene(params)
        self.info("Creating MTC task")
        return build_pick_place_task(self.model, params, self.fetch_scene, seed=self.seed)

    def setup_planning_scene(self, params: PickPlaceParameters, force: bool = False) -> None:
        """Table and cylinder into the planning_server's scene, posed as the seed does. Done at
        the first plan and again when a scene parameter changed since (not on every re-plan:
        after an execution the object stands at the place pose, where the user left it)."""
        key = tuple(repr(getattr(params, name)) for name in _SCENE_NAMES)
        if key == self._scene_key and not force:
            return
        self.info("Setting up planning scene")
        table, cylinder = seed_scene_objects(params)
        psi = self.scene_interface
        try:
            if self._spawned_table is not None and self._spawned_table != params.table_name:
                self._remove_if_present(self._spawned_table)
                self._spawned_table = None
            if table is not None:
                psi.apply_collision_object(table)
                self._spawned_table = table.id
                self.info("Added table to planning scene")
            else:
                if self._remove_if_present(params.table_name):
                    self.info(f"Removed table '{params.table_name}' from the planning scene (spawn_table is false)")
                self.info("Skipping table spawn as per configuration")
            if params.object_name in psi.get_attached_objects([params.object_name]):
                psi.detach_object(params.object_name)  # a previous execution stopped while holding it
            psi.apply_collision_object(cylinder)
            self.info("Added object to planning scene")
        except RpcError as exc:
            self._scene_key = None
            raise ValueError(f"planning scene setup failed: {exc.message}") from None
        self._scene_key = key
        self.info("Planning scene setup completed")

    def _remove_if_present(self, object_id: str) -> bool:
        psi = self.scene_interface
        if object_id in psi.get_attached_objects([object_id]):
            psi.detach_object(object_id)
        if object_id in psi.get_objects([object_id]):
            psi.remove_object(object_id)
            return True
        return False
