"""Objectives over ROS: the behaviors that are clients of move_group, the controllers, the
perception_server and task nodes, their context, and the objective_server node."""
