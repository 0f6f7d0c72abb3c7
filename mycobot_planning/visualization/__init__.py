"""ROS-free drawing of robots, scenes, task solutions and trajectories.

* ``geometry``: triangle meshes of the robot's collision shapes and of scene objects.
* ``playback``: a task solution or trajectory as a timeline of joint vectors and object poses.
* ``task_tree``: the stage tree of a published task (description + statistics + solutions).
* ``plots``: PNG pictures with matplotlib — a trajectory plot and a scene snapshot.

The browser viewer (``mycobot_planning.ros.task.task_viewer``) and the ``plot_solution`` tool are
thin layers over these modules.
"""
