"""The rclpy library: the ROS faces of the ROS-free layers, shared by the executables in nodes/
(each of which is one thin ``main``). As moveit_ros does, one package per concept:

- move_group: the planning_server node, move_group's moveit_msgs face, and the controller bus
  that executes through the controllers' actions (moveit_simple_controller_manager's role);
- controllers: the ros2_control stand-in (mock controllers, the myCobot driver) and their actions;
- task: task nodes (MTC's task ROS interface, introspection topics, the task viewer);
- perception: the camera simulator, the perception server and what task nodes take from it;
- demos: the seed demos as nodes (their tasks and workflows live in mycobot_planning.demos);
- node_runtime (parameters, start-up, spinning), workflow_runtime (move_group workflows) and
  robot_state_publisher.

Nothing is imported here: loading one node does not load the others."""
