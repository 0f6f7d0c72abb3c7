"""ROS names of the two faces, in one place.

MoveIt's names carry MoveIt's types only (moveit_msgs on /monitored_planning_scene,
/display_planned_path, /collision_object, ...), so that MoveIt's clients and RViz work unchanged;
the standard-message face (JSON in std_msgs/String, plain trajectory_msgs) has names of its own.
"""
from __future__ import annotations

# ----------------------------------------------------------------- the standard-message face
#: trajectory_msgs/JointTrajectory of every plan (planning_server and task nodes): `ros2 topic echo`
PLANNED_PATH = "/planned_path"
#: std_msgs/String, JSON PlanningScene, transient local
JSON_MONITORED_SCENE = "/planning_server/monitored_planning_scene"
#: std_msgs/String, JSON scene updates into the planning_server
JSON_PLANNING_SCENE = "/planning_server/planning_scene"
JSON_COLLISION_OBJECT = "/planning_server/collision_object"
JSON_ATTACHED_COLLISION_OBJECT = "/planning_server/attached_collision_object"

# ----------------------------------------------------------------- MoveIt's face (move_group)
MOVE_GROUP_NODE = "move_group"
MONITORED_PLANNING_SCENE = "/monitored_planning_scene"
PLANNING_SCENE = "/planning_scene"
COLLISION_OBJECT = "/collision_object"
ATTACHED_COLLISION_OBJECT = "/attached_collision_object"
DISPLAY_PLANNED_PATH = "/display_planned_path"
TRAJECTORY_EXECUTION_EVENT = "/trajectory_execution_event"
MOVE_ACTION = "/move_action"
EXECUTE_TRAJECTORY_ACTION = "/execute_trajectory"
EXECUTE_TASK_SOLUTION_ACTION = "/execute_task_solution"
PLAN_SERVICE = "/plan_kinematic_path"
CARTESIAN_PATH_SERVICE = "/compute_cartesian_path"
IK_SERVICE = "/compute_ik"
FK_SERVICE = "/compute_fk"
GET_PLANNING_SCENE_SERVICE = "/get_planning_scene"
APPLY_PLANNING_SCENE_SERVICE = "/apply_planning_scene"
STATE_VALIDITY_SERVICE = "/check_state_validity"
QUERY_PLANNERS_SERVICE = "/query_planner_interface"
GET_PLANNER_PARAMS_SERVICE = "/get_planner_params"
SET_PLANNER_PARAMS_SERVICE = "/set_planner_params"
