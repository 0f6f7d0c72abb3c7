"""The warehouse (moveit_ros_warehouse): stored robot states, planning scenes with their queries
(what the benchmarks read), and the name and atomic-write rules the waypoint store shares."""
