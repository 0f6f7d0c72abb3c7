"""MTC's Python bindings (``from moveit.task_constructor import core, stages``): the task
constructor of mycobot_planning.task, whose names and behaviour are MTC's (docs/task.md)."""
