"""``moveit.core``: moveit_py's core modules (robot_model, robot_state, planning_scene,
kinematic_constraints, robot_trajectory, planning_interface, controller_manager) over the
mycobot_planning core. Import them as modules: ``from moveit.core.robot_state import RobotState``."""
