"""Our own `ros2` command for the pip environment, where ros2cli cannot be installed.

The full story: docs/ros2cli.md, section mycobot_planning.ros2cli.__init__.
"""
