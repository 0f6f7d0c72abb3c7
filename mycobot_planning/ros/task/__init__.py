"""Task nodes: the TaskNode base (MTC's demo node pattern), the task's ROS interface (robot model,
scene and execution from move_group), the introspection topics and the browser task viewer."""
