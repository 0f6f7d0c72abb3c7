"""The ros2_control stand-in: the mock controller manager, the myCobot driver node built on it,
and the controllers' actions (FollowJointTrajectory, GripperCommand)."""
