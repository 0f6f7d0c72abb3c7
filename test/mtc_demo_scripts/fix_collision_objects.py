#! /usr/bin/env python3
# -*- coding: utf-8 -*-
# MoveIt Task Constructor's demo/scripts/fix_collision_objects.py (ros2 branch, commit 8e76def85452; BSD-3-Clause,
# (c) the moveit_task_constructor authors), run by test/ros/test_mtc_demo_scripts.py. Changed
# nothing but the import and ROS start-up lines:
#   from moveit.task_constructor import core, stages  ->  from mycobot_planning.task import core, stages
#   import rclcpp  ->  import rclpy
#   rclcpp.init()  ->  rclpy.init()
#   node = rclcpp.Node("mtc_tutorial")  ->  node = rclpy.create_node("mtc_tutorial")

from mycobot_planning.task import core, stages
import rclpy
import time

rclpy.init()
node = rclpy.create_node("mtc_tutorial")

# Create a task
task = core.Task()
task.name = "fix collision objects"
task.loadRobotModel(node)

# Add the current state to the task hierarchy
task.add(stages.CurrentState("current state"))

# [initAndConfig]
# check for collisions and find corrections
fixCollisionObjects = stages.FixCollisionObjects("FixCollisionObjects")

# cut off length for collision fixing
fixCollisionObjects.max_penetration = 0.01

# Add the stage to the task hierarchy
task.add(fixCollisionObjects)
# [initAndConfig]

if task.plan():
    task.publish(task.solutions[0])
time.sleep(1)
