"""The warehouse (moveit_ros_warehouse): stored robot states, and the name and atomic-write
rules the waypoint store shares."""
