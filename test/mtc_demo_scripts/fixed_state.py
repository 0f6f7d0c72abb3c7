#! /usr/bin/env python3
# -*- coding: utf-8 -*-
# MoveIt Task Constructor's demo/scripts/fixed_state.py (ros2 branch, commit 8e76def85452; BSD-3-Clause,
# (c) the moveit_task_constructor authors), run by test/ros/test_mtc_demo_scripts.py. Changed
# nothing but the import and ROS start-up lines:
#   from moveit.task_constructor import core, stages  ->  from mycobot_planning.task import core, stages
#   from moveit.core.planning_scene import PlanningScene  ->  from mycobot_planning.core.planning_scene import PlanningScene
#   from moveit.core import planning_scene  ->  from mycobot_planning.core import planning_scene
#   import rclcpp  ->  import rclpy
#   rclcpp.init()  ->  rclpy.init()
#   node = rclcpp.Node("mtc_tutorial")  ->  node = rclpy.create_node("mtc_tutorial")

from mycobot_planning.core.planning_scene import planning_scene
from mycobot_planning.task import core, stages
import rclpy
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
import time

rclpy.init()
node = rclpy.create_node("mtc_tutorial")

# Create a task
task = core.Task()
task.name = "fixed state"

# [initAndConfigFixedState]
# Initialize a PlanningScene for use in a FixedState stage
task.loadRobotModel(node)  # load the robot model (usually done in init())
planningScene = PlanningScene(task.getRobotModel())

# Create a FixedState stage and pass the created PlanningScene as its state
fixedState = stages.FixedState("fixed state")
fixedState.setState(planningScene)

# Add the stage to the task hierarchy
task.add(fixedState)
# [initAndConfigFixedState]

if task.plan():
    task.publish(task.solutions[0])

del planningScene  # Avoid ClassLoader warning by destroying the RobotModel
time.sleep(1)
