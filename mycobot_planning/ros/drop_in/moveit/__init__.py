"""MoveIt's ``moveit`` Python package, served by mycobot_planning (see mycobot_planning.ros.drop_in):
``moveit.task_constructor`` (MTC's bindings: our task constructor), ``moveit.planning`` (MoveItPy,
PlanningComponent, plan request parameters), ``moveit.core`` (robot model and state, planning
scene, kinematic constraints, trajectories) and ``moveit.utils``. docs/moveit_py.md says what is
offered and how it differs from moveit_py."""
