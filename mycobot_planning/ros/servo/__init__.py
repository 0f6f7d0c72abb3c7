"""MoveIt Servo on ROS: servo_node (servo_node.py) and its keyboard front end (keyboard_input.py)."""
