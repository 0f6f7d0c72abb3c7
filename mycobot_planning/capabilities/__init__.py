"""move_group's capabilities, between the planning core and the nodes, MoveIt's way: a
MoveGroupContext (move_group_context: the monitored scene and current state, the planning
pipeline, the trajectory execution manager) and one module per capability, each a typed call on
core types:

plan, cartesian_path, kinematics (IK/FK), state_validation, planner_query (planner interfaces
and parameters), planning_scene (get/apply), execute_trajectory, move_action (plan and execute),
task_solution (MTC's execute_task_solution), stop. trajectory_cache is no capability of its own:
the trajectory cache plan and cartesian_path consult (off unless configured).

Two faces translate to and from these calls and nothing else: the moveit_msgs face
(ros/move_group/move_group.py with ros/move_group/moveit_translation.py) and the JSON face
(json_face.py, served by ros/move_group/planning_server.py). No rclpy here.

Submodules are not imported here (``from mycobot_planning.capabilities import plan``), so the
context can be used without loading every capability.
"""
CAPABILITIES = ("plan", "cartesian_path", "kinematics", "state_validation", "planner_query", "planning_scene",
                "execute_trajectory", "move_action", "task_solution", "stop")

__all__ = ["CAPABILITIES"]
