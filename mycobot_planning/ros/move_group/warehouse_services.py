"""MoveIt's warehouse robot-state services (moveit_ros_warehouse's warehouse_services node), on
its names, hosted by the planning_server process beside move_group:

``/save_robot_state`` (SaveRobotStateToWarehouse), ``/list_robot_states``
(ListRobotStatesInWarehouse: ``regex`` searched in each name, ``robot`` empty for every robot),
``/get_robot_state`` (GetRobotStateFromWarehouse), ``/has_robot_state``
(CheckIfRobotStateExistsInWarehouse), ``/rename_robot_state`` (RenameRobotStateInWarehouse),
``/delete_robot_state`` (DeleteRobotStateFromWarehouse).

A thin face: the states live in core.warehouse.RobotStateStorage (SQLite), each as its
serialized moveit_msgs/RobotState (what warehouse_ros_sqlite stores too). A refused request
(an empty name or one with control characters, an unknown name, a bad regex) answers as MoveIt's
does (success false, an empty state or list) and logs why."""
from __future__ import annotations

from typing import Any, Callable

from moveit_msgs.msg import RobotState
from moveit_msgs.srv import (
    CheckIfRobotStateExistsInWarehouse,
    DeleteRobotStateFromWarehouse,
    GetRobotStateFromWarehouse,
    ListRobotStatesInWarehouse,
    RenameRobotStateInWarehouse,
    SaveRobotStateToWarehouse,
)
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from rclpy.serialization import deserialize_message, serialize_message

from mycobot_planning.core.warehouse.robot_state_storage import RobotStateStorage, WarehouseError

__all__ = ["SERVICES", "WarehouseServices"]

#: MoveIt's service names (warehouse_services at the root namespace)
SAVE_ROBOT_STATE = "/save_robot_state"
LIST_ROBOT_STATES = "/list_robot_states"
GET_ROBOT_STATE = "/get_robot_state"
HAS_ROBOT_STATE = "/has_robot_state"
RENAME_ROBOT_STATE = "/rename_robot_state"
DELETE_ROBOT_STATE = "/delete_robot_state"
SERVICES = (SAVE_ROBOT_STATE, LIST_ROBOT_STATES, GET_ROBOT_STATE, HAS_ROBOT_STATE, RENAME_ROBOT_STATE,
            DELETE_ROBOT_STATE)


class WarehouseServices:
    """The six services on ``node``, answered from ``storage``; ``log(level, text)``."""

    def __init__(self, node: Node, storage: RobotStateStorage, log: Callable[[str, str], None]) -> None:
        self.storage = storage
        self._log = log
        group = MutuallyExclusiveCallbackGroup()
        self._services = [node.create_service(srv, name, self._guarded(name, handler), callback_group=group)
                          for srv, name, handler in (
            (SaveRobotStateToWarehouse, SAVE_ROBOT_STATE, self._save),
            (ListRobotStatesInWarehouse, LIST_ROBOT_STATES, self._list),
            (GetRobotStateFromWarehouse, GET_ROBOT_STATE, self._get),
            (CheckIfRobotStateExistsInWarehouse, HAS_ROBOT_STATE, self._has),
            (RenameRobotStateInWarehouse, RENAME_ROBOT_STATE, self._rename),
            (DeleteRobotStateFromWarehouse, DELETE_ROBOT_STATE, self._delete),
        )]

    def _guarded(self, name: str, handler: Callable[[Any, Any], Any]) -> Callable[[Any, Any], Any]:
        def serve(request: Any, response: Any) -> Any:
            try:
                return handler(request, response)
            except WarehouseError as exc:
                self._log("warning", f"{name}: refused: {exc}")
                if hasattr(response, "success"):
                    response.success = False
                return response
        return serve

    def _save(self, request: SaveRobotStateToWarehouse.Request, response: Any) -> Any:
        self.storage.save(request.name, request.robot, serialize_message(request.state))
        self._log("info", f"{SAVE_ROBOT_STATE}: saved robot state '{request.name}' (robot '{request.robot}')")
        response.success = True
        return response

    def _list(self, request: ListRobotStatesInWarehouse.Request, response: Any) -> Any:
        response.states = self.storage.names(request.regex, request.robot)
        return response

    def _get(self, request: GetRobotStateFromWarehouse.Request, response: Any) -> Any:
        response.state = deserialize_message(self.storage.get(request.name, request.robot), RobotState)
        return response

    def _has(self, request: CheckIfRobotStateExistsInWarehouse.Request, response: Any) -> Any:
        response.exists = self.storage.has(request.name, request.robot)
        return response

    def _rename(self, request: RenameRobotStateInWarehouse.Request, response: Any) -> Any:
        self.storage.rename(request.old_name, request.new_name, request.robot)
        self._log("info", f"{RENAME_ROBOT_STATE}: '{request.old_name}' is now '{request.new_name}'")
        return response

    def _delete(self, request: DeleteRobotStateFromWarehouse.Request, response: Any) -> Any:
        count = self.storage.delete(request.name, request.robot)
        self._log("info" if count else "warning",
                  f"{DELETE_ROBOT_STATE}: " + (f"deleted '{request.name}'" if count else f"no state '{request.name}'"))
        return response
