"""mycobot_planning: MoveIt's move_group and the Task Constructor, rebuilt in Python for pip users.

Layers (see README): ``core`` (robot model, kinematics, scene, planners; no rclpy),
``task`` (task constructor), ``perception``, ``nodes`` (thin rclpy nodes).
"""

__version__ = "0.1.0"
