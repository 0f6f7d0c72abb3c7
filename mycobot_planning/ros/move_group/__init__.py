"""move_group's ROS side: the planning_server node (its JSON and std_srvs face), the node
``move_group`` with MoveIt's moveit_msgs face, and the controller bus over the controllers'
FollowJointTrajectory and GripperCommand actions."""
